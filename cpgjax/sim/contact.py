"""Ground contact at the contact vertices (eq. 3.7, Appendix B).

Normal reaction ``f_r = A d - B v_n`` for a vertex at depth ``d`` below the terrain
(A = 1e5 kg/s^2, B = 1e3 kg/s in the thesis), never pulling.  The damper is integrated
implicitly per vertex with a conservative effective mass (see `joints`), so the
resting penetration is exactly ``m g / (A * contacts)``.

Friction (Appendix B has a static and a dynamic branch) is a stick-slip penalty:
each vertex in contact is tied to an anchor on the ground by a tangential spring
``k_t`` with damper ``b_t`` (static friction: the vertex sticks while that force is
within ``mu_s f_r``); beyond it the vertex slides with ``mu_d f_r`` and its anchor is
dragged along so that the spring holds exactly that force (dynamic friction).  A
vertex out of contact carries its anchor with it.  Unlike a velocity-only friction,
the sticking force does not depend on the step.
"""

from __future__ import annotations

import jax.numpy as jnp

from cpgjax.sim.rotation import dot
from cpgjax.sim.terrain import height_and_normal

FRICTION_K = 1.0e5  # N/m    tangential (stiction) spring, as stiff as the ground (A)
FRICTION_B = 1.0e3  # N s/m  its damper, as the ground's (B)


def contact_forces(model, p, pv, anchor, var=None):
    """Force [3, nc, B] at each contact vertex, its depth [nc, B] and the new anchors [3, nc, B].

    ``var`` (a :class:`~cpgjax.sim.variation.Variation`) scales the friction coefficients and shifts the
    terrain lookup per robot; ``None`` is the nominal robot.
    """
    cp, cv = p[:, model.ct_pt], pv[:, model.ct_pt]
    if model.terrain.flat:  # fast path: z_g = 0, n = (0, 0, 1), no lookup
        zero = jnp.zeros_like(cp[2])
        n = jnp.stack([zero, zero, zero + 1.0])
        depth = -cp[2]
    else:
        sx, sy = (0.0, 0.0) if var is None else (var.shift[0], var.shift[1])
        zg, n = height_and_normal(model.terrain, cp[0] + sx, cp[1] + sy)
        n = jnp.stack(n)
        depth = (zg - cp[2]) * n[2]
    vn = dot(cv, n)
    inv_m = model.ct_inv_meff[:, None]
    dt = model.dt
    B_eff = model.ground_B / (1.0 + dt * model.ground_B * inv_m)
    touch = depth > 0
    fn = jnp.where(touch, jnp.maximum(model.ground_A * depth - B_eff * vn, 0.0), 0.0)
    # stick-slip friction
    d = cp - anchor
    d = d - dot(d, n) * n
    vt = cv - vn * n
    bt_eff = FRICTION_B / (1.0 + dt * FRICTION_B * inv_m)
    f_spring = -FRICTION_K * d - bt_eff * vt
    mag = jnp.sqrt(dot(f_spring, f_spring) + 1e-12)
    mu_s, mu_d = model.mu_static, model.mu_dynamic
    if var is not None:
        mu_s, mu_d = mu_s * var.friction, mu_d * var.friction
    slide = mag > mu_s * fn
    f_slide = mu_d * fn
    ft = jnp.where(slide, f_spring * (f_slide / mag), f_spring)
    # sliding: the anchor trails the vertex so that the spring alone holds mu_d f_r
    d_mag = jnp.sqrt(dot(d, d) + 1e-18)
    d_new = d * jnp.minimum(1.0, f_slide / (FRICTION_K * d_mag))
    new_anchor = jnp.where(touch, jnp.where(slide, cp - d_new, anchor), cp)
    ft = jnp.where(touch, ft, 0.0)
    return fn * n + ft, depth, new_anchor
