"""Terrain: a matrix of heights scaled over the workspace, bilinearly interpolated (Appendix A).

Kinds (CLI syntax ``--terrain``, `.wl` syntax ``Terrain``):

- ``flat``: z = 0 (a fast path: no lookup at all);
- ``ramp:SLOPE[:AXIS]``: a plane descending along +AXIS (default y) with slope SLOPE rad,
  starting at the origin (flat before it);
- ``bump:HEIGHT[@Y][:WIDTH]``: a bump of HEIGHT m across the path, from y = Y (default 1.0 m)
  to Y + WIDTH (default 0.3 m), flat elsewhere (thesis Ch. 6.4, Fig. 6.13);
- ``rough:RANGE[:CELL[:SEED]]``: heights uniform in [0, RANGE] m on a grid of CELL m
  (default 0.1 m), seeded (default 0) (thesis Ch. 6.4, Fig. 6.14);
- ``matrix``: an explicit height matrix from a `.wl` file.

Outside the matrix the height of the nearest edge is used.
"""

from __future__ import annotations

from dataclasses import dataclass

import jax.numpy as jnp
import numpy as np

from cpgjax.sim.description import TerrainDef

EXTENT_X = (-3.0, 3.0)
EXTENT_Y = (-3.0, 12.0)


@dataclass(eq=False, frozen=True)
class Terrain:
    """A heightfield: heights[iy, ix] at x = x0 + ix*dx, y = y0 + iy*dy; ``None`` for flat."""

    spec: str = "flat"
    heights: np.ndarray | None = None
    x0: float = 0.0
    y0: float = 0.0
    dx: float = 1.0
    dy: float = 1.0

    @property
    def flat(self) -> bool:
        return self.heights is None

    def height_np(self, x, y):
        """Heights at numpy points (for plotting and exports)."""
        if self.flat:
            return np.zeros_like(np.asarray(x, float))
        return np.asarray(height_and_normal(self, jnp.asarray(x), jnp.asarray(y))[0])


def _grid(extent_x, extent_y, cell):
    nx = int(round((extent_x[1] - extent_x[0]) / cell)) + 1
    ny = int(round((extent_y[1] - extent_y[0]) / cell)) + 1
    xs = extent_x[0] + cell * np.arange(nx)
    ys = extent_y[0] + cell * np.arange(ny)
    return xs, ys


def make_terrain(spec: str | TerrainDef | None) -> Terrain:
    """Build a Terrain from CLI text (``bump:0.02@1.0``) or a `.wl` TerrainDef."""
    if spec is None:
        return Terrain()
    if isinstance(spec, TerrainDef):
        kind, params, axis = spec.kind.lower(), tuple(spec.params), spec.axis
        if kind == "matrix":
            nx, ny, x0, x1, y0, y1 = params[:6]
            h = np.asarray(spec.heights, float).reshape(int(ny), int(nx))
            return Terrain("matrix", h, x0, y0, (x1 - x0) / max(int(nx) - 1, 1), (y1 - y0) / max(int(ny) - 1, 1))
        p = [repr(float(v)) for v in params]
        if kind == "bump":
            text = f"bump:{p[0]}" + (f"@{p[1]}" if len(p) > 1 else "") + (f":{p[2]}" if len(p) > 2 else "")
        elif kind == "ramp":
            text = f"ramp:{p[0]}:{axis}"
        else:
            text = ":".join([kind, *p])
        return make_terrain(text)
    text = spec.strip()
    kind, _, rest = text.partition(":")
    kind = kind.lower()
    try:
        if kind == "flat":
            return Terrain()
        if kind == "ramp":
            parts = rest.split(":")
            slope = float(parts[0])
            axis = parts[1].upper() if len(parts) > 1 else "Y"
            xs, ys = _grid(EXTENT_X, EXTENT_Y, 0.5)
            coord = xs[None, :] if axis == "X" else ys[:, None]
            h = -np.tan(slope) * np.maximum(coord, 0.0) * np.ones((len(ys), len(xs)))
            return Terrain(text, h, xs[0], ys[0], xs[1] - xs[0], ys[1] - ys[0])
        if kind == "bump":
            head, _, width = rest.partition(":")
            hstr, _, ystr = head.partition("@")
            height = float(hstr)
            y_at = float(ystr) if ystr else 1.0
            w = float(width) if width else 0.3
            cell = 0.01
            ys = np.arange(y_at - 0.1, y_at + w + 0.1 + cell / 2, cell)
            inside = (ys >= y_at - 1e-9) & (ys <= y_at + w + 1e-9)
            h = np.where(inside, height, 0.0)[:, None] * np.ones((1, 2))
            return Terrain(text, h, EXTENT_X[0], ys[0], EXTENT_X[1] - EXTENT_X[0], cell)
        if kind == "rough":
            parts = rest.split(":")
            rng_range = float(parts[0])
            cell = float(parts[1]) if len(parts) > 1 and parts[1] else 0.1
            seed = int(float(parts[2])) if len(parts) > 2 and parts[2] else 0
            xs, ys = _grid(EXTENT_X, EXTENT_Y, cell)
            h = np.random.default_rng(seed).uniform(0.0, rng_range, size=(len(ys), len(xs)))
            return Terrain(text, h, xs[0], ys[0], cell, cell)
    except (ValueError, IndexError) as e:
        raise ValueError(f"bad terrain {text!r}: {e}; expected flat | ramp:SLOPE[:X|Y] | "
                         "bump:HEIGHT[@Y][:WIDTH] | rough:RANGE[:CELL[:SEED]]") from None
    raise ValueError(f"unknown terrain {text!r}; expected flat | ramp:SLOPE[:X|Y] | "
                     "bump:HEIGHT[@Y][:WIDTH] | rough:RANGE[:CELL[:SEED]]")


def height_and_normal(terrain: Terrain, x, y):
    """Height z_g(x, y) and unit surface normal (3-tuple) by bilinear interpolation."""
    if terrain.flat:
        z = jnp.zeros_like(x)
        return z, (z, z, z + 1.0)
    h = jnp.asarray(terrain.heights, dtype=x.dtype)
    ny, nx = terrain.heights.shape
    u = jnp.clip((x - terrain.x0) / terrain.dx, 0.0, nx - 1.000001)
    v = jnp.clip((y - terrain.y0) / terrain.dy, 0.0, ny - 1.000001)
    ix = jnp.floor(u).astype(jnp.int32)
    iy = jnp.floor(v).astype(jnp.int32)
    fx, fy = u - ix, v - iy
    flat = h.reshape(-1)
    i00 = iy * nx + ix
    h00, h01 = flat[i00], flat[i00 + 1]
    h10, h11 = flat[i00 + nx], flat[i00 + nx + 1]
    z = (1 - fy) * ((1 - fx) * h00 + fx * h01) + fy * ((1 - fx) * h10 + fx * h11)
    gx = ((1 - fy) * (h01 - h00) + fy * (h11 - h10)) / terrain.dx
    gy = ((1 - fx) * (h10 - h00) + fx * (h11 - h01)) / terrain.dy
    inv = jnp.reciprocal(jnp.sqrt(1.0 + gx * gx + gy * gy))
    return z, (-gx * inv, -gy * inv, inv)
