"""One step of either physics pipeline: ``step(model, state, ctrl, var) -> state``, the one entry.

The model's ``pipeline`` says which runs it: ``"springs"``, the thesis's (`sim.springs`: every body free, each
joint two stiff pivot springs, eq. 3.6), or ``"exact"`` (`sim.exact`: generalized coordinates, the joints
exact).  Both read and write the same :class:`~cpgjax.sim.state.State` fields (the bodies' poses and
velocities, the servo's memory, the friction anchors), so what runs them (`cpgjax.episode`) does not depend
on the pipeline.
"""

from __future__ import annotations

from cpgjax.sim.exact import step as exact_step
from cpgjax.sim.springs import step as springs_step


def step(model, state, ctrl, var=None):
    """Advance a batch of robots by ``model.dt`` under servo targets ``ctrl = (q*, dq*/dt)`` [nctrl, B] each;
    ``var``: an optional per-robot :class:`~cpgjax.sim.variation.Variation` (None: the nominal robot)."""
    fn = exact_step.step if model.pipeline == "exact" else springs_step.step
    return fn(model, state, ctrl, var)
