"""Ground contact at the contact vertices (eq. 3.7, Appendix B).

Normal reaction ``f_r = A d - B v_n`` for a vertex at depth ``d`` below the terrain
(A = 1e5 kg/s^2, B = 1e3 kg/s in the thesis), never pulling.  The damper is integrated
implicitly per vertex with a conservative effective mass (see `joints`), so the
resting penetration is exactly ``m g / (A * contacts)``.

Friction (Appendix B has a static and a dynamic branch): the tangential force that
would stop the vertex's sliding within one step, ``m_eff |v_t| / dt``, is applied if
it is within ``mu_s f_r`` (static friction: sticking); otherwise the vertex slides
with ``mu_d f_r`` against its tangential velocity (dynamic friction).
"""

from __future__ import annotations

import jax.numpy as jnp

from cpgjax.sim.rotation import dot
from cpgjax.sim.terrain import height_and_normal


def contact_forces(model, p, pv):
    """Force [3, nc, B] at each contact vertex, and its depth [nc, B] (positive when inside)."""
    cp, cv = p[:, model.ct_pt], pv[:, model.ct_pt]
    if model.terrain.flat:  # fast path: z_g = 0, n = (0, 0, 1), no lookup
        zero = jnp.zeros_like(cp[2])
        n = jnp.stack([zero, zero, zero + 1.0])
        depth = -cp[2]
    else:
        zg, n = height_and_normal(model.terrain, cp[0], cp[1])
        n = jnp.stack(n)
        depth = (zg - cp[2]) * n[2]
    vn = dot(cv, n)
    inv_m = model.ct_inv_meff[:, None]
    dt = model.dt
    B_eff = model.ground_B / (1.0 + dt * model.ground_B * inv_m)
    fn = jnp.where(depth > 0, jnp.maximum(model.ground_A * depth - B_eff * vn, 0.0), 0.0)
    vt = cv - vn * n
    speed = jnp.sqrt(dot(vt, vt) + 1e-12)
    f_stick = speed / (inv_m * dt)
    ft = jnp.where(f_stick <= model.mu_static * fn, f_stick, model.mu_dynamic * fn)
    return fn * n - (ft / speed) * vt, depth
