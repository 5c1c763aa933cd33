"""One step of the thesis's pipeline: ``step(model, state, ctrl) -> state`` (Ch. 3.4.1).

The stages follow the thesis's dynamics engine (Ch. 3.4.1, Appendix B): pivot positions
and velocities, joint penalties, servo torques, gravity; then the ground collisions, solved
against the velocities all those forces would give (see `contact`); then integration.
All arrays are batch-last (see `cpgjax.sim.state`): the same code runs
one robot (B = 1) or thousands.
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from cpgjax.sim import tricks
from cpgjax.sim.contact import contact_body_ranges, contact_forces
from cpgjax.sim.joints import joint_angles, limit_torques
from cpgjax.sim.rotation import cross, dot, quat_to_mat
from cpgjax.sim.servo import servo_pi, servo_torques
from cpgjax.sim.springs.bodies import accelerations, force_accelerations, integrate, torque_accelerations
from cpgjax.sim.springs.pivots import pivot_spring_forces
from cpgjax.sim.state import point_kinematics


def sum_onto_bodies(model, f_pt, torque_joint):
    """Sum point forces [3, npt, B] (or None) and joint torques [3, nj, B] onto bodies [3, nb, B].

    Static slices and sums in a fixed order: bitwise the same result for any batch size.
    """
    some = f_pt if f_pt is not None else torque_joint
    zero = jnp.zeros((3, some.shape[-1]), some.dtype)
    out = []
    for b in range(model.nb):
        lo, hi = int(model.pt_start[b]), int(model.pt_start[b + 1])
        acc = f_pt[:, lo:hi].sum(1) if f_pt is not None and hi > lo else zero
        if torque_joint is not None:
            for j in np.nonzero(model.j_b == b)[0]:
                acc = acc + torque_joint[:, j]
            for j in np.nonzero(model.j_a == b)[0]:
                acc = acc - torque_joint[:, j]
        out.append(acc)
    return jnp.stack(out, 1)


def sum_contacts_onto_bodies(model, f, r):
    """Contact forces [3, nc, B] at offsets r [3, nc, B] summed onto bodies: force, torque [3, nb, B]."""
    tq = cross(r, f)
    zero = jnp.zeros((3, f.shape[-1]), f.dtype)
    ranges = {b: (lo, hi) for b, lo, hi in contact_body_ranges(model)}
    F, T = [], []
    for b in range(model.nb):
        lo, hi = ranges.get(b, (0, 0))
        F.append(f[:, lo:hi].sum(1) if hi > lo else zero)
        T.append(tq[:, lo:hi].sum(1) if hi > lo else zero)
    return jnp.stack(F, 1), jnp.stack(T, 1)


class Servos(NamedTuple):
    """What the servos' derivative term needs of the joints (:func:`servo_derivative`)."""

    rate: jax.Array     # [nj, B] joint rates
    axis: jax.Array     # [3, nj, B] joint axes in the world
    tau_pi: jax.Array   # [nctrl, B] the servos' proportional and integral torque


class Forces(NamedTuple):
    """The stage before the ground (:func:`forces`): the bodies' pose, the points, and the force and torque on
    every body from everything but the ground and the servos' derivative term."""

    R: jax.Array        # [3, 3, nb, B] body rotations
    r: jax.Array        # [3, npt, B] points relative to their body's CM, in the world
    p: jax.Array        # [3, npt, B] points in the world
    pv: jax.Array       # [3, npt, B] their velocities
    force: jax.Array    # [3, nb, B]
    torque: jax.Array   # [3, nb, B]
    err: jax.Array      # [nctrl, B] the servos' error (their integral's rate)
    servos: Servos


def forces(model, state, ctrl, var=None) -> Forces:
    """Force and torque on every body [3, nb, B] from everything but the ground and the servos'
    derivative term, plus what the servos and the contacts need."""
    target, _ = ctrl
    R = quat_to_mat(state.q)
    r, p, pv = point_kinematics(model, state, R)
    fs = pivot_spring_forces(model, p, pv)
    no_contact = jnp.zeros((3, len(model.ct_pt), fs.shape[-1]), fs.dtype)
    f_pt = jnp.concatenate([fs, -fs, no_contact], 1)[:, model.springs.pt_src]
    angle, rate, axis = joint_angles(model, R, state.w)
    tau_pi, err = servo_pi(model, angle, target, state.e_int, None if var is None else var.gain)
    tau = limit_torques(model, angle, rate).at[model.ctrl_joint].add(tau_pi)
    force = sum_onto_bodies(model, f_pt, None)
    torque = sum_onto_bodies(model, cross(r, f_pt), tau * axis)
    return Forces(R, r, p, pv, force, torque, err, Servos(rate, axis, tau_pi))


def servo_derivative(model, R, ctrl, joints: Servos, alpha, var=None):
    """Angular accelerations [3, nb, B] added by the servos' saturated derivative term (`servo`).

    ``alpha``: the bodies' angular accelerations under every other force and torque, from which
    the joint rates at the end of the step are predicted.
    """
    cj = model.ctrl_joint
    if not len(cj):
        return jnp.zeros_like(alpha)
    rate, axis, tau_pi = joints
    ja, jb = model.j_a[cj], model.j_b[cj]
    rate_pred = rate[cj] + model.dt * dot(alpha[:, jb] - alpha[:, ja], axis[:, cj])
    gain = None if var is None else var.gain
    torque = None if var is None else var.torque
    extra = servo_torques(model, tau_pi, rate_pred, ctrl[1], gain, torque=torque) - tau_pi
    tau = jnp.zeros_like(rate).at[cj].set(extra)
    return torque_accelerations(model, R, sum_onto_bodies(model, None, tau * axis), None if var is None else var.mass)


def step(model, state, ctrl, var=None):
    """Advance the batch by one step of ``model.dt`` under servo targets ``ctrl = (q*, dq*/dt)``, the joints held by
    pivot springs.

    ``var``: an optional per-robot :class:`~cpgjax.sim.variation.Variation` (``None``: the nominal robot).
    """
    scale = None if var is None else var.mass
    f = forces(model, state, ctrl, var)
    R, r, p, pv = f.R, f.r, f.p, f.pv
    a, alpha = accelerations(model, R, state.w, f.force, f.torque, scale)
    alpha = alpha + servo_derivative(model, R, ctrl, f.servos, alpha, var)
    # On uneven terrain the contact frame under each vertex (looked up in the heightfield) and the contact forces
    # are computed once into memory (`sim/tricks.py: keep`): XLA's CPU fusion otherwise recomputed the frame for
    # every component and every body sum that reads it, in scalar code (the car on its ramp: 5x the CPU per
    # step, at 1 and at 16 robots; the quadruped on 2 cm roughness 3.6x; docs/results/performance.md).  Flat
    # ground has no lookup and is left as it was, bit for bit.
    keep = None if model.terrain.flat else tricks.keep
    fc, _, anchor, f_n = contact_forces(model, R, r, p, pv, a, alpha, state.anchor, state.f_n, var, keep)
    if keep is not None:
        fc = keep(fc)
    ac, alc = force_accelerations(model, R, *sum_contacts_onto_bodies(model, fc, r[:, model.ct_pt]), scale)
    new = integrate(state, a + ac, alpha + alc, model.dt)
    return new._replace(e_int=state.e_int + model.dt * f.err, anchor=anchor, f_n=f_n, n=state.n + 1)
