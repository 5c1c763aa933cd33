"""The perturbation experiments' ground (thesis Ch. 6.4, Figs. 6.13-6.16): every condition side by side.

The thesis walked a controller on flat ground, over a bump of 1, 2 or 3 cm across its path halfway
through the episode, and on random roughness of 1-4 cm.  Here all those grounds are *lanes* of one
heightfield: lane k is a strip of :data:`LANE` m in x, holding one condition (flat, a bump of a height, or
a rough field of a range and seed).  Each robot stands on its lane through its terrain shift
(:class:`~cpgjax.sim.variation.Variation`), so every controller x condition x seed runs in one batch and
one compiled program.

* a bump lane has a bump of the height across the whole lane from y = ``bump_y`` to ``bump_y + width``;
  a robot is shifted along y so that the halfway point of its own flat-ground path lands on the bump's
  near edge (:func:`placement`);
* a rough lane has heights uniform in [0, RANGE] on a grid of :data:`ROUGH_CELL` m (as the ``rough:``
  terrain), seeded; its robot is lifted by RANGE at the start so that no foot starts under the ground.

The grid is :data:`CELL_X` x :data:`CELL_Y` m (fine along y, for the bump's edges); the rough fields are
interpolated onto it along y, which leaves their bilinear surface as it is.  A robot drifting more than
``LANE / 2`` sideways leaves its lane.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cpgjax.sim import ledges
from cpgjax.sim.terrain import Terrain

LANE = 6.0          # m: width of a lane (x)
CELL_X = 0.1        # m
CELL_Y = 0.02       # m: a bump's edges rise over one cell
ROUGH_CELL = 0.1    # m: the roughness grid (the ``rough:`` terrain's default)
MARGIN = 1.5        # m: ground beyond the farthest point a robot's body reaches on flat ground


STAIR_STEPS = 3     # a stair condition: a flight of this many steps of its rise
STAIR_TREAD = 0.3   # m
LEDGE_KINDS = ("stair", "bar")   # conditions with vertical faces (sim.ledges): a ground of their own, not a lane


@dataclass(frozen=True)
class Condition:
    """One ground: ``kind`` flat, bump (``level`` = height, m), rough (``level`` = range, m; ``seed``), stair (a flight
    of :data:`STAIR_STEPS` steps of ``level`` rise) or bar (``level`` high, ``sim.ledges.BAR_DEPTH`` deep)."""

    kind: str
    level: float = 0.0
    seed: int = 0

    @property
    def label(self) -> str:
        if self.kind == "flat":
            return "flat"
        return f"{self.kind} {100 * self.level:g} cm" + (f" #{self.seed}" if self.kind == "rough" else "")


def conditions(bumps, roughs, seeds: int, seed0: int = 0, stairs=(), bars=()) -> list[Condition]:
    """flat, then each bump height, then each roughness range with ``seeds`` fields (seeds seed0, seed0+1, ...),
    then each stair rise and bar height."""
    out = [Condition("flat")]
    out += [Condition("bump", float(h)) for h in bumps]
    out += [Condition("rough", float(r), seed0 + s) for r in roughs for s in range(seeds)]
    out += [Condition("stair", float(h)) for h in stairs] + [Condition("bar", float(h)) for h in bars]
    return out


def _rough(level: float, seed: int, nx: int, ys: np.ndarray) -> np.ndarray:
    """A rough field [len(ys), nx]: uniform in [0, level] on ROUGH_CELL rows, linear along y between them."""
    y0, y1 = ys[0], ys[-1]
    rows = np.arange(np.floor(y0 / ROUGH_CELL + 1e-6), np.ceil(y1 / ROUGH_CELL - 1e-6) + 1) * ROUGH_CELL
    step = int(round(ROUGH_CELL / CELL_X))
    cols = (nx - 1) // step + 1
    coarse = np.random.default_rng(seed).uniform(0.0, level, size=(len(rows), cols))
    along_x = np.stack([np.interp(np.arange(nx) * CELL_X, np.arange(cols) * ROUGH_CELL, r) for r in coarse])
    return np.stack([np.interp(ys, rows, along_x[:, i]) for i in range(nx)], axis=1)


def course(conds: list[Condition], y_range: tuple[float, float], bump_y: float, bump_width: float) -> Terrain:
    """One heightfield with a lane per condition (lane k centred on x = k * LANE); a stair or a bar (one condition
    alone: vertical faces span every x) is a ground of ledges whose first face stands at ``bump_y``."""
    if len(conds) == 1 and conds[0].kind in LEDGE_KINDS:
        c = conds[0]
        led = (ledges.stairs(c.level, STAIR_TREAD, STAIR_STEPS, at=bump_y) if c.kind == "stair"
               else ledges.bar(c.level, bump_y))
        return Terrain(f"{c.kind}:{c.level:g}@{bump_y:g}", ledges=led)
    nxl = int(round(LANE / CELL_X))
    ys = np.arange(y_range[0], y_range[1] + CELL_Y / 2, CELL_Y)
    lanes = []
    for c in conds:
        if c.kind == "flat":
            h = np.zeros((len(ys), nxl))
        elif c.kind == "bump":
            on = (ys >= bump_y - 1e-9) & (ys <= bump_y + bump_width + 1e-9)
            h = np.where(on, c.level, 0.0)[:, None] * np.ones((1, nxl))
        elif c.kind == "rough":
            h = _rough(c.level, c.seed, nxl, ys)
        else:
            raise ValueError(f"unknown ground condition {c.kind!r}; expected flat, bump or rough")
        lanes.append(h)
    heights = np.concatenate(lanes, axis=1)
    spec = "course:" + ",".join(c.label.replace(" ", "") for c in conds)
    return Terrain(spec, heights, -LANE / 2, float(ys[0]), CELL_X, CELL_Y)


def placement(conds: list[Condition], lane: np.ndarray, distance: np.ndarray, start_y: float, bump_y: float,
              bump_width: float, reach: tuple[float, float] = (0.0, 0.0)):
    """Per robot: terrain shift [2, N], initial lift [N] and the y range the course must cover.

    ``lane`` [N]: each robot's condition; ``distance`` [N]: how far (y) its tracked body walks on flat ground in
    the episode, from ``start_y``.  A robot on a bump lane is shifted along y so that its body meets the bump
    halfway through its path (walking backwards, from the other side), but never closer than ``reach`` =
    (ahead, behind), m: how far its feet stand in front of and behind the body at the start, plus 5 cm.
    """
    d = np.asarray(distance, float)
    kind = np.array([conds[k].kind for k in lane])
    level = np.array([conds[k].level for k in lane])
    ahead, behind = reach[0] + 0.05, reach[1] + 0.05
    width = np.where(kind == "stair", STAIR_STEPS * STAIR_TREAD, np.where(kind == "bar", ledges.BAR_DEPTH, bump_width))
    world = np.where(d >= 0, start_y + np.maximum(d / 2, ahead), start_y + np.minimum(d / 2, -behind) - width)
    sy = np.where(np.isin(kind, ("bump", *LEDGE_KINDS)), bump_y - world, 0.0)
    # from the top of a stair, walking backwards down it
    lift = np.where(kind == "rough", level, np.where((kind == "stair") & (d < 0), STAIR_STEPS * level, 0.0))
    lo = float(np.min(start_y + np.minimum(d, 0.0) + sy, initial=start_y)) - MARGIN
    hi = float(np.max(start_y + np.maximum(d, 0.0) + sy, initial=start_y)) + MARGIN
    return np.stack([lane * LANE, sy]).astype(np.float32), lift.astype(np.float32), (lo, hi)
