"""Free rigid bodies (cpgjax/sim/springs/bodies.py): free fall, momentum and energy."""

import jax
import jax.numpy as jnp
import numpy as np
from simcases import BOX_DROPPED, BOXES, box, boxes, chain, energy

from cpgjax.episode.batch import simulate
from cpgjax.io.logs import quat_to_mat_np
from cpgjax.sim import step
from cpgjax.sim.state import initial_state


def test_free_fall_matches_z0_minus_half_g_t2():
    m = box(z=50.0, contact=False)
    r = simulate(m, np.zeros((0, 5)), time=1.0, record=True)
    t = r["traj"]["t"]
    z = r["traj"]["x"][:, 2, 0]
    exact = 50.0 - 0.5 * 9.81 * t**2
    # semi-implicit Euler lags the exact parabola by g t dt / 2 at most
    assert np.all(np.abs(z - exact) <= 9.81 * t * m.dt + 1e-4)
    assert abs(z[-1] - exact[-1]) < 5e-3


def test_gravity_is_a_parameter():
    m = box(z=50.0, contact=False, gravity=1.62)
    r = simulate(m, np.zeros((0, 5)), time=1.0, record=True)
    assert abs(r["traj"]["x"][-1, 2, 0] - (50.0 - 0.5 * 1.62)) < 2e-3


def _momenta(model, s):
    x, v, w, q = (np.asarray(a)[..., 0] for a in (s.x, s.v, s.w, s.q))
    P = (model.mass[None] * v).sum(1)
    L = np.zeros(3)
    for b in range(model.nb):
        R = quat_to_mat_np(q[:, b])
        L += model.mass[b] * np.cross(x[:, b], v[:, b]) + R @ model.inertia[:, :, b] @ R.T @ w[:, b]
    return P, L


def test_momentum_of_a_jointed_chain_is_conserved_without_gravity_and_ground():
    model = chain()
    s = initial_state(model, 1)
    rng = np.random.default_rng(1)
    s = s._replace(v=jnp.asarray(rng.normal(0, 0.3, s.v.shape), jnp.float32),
                   w=jnp.asarray(rng.normal(0, 1.0, s.w.shape), jnp.float32))
    P0, L0 = _momenta(model, s)
    targets = (jnp.full((2, 1), 0.5), jnp.zeros((2, 1)))  # servos drive: internal torques only

    @jax.jit
    def run(s):
        return jax.lax.scan(lambda s, _: (step(model, s, targets), None), s, None, length=2000)[0]

    s1 = run(s)
    P1, L1 = _momenta(model, s1)
    assert np.isfinite(P1).all()
    np.testing.assert_allclose(P1, P0, atol=2e-3 * (1 + np.abs(P0).max()))
    np.testing.assert_allclose(L1, L0, atol=5e-3 * (1 + np.abs(L0).max()))
    # and the joints did move
    assert np.abs(np.asarray(s1.x) - np.asarray(s.x)).max() > 0.01


def test_a_dropped_passive_body_never_gains_energy():
    """A 10 kg box dropped from 0.5 m (tests/simcases.py: the shared boxes' program), sampled every 5 ms."""
    m = box(z=0.05, mass=10.0)
    r = boxes()
    E = energy(m, {k: v[..., BOX_DROPPED] for k, v in r["traj"].items() if k != "t"})
    E0 = m.gravity * m.mass[0] * (m.x0[2, 0] + BOXES["lift"][BOX_DROPPED])
    assert np.all(E <= E0 * (1 + 1e-3)), E.max() / E0
    assert E[-1] < 0.2 * E0  # it came to rest on the ground
