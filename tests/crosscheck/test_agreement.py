"""`cpgjax agreement` (cpgjax/crosscheck/agreement.py): evolved gaits here and in MuJoCo C, their feet watched."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from cpgjax import cli
from cpgjax.crosscheck import agreement as ag

LEGS = ("AR", "AL", "PR", "PL")


def _watch(S=100, touch=True, speed=0.0, depth=1e-3, nz=1.0, up=None):
    """One gait's feet: four feet touching (or not), sliding along x at ``speed`` m/s."""
    t = np.arange(S) * ag.SAMPLE
    feet = np.zeros((S, 4, 3))
    feet[..., 0] = speed * t[:, None]
    tch = np.full((S, 4), touch)
    return ag.Watch(feet=feet, touch=tch, depth=np.where(tch, depth, 0.0), nz=np.full((S, 4), nz),
                    up=np.ones(S) if up is None else up)


def test_feet_that_stand_do_not_slip_and_feet_that_slide_slip_at_their_speed():
    assert ag.diagnose(_watch(), LEGS, ag.SAMPLE)["slip"] == 0.0
    assert ag.diagnose(_watch(speed=0.05), LEGS, ag.SAMPLE)["slip"] == pytest.approx(50.0)       # mm/s
    assert ag.diagnose(_watch(touch=False, speed=0.05), LEGS, ag.SAMPLE)["slip"] == 0.0            # in the air


def test_only_feet_deeper_than_deep_count_in_the_loaded_slip():
    """``slip_deep``: the slip of feet that carry a load (deeper than ag.DEEP, 2 mm); a foot skimming the ground at
    1 mm slides without counting there."""
    assert ag.diagnose(_watch(speed=0.05, depth=3e-3), LEGS, ag.SAMPLE)["slip_deep"] == pytest.approx(50.0)
    d = ag.diagnose(_watch(speed=0.05, depth=1e-3), LEGS, ag.SAMPLE)
    assert d["slip"] == pytest.approx(50.0) and d["slip_deep"] == 0.0


def test_depth_and_steep_contacts_are_counted_over_the_touching_feet():
    d = ag.diagnose(_watch(depth=2e-3, nz=math.cos(math.radians(30))), LEGS, ag.SAMPLE)
    assert d["depth"] == pytest.approx((2.0, 2.0, 2.0))
    assert d["steep"] == 1.0
    assert ag.diagnose(_watch(nz=math.cos(math.radians(20))), LEGS, ag.SAMPLE)["steep"] == 0.0


def test_the_first_leg_to_lose_the_ground_is_the_one_whose_last_touch_before_the_fall_came_first():
    S = 100
    up = np.ones(S)
    up[60:] = np.linspace(0.4, -1.0, 40)          # tilted past 60 degrees at sample 60, turned over after
    w = _watch(S, up=up)
    for leg, last in ((0, 55), (1, 30), (2, 58), (3, 50)):
        w.touch[last + 1:, leg] = False
    assert ag.diagnose(w, LEGS, ag.SAMPLE)["lost"] == "AL"
    assert ag.diagnose(_watch(S), LEGS, ag.SAMPLE)["lost"] == "—"      # no fall


def test_past_a_limit_is_the_largest_overshoot_over_joints_and_samples():
    w = _watch()
    w.angle = np.zeros((len(w.up), 2))
    w.angle[10, 0], w.angle[20, 1] = 1.6, -1.7
    limits = (np.array([-1.5, -1.5]), np.array([1.5, 1.5]))
    assert ag.diagnose(w, LEGS, ag.SAMPLE, limits)["past"] == pytest.approx(0.2)
    assert ag.diagnose(w, LEGS, ag.SAMPLE)["past"] == 0.0                                   # no limits given
    free = (np.full(2, -np.inf), np.full(2, np.inf))
    assert ag.diagnose(w, LEGS, ag.SAMPLE, free)["past"] == 0.0                             # joints without limits


