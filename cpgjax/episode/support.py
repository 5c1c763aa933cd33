"""Projection stability (thesis Ch. 6.4.2, Figs. 6.17-6.21): the CM's ground projection in the support polygon.

The thesis's second stability measure: the distance of the projection of the centre of mass on the ground
from the boundary of the *support polygon*, the convex hull of the feet in contact, divided by the height of
the centre of mass.  It is undefined with fewer than three feet down (the polygon degenerates into a segment
or a point): there it is NaN, and the episode counts such samples.

Here the distance is signed: positive with the projection inside the polygon, negative outside (the
Euclidean distance to the polygon, with a minus sign), so a statically unstable posture reads below zero.

The hull is found with fixed-size masked operations (no sorting, no data-dependent shapes), fit for a few
contact points (4 for the quadruped's feet, 12 vertices in all for the hexapod): the ordered pair of
touching points ``(i, j)`` is a counter-clockwise hull edge when every touching point lies on or left of
the line from ``i`` to ``j``.  The projection is inside when it is left of every hull edge; its distance to
the boundary is the smallest distance to a hull edge's segment.
"""

from __future__ import annotations

import jax.numpy as jnp

MIN_FEET = 3          # fewer touching points: the polygon is degenerate and the stability undefined
EDGE_TOL = 1e-9       # m^2: a point this close to an edge's line (cross product) counts as on it


def _cross(ax, ay, bx, by):
    return ax * by - ay * bx


def support_distance(px, py, down, cx, cy):
    """Signed distance of (cx, cy) to the boundary of the convex hull of the touching points.

    ``px, py`` [n, ...]: the points on the ground plane; ``down`` [n, ...] bool: which touch;
    ``cx, cy`` [...]: the point to test (the CM's projection).  Returns ``(distance [...], n_down [...])``:
    the distance is positive inside the hull, negative outside, NaN with fewer than :data:`MIN_FEET`
    touching points.  Batched over the trailing axes.
    """
    n = px.shape[0]
    ex = px[None, :] - px[:, None]          # [i, j, ...] edge i -> j
    ey = py[None, :] - py[:, None]
    # every touching k on or left of the edge i -> j
    side = _cross(ex[:, :, None], ey[:, :, None], px[None, None, :] - px[:, None, None],
                  py[None, None, :] - py[:, None, None])                                   # [i, j, k, ...]
    ok_k = (side >= -EDGE_TOL) | ~down[None, None, :]
    length2 = ex * ex + ey * ey
    eye = jnp.eye(n, dtype=bool).reshape((n, n) + (1,) * (px.ndim - 1))
    edge = jnp.all(ok_k, axis=2) & down[:, None] & down[None, :] & ~eye & (length2 > 0)    # [i, j, ...]
    # the point against each edge: left of it (inside) and its distance to the segment
    rx, ry = cx[None, None] - px[:, None], cy[None, None] - py[:, None]                    # [i, 1, ...]
    safe = jnp.where(length2 > 0, length2, 1.0)
    left = _cross(ex, ey, rx, ry)
    s = jnp.clip((rx * ex + ry * ey) / safe, 0.0, 1.0)
    dx, dy = rx - s * ex, ry - s * ey
    seg = jnp.sqrt(dx * dx + dy * dy)
    inside = jnp.all(jnp.where(edge, left >= 0, True), axis=(0, 1))
    dist = jnp.min(jnp.where(edge, seg, jnp.inf), axis=(0, 1))
    n_down = jnp.sum(down, axis=0)
    d = jnp.where(inside, dist, -dist)
    defined = (n_down >= MIN_FEET) & jnp.any(edge, axis=(0, 1))   # (three coincident points have no edge)
    return jnp.where(defined, d, jnp.nan), n_down


def projection_stability(px, py, down, cm):
    """The thesis's projection stability: signed support distance over the CM height (NaN: < 3 feet down).

    ``cm`` = (x, y, h) with h the CM's height above the ground under it.  Returns ``(stability, n_down)``.
    """
    cx, cy, h = cm
    d, n_down = support_distance(px, py, down, cx, cy)
    return d / h, n_down
