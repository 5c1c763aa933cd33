"""Ledges: a ground of vertical faces across the path (stairs, a bar, a gap; thesis Ch. 7.4-7.5).

A heightfield (Appendix A, :mod:`cpgjax.sim.terrain`) is bilinear between its grid points, so its steps are
ramps as wide as a cell, and eq. 3.7's depth there is measured along the slope's normal.  A stair's riser is
vertical: a foot that meets it is pushed back, not lifted onto the tread.  A :class:`Ledges` ground is a profile
along y, the same at every x: ``levels[i]`` is the ground's height between ``edges[i-1]`` and ``edges[i]`` (the
first level before the first edge, the last after the last).  A contact vertex under it leaves by the nearest
way out (the vertex's penetration of the solid): up through its tread, or sideways through the riser of a
neighbouring level below it (:func:`riser_exit`).  So a point foot meets the profile's exact faces; MuJoCo's
1 cm foot spheres meet the same solid as boxes (:mod:`cpgjax.crosscheck.ground`, ``ledge_boxes``).

Kinds (CLI ``--terrain``, `.wl` ``Terrain``; checked by ``terrain.check_terrain``):

- ``stairs:RISE:TREAD[:N]``: N steps (default 5) of RISE m (negative: down) and TREAD m from y = :data:`STAIRS_AT`;
  the last tread goes on (Ch. 7.4's "regular structures (e.g. stairs)");
- ``bar:HEIGHT@Y[:DEPTH]``: a bar HEIGHT m high from y = Y to Y + DEPTH (default :data:`BAR_DEPTH`), to step
  over (Ch. 7.5's "jumping over obstacles");
- ``gap:WIDTH@Y``: a trench :data:`GAP_DEPTH` deep from y = Y to Y + WIDTH.
"""

from __future__ import annotations

from dataclasses import dataclass

import jax.numpy as jnp
import numpy as np

STAIRS_AT = 1.0     # m: where the first riser stands (the quadruped's front feet start near y = 0.3)
STAIRS_N = 5        # steps of a flight, by default
BAR_DEPTH = 0.05    # m: a bar's extent along the path, by default
GAP_DEPTH = 0.5     # m: a gap's depth (deeper than a leg: a foot that steps in falls in)
RISE_MAX = 0.3      # m: the quadruped's leg is 0.32 m long; a taller step is a wall
TREAD_MIN = 0.05    # m: five foot spheres' radii; a narrower tread is no step to stand on
TREAD_MAX = 3.0     # m: a stair's tread at most this long
WIDTH_MAX = 2.0     # m: a gap or a bar at most this long along the path
STEPS_MAX = 50      # steps of one flight
_FAR = 1e6          # m: beyond every edge (pads the profile's ends)
FINISH_BEHIND = 0.4  # m: the quadruped's hind feet are 0.3 m behind its body's centre: past the last face by this


@dataclass(frozen=True, eq=False)
class Ledges:
    """A profile of vertical faces along y: ``edges`` [K] ascending, ``levels`` [K + 1] (m)."""

    edges: np.ndarray
    levels: np.ndarray

    def level_np(self, y, dtype=float) -> np.ndarray:
        """The profile's height at numpy ``y``, computed in ``dtype`` (float32: :func:`ledge_level`'s bits)."""
        return np.asarray(self.levels, dtype)[np.searchsorted(np.asarray(self.edges, dtype), np.asarray(y, dtype),
                                                              side="right")]


def stairs(rise: float, tread: float, n: int = STAIRS_N, at: float = STAIRS_AT) -> Ledges:
    """``n`` steps of ``rise`` and ``tread`` from y = ``at``; the last level goes on."""
    return Ledges(at + tread * np.arange(n, dtype=float), rise * np.arange(n + 1, dtype=float))


