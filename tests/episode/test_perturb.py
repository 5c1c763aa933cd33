"""The robust evaluation's perturbations (cpgjax/episode/perturb.py): domain randomisation's draws and records."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from simcases import rig

from cpgjax.episode.perturb import LATER, PRESETS, Perturbations, commands, draw

DOMAIN = {"preset": "domain", "mass": 0.08}          # a key beside the preset wins


def test_the_domain_preset_draws_every_range_within_its_bounds_and_spans_it():
    m = rig()               # the test rig (1 servo, 2 bodies): the same code, compiled in 2/3 the quadruped's time
    p = Perturbations.from_settings(DOMAIN)
    assert p.roughness == 0.04 and p.relief == 1.0 and p.mass == 0.08 and p.fall_survival
    keys = jax.random.split(jax.random.key(5), 512)
    var, offsets = jax.tree.map(np.asarray, jax.jit(lambda k: draw(m, p, k, 40))(keys))
    for name, r in (("friction", p.friction), ("mass", p.mass), ("gain", p.gain), ("torque", p.torque),
                    ("stiffness", p.stiffness), ("damping", p.damping)):
        a = getattr(var, name)
        assert a.shape[-1] == 512 and a.min() >= 1 - r and a.max() <= 1 + r, name
        assert a.min() < 1 - 0.95 * r and a.max() > 1 + 0.95 * r, name            # the whole range is drawn
    assert var.torque.shape == (m.n_ctrl, 512) and var.mass.shape == (m.nb, 512)
    assert var.relief.min() >= 0 and var.relief.max() <= 1 and var.relief.min() < 0.01 and var.relief.max() > 0.99
    d = np.log10(var.bristle)
    assert d.min() >= 0 and d.max() <= p.bristle + 1e-6 and d.max() > 0.95 * p.bristle
    assert np.abs(var.shift[0]).max() <= 1.5 and np.abs(var.shift[1]).max() <= 2.0
    assert np.abs(offsets).max() <= np.sqrt(3) * p.jitter * (1 + 1e-6)


def test_the_bristle_can_be_kept_stiffer_than_the_models_own():
    """``bristle_from=1,bristle=3``: every foot 10 to 1000 times stiffer than the model's, the whole range drawn."""
    m = rig()
    p = Perturbations.from_settings({"bristle": 3.0, "bristle_from": 1.0})
    keys = jax.random.split(jax.random.key(5), 512)
    d = np.log10(np.asarray(jax.jit(lambda k: draw(m, p, k, 40))(keys)[0].bristle))
    assert d.min() >= 1 - 1e-6 and d.max() <= 3 + 1e-6 and d.min() < 1.05 and d.max() > 2.95
    assert "bristle_from" in p.to_dict() and "bristle_from" not in Perturbations(bristle=3.0).to_dict()


def test_a_shove_is_drawn_horizontal_in_its_range_at_a_time_in_its_window_leaving_the_other_draws():
    """``push=0.3``: x and y velocities in [-0.3, 0.3] m/s (the range spanned), none vertical, a time in
    PUSH_WINDOW's share of the episode; every other draw the same bits as without it (its own key)."""
    from cpgjax.episode.perturb import PUSH_WINDOW

    m = rig()
    keys = jax.random.split(jax.random.key(3), 512)
    fn = jax.jit(lambda k, p: draw(m, p, k, 40), static_argnums=1)
    # the settings of the test above, its program (the draws are constants of the program; the keys are data)
    base = Perturbations.from_settings(DOMAIN)
    var, off = jax.tree.map(np.asarray, fn(keys, base))
    pushed, off2 = jax.tree.map(np.asarray, fn(keys, Perturbations.from_settings({**DOMAIN, "push": 0.3})))
    assert pushed.push.shape == (3, 512) and np.all(pushed.push[2] == 0)
    assert np.abs(pushed.push[:2]).max() <= 0.3 and np.abs(pushed.push[:2]).min(axis=1).max() < 0.01
    assert pushed.push[:2].min() < -0.29 and pushed.push[:2].max() > 0.29
    assert pushed.push_at.min() >= PUSH_WINDOW[0] and pushed.push_at.max() <= PUSH_WINDOW[1]
    for name in var._fields:
        if getattr(var, name) is not None:
            np.testing.assert_array_equal(getattr(pushed, name), getattr(var, name), err_msg=name)
    np.testing.assert_array_equal(off2, off)


