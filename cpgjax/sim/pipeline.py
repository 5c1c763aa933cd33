"""Either physics pipeline's two entries, as MJX's and Brax's: ``init(model, batch, var) -> state`` and
``step(model, state, ctrl, var) -> state``.

The model's ``pipeline`` says which runs it: ``"springs"``, the thesis's (`sim.springs`: every body free, each
joint two stiff pivot springs, eq. 3.6), or ``"exact"`` (`sim.exact`: generalized coordinates, the joints
exact).  Both read and write the same :class:`~cpgjax.sim.state.State` fields (the bodies' poses and
velocities, the servo's memory, the friction anchors), so what runs them (`cpgjax.episode`) does not depend
on the pipeline.
"""

from __future__ import annotations

import jax.numpy as jnp

from cpgjax.sim.exact import step as exact_step
from cpgjax.sim.springs import step as springs_step
from cpgjax.sim.state import State, initial_state, varied_initial_state


def init(model, batch: int = 1, var=None, dtype=jnp.float32) -> State:
    """The state of ``batch`` robots at the model's initial pose, at rest (the exact pipeline's joint angles and
    rates too); with a per-robot :class:`~cpgjax.sim.variation.Variation` ``var``, each robot lifted and tilted by
    it and ``batch`` its width."""
    return initial_state(model, batch, dtype) if var is None else varied_initial_state(model, var, dtype)


def step(model, state, ctrl, var=None):
    """Advance a batch of robots by ``model.dt`` under servo targets ``ctrl = (q*, dq*/dt)`` [nctrl, B] each;
    ``var``: an optional per-robot :class:`~cpgjax.sim.variation.Variation` (None: the nominal robot)."""
    fn = exact_step.step if model.pipeline == "exact" else springs_step.step
    return fn(model, state, ctrl, var)
