"""Episodes (cpgjax/episode/rollout.py, batch.py) on the quadruped: standing, walking, batching, divergence, clock."""

import math

import jax
import numpy as np
import pytest
from runcases import TINY_TIME

from cpgjax.episode.batch import simulate
from cpgjax.episode.probes import Record
from cpgjax.episode.rollout import FALL_TILT, episode_length, rollout
from cpgjax.io.ctl import read_ctl
from cpgjax.io.wl import load_model

QUAD = "models/quadruped.wl"
TROT = "models/quadruped-trot.ctl"


@pytest.fixture(scope="module")
def quad():
    return load_model(QUAD)


def test_quadruped_stands_with_zero_targets(quad):
    r = simulate(quad, np.zeros((8, 5)), time=5.0, record=True)
    z = r["traj"]["x"][:, 2, quad.track]
    t = r["traj"]["t"]
    assert not r["diverged"] and not r["fallen"]
    assert np.ptp(z[t > 0.5]) < 0.01
    assert r["pivot_err"] < 1e-3
    assert abs(r["distance"]) < 0.01


def test_hand_written_trot_walks_forward_without_turning_over(quad):
    c = read_ctl(TROT, n_dof=8, harmonics=2).coeffs
    r = simulate(quad, c, time=5.0, record=True)       # the recording program of the two tests around it
    assert r["distance"] > 0.5                          # 0.687 m in 5 s (cpgjax simulate --time 5)
    assert not r["fallen"] and not r["diverged"]
    assert 0 < r["fitness"] <= r["speed"] + 1e-6  # eq. 4.6 never above the mean speed


def test_left_right_symmetric_gait_does_not_drift_sideways(quad):
    # a bound: left and right legs in phase, front and back in antiphase
    c = np.zeros((8, 5))
    front = np.array([1, 1, 1, 1, 0, 0, 0, 0], bool)
    knee = np.array([0, 1] * 4, bool)
    sign = np.where(front, 1.0, -1.0)
    c[~knee, 0], c[~knee, 1] = -0.2, 0.3 * sign[~knee]
    c[knee, 0], c[knee, 2] = 0.4, 0.3 * sign[knee]
    r = simulate(quad, c, time=5.0, record=True)
    x = r["traj"]["x"][:, 0, quad.track]
    assert np.abs(x).max() < 1e-3


def test_a_batch_of_n_equals_n_single_runs_and_is_deterministic(quad):
    rng = np.random.default_rng(0)
    # not a multiple of the SIMD width, split over devices, and over 96 per device: where XLA would hand the
    # reductions to YNNPACK, which sums in another order (cpgjax/_xla.py).  The suite's tiny episode length:
    # one robot alone and recorded are the programs of cli/test_replay.py, cli/test_cli.py, episode/test_policy.py
    C = rng.uniform(-0.5, 0.5, (197, 8, 5))
    batch = simulate(quad, C, time=TINY_TIME)
    assert np.ptp(batch["distance"]) > 0                     # 197 different episodes
    # deterministic: three programs (197 robots, one, three recorded) give each robot the same bits
    recorded = simulate(quad, C[:3], time=TINY_TIME, record=True)
    for i in (0, 1, 2, 20, 196):
        one = simulate(quad, C[i], time=TINY_TIME)
        np.testing.assert_array_equal(one["distance"], batch["distance"][i])
        np.testing.assert_array_equal(one["fitness"], batch["fitness"][i])
    np.testing.assert_array_equal(recorded["fitness"], batch["fitness"][:3])


LOWERED: list = []     # one entry per program lowered to XLA (every program compiled or read from the cache)
jax.monitoring.register_event_duration_secs_listener(
    lambda name, secs, **kw: LOWERED.append(name) if name.endswith("/jaxpr_to_mlir_module_duration") else None)


def test_one_program_serves_every_episode_length_with_the_bits_of_the_length_compiled_in(quad):
    """The episode's length is data (`episode_length`: a while loop over the log samples): two lengths of one model
    and width are one program (no second lowering, so no second compile), and its scores are the bits of the length
    compiled in (a recorded episode: a static scan), every key."""
    C = np.random.default_rng(0).uniform(-0.5, 0.5, (197, 8, 5))[:3]     # the robots recorded in the test above
    short = simulate(quad, C, time=TINY_TIME)             # one robot's program in the test above (the same width)
    n = len(LOWERED)
    longer = simulate(quad, C, time=2 * TINY_TIME)
    assert len(LOWERED) == n, "a second episode length compiled a program of its own"
    assert np.all(longer["distance"] != short["distance"])
    recorded = simulate(quad, C, time=TINY_TIME, record=True)
    assert set(short) == set(recorded) - {"traj"}
    for k in short:
        np.testing.assert_array_equal(short[k], recorded[k], err_msg=k)
    with pytest.raises(ValueError, match="length"):
        rollout(quad, np.zeros((8, 5, 16), np.float32), length=episode_length(quad, 1.0), probes=(Record(),))


def test_a_diverging_episode_is_flagged_not_crashed():
    """A step far too long for the joints' pivot springs (5 ms, 2.5x the thesis's): the test rig's arm blows up."""
    from simcases import rig

    wild = rig().replace(dt=5e-3)
    r = simulate(wild, np.zeros((2, wild.n_ctrl, wild.n_coeff)), time=1.0)
    assert r["diverged"].all()
    assert np.isfinite(r["fitness"]).all() and (r["fitness"] == 0).all()
    assert np.isfinite(r["distance"]).all()


