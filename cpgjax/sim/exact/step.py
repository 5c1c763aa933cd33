"""Exact joints: one step of the robot in generalized coordinates.

The thesis's pipeline (`sim.springs`) integrates every body free and holds the joints with stiff pivot springs
(eq. 3.6); its step is bound by those springs.  This pipeline keeps the same bodies, servo (PID with saturation,
Ch. 5), joint limits, eq. 3.7's ground with the implicit damper and friction bristle (`sim.contact`), terrain and
`Variation`s, but describes the robot by a floating base and one angle per revolute joint (`sim.exact.tree`), so
that the joints hold exactly.  A step, in MuJoCo's stages (`sim.exact.smooth`):

1. ``com_pos``, ``inertia``, ``crb``: the joint-space inertia ``qM`` by the composite-rigid-body algorithm, in
   world axes about each tree root's CM;
2. the servos' torque (saturated) and the joint limits', on the joint rates at the start of the step, their
   dampers ``D`` implicit: ``dt D`` added to ``qM``'s diagonal (a saturated servo adds none, as in MuJoCo's
   implicit integrators);
3. ``rne``'s two passes: the bias forces (gravity, Coriolis, gyroscopic) by recursive Newton-Euler;
4. ``contact`` (`sim.exact.contact`): ``(qM + dt D + dt J^T K J) qacc = tau - qfrc_bias + J^T (a - K J u)``, the
   ground's dampers implicit and coupled over the whole robot (without contact vertices: ``factor_m`` and
   ``solve_m`` alone);
5. :func:`integrate`: semi-implicit Euler on the generalized velocities and positions, then ``kinematics`` for the
   bodies' poses and velocities (``State.x, q, v, w``: what the rest of cpgjax reads, as from the other pipeline).
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from cpgjax.sim.exact.contact import contact
from cpgjax.sim.exact.levels import Dofs, dofs_add, from_levels, to_levels
from cpgjax.sim.exact.smooth import bias_wrenches, com_pos, crb, factor_m, inertia, kinematics, project, solve_m
from cpgjax.sim.joints import limit_torques
from cpgjax.sim.rotation import quat_integrate
from cpgjax.sim.servo import servo_gains, servo_pi, servo_torques
from cpgjax.sim.state import ExactState
from cpgjax.sim.tricks import add_at, take


def step(model, state, ctrl, var=None):
    """Advance a batch of robots by ``model.dt`` on exact joints under servo targets ``ctrl = (q*, dq*/dt)``."""
    lv = model.exact.levels
    dt = model.dt
    target, target_rate = ctrl
    gain = None if var is None else var.gain
    angle, rate = state.exact.angle, state.exact.rate
    com = com_pos(model, state)
    inert = inertia(model, com, var)
    qM = crb(model, com, inert)
    # servo and joint limits: their torques on the rates at the start of the step, their dampers implicit in
    # the joint-space inertia (qM + dt D), as MuJoCo's implicit integration does (a saturated servo adds none)
    tau_pi, err = servo_pi(model, angle, target, state.e_int, gain)
    tau_j = limit_torques(model, angle, rate, implicit=False)
    if model.nj:
        lo, hi = model.j_lo[:, None], model.j_hi[:, None]
        damp = jnp.where((angle > hi) | (angle < lo), model.limit_c, 0.0)
        if model.n_ctrl:
            cj = model.ctrl_joint
            torque = None if var is None else var.torque
            tau_s = servo_torques(model, tau_pi, rate[cj], target_rate, gain, implicit=False, torque=torque)
            _, _, kd, tmax = servo_gains(model, gain, implicit=False, torque=torque)
            tau_j = add_at(tau_j, cj, tau_s)
            damp = add_at(damp, cj, jnp.where(jnp.abs(tau_s) < tmax, kd, 0.0))
        qM = qM._replace(diag=tuple(None if lvl == 0 else d + dt * take(damp, lv.joint[lvl])
                                    for lvl, d in enumerate(qM.diag)))
    # -qfrc_bias (smooth.rne) with the wrenches negated before the projection: the same numbers as negating
    # qfrc_bias, compiled otherwise by XLA, whose last-bit difference a walk's chaos grows
    force, torque = bias_wrenches(model, com, inert, to_levels(model, rate))
    qfrc = project(model, com, [-f for f in force], [-n for n in torque])
    if model.nj:
        qfrc = dofs_add(qfrc, Dofs(None, to_levels(model, tau_j)))
    if len(model.ct_pt):
        qacc, anchor, f_n = contact(model, state, com, qM, qfrc, var)
    else:
        qacc = solve_m(model, factor_m(model, qM), qfrc)
        anchor, f_n = state.anchor, state.f_n
    return integrate(model, state, qacc)._replace(e_int=state.e_int + dt * err, anchor=anchor, f_n=f_n,
                                                  n=state.n + 1)


def integrate(model, state, qacc: Dofs):
    """Semi-implicit Euler on the generalized coordinates (velocities first, then positions with the new
    velocities), then the bodies' poses and velocities by forward kinematics."""
    lv = model.exact.levels
    dt = model.dt
    roots = lv.bodies[0]
    free = lv.free.astype(np.float32)[:, None]
    v0 = take(state.v, roots) + dt * qacc.root[0:3] * free
    w0 = take(state.w, roots) + dt * qacc.root[3:6] * free
    x0 = take(state.x, roots) + dt * v0
    q0 = quat_integrate(take(state.q, roots), w0, dt)
    if not lv.free.all():
        q0 = jnp.where(lv.free[:, None], q0, take(state.q, roots))
    angle, rate = state.exact.angle, state.exact.rate
    if model.nj:
        rate = rate + dt * from_levels(model, qacc.joint)
        angle = angle + dt * rate
    x, q, v, w = kinematics(model, (x0, q0, v0, w0), to_levels(model, angle), to_levels(model, rate))
    return state._replace(x=x, q=q, v=v, w=w, exact=ExactState(angle, rate))
