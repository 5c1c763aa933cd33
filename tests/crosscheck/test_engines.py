"""MuJoCo C's side of a closed-loop controller (cpgjax/crosscheck/engines.py): the same observation, the same policy."""

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
import pytest

from cpgjax.crosscheck.engines import control_period, mujoco_closed_run, mujoco_observe, mujoco_run
from cpgjax.crosscheck.mjcf import initial_qpos, load
from cpgjax.episode import policy as pol
from cpgjax.episode import sensors
from cpgjax.io.ctl import read_ctl
from cpgjax.io.wl import load_model
from cpgjax.sim.state import varied_initial_state
from cpgjax.sim.variation import Variation

SINK = 0.001    # m: the robot pushed 1 mm into the ground, so that its feet are down in both engines (in the design
#                pose they are exactly on it: a contact of distance 0, which MuJoCo may or may not list)


def _ours(model, tilt):
    lift = 0.01 if any(tilt) else -SINK
    var = Variation.nominal(model, 1)._replace(tilt=jnp.asarray(np.reshape(tilt, (2, 1)), jnp.float32),
                                               lift=jnp.asarray([lift], jnp.float32))
    s = varied_initial_state(model, var)
    z = jnp.zeros((1,), jnp.float32)
    obs = jax.jit(lambda s: sensors.observe(model, sensors.GROUPS, s, None, (z + 0.3, z - 0.2), z + 0.25))(s)
    return np.asarray(obs)[:, 0]


def _mujoco(model, mj, tilt):
    d = mujoco.MjData(mj)
    d.qpos[:] = initial_qpos(model, mj)
    a, b = tilt                                    # the free joint turned by Ry(b) Rx(a), as varied_initial_state
    qa, qb = np.array([np.cos(a / 2), np.sin(a / 2), 0, 0]), np.array([np.cos(b / 2), 0, np.sin(b / 2), 0])
    q = np.zeros(4)
    mujoco.mju_mulQuat(q, qb, qa)
    d.qpos[3:7] = q
    d.qpos[2] += 0.01 if (a or b) else -SINK       # lifted: the tilted robot does not start in the ground
    mujoco.mj_forward(mj, d)
    return mujoco_observe(model, mj, [d], sensors.GROUPS, (np.array([0.3]), np.array([-0.2])), np.full(1, 0.25))[0]


def test_mujoco_sees_the_observation_we_see_at_t0():
    """The design pose 1 mm down: the same readings, every foot down (ours: the vertex in the ground; MuJoCo: a
    contact of its sphere); turned by known angles and lifted, the same roll and pitch.  Tolerance: float32 against
    MuJoCo's float64."""
    m = load_model("models/quadruped.wl", pipeline="exact")
    mj = load(m)
    for tilt in ((0.0, 0.0), (0.15, -0.1)):
        ours, theirs = _ours(m, tilt), _mujoco(m, mj, tilt)
        n = sensors.sizes(m)
        contact = slice(n["angles"] + 4, n["angles"] + 4 + n["contact"])
        if tilt == (0.0, 0.0):
            np.testing.assert_array_equal(ours[contact], 1.0)
            np.testing.assert_array_equal(theirs[contact], 1.0)
        keep = np.ones(len(ours), bool)
        keep[contact] = False
        np.testing.assert_allclose(ours[keep], theirs[keep], rtol=0, atol=2e-6)
    a, b = 0.15, -0.1        # the pendulums of a body turned by Ry(b) Rx(a): pitch a, roll atan2(sin b, cos a cos b)
    np.testing.assert_allclose(theirs[8:10], [np.arctan2(np.sin(b), np.cos(a) * np.cos(b)), a], atol=2e-6)


