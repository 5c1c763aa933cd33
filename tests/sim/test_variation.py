"""Per-robot variation (cpgjax/sim/variation.py): the nominal one changes nothing; each scale acts as physics says."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from simcases import block_on_slope, box

from cpgjax.episode.batch import evaluate
from cpgjax.episode.rollout import rollout
from cpgjax.io.wl import load_model
from cpgjax.sim.rotation import quat_to_mat
from cpgjax.sim.state import initial_state, varied_initial_state
from cpgjax.sim.variation import Variation


def _run(m, var, time, record=False):
    B = var.friction.shape[-1]
    coeffs = jnp.zeros((m.n_ctrl, m.n_coeff, B))
    return jax.tree.map(np.asarray, jax.jit(lambda v: rollout(m, coeffs, time=time, var=v, record=record))(var))


@pytest.mark.slow  # 9 s; fast: test_bristle_scale_is_a_stiffer_friction_spring runs the varied step
def test_the_nominal_variation_is_the_nominal_robot():
    m = load_model("models/quadruped.wl")
    rng = np.random.default_rng(0)
    C = jnp.asarray(rng.uniform(-0.5, 0.5, (3, m.n_ctrl, m.n_coeff)), jnp.float32)
    plain = jax.jit(lambda c: evaluate(m, c, time=0.5))(C)
    nominal = jax.jit(lambda c, v: evaluate(m, c, time=0.5, var=v))(C, Variation.nominal(m, 3))
    # Two compiled programs (with and without the variation's inputs): equal bits natively (AVX512, AMD EPYC),
    # but under XLA_FLAGS=--xla_cpu_max_isa=SSE4_2 and AVX they differ by up to 9.2e-7 (fitness; distance
    # 4.3e-7) over this 0.5 s episode (docs/reproducibility.md).  Flags exact, numbers within 10x that.
    for k in plain:
        a, b = np.asarray(plain[k]), np.asarray(nominal[k])
        if a.dtype == bool:
            np.testing.assert_array_equal(a, b, err_msg=k)
        else:
            np.testing.assert_allclose(a, b, rtol=0, atol=1e-5, err_msg=k)


def _resting_box(mass=(1.0, 1.0, 1.0), stiffness=(1.0, 1.0, 1.0), damping=(1.0, 1.0, 1.0)):
    """Three 10 kg boxes resting on the ground for 2 s with their mass, the ground's stiffness and its damping
    scaled (every scale given, ones for the nominal: one compiled program for the tests below)."""
    m = box(z=0.05, mass=10.0)
    f32 = lambda a: jnp.asarray(a, jnp.float32)  # noqa: E731
    var = Variation.nominal(m, 3)._replace(mass=f32(mass)[None], stiffness=f32(stiffness), damping=f32(damping))
    return _run(m, var, 2.0, record=True)


def test_resting_penetration_follows_the_scaled_mass():
    """m g / (A contacts) with m scaled per robot: a box 0.8x and 1.5x as heavy sinks 0.8x and 1.5x as deep."""
    scale = np.array([0.8, 1.0, 1.5], np.float32)
    r = _resting_box(mass=scale)
    depth = 0.05 - r["traj"]["x"][-1, 2, 0]
    expected = scale * 10.0 * 9.81 / (1e5 * 4)
    np.testing.assert_allclose(depth, expected, rtol=0.02)


def test_friction_scale_moves_the_friction_angle():
    """A block on a 0.3 rad slope (tan 0.31) with mu 0.4 sticks; scaled to 0.6 x 0.4 = 0.24 it slides."""
    m = block_on_slope(0.3, 0.4)
    var = Variation.nominal(m, 2)._replace(friction=jnp.asarray([1.0, 0.6]))
    y = _run(m, var, 1.5, record=True)["traj"]["x"][:, 1, 0]
    moved = np.abs(y[-1] - y[10])
    assert moved[0] < 2e-3 and moved[1] > 0.05, moved


def test_initial_tilt_and_lift_turn_the_whole_robot_rigidly():
    m = load_model("models/quadruped.wl")
    var = Variation.nominal(m, 2)._replace(tilt=jnp.asarray([[0.05, 0.0], [0.0, -0.03]]),
                                            lift=jnp.asarray([0.0, 0.004]))
    s0 = initial_state(m, 2)
    s1 = jax.jit(lambda v: varied_initial_state(m, v))(var)        # op by op: a compile for each operation
    R0, R1 = np.asarray(quat_to_mat(s0.q)), np.asarray(jax.jit(quat_to_mat)(s1.q))
    # every body turned by the same rotation: relative orientations (joint angles) unchanged
    for b in range(2):
        rel0 = np.einsum("jik,jlk->ilk", R0[:, :, :, b], R0[:, :, m.track:m.track + 1, b].repeat(m.nb, 2))
        rel1 = np.einsum("jik,jlk->ilk", R1[:, :, :, b], R1[:, :, m.track:m.track + 1, b].repeat(m.nb, 2))
        np.testing.assert_allclose(rel0, rel1, atol=1e-6)
    # robot 0 rolled by 0.05 rad about x: the tracked body's z axis tilts by that angle
    assert np.isclose(np.arccos(R1[2, 2, m.track, 0]), 0.05, atol=1e-5)
    assert np.isclose(np.arccos(R1[2, 2, m.track, 1]), 0.03, atol=1e-5)
    # the tracked body's CM is lifted, not moved sideways
    dx = np.asarray(s1.x[:, m.track] - s0.x[:, m.track])
    np.testing.assert_allclose(dx[:, 0], 0.0, atol=1e-7)
    np.testing.assert_allclose(dx[:, 1], [0.0, 0.0, 0.004], atol=1e-7)


def test_bristle_scale_is_a_stiffer_friction_spring():
    """A robot with ``bristle`` 100 runs as the model with a 100x stiffer ``FrictionSpring``; the draws of
    ``Perturbations(bristle=D)`` lie in [1, 10^D], and with D = 0 they are exactly 1."""
    from cpgjax.episode.perturb import Perturbations, draw

    m = load_model("models/quadruped.wl")
    stiff = m.replace(friction_k=m.friction_k * 100.0)
    one = np.random.default_rng(1).uniform(-0.5, 0.5, (m.n_ctrl, m.n_coeff, 1))
    c = jnp.asarray(np.repeat(one, 2, -1), jnp.float32)                 # one controller, twice
    var = Variation.nominal(m, 2)._replace(bristle=jnp.asarray([1.0, 100.0]))
    got = jax.jit(lambda v: rollout(m, c, time=0.5, var=v))(var)       # (scale 1 is the nominal robot: see above)
    hard = jax.jit(lambda: rollout(stiff, c, time=0.5))()
    d = np.asarray(got["distance"])
    # Two different compiled programs (the scale a traced input, the stiffness a constant) on a chaotic 0.5 s
    # episode: equal physics, not equal bits.  Measured |d[1] - hard| (docs/reproducibility.md): 2e-6 natively
    # (AVX512) and under XLA_FLAGS=--xla_cpu_max_isa=AVX2 and AVX, 1.9e-3 under SSE4_2, on an AMD EPYC; 2.0e-3 on
    # an Intel Xeon (AVX512, from the report).  The tolerance is 2.5x the largest.
    tol = 5e-3
    np.testing.assert_allclose(d[1], float(hard["distance"][1]), atol=tol)
    # the bristle matters beyond that noise (measured |d[0] - d[1]|: 0.0117 .. 0.0151 over the same four ISAs)
    assert abs(d[0] - d[1]) > tol
    keys = jax.random.split(jax.random.PRNGKey(0), 256)
    bristle = jax.jit(lambda p, k: draw(m, p, k, 40)[0].bristle, static_argnums=0)   # op by op: a compile each
    b = np.asarray(bristle(Perturbations(bristle=2.0), keys))
    assert b.min() >= 1.0 and b.max() <= 100.0 and b.max() > 30 and b.min() < 3
    assert np.all(np.asarray(bristle(Perturbations(), keys)) == 1.0)


def test_ground_stiffness_scale_sets_the_resting_penetration_and_damping_scale_does_not():
    """m g / (s A contacts): a box on ground 0.5x and 1.5x as stiff sinks 2x and 1/1.5x as deep (eq. 3.7); the
    damper's scale changes how it settles, not where."""
    s = np.array([0.5, 1.0, 1.5], np.float32)
    r = _resting_box(stiffness=s, damping=(1.5, 0.6, 1.0))
    depth = 0.05 - r["traj"]["x"][-1, 2, 0]
    # measured: within 2.1e-4 of it (float32 positions of a box 5 cm up: 4 ulp of 0.05 m is 1.5e-8 m)
    np.testing.assert_allclose(depth, 10.0 * 9.81 / (1e5 * s * 4), rtol=1e-3)


