"""Per-robot variation (cpgjax/sim/variation.py): the nominal one changes nothing; each scale acts as physics says."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from simcases import BOXES, SLOPE, SLOPES, block_on_slope, box, boxes, slopes

from cpgjax.episode.batch import evaluate, simulate
from cpgjax.episode.probes import Record
from cpgjax.episode.rollout import rollout
from cpgjax.io.wl import load_model
from cpgjax.sim.rotation import quat_to_mat
from cpgjax.sim.state import initial_state, varied_initial_state
from cpgjax.sim.variation import Variation


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


def test_resting_penetration_follows_the_scaled_mass():
    """m g / (A contacts) with m scaled per robot: a box 0.8x and 1.5x as heavy sinks 0.8x and 1.5x as deep."""
    scale = np.array(BOXES["mass"][:3], np.float32)           # 1, 0.8, 1.5 (tests/simcases.py)
    depth = 0.05 - boxes()["traj"]["x"][-1, 2, 0, :3]
    expected = scale * 10.0 * 9.81 / (1e5 * 4)
    np.testing.assert_allclose(depth, expected, rtol=0.02)


def test_friction_scale_moves_the_friction_angle():
    """A block on a 0.3 rad slope (tan 0.31) with mu 0.4 sticks; scaled to 0.6 x 0.4 = 0.24 it slides."""
    assert SLOPES["friction"][2:4] == [1.0, 0.6]
    y = slopes()["traj"]["x"][:, 1, 0, 2:4]
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
    """A block with ``bristle`` 100 held on a slope by friction runs as the model with a 100x stiffer
    ``FrictionSpring``: its bristles stretch m g sin(slope) / (4 k) along the slope, 100x less; the draws of
    ``Perturbations(bristle=D)`` lie in [1, 10^D], and with D = 0 they are exactly 1."""
    from cpgjax.episode.perturb import Perturbations, draw

    r = slopes()                                                # mu 0.6, bristle 1 and 100 (tests/simcases.py)
    assert SLOPES["friction"][4] == SLOPES["friction"][0] and SLOPES["bristle"][4] == 100.0
    y = r["traj"]["x"][:, 1, 0]                                 # [samples, robot]: up the slope is +y
    base = block_on_slope(SLOPE, 0.6)
    stiff = base.replace(friction_k=base.friction_k * 100.0)
    hard = simulate(stiff, np.zeros((0, 5)), time=2.0, record=True)["traj"]["x"][:, 1, 0]
    # two programs (the scale a traced input, the stiffness a constant), the same smooth physics: measured
    # |difference| of the block's y over the 2 s: 0 natively (AVX-512, AMD EPYC) and under
    # XLA_FLAGS=--xla_cpu_max_isa=AVX2 and SSE4_2; the tolerance 1 um (the quadruped walking: 2e-3 m, chaotic)
    np.testing.assert_allclose(y[:, 4], hard, rtol=0, atol=1e-6)
    # at rest the bristles hold m g sin(slope), stretched by that over 4 k: 1.45 mm at k = 1000 N/m, 14.5 um at
    # 100x.  The soft block settles further down the slope by at least the difference (measured: 2.6 mm, as it
    # also slips while its weight comes onto the ground), and both then hold (measured: 56 um in the last second)
    stretch = 2.0 * 9.81 * np.sin(SLOPE) / (4 * base.friction_k)
    slid = (y[-1, 0] - y[-1, 4]) / np.cos(SLOPE)                # downhill is +y
    assert stretch * (1 - 1 / 100) < slid < 3 * stretch, (slid, stretch)
    assert np.abs(y[-1, [0, 4]] - y[50, [0, 4]]).max() < 1e-4   # from 1 s on
    keys = jax.random.split(jax.random.PRNGKey(0), 256)
    m = box()
    bristle = jax.jit(lambda p, k: draw(m, p, k, 40)[0].bristle, static_argnums=0)   # op by op: a compile each
    b = np.asarray(bristle(Perturbations(bristle=2.0), keys))
    assert b.min() >= 1.0 and b.max() <= 100.0 and b.max() > 30 and b.min() < 3
    assert np.all(np.asarray(bristle(Perturbations(), keys)) == 1.0)


def test_ground_stiffness_scale_sets_the_resting_penetration_and_damping_scale_does_not():
    """m g / (s A contacts): a box on ground 0.5x and 1.5x as stiff sinks 2x and 1/1.5x as deep (eq. 3.7); the
    damper's scale changes how it settles, not where."""
    s = np.array(BOXES["stiffness"][3:6], np.float32)          # 0.5, 1, 1.5 with damping 1.5, 0.6, 1
    assert BOXES["damping"][3:6] == [1.5, 0.6, 1.0]
    depth = 0.05 - boxes()["traj"]["x"][-1, 2, 0, 3:6]
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
    r = jax.tree.map(np.asarray, jax.jit(lambda v: rollout(m, coeffs, time=1.0, var=v, probes=(Record(),)))(var))
    swing = np.abs(r["traj"]["angle"][:, 0]).max(0)
    mgd = 0.5 * 9.81 * 0.065
    expected = [brentq(lambda q, t=0.1 * k: mgd * (1 - np.cos(q)) - t * q, 0.1, 1.3) for k in s]
    # measured: within 1.7e-4 of it on both pipelines (the log samples every 10 ms miss the turning point by less)
    np.testing.assert_allclose(swing, expected, rtol=1e-3)
