"""Joint angles and joint limits, shared by both pipelines.

A joint's angle is measured from its two bodies' rotations (b relative to a, about the axis; 0 is the
design pose of the `.wl` file); beyond ``Limits lo hi`` a stiff penalty torque pushes it back.  On the
springs pipeline a damper about a joint axis (the limits', the servo's derivative) is integrated
implicitly and locally: ``c_eff = c / (1 + dt c / I_eff)`` with a conservative effective inertia
(:func:`implicit_damping`); the exact pipeline puts ``dt c`` into its joint-space inertia instead.
"""

from __future__ import annotations

import jax.numpy as jnp

from cpgjax.sim.rotation import cross, dot, matvec
from cpgjax.sim.tricks import poly_atan2


def joint_angles(model, R, w):
    """Joint angle [nj, B] (b relative to a, about the axis) and its rate, plus the world axis."""
    Ra, Rb = R[:, :, model.j_a], R[:, :, model.j_b]
    axis = matvec(Ra, model.j_axis[:, :, None])
    ua = matvec(Ra, model.j_ref[:, :, None])
    ub = matvec(Rb, model.j_ref[:, :, None])
    angle = (poly_atan2 if model.poly_atan2 else jnp.arctan2)(dot(cross(ua, ub), axis), dot(ua, ub))
    rate = dot(w[:, model.j_b] - w[:, model.j_a], axis)
    return angle, rate, axis


def implicit_damping(model, c):
    """Damping coefficient about the joint axes integrated implicitly: c / (1 + dt c / I_eff) [nj, 1].

    1/I_eff = a.(Ia^-1 + Ib^-1).a in the body frames (the axis is fixed in both), a
    conservative bound: the relative rotation of two free bodies about their CMs.
    """
    return (c / (1.0 + model.dt * c * model.springs.j_inv_ieff))[:, None]


def limit_torques(model, angle, rate, implicit=True):
    """Stiff penalty torque [nj, B] beyond the joint limits (implicit damper; ``implicit=False``: the nominal
    damping on the rate given, for exact joints, which put ``dt c`` into the joint-space inertia)."""
    lo, hi = model.j_lo[:, None], model.j_hi[:, None]
    over = jnp.maximum(angle - hi, 0.0)
    under = jnp.minimum(angle - lo, 0.0)
    active = (over > 0) | (under < 0)
    c = implicit_damping(model, model.limit_c * jnp.ones(model.nj)) if implicit else model.limit_c
    return -model.limit_k * (over + under) - jnp.where(active, c * rate, 0.0)
