"""Per-robot variation of the physics: each robot of a batch built and placed a little differently.

The :class:`~cpgjax.sim.model.Model` is one nominal robot; a :class:`Variation` holds, per robot
of the batch (batch-last arrays), scale factors on its friction coefficients, friction bristle, body
masses and inertias and servo gains, a shift of where it stands on the terrain, and an offset of its initial
pose; optionally (``None``: as the model says, the same program as without the field) scale factors on the
servos' torque limit, the ground's stiffness A and damping B (eq. 3.7) and the relief of the terrain, and a shove
(which the episode applies, not the step).
``Variation.nominal(model, B)`` is the identity (all scales 1, no shift, no offset); the simulator with it
computes exactly what it computes without one.

This is what the robust evaluation (``optim.factory``, docs/evolution.md) draws afresh every
generation, so that a controller cannot win by luck in one exact episode: a real robot is never
built, weighed, placed or tuned exactly as its model says.
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp


class Variation(NamedTuple):
    """Per-robot physical variation; every array ends with the robot axis B."""

    friction: jax.Array   # [B]   scale of mu_static and mu_dynamic
    mass: jax.Array       # [nb, B] scale of each body's mass and inertia
    gain: jax.Array       # [nctrl, B] scale of the servo gains kp, ki, kd
    shift: jax.Array      # [2, B] where the robot stands on the terrain: (x, y) offset of the lookup, m
    lift: jax.Array       # [B]   initial height offset of the whole robot, m
    tilt: jax.Array       # [2, B] initial roll and pitch of the whole robot about its tracked body's CM, rad
    bristle: jax.Array    # [B]   scale of the friction bristle's spring k (``FrictionSpring``, sim.contact)
    torque: jax.Array | None = None     # [nctrl, B] scale of each servo's torque limit (sim.servo)
    stiffness: jax.Array | None = None  # [B] scale of the ground's A (eq. 3.7, sim.contact)
    damping: jax.Array | None = None    # [B] scale of the ground's B (eq. 3.7, sim.contact)
    relief: jax.Array | None = None     # [B] scale of the terrain's heights (and slopes) under the robot
    push: jax.Array | None = None       # [3, B] a shove: the velocity added to every body once (episode.rollout)
    push_at: jax.Array | None = None    # [B] when, as a share of the episode

    @staticmethod
    def nominal(model, batch: int, dtype=jnp.float32) -> Variation:
        one = jnp.ones((batch,), dtype)
        return Variation(friction=one, mass=jnp.ones((model.nb, batch), dtype),
                         gain=jnp.ones((model.n_ctrl, batch), dtype), shift=jnp.zeros((2, batch), dtype),
                         lift=jnp.zeros((batch,), dtype), tilt=jnp.zeros((2, batch), dtype), bristle=one)
