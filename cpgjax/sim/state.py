"""The dynamic state of a batch of robots (batch-last arrays)."""

from __future__ import annotations

from typing import NamedTuple

import jax.numpy as jnp
import numpy as np

from cpgjax.sim.rotation import cross, matvec, quat_to_mat_np


class ExactState(NamedTuple):
    """The exact pipeline's part of a :class:`State` (`sim.exact`): the joints' generalized coordinates.

    angle, rate: [nj, B] each joint's angle and rate (the `.wl` file's sign: body_b relative to body_a about the
    axis).  The floating bases are the tree roots' ``x, q, v, w``; the bodies' poses and velocities, which the
    rest of cpgjax reads, are kept as the forward kinematics of these coordinates.
    """

    angle: jnp.ndarray
    rate: jnp.ndarray


class State(NamedTuple):
    """Positions, velocities and servo memory of B robots; arrays end with the robot axis B.

    x: [3, nb, B] CM positions; q: [4, nb, B] orientations (w, x, y, z);
    v: [3, nb, B] CM velocities; w: [3, nb, B] angular velocities (world frame);
    e_int: [nctrl, B] integral of the servo error;
    anchor: [3, nc, B] static-friction anchor of each contact vertex (its position when not in contact);
    f_n: [nc, B] each contact vertex's normal force of the last step (see `contact`);
    n: [] int32 steps taken: the simulated time is ``n * dt`` (:func:`sim_time`), never a running
    float sum of ``dt`` (which drifts: 6.000610 s after 6 s in float32);
    exact: the exact pipeline's joint coordinates (:class:`ExactState`), None on the springs pipeline.
    """

    x: jnp.ndarray
    q: jnp.ndarray
    v: jnp.ndarray
    w: jnp.ndarray
    e_int: jnp.ndarray
    anchor: jnp.ndarray
    f_n: jnp.ndarray
    n: jnp.ndarray
    exact: ExactState | None = None


def point_kinematics(model, state: State, R):
    """World offset from the CM, position and velocity [3, npt, B] of every point of the bodies (pivot-spring ends,
    contact vertices); ``R`` [3, 3, nb, B]: the bodies' rotations."""
    pb = model.pt_body
    r = matvec(R[:, :, pb], model.pt_local[:, :, None])
    return r, state.x[:, pb] + r, state.v[:, pb] + cross(state.w[:, pb], r)


def sim_time(model, state: State):
    """Simulated time [] of ``state``: the integer step count times ``dt`` (one rounding, no drift)."""
    return state.n.astype(state.x.dtype) * model.dt


def initial_state(model, batch: int = 1, dtype=jnp.float32) -> State:
    """All robots at the model's initial pose, at rest."""
    nb = model.nb

    def tile(a):
        return jnp.asarray(np.repeat(np.asarray(a)[..., None], batch, -1), dtype)

    x0 = np.asarray(model.x0)
    anchors = np.zeros((3, len(model.ct_pt)))
    for k, pt in enumerate(model.ct_pt):
        b = model.pt_body[pt]
        anchors[:, k] = x0[:, b] + quat_to_mat_np(model.q0[:, b]) @ model.pt_local[:, pt]
    exact = None
    if model.pipeline == "exact":
        exact = ExactState(angle=tile(model.j_q0), rate=jnp.zeros((model.nj, batch), dtype))
    return State(
        x=tile(model.x0), q=tile(model.q0), anchor=tile(anchors), v=jnp.zeros((3, nb, batch), dtype),
        w=jnp.zeros((3, nb, batch), dtype), e_int=jnp.zeros((model.n_ctrl, batch), dtype),
        f_n=jnp.zeros((len(model.ct_pt), batch), dtype), n=jnp.zeros((), jnp.int32), exact=exact,
    )


def varied_initial_state(model, var, dtype=jnp.float32) -> State:
    """:func:`initial_state` with each robot lifted by ``var.lift`` and rolled/pitched by ``var.tilt``.

    The whole robot turns rigidly about its tracked body's CM (x axis: roll, then y: pitch), so every
    joint keeps its initial angle; velocities stay zero.
    """
    s = initial_state(model, var.lift.shape[-1], dtype)
    rx, ry = var.tilt[0], var.tilt[1]
    cx, sx, cy, sy = jnp.cos(rx), jnp.sin(rx), jnp.cos(ry), jnp.sin(ry)
    zero = jnp.zeros_like(rx)
    # R = Ry @ Rx  [3, 3, B]
    Rm = jnp.stack([jnp.stack([cy, sy * sx, sy * cx]),
                    jnp.stack([zero, cx, -sx]),
                    jnp.stack([-sy, cy * sx, cy * cx])])
    c = s.x[:, model.track:model.track + 1]                                  # [3, 1, B]
    up = jnp.stack([zero, zero, var.lift])[:, None]                          # [3, 1, B]
    # x' = x + (R - I)(x - c) + lift: exactly x when R = I and lift = 0 (the nominal Variation)
    eye = jnp.eye(3, dtype=rx.dtype)[:, :, None]
    dR = (Rm - eye)[:, :, None]
    x = s.x + matvec(dR, s.x - c) + up
    anchor = s.anchor + matvec(dR, s.anchor - c) + up
    # q' = qr * q with qr the quaternion of R = Ry Rx
    hx, hy = 0.5 * rx, 0.5 * ry
    qr = jnp.stack([jnp.cos(hy) * jnp.cos(hx), jnp.cos(hy) * jnp.sin(hx), jnp.sin(hy) * jnp.cos(hx),
                    -jnp.sin(hy) * jnp.sin(hx)])[:, None]                     # [4, 1, B]
    w1, x1, y1, z1 = qr
    w2, x2, y2, z2 = s.q
    q = jnp.stack([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                   w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])
    return s._replace(x=x, q=q, anchor=anchor)
