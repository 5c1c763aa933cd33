"""A mirror-symmetric closed-loop genome (cpgjax/episode/mirror.py): pairs, the symmetry itself, the start."""

import numpy as np
import pytest
from simcases import rig

from cpgjax.episode import sensors
from cpgjax.episode.cpg import basis
from cpgjax.episode.mirror import MirrorError, expand, input_map, joint_pairs, leg_pairs, mirror
from cpgjax.episode.policy import act, base_genome, from_genomes, parse_controller, to_genome
from cpgjax.io.ctl import read_ctl
from cpgjax.io.wl import load_model

STEER = "pmtg:tilt+contact+command+steer+bias:mirror"
EVERY = "pmtg:" + "+".join(sensors.GROUPS) + ":mirror"


@pytest.fixture(scope="module")
def quad():
    return load_model("models/quadruped.wl", pipeline="exact")


def test_the_quadrupeds_joints_and_legs_pair_across_its_sagittal_plane(quad):
    partner, sigma = joint_pairs(quad)             # HipAR HipAL, KneeAR KneeAL, HipPR HipPL, KneePR KneePL
    np.testing.assert_array_equal(partner, [2, 3, 0, 1, 6, 7, 4, 5])
    np.testing.assert_array_equal(sigma, 1.0)      # every axis along x: a mirrored turn is the partner's own
    np.testing.assert_array_equal(leg_pairs(quad), [1, 0, 3, 2])          # AR AL, PR PL
    m, s = input_map(quad, parse_controller(STEER))  # roll, pitch, 4 feet, command, c sin, c cos, bias
    np.testing.assert_array_equal(m, [0, 1, 3, 2, 5, 4, 6, 7, 8, 9])
    np.testing.assert_array_equal(s, [-1, 1, 1, 1, 1, 1, -1, 1, 1, 1])


def test_a_model_that_is_not_its_own_mirror_image_is_refused():
    m = rig()
    with pytest.raises(MirrorError, match="mirror"):
        parse_controller("pmtg:angles+bias:mirror").n_genes(m)


def test_the_spec_names_the_option_and_reads_back():
    assert parse_controller("pmtg:mirror").mirror and parse_controller("pmtg:mirror").spec == "pmtg:mirror"
    for text in (STEER, EVERY, "pmtg:tilt+bias", "pmtg:mirror"):
        f = parse_controller(text)
        assert parse_controller(f.spec) == f and f.mirror == text.endswith(":mirror")
    assert parse_controller(STEER).plain == parse_controller(STEER.rsplit(":", 1)[0])
    with pytest.raises(ValueError, match="expected"):
        parse_controller("pmtg:tilt+bias:sideways")


def test_the_trot_is_its_own_mirror_image_and_starts_a_mirror_genome(quad):
    f = parse_controller(STEER)
    trot = np.asarray(read_ctl("models/quadruped-trot.ctl", n_dof=8, harmonics=2).coeffs).reshape(-1)
    g = base_genome(f, quad, trot)
    assert g.shape == (72,) and f.plain.n_genes(quad) == 140      # 4 joints' CPG rows and policy rows, 12 shared
    np.testing.assert_array_equal(expand(mirror(quad, f), g[None].astype(np.float32))[0],
                                  base_genome(f.plain, quad, trot).astype(np.float32))
    lopsided = from_genomes(f.plain, quad, base_genome(f.plain, quad, trot)[None].astype(np.float32))[0]
    lopsided = lopsided.replace(coeffs=lopsided.coeffs.copy())
    lopsided.coeffs[2, 1] += 0.1                   # HipAL's swing no longer HipAR's, half a period on
    with pytest.raises(MirrorError, match="not mirror-symmetric"):
        to_genome(lopsided, quad, f)