def test_a_robot_at_rest_stands_on_its_four_feet_in_both_engines():
    """The quadruped holding its design pose on flat ground for 1 s.  Here each foot carries a quarter of the
    robot: depth m g / (4 A) (eq. 3.7; sim/contact.py makes it exact at rest), the normal vertical, no slip.  In
    MuJoCo C its spheres touch too, with a vertical normal and no slip; their depth is MuJoCo's (its
    regularisation sinks them deeper: docs/results/engine-agreement.md, MuJoCo's ground at rest), only checked to be
    of the same order."""
    from cpgjax.io.wl import load_model

    model = load_model("models/quadruped.wl", pipeline="exact")
    C = np.zeros((1, model.n_ctrl, model.n_coeff), np.float32)
    _, (here,) = ag.watch_ours(model, C, 1.0)
    _, (there,) = ag.watch_mujoco(model, ag.as_closed(model, None, C), 1.0, 0.0005)
    rest = model.mass.sum() * model.gravity / (4 * model.ground_A)
    tail = slice(-100, None)                                  # the last 0.2 s, settled
    assert here.touch[tail].all() and there.touch[tail].all()
    np.testing.assert_allclose(here.depth[tail], rest, rtol=0.02)
    assert 0.5 * rest < np.median(there.depth[tail]) < 20 * rest
    assert ag.diagnose(ag.Watch(*(a[tail] for a in (here.feet, here.touch, here.depth, here.nz, here.up))),
                       LEGS, ag.SAMPLE)["slip"] < 0.1                                             # mm/s
    assert ag.diagnose(ag.Watch(*(a[tail] for a in (there.feet, there.touch, there.depth, there.nz, there.up))),
                       LEGS, ag.SAMPLE)["slip"] < 0.5
    assert (here.nz[tail] == 1.0).all() and (there.nz[tail] > 0.999).all()
    limits = (model.j_lo, model.j_hi)
    assert ag.diagnose(here, LEGS, ag.SAMPLE, limits)["past"] == 0.0
    assert ag.diagnose(there, LEGS, ag.SAMPLE, limits)["past"] == 0.0


def test_mujoco_stiffness_scales_the_exported_contact_and_sinks_the_resting_feet_less():
    """``contact_stiffness(F)`` (``agreement --mujoco-stiffness``) multiplies both numbers of MuJoCo's direct solref
    by F, and only inside its block.  The quadruped at rest in MuJoCo C (0.5 ms, 1 s): its feet's median depth over
    the last 0.2 s measured 4.14x eq. 3.7's as exported, 2.30x at F = 2 and 1.57x at F = 4 (MuJoCo 4.0.0; not 1/F:
    the impedance changes with the depth).  Tolerance: ranges around each, +-10 %."""
    from cpgjax.crosscheck.mjcf import contact_solref, contact_stiffness
    from cpgjax.io.wl import load_model

    model = load_model("models/quadruped.wl", pipeline="exact")
    k, b = (float(x) for x in contact_solref(model).split())
    with contact_stiffness(4.0):
        np.testing.assert_allclose([float(x) for x in contact_solref(model).split()], [4 * k, 4 * b], rtol=1e-5)
    assert contact_solref(model) == f"{k:.6g} {b:.6g}"
    with pytest.raises(ValueError, match="stiffness scale must be a number > 0"):
        with contact_stiffness(0.0):
            pass
    C = np.zeros((1, model.n_ctrl, model.n_coeff), np.float32)
    rest = model.mass.sum() * model.gravity / (4 * model.ground_A)
    for scale, depth in ((None, 4.14), (4.0, 1.57)):
        with contact_stiffness(scale):
            _, (there,) = ag.watch_mujoco(model, ag.as_closed(model, None, C), 1.0, 0.0005)
        assert there.touch[-100:].all()
        assert np.median(there.depth[-100:]) / rest == pytest.approx(depth, rel=0.1)


def test_gaits_are_picked_from_generations_spread_over_the_run_once_each(tiny_runs):
    from cpgjax.io.results import read_run

    run = read_run(tiny_runs["thesis"])
    picked = ag.pick_gaits(run, 2)
    assert [g for g, _ in picked] == [0, 1] or [g for g, _ in picked] == [0]       # a genome met twice is kept once
    for gen, genome in picked:
        v = run.valid_fitness()[gen]
        np.testing.assert_array_equal(genome, run.genomes[gen, int(np.nanargmax(v))])


