"""The penalty-method rigid-body simulator (thesis Ch. 3, Appendix B): pure physics, nothing else.

A frozen, static :class:`Model` (built from a :class:`~cpgjax.sim.description.Description`),
a dynamic :class:`State`, and ``step(model, state, ctrl) -> state``.  Arrays are batch-last:
the same code runs one robot or thousands.  This layer knows nothing of controllers, fitness,
files or devices (see docs/architecture.md).

The parts both pipelines share are here (the description, the model, the state, the terrain, the contact
law, the servo, joint angles and limits, rotations, per-robot variation, what the steps do for XLA's
compiler); each pipeline is a subpackage with
its own step: `sim.springs` (the thesis's pivot springs) and `sim.exact` (exact joints);
`sim.pipeline.init` and `sim.pipeline.step` run the model's.
"""

from cpgjax.sim.description import Description, TerrainDef
from cpgjax.sim.model import EpisodeConfig, Model, build_model
from cpgjax.sim.pipeline import init, step
from cpgjax.sim.state import State, initial_state
from cpgjax.sim.terrain import Terrain, make_terrain

__all__ = ["Description", "EpisodeConfig", "Model", "State", "Terrain", "TerrainDef", "build_model", "init",
           "initial_state", "make_terrain", "step"]
