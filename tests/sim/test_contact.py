"""Ground contact (cpgjax/sim/contact.py): eq. 3.7, static and dynamic friction, and a score that is not chaotic."""

import numpy as np
import pytest
from simcases import BOX_DROPPED, SLOPE, SLOPES, box, boxes, slopes

from cpgjax.episode.batch import simulate


def test_resting_penetration_is_m_g_over_A_contacts():
    r = boxes()                                   # the nominal box: tests/simcases.py, one program for the file
    depth = 0.05 - r["traj"]["x"][-1, 2, 0, 0]
    expected = 10.0 * 9.81 / (1e5 * 4)  # four bottom corners
    assert abs(depth - expected) / expected < 0.02, (depth, expected)


def test_static_friction_holds_a_block_on_a_slope_below_the_friction_angle():
    r = slopes()                                  # mu 0.6 on a 0.3 rad ramp (tan 0.31)
    y, t = r["traj"]["x"][:, 1, 0, 0], r["traj"]["t"]
    creep = abs(y[-1] - y[25]) / (t[-1] - t[25])       # after settling (0.5 s)
    assert creep < 1e-3, f"creeps {creep * 1e3:.3f} mm/s"


def test_dynamic_friction_lets_it_slide_with_the_coulomb_acceleration():
    r = slopes()                                  # mu 0.1 on the same ramp
    t = r["traj"]["t"]
    v = r["traj"]["v"][:, :, 0, 1]
    speed = np.linalg.norm(v, axis=1)
    sel = (t > 0.5) & (t < 1.8)
    acc = np.polyfit(t[sel], speed[sel], 1)[0]
    mu = 0.4 * SLOPES["friction"][1]
    expected = 9.81 * (np.sin(SLOPE) - mu * np.cos(SLOPE))
    assert abs(acc - expected) / expected < 0.05, (acc, expected)


def test_a_body_sinks_no_deeper_than_a_few_millimetres_when_dropped():
    r = boxes()                                   # the box dropped from 0.5 m
    assert not r["diverged"][BOX_DROPPED]
    assert r["depth"][BOX_DROPPED] < 0.01
    z = r["traj"]["x"][:, 2, 0, BOX_DROPPED]
    assert z[0] > 0.49 and abs(z[-1] - r["traj"]["x"][-1, 2, 0, 0]) < 1e-4      # it fell, and rests as the others


@pytest.mark.slow  # 3 s of the quadruped on a ramp; fast: a block held on a slope below its friction angle, this file
def test_the_quadruped_standing_on_a_gentle_ramp_does_not_creep():
    """Below its friction angle (tan 0.1 << mu 2.5) the standing robot holds: it creeps < 1 mm/s."""
    from cpgjax.io.wl import load_model

    m = load_model("models/quadruped.wl", terrain="ramp:0.1")
    r = simulate(m, np.zeros((m.n_ctrl, m.n_coeff)), time=3.0, record=True)
    y, t = r["traj"]["x"][:, 1, m.track], r["traj"]["t"]
    sel = t >= 1.0
    creep = abs(y[sel][-1] - y[sel][0]) / (t[sel][-1] - t[sel][0])
    assert not r["fallen"] and creep < 1e-3, f"creeps {creep * 1e3:.3f} mm/s"


@pytest.mark.slow  # three steps, three programs; fast: a dropped body sinks no deeper than a few mm, this file
def test_the_bounce_of_a_dropped_box_converges_as_the_step_shrinks():
    """B, not dt, sets the restitution: a 1 kg box dropped from 0.5 m (B = 1e3 over-damps it on 4 corners:
    damping ratio 3.2) bounces (almost) nothing, and the bounce shrinks with the step.  The old locally
    implicit damper bounced 0.21 / 0.027 / 0.0007 m at 5e-4 / 1e-4 / 2e-5 s."""
    bounce = []
    for dt in (5e-4, 1e-4, 2e-5):
        m = box(z=0.5, mass=1.0, log_rate=1000).replace(dt=dt)
        r = simulate(m, np.zeros((0, 5)), time=0.7, record=True)
        z, t = r["traj"]["x"][:, 2, 0], r["traj"]["t"]
        i = int(np.argmin(z[t < 0.45]))                       # the first impact, at t = 0.32 s
        bounce.append(float(z[i:].max() - 0.05))
    assert bounce[0] < 0.1 and bounce[1] < 1e-3 and bounce[2] < 1e-3, bounce
    assert abs(bounce[2] - bounce[1]) <= abs(bounce[1] - bounce[0]), bounce


