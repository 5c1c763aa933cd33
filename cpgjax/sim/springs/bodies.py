"""Free rigid bodies: Newton-Euler about the CM (eq. 3.5) and semi-implicit Euler.

Each body has 6 DOF.  With forces F and torques tau (world frame) about the CM:
``m dv/dt = F + m g`` and, in the body frame, ``I dw_b/dt = tau_b - w_b x (I w_b)``
(the gyroscopic term of eq. 3.1).  Velocities are updated first, then positions with
the new velocities (semi-implicit, symplectic Euler); orientations are unit quaternions.
"""

from __future__ import annotations

from cpgjax.sim.rotation import cross, matTvec, matvec, quat_integrate


def accelerations(model, R, w, force, torque, mass_scale=None):
    """Linear and angular accelerations [3, nb, B] of the free bodies (fixed bodies: zero).

    ``mass_scale`` [nb, B] (a :class:`~cpgjax.sim.variation.Variation`) scales each body's mass and
    inertia per robot; ``None`` is the nominal robot.
    """
    free = (~model.fixed).astype(float)[:, None]
    m = model.mass[:, None] if mass_scale is None else model.mass[:, None] * mass_scale
    a = force / m
    a = a.at[2].add(-model.gravity)
    wb = matTvec(R, w)
    tb = matTvec(R, torque)
    I = model.inertia[:, :, :, None]
    Iinv = model.inv_inertia[:, :, :, None]
    if mass_scale is None:
        alpha_b = matvec(Iinv, tb - cross(wb, matvec(I, wb)))
    else:   # I' = s I: alpha = I^-1 (tau / s - w x I w)
        alpha_b = matvec(Iinv, tb / mass_scale - cross(wb, matvec(I, wb)))
    return a * free, matvec(R, alpha_b) * free


def torque_accelerations(model, R, torque, mass_scale=None):
    """Angular accelerations [3, nb, B] from extra torques alone (no gyroscopic term)."""
    free = (~model.fixed).astype(float)[:, None]
    alpha_b = matvec(model.inv_inertia[:, :, :, None], matTvec(R, torque))
    if mass_scale is not None:
        alpha_b = alpha_b / mass_scale
    return matvec(R, alpha_b) * free


def force_accelerations(model, R, force, torque, mass_scale=None):
    """Accelerations [3, nb, B] from extra forces and torques alone (no gravity, no gyroscopic term)."""
    free = (~model.fixed).astype(float)[:, None]
    m = model.mass[:, None] if mass_scale is None else model.mass[:, None] * mass_scale
    return force / m * free, torque_accelerations(model, R, torque, mass_scale)


def integrate(state, a, alpha, dt):
    """Semi-implicit Euler: v, w first, then x, q with the new velocities."""
    v = state.v + dt * a
    w = state.w + dt * alpha
    return state._replace(x=state.x + dt * v, v=v, w=w, q=quat_integrate(state.q, w, dt))
