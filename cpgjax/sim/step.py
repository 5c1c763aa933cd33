"""One simulation step of a batch of robots: ``step(model, state, ctrl) -> state`` (Ch. 3.4.1).

The stages follow the thesis's dynamics engine (Ch. 3.4.1, Appendix B): pivot positions
and velocities, joint penalties, servo torques, ground collisions, gravity, then
integration.  All arrays are batch-last (see `cpgjax.sim.layout`): the same code runs
one robot (B = 1) or thousands.
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from cpgjax.sim.bodies import accelerations, integrate
from cpgjax.sim.contact import contact_forces
from cpgjax.sim.joints import joint_angles, limit_torques, pivot_spring_forces
from cpgjax.sim.rotation import cross, matvec, quat_to_mat
from cpgjax.sim.servo import servo_torques


def point_kinematics(model, state, R):
    """World offset from the CM, position and velocity [3, npt, B] of every point."""
    pb = model.pt_body
    r = matvec(R[:, :, pb], model.pt_local[:, :, None])
    return r, state.x[:, pb] + r, state.v[:, pb] + cross(state.w[:, pb], r)


def incidence(model):
    """Static matrices that sum point forces and joint torques onto bodies."""
    P = np.zeros((model.nb, len(model.pt_body)))
    P[model.pt_body, np.arange(len(model.pt_body))] = 1.0
    J = np.zeros((model.nb, model.nj))
    J[model.j_b, np.arange(model.nj)] += 1.0
    J[model.j_a, np.arange(model.nj)] -= 1.0
    return P, J


def forces(model, state, ctrl):
    """Total force and torque on every body [3, nb, B], plus diagnostics."""
    target, target_rate = ctrl
    R = quat_to_mat(state.q)
    r, p, pv = point_kinematics(model, state, R)
    fs = pivot_spring_forces(model, p, pv)
    fc, depth, anchor = contact_forces(model, p, pv, state.anchor)
    ns = fs.shape[1]
    # points are ordered [spring a-end, spring b-end] * ns, then the contact vertices
    f_pt = jnp.concatenate([jnp.stack([fs, -fs], 2).reshape(3, 2 * ns, -1), fc], 1)
    angle, rate, axis = joint_angles(model, R, state.w)
    tau_servo, err = servo_torques(model, angle, rate, target, target_rate, state.e_int)
    tau = tau_servo + limit_torques(model, angle, rate)
    P, J = incidence(model)
    force = jnp.einsum("bp,kpn->kbn", P, f_pt)
    torque = jnp.einsum("bp,kpn->kbn", P, cross(r, f_pt)) + jnp.einsum("bj,kjn->kbn", J, tau * axis)
    return R, force, torque, err, anchor


def step(model, state, ctrl):
    """Advance the batch by one step of ``model.dt`` under servo targets ``ctrl = (q*, dq*/dt)``."""
    R, force, torque, err, anchor = forces(model, state, ctrl)
    a, alpha = accelerations(model, R, state.w, force, torque)
    new = integrate(state, a, alpha, model.dt)
    return new._replace(e_int=state.e_int + model.dt * err, anchor=anchor, t=state.t + model.dt)