def test_a_mirrored_state_half_a_period_on_gets_the_mirrored_action(quad):
    """For random genes and readings: the policy's action on the mirrored observation is the mirrored action (each
    joint's offset is its partner's, frequency and amplitude unchanged), and the CPG's target of a joint's partner
    half a period later is the joint's own now.  Float32, the sums in another order: measured 6e-8 (offsets, of
    actions up to 0.38), 1.5e-8 (amplitude) and 4.8e-7 (the CPG, a sine of a larger argument), the same natively
    (AVX-512), under AVX2 and under SSE4_2; tolerances 1e-6 and 1e-5."""
    f = parse_controller(EVERY)
    rng = np.random.default_rng(0)
    g = rng.uniform(-0.8, 0.8, (1, f.n_genes(quad))).astype(np.float32)
    c = from_genomes(f, quad, g)[0]
    m, s = input_map(quad, f)
    obs = rng.normal(size=(f.n_in(quad), 5)).astype(np.float32) * 0.1
    off, m_f, m_a = (np.asarray(x) for x in act(c.family, quad, np.asarray(c.weights)[..., None], obs))
    off2, m_f2, m_a2 = (np.asarray(x) for x in act(c.family, quad, np.asarray(c.weights)[..., None],
                                                   s[:, None].astype(np.float32) * obs[m]))
    partner, sigma = joint_pairs(quad)
    np.testing.assert_allclose(off2[partner], sigma[:, None] * off, atol=1e-6)
    np.testing.assert_allclose(m_f2, m_f, atol=1e-6)
    np.testing.assert_allclose(m_a2, m_a, atol=1e-6)
    t = np.linspace(0.0, 2.0, 9)
    half = 0.5 / quad.episode.frequency
    now, later = (np.asarray(basis(x, quad.episode.harmonics, quad.episode.frequency)[0]) for x in (t, t + half))
    coeffs = np.asarray(c.coeffs)
    np.testing.assert_allclose(coeffs[partner] @ later, sigma[:, None] * (coeffs @ now), atol=1e-5)


def test_a_mirror_run_starts_from_the_trot_with_its_reduced_genome():
    from cpgjax.optim.factory import make_problem

    p = make_problem("models/quadruped.wl", time=0.2, evaluation="robust", controller=STEER,
                     perturb={"command": 0.3}, start="models/quadruped-trot.ctl")
    assert p.n_genes == 72 and p.meta["controller"] == STEER
    quad = load_model("models/quadruped.wl", pipeline="exact")
    c = from_genomes(parse_controller(STEER), quad, np.asarray(p.base_genome, np.float32)[None])
    np.testing.assert_allclose(c.coeffs[0], read_ctl("models/quadruped-trot.ctl", n_dof=8, harmonics=2).coeffs)
    np.testing.assert_array_equal(c.weights, 0.0)


def test_a_gait_reading_fewer_groups_starts_a_steering_run_with_the_command_weights_zero(tmp_path):
    """A fast gait (tilt+contact+bias) as the start of a run that learns to read the command: its weights kept,
    those of command and steer 0; a start reading a group the run's policy lacks is refused naming it."""
    from cpgjax.episode import policy as pol
    from cpgjax.io.ctl import PolicyTable, write_ctl
    from cpgjax.optim.factory import make_problem

    quad = load_model("models/quadruped.wl", pipeline="exact")
    fast = parse_controller("pmtg:tilt+contact+bias:mirror")
    p0 = make_problem("models/quadruped.wl", time=0.2, evaluation="robust", controller=fast.spec, perturb={},
                      start="models/quadruped-trot.ctl")
    g = np.asarray(p0.base_genome, np.float32) + np.random.default_rng(3).uniform(-0.3, 0.3, p0.n_genes).astype(
        np.float32)
    c = pol.from_genomes(fast, quad, g[None])[0]
    path = tmp_path / "fast.ctl"
    write_ctl(path, np.asarray(c.coeffs), policy=PolicyTable(**pol.table_fields(c, quad)), exact=True)
    p = make_problem("models/quadruped.wl", time=0.2, evaluation="robust", controller=STEER,
                     perturb={"command": 0.3}, start=str(path))
    w = from_genomes(parse_controller(STEER), quad, np.asarray(p.base_genome, np.float32)[None]).weights[0]
    np.testing.assert_allclose(w[:, :6], c.weights[:, :6], rtol=1e-6)      # roll, pitch, the four feet
    np.testing.assert_allclose(w[:, 9], c.weights[:, 6], rtol=1e-6)        # the bias
    np.testing.assert_array_equal(w[:, 6:9], 0.0)                           # command, c sin, c cos
    with pytest.raises(ValueError, match="lacks tilt"):
        make_problem("models/quadruped.wl", time=0.2, evaluation="robust", controller="pmtg:contact+bias:mirror",
                     perturb={}, start=str(path))
