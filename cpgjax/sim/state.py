"""The dynamic state of a batch of robots (batch-last arrays)."""

from __future__ import annotations

from typing import NamedTuple

import jax.numpy as jnp
import numpy as np

from cpgjax.sim.rotation import quat_to_mat_np


class State(NamedTuple):
    """Positions, velocities and servo memory of B robots; arrays end with the robot axis B.

    x: [3, nb, B] CM positions; q: [4, nb, B] orientations (w, x, y, z);
    v: [3, nb, B] CM velocities; w: [3, nb, B] angular velocities (world frame);
    e_int: [nctrl, B] integral of the servo error;
    anchor: [3, nc, B] static-friction anchor of each contact vertex (its position when not in contact);
    t: [] simulated time.
    """

    x: jnp.ndarray
    q: jnp.ndarray
    v: jnp.ndarray
    w: jnp.ndarray
    e_int: jnp.ndarray
    anchor: jnp.ndarray
    t: jnp.ndarray


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
    return State(
        x=tile(model.x0), q=tile(model.q0), anchor=tile(anchors), v=jnp.zeros((3, nb, batch), dtype),
        w=jnp.zeros((3, nb, batch), dtype), e_int=jnp.zeros((model.n_ctrl, batch), dtype),
        t=jnp.zeros((), dtype),
    )