def test_a_policy_of_zeros_walks_in_mujoco_as_the_open_loop_cpg():
    """The closed loop stepped one step at a time by hand equals MuJoCo's own rollout of the CPG's controls: the same
    targets, the CPG's phase in float64 there and its basis in float32 here (measured: qpos within 3.7e-8 over 1 s,
    9.4e-7 over 10 s)."""
    m = load_model("models/quadruped.wl", pipeline="exact")
    c = read_ctl("models/quadruped-trot.ctl", n_dof=8, harmonics=2).coeffs.astype(np.float32)
    fam = pol.Family()
    closed = pol.from_genomes(fam, m, np.concatenate([c.reshape(1, -1), np.zeros((1, fam.n_weights(m)))], 1))
    _, q_open, _ = mujoco_run(m, c[None], time=1.0)
    _, q_closed, _, obs = mujoco_closed_run(m, closed, time=1.0, record=True)
    assert q_closed.shape == q_open.shape and obs.shape == (1, 500, 20)
    np.testing.assert_allclose(q_closed, q_open, rtol=0, atol=1e-6)
    assert obs[0, -1, 12:16].sum() >= 1                      # it walks on its feet


def test_the_controller_is_held_for_the_robots_control_period_at_a_shorter_mujoco_step():
    """MuJoCo C at a quarter of the model's 2 ms step: the controller reads and acts every fourth step and holds its
    action in between, as our step holds it (one observation per 2 ms, the actuators' inputs constant over each)."""
    m = load_model("models/quadruped.wl", pipeline="exact")
    c = read_ctl("models/quadruped-trot.ctl", n_dof=8, harmonics=2).coeffs.astype(np.float32)
    fam = pol.Family()
    closed = pol.from_genomes(fam, m, np.concatenate([c.reshape(1, -1), np.zeros((1, fam.n_weights(m)))], 1))
    seen = []
    _, q, _, obs = mujoco_closed_run(m, closed, time=0.02, timestep=m.dt / 4, record=True,
                                     watch=lambda s, ds: seen.append(ds[0].ctrl.copy()))
    assert q.shape[1] == 41 and obs.shape == (1, 10, 20)
    u = np.asarray(seen).reshape(10, 4, -1)
    np.testing.assert_array_equal(u, np.repeat(u[:, :1], 4, 1))
    assert np.abs(np.diff(u[:, 0], axis=0)).max() > 1e-4      # and it acts anew each period
    with control_period(m.dt / 4):          # `agreement --mujoco-control-dt`: every MuJoCo step, as before
        _, _, _, every = mujoco_closed_run(m, closed, time=0.02, timestep=m.dt / 4, record=True)
    assert every.shape == (1, 40, 20)
    np.testing.assert_array_equal(every[:, 0], obs[:, 0])    # the same first reading, at t = 0
    with pytest.raises(ValueError, match="control period"):
        with control_period(0.0):
            pass


def test_the_stance_reading_is_the_touch_sensors_low_pass_in_mujoco_as_here():
    """``stance`` is each touch sensor's reading low-passed step by step (sensors.stance_update, a = dt / tau), from
    its first reading on, in MuJoCo C's runner as in our episode (episode/test_policy.py's touch test): checked on
    every control period of the trot's first 0.3 s, whose feet land and lift, its policy reading both groups with
    weights of zero.  Tolerance: none beyond float64's rounding."""
    m = load_model("models/quadruped.wl", pipeline="exact")
    a = m.dt / sensors.STANCE_TAU
    c = read_ctl("models/quadruped-trot.ctl", n_dof=8, harmonics=2).coeffs.astype(np.float32)
    fam = pol.Family(inputs=("contact", "stance"))
    closed = pol.from_genomes(fam, m, np.concatenate([c.reshape(1, -1), np.zeros((1, fam.n_weights(m)))], 1))
    _, _, _, obs = mujoco_closed_run(m, closed, time=0.3, record=True)
    contact, stance = obs[0, :, :4], obs[0, :, 4:]
    assert 0 < contact.mean() < 1 and np.abs(np.diff(contact, axis=0)).sum() >= 4, "the feet land and lift"
    np.testing.assert_array_equal(stance[0], contact[0])
    np.testing.assert_allclose(stance[1:], stance[:-1] + a * (contact[1:] - stance[:-1]), rtol=0, atol=1e-12)
    assert ((stance > 0) & (stance < 1)).any()