def test_ranges_left_off_add_no_field_and_no_record():
    """Without the later ranges the draws and the record are those of the runs made before them (they resume)."""
    m = rig()
    p = Perturbations()
    keys = jax.random.split(jax.random.key(0), 16)
    var, _ = jax.jit(lambda k: draw(m, p, k, 40))(keys)      # jitted: op by op it compiles each operation
    assert var.torque is None and var.stiffness is None and var.damping is None and var.relief is None
    assert var.push is None and var.push_at is None
    assert set(p.to_dict()) == {"replicas", "lift", "tilt", "roughness", "friction", "mass", "gain", "jitter",
                                "bristle", "fall_ends", "fall_zero", "fall_survival"}
    assert set(Perturbations.from_settings({"preset": "domain"}).to_dict()) >= set(PRESETS["domain"])
    assert set(LATER) <= {f for f in Perturbations.__dataclass_fields__}


def test_the_run_records_every_range_drawn_and_the_controller_family():
    from cpgjax.optim.factory import make_problem

    p = make_problem("models/quadruped.wl", time=0.2, evaluation="robust", controller="pmtg",
                     perturb={"preset": "domain", "noise": 0.02, "latency": 1})
    rec = p.meta["perturbations"]
    assert Perturbations(**rec) == Perturbations.from_settings({"preset": "domain", "noise": 0.02, "latency": 1})
    assert rec["stiffness"] == 0.5 and rec["relief"] == 1.0 and rec["latency"] == 1 and rec["noise"] == 0.02
    assert p.meta["controller"] == "pmtg" and p.n_genes == 240
    np.testing.assert_array_equal(p.base_genome[40:], 0.0)                   # the start: the CPG's, no feedback
    assert "controller" not in make_problem("models/quadruped.wl", time=0.2).meta   # the thesis's runs as before


@pytest.mark.parametrize("bad, message", [({"latency": 2}, "latency is 0 or 1"), ({"relief": 1.5}, "relief"),
                                          ({"stiffness": 1.0}, "relative"), ({"preset": "moon"}, "unknown"),
                                          ({"speed": -0.12}, "speed must be a finite number >= 0"),
                                          ({"push": 2.5}, "push is the shove's range.* <= 2"),
                                          ({"bristle": 1.0, "bristle_from": 2.0}, "bristle_from"),
                                          ({"touch": 0.02}, "touch .* <= 0.01"), ({"touch": -0.001}, "touch"),
                                          ({"texture": 0.002}, "give roughness too"),
                                          ({"roughness": 0.02, "texture": 0.02}, "texture .* <= 0.01")])
def test_bad_ranges_are_refused(bad, message):
    with pytest.raises(ValueError, match=message):
        Perturbations.from_settings(bad)


def test_commands_are_drawn_per_half_within_the_range_from_the_key_alone():
    keys = jax.random.split(jax.random.key(7), 300)
    c = np.asarray(commands(keys, 0.3))
    assert c.shape == (2, 300) and np.abs(c).max() <= 0.3 and c.min() < -0.29 and c.max() > 0.29
    assert np.corrcoef(c[0], c[1])[0, 1] ** 2 < 0.05                         # the halves are drawn apart
    np.testing.assert_array_equal(np.asarray(commands(keys[:17], 0.3)), c[:, :17])   # a robot's, whatever the batch


def test_touch_thresholds_are_drawn_per_leg_within_the_range_from_the_key_alone():
    from cpgjax.episode.perturb import touch_thresholds

    keys = jax.random.split(jax.random.key(3), 300)
    t = np.asarray(touch_thresholds(keys, 4, 0.001))
    assert t.shape == (300, 4) and np.abs(t).max() <= 0.001 and t.min() < -0.00099 and t.max() > 0.00099
    np.testing.assert_array_equal(np.asarray(touch_thresholds(keys[:9], 4, 0.001)), t[:9])
    assert "touch" not in Perturbations().to_dict()                             # off: the earlier records


def test_the_touch_range_needs_a_controller_that_reads_contact():
    from cpgjax.optim.factory import make_problem

    p = make_problem("models/quadruped.wl", time=0.2, evaluation="robust", controller="pmtg:tilt+contact+bias",
                     perturb={"touch": 0.001})
    assert p.meta["perturbations"]["touch"] == 0.001
    for ctl in (None, "pmtg:tilt+bias"):
        with pytest.raises(ValueError, match="must read its touch sensors"):
            make_problem("models/quadruped.wl", time=0.2, evaluation="robust", controller=ctl, perturb={"touch": 0.001})


