"""The joint servo: a PID position loop with torque saturation (thesis Ch. 5, 6.1.1).

The real robot ran one LM628 PID chip per joint on 0.35 N m DC motors through 50:1
gearboxes, hence the default saturation of 17.5 N m.  The CPG gives the target angle
and its rate; the derivative acts on the error rate and is backward Euler over the step
(`servo_torques`; the PI torque is explicit), so the servo delivers its nominal kd.
"""

from __future__ import annotations

import jax.numpy as jnp

from cpgjax.sim.joints import implicit_damping


def servo_gains(model, gain=None, implicit=True, torque=None):
    """kp, ki, kd (implicit, see `joints.implicit_damping`) and the torque limit [nctrl, B|1].

    ``gain`` [nctrl, B] (a :class:`~cpgjax.sim.variation.Variation`) scales kp, ki and kd per robot, ``torque``
    [nctrl, B] (its ``torque``) the torque limit.
    ``implicit=False``: the nominal kd (exact joints put ``dt kd`` into the joint-space inertia instead).
    """
    cj = model.ctrl_joint
    kp, ki, tmax = (g[cj][:, None] for g in (model.j_kp, model.j_ki, model.j_taumax))
    if not implicit:
        kd = model.j_kd[cj][:, None]
        if gain is not None:
            kp, ki, kd = kp * gain, ki * gain, kd * gain
    elif gain is None:
        kd = implicit_damping(model, model.j_kd)[cj]
    else:
        kp, ki = kp * gain, ki * gain
        c = model.j_kd[cj][:, None] * gain
        kd = c / (1.0 + model.dt * c * model.springs.j_inv_ieff[cj][:, None])
    if torque is not None:
        tmax = tmax * torque
    return kp, ki, kd, tmax


def servo_pi(model, angle, target, e_int, gain=None):
    """The proportional and integral part of the servo torque [nctrl, B] and the error [nctrl, B]."""
    kp, ki, _, _ = servo_gains(model, gain, implicit=False)      # kp, ki: the same either way
    err = target - angle[model.ctrl_joint]
    return kp * err + ki * e_int, err


def servo_torques(model, tau_pi, rate_pred, target_rate, gain=None, implicit=True, torque=None):
    """Servo torque [nctrl, B]: ``clip(PI + kd' (dq*/dt - q'), -tau_max, tau_max)``.

    The derivative is backward Euler on the joint's two bodies: ``q'`` [nctrl, B] is the joint
    rate the step would give under every other force and torque, the PI torque included, and
    ``kd' = kd / (1 + dt kd / I_eff)`` (`joints.implicit_damping`), so that in slow motion the
    damper delivers the nominal ``kd``.  (With the rate at the start of the step in place of
    ``q'`` it would deliver ``kd'``, 0.45 kd on the quadruped's knee at 0.5 ms.)
    ``implicit=False`` (exact joints, `sim.exact`): the nominal kd on the rate given; the pipeline puts
    ``dt kd`` into its joint-space inertia, so that the damper acts on the end-of-step rate of the whole robot.
    """
    _, _, kd, tmax = servo_gains(model, gain, implicit, torque)
    return jnp.clip(tau_pi + kd * (target_rate - rate_pred), -tmax, tmax)