# the thesis's springs slow: the same servo law in both pipelines (sim/servo.py), a program each
@pytest.mark.parametrize("pipeline", [pytest.param("springs", marks=pytest.mark.slow), "exact"])
def test_torque_limit_scale_sets_how_far_a_saturated_servo_swings_an_arm_against_gravity(pipeline):
    """A servo asked for 1.4 rad saturates at its limit tau s and swings the hanging arm up from rest; the first swing
    stops where the work of the constant torque equals the gain of potential energy (no damper acts on a saturated
    servo): tau s q = m g d (1 - cos q), m = 0.5 kg, d = 0.065 m from the hip to the arm's CM, tau = 0.1 N m."""
    from scipy.optimize import brentq
    from simcases import model_from, rig

    m = model_from(rig(time=1, servo="60 0 1 0.1").description.text, pipeline=pipeline)
    s = np.array([0.8, 1.0, 1.2], np.float32)
    var = Variation.nominal(m, 3)._replace(torque=jnp.asarray(s[None]))
    coeffs = jnp.zeros((m.n_ctrl, m.n_coeff, 3)).at[:, 0].set(1.4)
    r = jax.tree.map(np.asarray, jax.jit(lambda v: rollout(m, coeffs, time=1.0, var=v, record=True))(var))
    swing = np.abs(r["traj"]["angle"][:, 0]).max(0)
    mgd = 0.5 * 9.81 * 0.065
    expected = [brentq(lambda q, t=0.1 * k: mgd * (1 - np.cos(q)) - t * q, 0.1, 1.3) for k in s]
    # measured: within 1.7e-4 of it on both pipelines (the log samples every 10 ms miss the turning point by less)
    np.testing.assert_allclose(swing, expected, rtol=1e-3)
