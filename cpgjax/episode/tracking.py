"""Servo tracking: one joint follows sinusoidal targets; its error is accumulated online (thesis 6.1.1).

The thesis measured the robot's PID chain by feeding single sinusoids of rising frequency to one
joint and averaging the absolute error over one oscillation (Figs. 6.1-6.2).  Here the same
experiment runs in the simulator on a *rig*: the joint's first body welded to the world (lifted
clear of the ground) and its second body with everything beyond it attached as in the robot
(:func:`servo_rig`).  :func:`tracking_rollout` drives the rig's joint with
``q*(t) = c + A sin(2 pi f t)`` (rate ``2 pi f A cos(2 pi f t)``), one ``(f, A)`` per robot of the
batch, holds every other controlled joint at ``c``, and accumulates in the `lax.scan`:

- ``err``: mean ``|q* - q|`` over the last whole periods of the episode (after ``settle`` s);
- ``ref``: mean ``|q* - c|`` over the same samples (``2A/pi`` for a sinusoid);
- ``rel = err / ref``: 0 for perfect tracking, 1 when the joint no longer moves (the quantity
  fitted with the thesis's sigmoid, `cpgjax.analysis.cutoff`).
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np

from cpgjax.errors import CpgjaxError
from cpgjax.sim.description import Description
from cpgjax.sim.joints import joint_angles
from cpgjax.sim.pipeline import step
from cpgjax.sim.rotation import mat_to_euler, quat_to_mat, quat_to_mat_np
from cpgjax.sim.state import initial_state, sim_time


class RigError(CpgjaxError, ValueError):
    """A servo rig that cannot be built (no such joint, a passive joint, ...)."""


def _subtree(desc: Description, body: str) -> list[str]:
    out, todo = [], [body]
    while todo:
        b = todo.pop()
        out.append(b)
        todo += [j.body_b for j in desc.joints if j.body_a == b]
    return out


def servo_rig(desc: Description, joint: str, *, lift: float = 1.0, gravity: float | None = None,
              tau_max: float | None = None) -> Description:
    """The test rig of ``joint``: its first body welded to the world ``lift`` m above its robot pose.

    Kept: the first body (``Fixed``) and the second body with its whole subtree of joints and bodies,
    each placed as in the robot's initial pose.  ``gravity``/``tau_max`` override the file's (e.g. 0
    and ``inf`` for a linear servo on a pure inertia).  The rig's first controlled joint is ``joint``.
    """
    from cpgjax.sim.model import build_model

    by_name = {j.name: j for j in desc.joints}
    if joint not in by_name:
        raise RigError(f"{desc.path}: no joint {joint!r} (joints: {', '.join(by_name) or 'none'})")
    jd = by_name[joint]
    if not jd.controlled:
        raise RigError(f"{desc.path}: joint {joint!r} is passive (no servo to measure); pick a controlled joint")
    robot = build_model(desc)
    ia = robot.body_names.index(jd.body_a)
    R = quat_to_mat_np(robot.q0[:, ia])
    frame = robot.x0[:, ia] - R @ robot.cm_local[:, ia] + np.array([0.0, 0.0, lift])
    pose = {"position": tuple(float(v) for v in frame),
            "orientation": tuple(float(v) for v in mat_to_euler(R)), "fixed": True}
    moving = _subtree(desc, jd.body_b)
    keep = [jd.body_a, *moving]
    joints = [jd] + [j for j in desc.joints if j.body_a in moving]
    joints = [dataclasses.replace(j, control_index=None) for j in joints]
    k = 0
    for i, j in enumerate(joints):
        if j.controlled:
            joints[i] = dataclasses.replace(j, control_index=k)
            k += 1
    objects, compounds = {}, {}
    for b in keep:
        if b in desc.compounds:
            c = desc.compounds[b]
            compounds[b] = dataclasses.replace(c, **pose) if b == jd.body_a else c
            for m in c.objects:
                objects[m] = desc.objects[m]
        else:
            o = desc.objects[b]
            objects[b] = dataclasses.replace(o, **pose) if b == jd.body_a else o
    # keep the file order (the model's body order follows it)
    objects = {n: objects[n] for n in desc.objects if n in objects}
    compounds = {n: compounds[n] for n in desc.compounds if n in compounds}
    servo = desc.servo if tau_max is None else dataclasses.replace(desc.servo, tau_max=float(tau_max))
    if tau_max is not None:
        joints = [dataclasses.replace(j, servo=dataclasses.replace(j.servo, tau_max=float(tau_max)))
                  if j.servo is not None else j for j in joints]
    return dataclasses.replace(
        desc, objects=objects, compounds=compounds, joints=joints, logs=[], track=jd.body_b, servo=servo,
        gravity=desc.gravity if gravity is None else float(gravity))


def axis_inertia(model, ctrl: int = 0) -> float:
    """Moment of inertia [kg m^2] about controlled joint ``ctrl``'s axis of everything it moves.

    The bodies of the joint's second body's subtree (in the initial pose), about the axis through the
    pivot: ``a.I.a + m |r x a|^2`` summed; the load a linear servo sees when the rest is held still.
    """
    j = int(model.ctrl_joint[ctrl])
    desc = model.description
    moving = set(_subtree(desc, model.body_names[model.j_b[j]]))
    ia = int(model.j_a[j])
    Ra = quat_to_mat_np(model.q0[:, ia])
    axis = Ra @ model.j_axis[:, j]
    jd = desc.joints[j]
    pivot = model.x0[:, ia] + Ra @ (np.asarray(jd.pivot_a) - model.cm_local[:, ia])
    total = 0.0
    for b, name in enumerate(model.body_names):
        if name not in moving:
            continue
        R = quat_to_mat_np(model.q0[:, b])
        Iw = R @ model.inertia[:, :, b] @ R.T
        r = model.x0[:, b] - pivot
        total += float(axis @ Iw @ axis + model.mass[b] * np.sum(np.cross(r, axis) ** 2))
    return total


def window_start(freq, time: float, settle: float):
    """Start [B] of the error window: the last whole periods of each frequency after ``settle`` s.

    Raises :class:`RigError` when a frequency has no whole period in the window (check before a run).
    """
    f = np.asarray(freq, float)
    periods = np.floor((time - settle) * f + 1e-6)
    if np.any(periods < 1):
        bad = f[periods < 1].min()
        raise RigError(f"{bad:g} Hz: not one whole period between the settling time {settle:g} s and the end "
                       f"of the episode {time:g} s; lengthen the episode")
    return time - periods / f


def tracking_rollout(model, freq, amp, *, center=None, time: float, settle: float, ctrl: int = 0,
                     record: bool = False):
    """Drive controlled joint ``ctrl`` with ``center + amp sin(2 pi freq t)``, freq/amp [B]; dict of [B].

    Keys ``err`` (mean absolute error, rad), ``ref`` (mean absolute excursion of the target, rad),
    ``rel`` (err / ref); with ``record=True`` also ``angle``/``target``
    [S, B] at every step and ``t`` [S].  ``center``: [n_ctrl] hold angles (default: the initial ones).
    """
    dt = model.dt
    nstep = int(round(time / dt))
    freq = jnp.asarray(freq, jnp.float32)
    amp = jnp.asarray(amp, jnp.float32)
    B = freq.shape[0]
    T = nstep * dt
    t0 = T - jnp.maximum(jnp.floor((T - settle) * freq + 1e-6), 1.0) / freq   # see window_start
    c = np.asarray(model.j_q0[model.ctrl_joint] if center is None else center, float)
    hold = jnp.asarray(np.repeat(c[:, None], B, 1), jnp.float32)
    w = 2 * jnp.pi * freq
    j = int(model.ctrl_joint[ctrl])

    def target(t):
        return c[ctrl] + amp * jnp.sin(w * t), amp * w * jnp.cos(w * t)

    def body(carry, _):
        s, e_sum, r_sum, n = carry
        q, dq = target(sim_time(model, s))
        ctrl_in = (hold.at[ctrl].set(q), jnp.zeros_like(hold).at[ctrl].set(dq))
        s = step(model, s, ctrl_in)
        t = sim_time(model, s)
        angle = joint_angles(model, quat_to_mat(s.q), s.w)[0][j]
        q1, _ = target(t)
        m = (t > t0 + 0.5 * dt).astype(jnp.float32)
        carry = (s, e_sum + m * jnp.abs(q1 - angle), r_sum + m * jnp.abs(q1 - c[ctrl]), n + m)
        return carry, ((angle, q1) if record else None)

    z = jnp.zeros((B,), jnp.float32)
    (_, e_sum, r_sum, n), ys = jax.lax.scan(body, (initial_state(model, B), z, z, z), None, length=nstep)
    out = {"err": e_sum / n, "ref": r_sum / n, "rel": e_sum / jnp.maximum(r_sum, 1e-30)}
    if record:
        out["angle"], out["target"] = ys
        out["t"] = (jnp.arange(nstep) + 1) * dt
    return out
