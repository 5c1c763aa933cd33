"""Exact joints' step (cpgjax/sim/exact/step.py): physics against physics, and against the thesis's pipeline.

Small models keep the compiled programs small (the step is straight-line code whose size grows with the robot).
The stages one by one against MuJoCo C: test_stages.py; the tree: test_tree.py.
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from simcases import box, chain, double_pendulum, energy, model_from, pendulum, period, rig

from cpgjax.episode.batch import simulate
from cpgjax.sim import step
from cpgjax.sim.state import initial_state


def test_pendulum_has_the_small_angle_period_of_its_inertia_at_a_2_ms_step():
    L, mass = 0.5, 1.0
    m = pendulum(angle=0.05, length=L, mass=mass, log_rate=500).replace(dt=2e-3, pipeline="exact")
    r = simulate(m, np.zeros((0, 5)), time=3.0, record=True)
    d = L / 2
    I_pivot = mass * (L**2 + 0.02**2) / 12 + mass * d**2
    expected = 2 * np.pi * np.sqrt(I_pivot / (mass * 9.81 * d))
    measured = period(r["traj"]["t"], r["traj"]["angle"][:, 0])
    # semi-implicit Euler's period error is O(dt^2) (about 1e-5 here) and the 0.05 rad amplitude adds 1.6e-4
    assert abs(measured - expected) / expected < 2e-3, (measured, expected)
    # the pivot is exact: the rod's end stays on the fixed block (float32 rounding only)
    assert r["pivot_err"] < 1e-5


def _run(model, state, n, ctrl=None):
    if ctrl is None:
        z = jnp.zeros((model.n_ctrl, state.x.shape[-1]))
        ctrl = (z, z)

    def body(s, _):
        s = step(model, s, ctrl)
        return s, s

    return jax.jit(lambda s: jax.lax.scan(body, s, None, length=n))(state)


def _momenta(model, s):
    """Linear and angular momentum (about the world origin) [3, B] of a state."""
    from cpgjax.sim.rotation import quat_to_mat

    m = jnp.asarray(model.mass)[:, None]
    p = jnp.sum(m * s.v, axis=1)
    R = quat_to_mat(s.q)
    L = 0.0
    for b in range(model.nb):
        Rb = R[:, :, b]
        Iw = jnp.einsum("ikB,kl,jlB->ijB", Rb, jnp.asarray(model.inertia[:, :, b], jnp.float32), Rb)
        L = L + jnp.einsum("ijB,jB->iB", Iw, s.w[:, b]) + jnp.cross(s.x[:, b], model.mass[b] * s.v[:, b], axis=0)
    return p, L


def _tumbling_chain(dt):
    m = chain(gravity=0.0).replace(dt=dt, pipeline="exact")
    free = m.replace(j_kp=np.zeros(2), j_kd=np.zeros(2))          # no servo: internal forces only
    s0 = initial_state(free, 1)
    # set it tumbling: a spin of the base and both joints moving
    s0 = s0._replace(exact=s0.exact._replace(rate=jnp.array([[2.0], [-3.0]])),
                     w=s0.w.at[:, 0].set(jnp.array([[0.5], [1.0], [-0.7]])))
    s0 = step(free, s0, (jnp.zeros((2, 1)), jnp.zeros((2, 1))))   # body velocities consistent with the coordinates
    return free, s0


@pytest.mark.slow  # 13 s; fast: the energy of the pendulum and the double pendulum
def test_a_free_chain_in_space_keeps_its_momentum_and_energy_to_the_steps_first_order():
    """No external force: momentum is constant.  Semi-implicit Euler in generalized coordinates keeps it to
    O(dt) (the Coriolis force is explicit), as MuJoCo's Euler does: measured over 2 s, the drift is 0.5 % of the
    linear and 1.3 % of the angular momentum at 2 ms, and halves with the step."""
    drift = []
    for dt in (2e-3, 1e-3):
        m, s0 = _tumbling_chain(dt)
        sN, traj = _run(m, s0, int(round(2.0 / dt)))
        p0, L0 = _momenta(m, s0)
        pN, LN = _momenta(m, sN)
        drift.append((float(jnp.linalg.norm(pN - p0) / jnp.linalg.norm(p0)),
                      float(jnp.linalg.norm(LN - L0) / jnp.linalg.norm(L0))))
        if dt == 2e-3:
            tr = {k: getattr(traj, k)[:, :, :, 0] for k in ("x", "v", "w", "q")}
            e = energy(m, tr)
            assert np.abs(e - e[0]).max() < 0.02 * e[0], (e[0], e.min(), e.max())
    (p2, l2), (p1, l1) = drift
    assert p2 < 0.01 and l2 < 0.025, drift
    assert 1.8 < p2 / p1 < 2.2 and 1.8 < l2 / l1 < 2.2, drift      # first order: the integrator, not a bug


def test_a_passive_double_pendulum_keeps_its_energy_without_damping():
    m = double_pendulum().replace(pipeline="exact", dt=1e-3)
    s0 = initial_state(m, 1)
    _, traj = _run(m, s0, 2000)
    tr = {"x": traj.x[:, :, :, 0], "v": traj.v[:, :, :, 0], "w": traj.w[:, :, :, 0], "q": traj.q[:, :, :, 0]}
    e = energy(m, tr)
    swing = float(np.ptp(np.asarray(traj.exact.angle[:, 0, 0])))
    assert swing > 1.0            # it really swings (a chaotic double pendulum from 1 rad)
    # semi-implicit Euler: bounded oscillation of the energy, no growth; measured at 1 ms over 2 s: 0.3 % of the
    # swing's kinetic energy scale (m g l = 4 J), checked at 2 %
    scale = 9.81 * (1.0 * 0.4 + 0.5 * 0.3) * 2
    assert np.abs(e - e[0]).max() < 0.02 * scale, (e[0], e.min(), e.max())


def test_a_sliding_box_decelerates_at_mu_g_and_rests_at_eq_3_7s_depth_and_the_ground_never_pulls():
    """Coulomb's law on the coupled contact solve: a box sliding at 1 m/s on mu = 0.5 slows at mu g while it
    slides (the bristle's pull capped at the cone's share), and a box dropped from 5 cm bounces on a ground
    that pushes only (the second solve releases the vertices it would pull); after 2 s both rest at eq. 3.7's
    depth (one program for the three)."""
    mu, g = 0.5, 9.81
    m = box(z=0.05, mass=10.0, friction=mu).replace(pipeline="exact", dt=2e-3)
    s = initial_state(m, 2)
    rest = 0.05 - 10.0 * g / (1e5 * 4)
    x = s.x.at[2, 0, 0].set(rest).at[2, 0, 1].set(0.1)
    v = s.v.at[0, 0, 0].set(1.0)
    anchor = s.anchor.at[2, :, 0].add(rest - 0.05)
    _, traj = _run(m, s._replace(x=x, v=v, anchor=anchor), 1000)
    vx = np.asarray(traj.v[:, 0, 0, 0])                    # [steps]
    t = (np.arange(len(vx)) + 1) * 2e-3
    sliding = (t > 0.02) & (t < 0.15)                        # stops at v0 / (mu g) = 0.20 s
    slope = np.polyfit(t[sliding], vx[sliding], 1)[0]
    # measured -4.83 m/s^2 against -mu g = -4.905 (1.6 %: the box rocks a little on its front edge)
    assert abs(slope + mu * g) < 0.03 * mu * g, slope
    fn = np.asarray(traj.f_n[:150, :, 1])                  # the dropped box's first bounce
    assert fn.max() > 10.0 and fn.min() >= 0.0, (fn.max(), fn.min())
    assert np.asarray(traj.f_n).min() >= 0.0
    depth = 0.05 - np.asarray(traj.x[-1, 2, 0])             # both boxes, at rest after 2 s
    # four bottom corners; measured within 3e-5 of it (both boxes), checked at 2 %
    np.testing.assert_allclose(depth, 10.0 * g / (1e5 * 4), rtol=0.02)


@pytest.mark.slow  # a program per pipeline; fast: the stages against MuJoCo C (test_stages.py), the pendulum, this file
def test_the_two_pipelines_agree_on_a_servo_rig():
    """A servo-driven arm on a fixed block follows a sinusoid: the joint's path agrees across the pipelines
    (the springs stretch by a fraction of a millimetre, so the exact path is the limit of theirs)."""
    springs = rig(time=4)      # 4 s recorded: the springs' program of sim/test_joints.py's servo rig
    exact = rig(time=4).replace(pipeline="exact", dt=2e-3)
    coeffs = np.zeros((1, 5), np.float32)
    coeffs[0, 1] = 0.5          # 0.5 rad at f0
    a = simulate(springs, coeffs, time=4.0, record=True)["traj"]
    b = simulate(exact, coeffs, time=4.0, record=True)["traj"]
    assert np.abs(a["angle"]).max() > 0.3
    # past the first 0.1 s (the servo saturates on the target's jump at t = 0, which the two steps resolve
    # differently): measured 6e-5 rad apart over the 4 s at 2 ms against the springs' 0.5 ms
    late = a["t"] > 0.1
    assert np.abs(a["angle"][late] - b["angle"][late]).max() < 0.005


HOPPER = """
TimeMax 1
Object Body {
    Type Cube
    Mass 2
    Dimensions .2 .1 .05
    Position 0 0 .25
    Contact -.1 0 -.025
    Contact .1 0 -.025
}
Object Leg {
    Type Cube
    Mass .3
    Dimensions .02 .02 .2
    Contact 0 0 -.1
}
Joint Hip {
    Body .1 0 -.025
    Leg 0 0 .1
    ControlX
}
"""


def test_a_robots_result_does_not_depend_on_its_neighbours():
    """Three robots, then the same three among 17 others: one compiled program (the same input shape, so the
    same width on any host), other neighbours in the batch, the same bits (two widths: the slow test below)."""
    m = model_from(HOPPER, pipeline="exact")
    rng = np.random.default_rng(0)
    c = rng.uniform(-0.5, 0.5, (20, 1, 5)).astype(np.float32)
    three = np.concatenate([c[:3], np.repeat(c[2:3], 17, 0)])     # what `evaluate` pads a batch of 3 with
    one = simulate(m, three, time=0.5)
    many = simulate(m, c, time=0.5)
    assert len(set(many["fitness"].tolist())) == 20                  # 20 different episodes
    for k in ("fitness", "distance"):
        np.testing.assert_array_equal(one[k][:3], many[k][:3])


@pytest.mark.slow  # two programs of the exact step (25 s of CPU); fast: the neighbours above
def test_results_do_not_depend_on_the_batch_size():
    m = model_from(HOPPER, pipeline="exact")
    rng = np.random.default_rng(0)
    c = rng.uniform(-0.5, 0.5, (40, 1, 5)).astype(np.float32)   # 16 and 32 robots wide per device, 2 devices
    one = simulate(m, c[:3], time=0.5)
    many = simulate(m, c, time=0.5)
    for k in ("fitness", "distance"):
        np.testing.assert_array_equal(one[k], many[k][:3])
