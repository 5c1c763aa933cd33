"""Joints as stiff damped pivot springs (eq. 3.6), joint angles and joint limits.

A revolute joint is two pivot springs a small distance apart along its axis: together
they hold the pivot and the axis; rotation about the axis stays free.  The spring
force on the first body's pivot is ``F = alpha (p_b - p_a) + beta (v_b - v_a)`` and
``-F`` acts on the second (eq. 3.6).  The damper is integrated implicitly, locally per
spring: ``beta_eff = beta / (1 + dt beta / m_eff)`` with a conservative (mass-split)
effective mass, which is what lets the step grow past the explicit limit ``dt < 2 m/beta``
while the static stiffness stays exactly ``alpha``.
"""

from __future__ import annotations

import jax.numpy as jnp

from cpgjax.sim.rotation import atan2, cross, dot, matvec


def pivot_spring_forces(model, p, pv):
    """Force on the first end of every pivot spring [3, ns, B] (its negative acts on the second)."""
    dpos = p[:, model.sp_b] - p[:, model.sp_a]
    dvel = pv[:, model.sp_b] - pv[:, model.sp_a]
    beta_eff = (model.beta / (1.0 + model.dt * model.beta * model.sp_inv_meff))[:, None]
    return model.alpha * dpos + beta_eff * dvel


def joint_angles(model, R, w):
    """Joint angle [nj, B] (b relative to a, about the axis) and its rate, plus the world axis."""
    Ra, Rb = R[:, :, model.j_a], R[:, :, model.j_b]
    axis = matvec(Ra, model.j_axis[:, :, None])
    ua = matvec(Ra, model.j_ref[:, :, None])
    ub = matvec(Rb, model.j_ref[:, :, None])
    angle = atan2(dot(cross(ua, ub), axis), dot(ua, ub))
    rate = dot(w[:, model.j_b] - w[:, model.j_a], axis)
    return angle, rate, axis


def implicit_damping(model, c, inv_ieff=None):
    """Damping coefficient about the joint axes integrated implicitly: c / (1 + dt c / I_eff) [nj, 1].

    1/I_eff = a.(Ia^-1 + Ib^-1).a in the body frames (the axis is fixed in both), a
    conservative bound: the relative rotation of two free bodies about their CMs.  ``inv_ieff``
    [nj, B]: the exact 1/I_eff of each joint in the articulated robot (exact joints, `sim.articulated`).
    """
    if inv_ieff is not None:
        return c[:, None] / (1.0 + model.dt * c[:, None] * inv_ieff)
    return (c / (1.0 + model.dt * c * model.j_inv_ieff))[:, None]


def limit_torques(model, angle, rate, inv_ieff=None):
    """Stiff penalty torque [nj, B] beyond the joint limits (implicit damper; ``inv_ieff``: see
    :func:`implicit_damping`)."""
    lo, hi = model.j_lo[:, None], model.j_hi[:, None]
    over = jnp.maximum(angle - hi, 0.0)
    under = jnp.minimum(angle - lo, 0.0)
    active = (over > 0) | (under < 0)
    c = implicit_damping(model, model.limit_c * jnp.ones(model.nj), inv_ieff)
    return -model.limit_k * (over + under) - jnp.where(active, c * rate, 0.0)