def bar(height: float, y: float, depth: float = BAR_DEPTH) -> Ledges:
    """A bar ``height`` high from ``y`` to ``y + depth``."""
    return Ledges(np.array([y, y + depth]), np.array([0.0, height, 0.0]))


def gap(width: float, y: float) -> Ledges:
    """A trench :data:`GAP_DEPTH` deep from ``y`` to ``y + width``."""
    return Ledges(np.array([y, y + width]), np.array([0.0, -GAP_DEPTH, 0.0]))


def _padded(led: Ledges, dtype):
    e = np.concatenate([[-_FAR], led.edges, [_FAR]])
    lv = np.concatenate([led.levels[:1], led.levels, led.levels[-1:]])
    return jnp.asarray(led.edges, dtype), jnp.asarray(e, dtype), jnp.asarray(lv, dtype)


def ledge_level(led: Ledges, y):
    """The profile's height under ``y`` (traceable)."""
    edges, _, lv = _padded(led, y.dtype)
    return lv[jnp.searchsorted(edges, y, side="right") + 1]


def riser_exit(led: Ledges, y, z, surface, scale=1.0):
    """The nearest way out sideways of points at ``(y, z)`` under the ground: (distance to the riser, m; its
    direction along y, -1 or +1).  ``surface``: the ground's height over the points (the profile's level times
    ``scale``, plus any heightfield under it); a riser is a way out only where the neighbouring level beyond it
    lies below the point (else the distance is infinite)."""
    edges, e, lv = _padded(led, y.dtype)
    i = jnp.searchsorted(edges, y, side="right")
    here, left, right = lv[i + 1], lv[i], lv[i + 2]
    base = surface - scale * here
    inf = jnp.asarray(jnp.inf, y.dtype)
    d_left = jnp.where(base + scale * left < z, y - e[i], inf)
    d_right = jnp.where(base + scale * right < z, e[i + 1] - y, inf)
    return jnp.minimum(d_left, d_right), jnp.where(d_left <= d_right, -1.0, 1.0).astype(y.dtype)


def check(kind: str, p) -> None:
    """ValueError saying what is wrong with a ledge's sizes: ``stairs`` (RISE, TREAD[, N]), ``bar`` (HEIGHT[, DEPTH])
    or ``gap`` (WIDTH,); where it stands is the caller's to check."""
    if kind == "stairs":
        if not 0 < abs(p[0]) <= RISE_MAX:
            raise ValueError(f"stairs RISE must be non-zero and at most {RISE_MAX:g} m either way (the quadruped's "
                             f"leg is 0.32 m; negative: down), got {p[0]:g}")
        if not TREAD_MIN <= p[1] <= TREAD_MAX:
            raise ValueError(f"stairs TREAD must be between {TREAD_MIN:g} and {TREAD_MAX:g} m, got {p[1]:g}")
        if len(p) > 2 and (not float(p[2]).is_integer() or not 1 <= p[2] <= STEPS_MAX):
            raise ValueError(f"stairs N must be a whole number of steps, 1 to {STEPS_MAX}, got {p[2]:g}")
    elif kind == "bar":
        if not 0 < p[0] <= RISE_MAX:
            raise ValueError(f"bar HEIGHT must be positive and at most {RISE_MAX:g} m, got {p[0]:g}")
        if len(p) > 1 and not 0 < p[1] <= WIDTH_MAX:
            raise ValueError(f"bar DEPTH must be positive and at most {WIDTH_MAX:g} m along the path, got {p[1]:g}")
    elif not 0 < p[0] <= WIDTH_MAX:
        raise ValueError(f"gap WIDTH must be positive and at most {WIDTH_MAX:g} m, got {p[0]:g}")


def finish_line(led: Ledges | None) -> float | None:
    """How far (m along y) a robot's tracked body must go for its hind feet to be past the last face: the last edge
    plus :data:`FINISH_BEHIND` (None: no ledges)."""
    return None if led is None else float(np.max(led.edges)) + FINISH_BEHIND
