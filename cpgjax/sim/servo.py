"""The joint servo: a PID position loop with torque saturation (thesis Ch. 5, 6.1.1).

The real robot ran one LM628 PID chip per joint on 0.35 N m DC motors through 50:1
gearboxes, hence the default saturation of 17.5 N m.  The CPG gives the target angle
and its rate; the derivative acts on the error rate and is integrated implicitly
(see `joints.implicit_damping`).
"""

from __future__ import annotations

import jax.numpy as jnp

from cpgjax.sim.joints import implicit_damping


def servo_torques(model, angle, rate, target, target_rate, e_int, gain=None):
    """Torque [nj, B] about each joint axis (zero on passive joints) and d(e_int)/dt [nctrl, B].

    ``gain`` [nctrl, B] (a :class:`~cpgjax.sim.variation.Variation`) scales kp, ki and kd per robot.
    """
    cj = model.ctrl_joint
    err = target - angle[cj]
    derr = target_rate - rate[cj]
    kp, ki, tmax = (g[cj][:, None] for g in (model.j_kp, model.j_ki, model.j_taumax))
    if gain is None:
        kd = implicit_damping(model, model.j_kd)[cj]
    else:
        kp, ki = kp * gain, ki * gain
        c = model.j_kd[cj][:, None] * gain
        kd = c / (1.0 + model.dt * c * model.j_inv_ieff[cj][:, None])
    tau_c = jnp.clip(kp * err + ki * e_int + kd * derr, -tmax, tmax)
    tau = jnp.zeros_like(angle).at[cj].set(tau_c) if len(cj) else jnp.zeros_like(angle)
    return tau, err