def test_with_replays_the_summary_compares_their_median_speeds_too():
    """Four gaits whose one replay as it is ranks them in reverse in MuJoCo C, and whose replays' medians rank
    them alike: Spearman -1 as they are, 1 over the medians; each median in the table."""
    def side(speed, median, falls):
        return {"fell": False, "speed": speed, "depth": (1.0, 2.0, 3.0), "steep": 0.0, "slip": 10.0,
                "landings": 1.0, "lost": "—", "replays": 8, "falls": falls, "speed_median": median}

    gaits = [ag.Gait(f"g{i}", side(0.1 * i, 0.1 * i, 0), side(0.5 - 0.1 * i, 0.11 * i, 4 * (i == 3)))
             for i in range(4)]
    s = ag.summary(gaits)
    assert s["spearman"] == pytest.approx(-1.0) and s["spearman_replays"] == pytest.approx(1.0)
    assert s["falls_agree"] == 0.75 and s["fell_only_mujoco"] == 1
    text = ag.table(gaits)
    assert "median speed of 8 [m/s] here" in text and "| 0.330 |" in text
    assert "Spearman of the speeds -1.00 (of the replays' median speeds 1.00)" in text


@pytest.mark.slow    # 15 s: a recording rollout and MuJoCo C, on top of the tiny run
def test_agreement_writes_its_table_and_summary(tiny_runs, tmp_path, capsys):
    out = tmp_path / "ag"
    assert cli.main(["agreement", tiny_runs["robust"], "--per-run", "2", "--terrain", "rough:0.02:0.1:1",
                     "--mujoco-dt", "0.001", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "| gait | speed [m/s] here" in text and "robust.h5@" in text and "Spearman of the speeds" in text
    data = json.loads((out / "agreement.json").read_text())
    assert (out / "agreement.png").stat().st_size > 10_000
    assert data["summary"]["terrain"] == "rough:0.02:0.1:1" and 1 <= data["summary"]["gaits"] <= 2
    for g in data["gaits"]:
        for side in ("ours", "mujoco"):
            assert set(g[side]) == {"fell", "speed", "depth", "steep", "slip", "slip_deep", "landings", "past",
                                    "lost"}


def test_a_controller_file_is_refused_in_one_line(capsys):
    from runcases import one_line_error

    assert cli.main(["agreement", "models/quadruped-trot.ctl"]) == 2
    one_line_error(capsys.readouterr().err, "agreement", expect=("run files", "cpgjax crosscheck"))
    assert cli.main(["agreement", "x.h5", "--mujoco-stiffness", "0"]) == 2
    one_line_error(capsys.readouterr().err, "agreement", expect=("--mujoco-stiffness", "> 0"))
    assert cli.main(["agreement", "x.h5", "--ground", "1e5", "-300"]) == 2
    one_line_error(capsys.readouterr().err, "agreement", expect=("--ground", "> 0"))


def test_a_change_to_our_side_stays_on_our_side_in_the_jittered_replays(monkeypatch):
    """``compare_runs(ours=...)``: the jittered replays here run the changed model, MuJoCo C's export the run's own
    (a field the export reads, such as the friction coefficient, would otherwise change MuJoCo's side too)."""
    from types import SimpleNamespace

    from cpgjax.crosscheck import agreement, engines
    from cpgjax.crosscheck import transfer as tr
    from cpgjax.episode import batch, policy

    seen = {}
    monkeypatch.setattr(tr, "jittered", lambda g, n: np.zeros((n + 1, 1)))
    monkeypatch.setattr(policy, "from_genomes", lambda fam, m, g: g)
    monkeypatch.setattr(batch, "simulate", lambda m, c, time: seen.update(here=m) or
                        {"fallen": np.zeros(2, bool), "speed": np.ones(2)})
    monkeypatch.setattr(engines, "mujoco_run", lambda m, c, time, mj: seen.update(there=m) or
                        ({"fallen": np.zeros(2, bool), "speed": np.ones(2)}, None, None))
    monkeypatch.setattr(agreement, "load", lambda m, timestep: None)
    run, ours = SimpleNamespace(name="run"), SimpleNamespace(name="ours")
    agreement._jittered_falls(run, None, np.zeros(1), 1.0, 0.001, 2, ours=ours)
    assert seen == {"here": ours, "there": run}
    agreement._jittered_falls(run, None, np.zeros(1), 1.0, 0.001, 2)
    assert seen == {"here": run, "there": run}