def test_a_steered_run_records_the_command_and_refuses_a_controller_that_cannot_read_it():
    from cpgjax.optim.factory import make_problem

    p = make_problem("models/quadruped.wl", time=0.2, evaluation="robust", controller="pmtg:tilt+command+steer+bias",
                     perturb={"command": 0.4})
    assert p.meta["perturbations"]["command"] == 0.4 and p.n_genes == 40 + 10 * 6
    assert "command" not in Perturbations().to_dict()                            # off: the earlier records
    assert "speed" not in Perturbations(command=0.4).to_dict()
    for ctl in (None, "pmtg:tilt+bias"):
        with pytest.raises(ValueError, match="must read the command"):
            make_problem("models/quadruped.wl", time=0.2, evaluation="robust", controller=ctl, perturb={"command": 0.4})


def test_a_steered_episode_is_scored_by_tracking_capped_at_the_speed_then_by_its_fall():
    """The robust evaluation's score of three episodes (0.2 and 0.1 m/s along the heading, 0.05 rad/s off a 0.4 rad/s
    range; the third fell): the tracking fitness, the speed credited up to ``speed``, a fall forfeiting."""
    from cpgjax.optim.factory import episode_scores

    r = {"fitness": jnp.asarray([9.0, 9.0, 9.0]), "heading_fitness": jnp.asarray([0.2, 0.1, 0.2]),
         "turn_error": jnp.full(3, 0.05), "down": jnp.asarray([False, False, True]), "up": jnp.ones(3)}
    share = 1 - 0.05 / 0.2
    free = episode_scores(r, Perturbations(command=0.4, fall_zero=True), steered=True)["fitness"]
    np.testing.assert_allclose(free, [0.2 * share, 0.1 * share, 0.0], rtol=1e-6)
    capped = episode_scores(r, Perturbations(command=0.4, speed=0.15, fall_zero=True), steered=True)["fitness"]
    np.testing.assert_allclose(capped, [0.15 * share, 0.1 * share, 0.0], rtol=1e-6)
    np.testing.assert_array_equal(episode_scores(r, Perturbations())["fitness"], r["fitness"])   # eq. 4.6's, kept


def test_without_a_command_the_speed_caps_eq_4_6s_score_before_the_fall_scales_it():
    """``speed`` without ``command``: eq. 4.6's episode fitness credited up to ``speed`` m/s, then scaled by the share
    of the episode before a fall (``fall_survival``); without ``speed`` it is kept as it is."""
    from cpgjax.optim.factory import episode_scores

    r = {"fitness": jnp.asarray([0.7, 0.3, 0.9]), "down": jnp.asarray([False, False, True]),
         "up": jnp.asarray([1.0, 1.0, 0.5])}
    capped = episode_scores(r, Perturbations(speed=0.5, fall_survival=True))["fitness"]
    np.testing.assert_allclose(capped, [0.5, 0.3, 0.25], rtol=1e-6)
    free = episode_scores(r, Perturbations(fall_survival=True))["fitness"]
    np.testing.assert_allclose(free, [0.7, 0.3, 0.45], rtol=1e-6)


def test_the_texture_is_the_rough_field_sampled_finer_plus_a_fine_relief_in_its_range():
    """``texture``: the roughness field on 2.5 cm cells, where it equals the field sampled there (bilinear), plus
    heights in [0, texture]; without it the field is as before, the same array."""
    from cpgjax.episode.perturb import TEXTURE_CELL, roughened
    from cpgjax.sim.terrain import make_terrain

    flat = make_terrain("flat")
    coarse = roughened(flat, 0.04)
    np.testing.assert_array_equal(roughened(flat, 0.04, 0.0).heights, coarse.heights)
    fine = roughened(flat, 0.04, 0.002)
    assert fine.dx == pytest.approx(TEXTURE_CELL) and fine.dy == pytest.approx(TEXTURE_CELL)
    ny, nx = fine.heights.shape
    X, Y = np.meshgrid(fine.x0 + fine.dx * np.arange(nx), fine.y0 + fine.dy * np.arange(ny))
    extra = fine.heights - coarse.height_np(X, Y)
    assert extra.min() >= -1e-9 and extra.max() <= 0.002 + 1e-9 and extra.max() > 0.0019 and extra.std() > 4e-4