@pytest.mark.slow  # 64 replays of 10 s; fast: the trot walks (episode/test_rollout.py)
def test_a_walking_score_is_not_chaotic():
    """The trot with every gene moved by N(0, 1e-6): 64 replays of 10 s score within sd 0.003, none falls.

    Measured: sd 0.0016-0.0019 (3 jitter seeds).

    With the thesis's stiff stick-slip friction the same replays scored with sd 0.0089 (MuJoCo C: 0.0003);
    docs/simulator.md has the measurements.
    """
    from cpgjax.io.ctl import read_ctl
    from cpgjax.io.wl import load_model

    m = load_model("models/quadruped.wl")
    c = read_ctl("models/quadruped-trot.ctl", n_dof=8, harmonics=2).coeffs
    C = c[None] + np.random.default_rng(0).normal(0.0, 1e-6, (64,) + c.shape)
    r = simulate(m, C, time=10.0)
    assert r["fallen"].sum() == 0 and r["fitness"].std() < 0.003, r["fitness"].std()


def test_the_friction_bristle_holds_with_its_spring_and_slides_at_the_coulomb_cap():
    """On an immovable body (K = 0) at rest the implicit friction is exactly the bristle spring ``-k z``
    (``FrictionSpring k b``), up to ``mu f_n`` with ``f_n = A d``; beyond it the vertex slides with ``mu_d f_n``."""
    import jax
    import jax.numpy as jnp

    from cpgjax.sim.contact import contact_forces
    from cpgjax.sim.rotation import quat_to_mat
    from cpgjax.sim.state import initial_state, point_kinematics

    m = box(z=0.049, friction=0.8, extra="FrictionSpring 2e4 50").replace(fixed=np.array([True]))
    assert (m.friction_k, m.friction_b) == (2e4, 50.0)
    z = np.zeros((3, len(m.ct_pt), 2))
    z[0, :, 0], z[1, :, 1] = 1e-4, 0.02       # robot 0: 0.1 mm along x (sticks); robot 1: 2 cm along y

    @jax.jit        # one program (op by op: a compile for each operation)
    def forces(z):
        s = initial_state(m, 2)
        R = quat_to_mat(s.q)
        r, p, pv = point_kinematics(m, s, R)
        anchor = p[:, m.ct_pt] - z
        zero = jnp.zeros((3, m.nb, 2))
        return (anchor, *contact_forces(m, R, r, p, pv, zero, zero, anchor, jnp.zeros((len(m.ct_pt), 2))))

    anchor, f, depth, new_anchor, fn = (np.asarray(x) for x in forces(jnp.asarray(z, jnp.float32)))
    down = depth[:, 0] > 0                                     # the four bottom corners, 1 mm deep
    assert down.sum() == 4
    np.testing.assert_allclose(fn[down], 1e5 * 1e-3, rtol=1e-3)
    np.testing.assert_allclose(f[0, down, 0], -2e4 * 1e-4, rtol=1e-3)      # -k z
    np.testing.assert_allclose(f[1, down, 0], 0.0, atol=1e-6)
    np.testing.assert_allclose(f[1, down, 1], -0.8 * 100.0, rtol=1e-3)     # capped: -mu f_n
    assert np.allclose(new_anchor[:, down, 0], anchor[:, down, 0])          # sticking: the anchor stays