@pytest.mark.slow  # a program of its own (12 s of CPU); fast: the diverging step above
def test_absurd_gains_are_flagged_too(quad):
    j = [jj for jj in quad.j_kp]
    wild = quad.replace(j_kp=np.full_like(quad.j_kp, 1e7), j_taumax=np.full_like(quad.j_taumax, 1e7))
    r = simulate(wild, np.full((8, 5), 0.5), time=1.0)
    assert j and r["diverged"]
    assert np.isfinite(r["fitness"])


def test_fall_tilt_is_the_tilt_counted_as_a_fall():
    """A box held still (no gravity, no contact) at 0, 50 and 70 degrees of pitch: past 60 degrees it has fallen
    (the rollout's default), and with a margin of 40 degrees (the robust evaluation's ``fall_tilt``) at 50 too."""
    import jax.numpy as jnp
    from simcases import box

    from cpgjax.sim.variation import Variation

    m = box(z=1.0, gravity=0.0, contact=False)
    var = Variation.nominal(m, 3)._replace(tilt=jnp.asarray([[0.0] * 3, [math.radians(a) for a in (0, 50, 70)]],
                                                            jnp.float32))
    coeffs = jnp.zeros((m.n_ctrl, m.n_coeff, 3))
    down = {}
    for tilt in (FALL_TILT, math.radians(40)):
        r = jax.jit(lambda v, t=tilt: rollout(m, coeffs, time=0.1, var=v, fall_ends=True, fall_tilt=t))(var)
        down[tilt] = np.asarray(r["down"]).tolist()
        assert np.allclose(np.asarray(r["tilt"]), np.radians([0, 50, 70]), atol=1e-4)
    assert down == {FALL_TILT: [False, False, True], math.radians(40): [False, True, True]}


def test_the_clock_is_a_step_count_and_the_record_starts_at_t0():
    """Simulated time is n * dt (one rounding), not a running float sum of dt; the first sample is t = 0."""
    from simcases import box

    m = box(z=0.5, log_rate=20, contact=False)           # dt 5e-4: 12000 steps in 6 s
    r = simulate(m, np.zeros((m.n_ctrl, m.n_coeff)), time=6.0, record=True)
    t = r["traj"]["t"]
    assert t.dtype == np.float32 and len(t) == 6 * 20 + 1
    k = np.arange(len(t))
    ulp = np.spacing(np.float32(6.0))
    assert t[0] == 0.0 and np.all(np.abs(t - k / 20.0) <= ulp)   # a float32 sum of dt was 6.000610 here
    # the first sample is the initial pose, at rest
    assert np.allclose(r["traj"]["x"][0, :, 0], m.x0[:, 0]) and np.all(r["traj"]["v"][0] == 0)
    # free fall from the very first step: z(t) = z0 - g t^2 / 2 at the recorded times
    z = r["traj"]["x"][:, 2, 0]
    assert np.max(np.abs(z - (0.5 - 0.5 * 9.81 * t.astype(float) ** 2))) < 9.81 * 6.0 * m.dt


def test_a_shove_adds_its_velocity_to_every_body_once_at_its_step():
    """``Variation.push`` (perturb ``push``): a free three-link worm swinging its two servos falls for 0.3 s (exact
    pipeline).  With no contact a velocity added to every body changes nothing else (Galilean invariance): each body's
    velocity differs from the same episode without the shove by exactly the shove after its step (float32, 1e-5 m/s;
    measured ~1e-7), and not at all (bit for bit) before it."""
    from simcases import chain

    from cpgjax.sim.variation import Variation

    worm = chain(gravity=9.81).replace(pipeline="exact")
    B = 4
    push = np.array([[0.3, -0.2, 0, 0], [-0.1, 0.25, 0, 0], [0, 0, 0, 0]], np.float32)
    at = jax.numpy.asarray([0.5, 0.25, 0.5, 0.25], np.float32)
    var = Variation.nominal(worm, B)._replace(push=jax.numpy.asarray(push), push_at=at)
    c = np.zeros((worm.n_ctrl, 2 * worm.episode.harmonics + 1, B), np.float32)
    c[:, 1] = 0.6                                                           # both servos swing
    r = jax.jit(lambda c, v: rollout(worm, c, time=TINY_TIME, var=v, probes=(Record(),)))(c, var)
    t, v = np.asarray(r["traj"]["t"]), np.asarray(r["traj"]["v"])          # v [S, 3, nb, B]
    steps = round(TINY_TIME / worm.dt)
    w = np.asarray(r["traj"]["w"])
    assert np.abs(w[-1, :, 0, 2] - w[-1, :, 1, 2]).max() > 0.1             # its servos bend it: internal forces act
    for b, share in enumerate((0.5, 0.25)):
        when = (np.floor(np.float32(share) * steps) + 1) * worm.dt          # the shove's time
        dv = v[..., b] - v[..., b + 2]                                      # [S, 3, nb]: against no shove
        before, after = t < when - 1e-6, t > when + 1e-6
        assert before.sum() >= 2 and after.sum() >= 1
        np.testing.assert_array_equal(dv[before], 0.0)
        np.testing.assert_allclose(dv[after], np.broadcast_to(push[:, b, None], dv[after].shape), atol=1e-5)
