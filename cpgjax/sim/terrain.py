"""Terrain: a matrix of heights scaled over the workspace, bilinearly interpolated (Appendix A).

Kinds (CLI syntax ``--terrain``, `.wl` syntax ``Terrain``; docs/wl-format.md §3.1):

- ``flat``: z = 0 (a fast path: no lookup at all);
- ``ramp:SLOPE[:AXIS]``: a plane descending along +AXIS (X or Y, default Y) with slope
  SLOPE rad (|SLOPE| < pi/2), starting at the origin (flat before it);
- ``bump:HEIGHT[@Y][:WIDTH]``: a bump of HEIGHT m across the path, from y = Y (default 1.0 m,
  |Y| <= 1000) to Y + WIDTH (default 0.3 m, 0.01 <= WIDTH <= 100), flat elsewhere
  (thesis Ch. 6.4, Fig. 6.13);
- ``rough:RANGE[:CELL[:SEED]]``: heights uniform in [0, RANGE] m (RANGE >= 0) on a grid of
  CELL m (default 0.1 m, 0.005 <= CELL <= 3), seeded (an integer >= 0, default 0)
  (thesis Ch. 6.4, Fig. 6.14);
- ``matrix``: an explicit height matrix from a `.wl` file;
- ``stairs:RISE:TREAD[:N]``, ``bar:HEIGHT@Y[:DEPTH]``, ``gap:WIDTH@Y``: vertical faces across the path
  (:mod:`cpgjax.sim.ledges`), not a heightfield;
- ``course:ITEM,ITEM,...``: grounds chained along the path (:mod:`cpgjax.sim.course`).

Outside the matrix the height of the nearest edge is used.

A robot starts on its terrain, never in it: :func:`start_lift` is how far its design pose is raised so
that no contact vertex starts under the ground (zero on flat ground, which leaves the pose as it is).

:func:`check_terrain` is the one validation of the values, shared by the command line
(:func:`parse_terrain`, which reads the text above) and the `.wl` parser; both raise
``ValueError`` messages that say what is wrong and what is allowed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import jax.numpy as jnp
import numpy as np

from cpgjax.sim import course as _course
from cpgjax.sim import ledges as _ledges
from cpgjax.sim.description import TerrainDef
from cpgjax.sim.ledges import Ledges

EXTENT_X = (-3.0, 3.0)
EXTENT_Y = (-3.0, 12.0)


@dataclass(eq=False, frozen=True)
class Terrain:
    """A heightfield: heights[iy, ix] at x = x0 + ix*dx, y = y0 + iy*dy (``None``: none), and vertical faces across
    the path added to it (``ledges``, :mod:`cpgjax.sim.ledges`; ``None``: none).  Neither: flat."""

    spec: str = "flat"
    heights: np.ndarray | None = None
    x0: float = 0.0
    y0: float = 0.0
    dx: float = 1.0
    dy: float = 1.0
    ledges: Ledges | None = None

    @property
    def flat(self) -> bool:
        return self.heights is None and self.ledges is None

    def height_np(self, x, y):
        """Heights at numpy points (for plotting, exports and the perturbed grounds), float32: the height of
        :func:`height_and_normal` computed in numpy, operation by operation as JAX runs it op by op, so the same
        bits on every host and no program to compile (a jitted one may fuse a product and a sum into one
        rounding where the CPU has FMA; ``tests/sim/test_terrain.py`` compares the two)."""
        if self.flat:
            return np.zeros_like(np.asarray(x, float))
        x, y = np.asarray(x, np.float32), np.asarray(y, np.float32)
        one = np.float32(1.0)
        if self.heights is None:
            z = np.zeros_like(x)
        else:
            h = np.asarray(self.heights, np.float32).reshape(-1)
            ny, nx = self.heights.shape
            f32 = np.float32
            # XLA divides by a constant as it multiplies by the constant's float32 reciprocal
            u = np.clip((x - f32(self.x0)) * (one / f32(self.dx)), f32(0.0), f32(nx - 1.000001))
            v = np.clip((y - f32(self.y0)) * (one / f32(self.dy)), f32(0.0), f32(ny - 1.000001))
            ix, iy = np.floor(u).astype(np.int32), np.floor(v).astype(np.int32)
            fx, fy = u - ix.astype(np.float32), v - iy.astype(np.float32)
            i00 = iy * nx + ix
            last = h.size - 1       # JAX clamps an index past the end (where u or v rounds up to the last row)
            h00, h01 = h[np.minimum(i00, last)], h[np.minimum(i00 + 1, last)]
            h10, h11 = h[np.minimum(i00 + nx, last)], h[np.minimum(i00 + nx + 1, last)]
            z = (one - fy) * ((one - fx) * h00 + fx * h01) + fy * ((one - fx) * h10 + fx * h11)
        if self.ledges is not None:
            z = z + self.ledges.level_np(y, np.float32)
        return z


def _grid(extent_x, extent_y, cell):
    nx = int(round((extent_x[1] - extent_x[0]) / cell)) + 1
    ny = int(round((extent_y[1] - extent_y[0]) / cell)) + 1
    xs = extent_x[0] + cell * np.arange(nx)
    ys = extent_y[0] + cell * np.arange(ny)
    return xs, ys


#: The command-line syntax of a terrain (``--terrain``); the `.wl` ``Terrain`` statement has the
#: same kinds and parameters, written as separate numbers (docs/wl-format.md §3.1).
TERRAIN_SYNTAX = ("flat | ramp:SLOPE[:X|Y] | bump:HEIGHT[@Y][:WIDTH] | rough:RANGE[:CELL[:SEED]] | "
                  "stairs:RISE:TREAD[:N] | bar:HEIGHT@Y[:DEPTH] | gap:WIDTH@Y | course:ITEM,ITEM,...")
TERRAIN_KINDS = ("flat", "ramp", "bump", "rough", "matrix", "stairs", "bar", "gap", "course")
_EXAMPLES = {"flat": "flat", "ramp": "ramp:0.1", "bump": "bump:0.02@1.0:0.3", "rough": "rough:0.02:0.1:7",
             "stairs": "stairs:0.04:0.3:5", "bar": "bar:0.03@1.0:0.05", "gap": "gap:0.1@1.0",
             "course": "course:flat:1,rough:0.02:2,stairs:0.04:0.3:3,bar:0.03,flat:1"}
BUMP_CELL = 0.01  # m: the grid of a bump along y
BUMP_WIDTH = (BUMP_CELL, 100.0)  # m: a bump narrower than its grid cell could fall between two rows
BUMP_MAX_Y = 1000.0  # m: |Y|; beyond, y + WIDTH rounds to y in float64
ROUGH_CELL = (0.005, 3.0)  # m: finer does not fit in memory, coarser leaves < 3 grid points across x


def _g(v: float) -> str:
    return str(int(v)) if v.is_integer() and abs(v) < 1e15 else f"{v:g}"


def check_terrain(kind: str, params=(), axis: str = "Y", heights=None, line: int = 0) -> TerrainDef:
    """The one validation of a terrain's values, shared by ``--terrain`` and the `.wl` ``Terrain``.

    Returns the :class:`TerrainDef`; raises ``ValueError`` with a message that says what is
    wrong and the allowed range (the `.wl` parser prefixes ``path:line:``, :func:`parse_terrain`
    the spec).  Counts of parameters are checked too (for a TerrainDef built in code).
    """
    kind = str(kind).lower()
    p = tuple(float(v) for v in params)
    axis = str(axis).upper()
    if kind not in TERRAIN_KINDS:
        raise ValueError(f"unknown terrain kind {kind!r}; expected one of {', '.join(TERRAIN_KINDS)}")
    if kind == "course":
        _course.check_items(_course.decode(p))
        return TerrainDef(kind, p, line=line)
    counts = {"flat": (0, 0), "ramp": (1, 1), "bump": (1, 3), "rough": (1, 3), "matrix": (6, 6), "stairs": (2, 3),
              "bar": (2, 3), "gap": (2, 2)}[kind]
    if not counts[0] <= len(p) <= counts[1]:
        raise ValueError(f"{kind} terrain takes {counts[0]} to {counts[1]} parameters, got {len(p)}")
    if not all(math.isfinite(v) for v in p):
        raise ValueError(f"{kind} terrain parameters must be finite numbers, got {' '.join(map(_g, p))}")
    if kind == "ramp":
        if axis not in ("X", "Y"):
            raise ValueError(f"ramp axis must be X or Y, got {axis!r}")
        if abs(p[0]) >= math.pi / 2:
            raise ValueError(f"ramp slope is an angle in radians, |SLOPE| < pi/2, got {p[0]:g}")
    elif kind == "bump":
        if len(p) > 1 and abs(p[1]) > BUMP_MAX_Y:
            raise ValueError(f"bump Y must be within +-{BUMP_MAX_Y:g} m, got {p[1]:g}")
        if len(p) > 2:
            if p[2] <= 0:
                raise ValueError(f"bump WIDTH must be positive (metres along y), got {p[2]:g}")
            if not BUMP_WIDTH[0] <= p[2] <= BUMP_WIDTH[1]:
                raise ValueError(f"bump WIDTH must be between {BUMP_WIDTH[0]:g} m (the bump's grid cell) and "
                                 f"{BUMP_WIDTH[1]:g} m, got {p[2]:g}")
    elif kind == "rough":
        if p[0] < 0:
            raise ValueError(f"rough RANGE must be >= 0 (metres), got {p[0]:g}")
        if len(p) > 1:
            if p[1] <= 0:
                raise ValueError(f"rough CELL must be positive (metres), got {p[1]:g}")
            if not ROUGH_CELL[0] <= p[1] <= ROUGH_CELL[1]:
                raise ValueError(f"rough CELL must be between {ROUGH_CELL[0]:g} and {ROUGH_CELL[1]:g} m (the "
                                 f"grid covers x {EXTENT_X[0]:g}..{EXTENT_X[1]:g}, y {EXTENT_Y[0]:g}.."
                                 f"{EXTENT_Y[1]:g}), got {p[1]:g}")
        if len(p) > 2 and (p[2] < 0 or not p[2].is_integer()):
            raise ValueError(f"rough SEED must be a non-negative integer, got {_g(p[2])}")
    elif kind in ("stairs", "bar", "gap"):
        _check_ledges(kind, p)
    elif kind == "matrix":
        if not (p[0].is_integer() and p[1].is_integer()) or p[0] < 2 or p[1] < 2:
            raise ValueError(f"matrix needs NX >= 2 and NY >= 2 grid points, got {_g(p[0])} x {_g(p[1])}")
        if p[3] <= p[2] or p[5] <= p[4]:
            raise ValueError(f"matrix extent needs X0 < X1 and Y0 < Y1, got x {p[2]:g}..{p[3]:g}, "
                             f"y {p[4]:g}..{p[5]:g}")
        if heights is not None:
            nx, ny = int(p[0]), int(p[1])
            rows = [tuple(float(v) for v in row) for row in heights]
            if len(rows) != ny or any(len(r) != nx for r in rows):
                raise ValueError(f"matrix heights must be NY = {ny} rows of NX = {nx} numbers")
            if not all(math.isfinite(v) for r in rows for v in r):
                raise ValueError("matrix heights must be finite numbers")
            heights = tuple(rows)
    return TerrainDef(kind, p, heights=heights, axis=axis if kind == "ramp" else "Y", line=line)


def _check_ledges(kind: str, p: tuple[float, ...]) -> None:
    if kind == "stairs":
        _ledges.check(kind, p)
        return
    _ledges.check(kind, (p[0], *p[2:]))
    if abs(p[1]) > BUMP_MAX_Y:
        raise ValueError(f"{kind} Y must be within +-{BUMP_MAX_Y:g} m, got {p[1]:g}")


def _spec_number(tok: str, what: str) -> float:
    try:
        v = float(tok)
    except ValueError:
        raise ValueError(f"{what} expects a number, got {tok!r}") from None
    if not math.isfinite(v):
        raise ValueError(f"{what}: {tok!r} is not a finite number")
    return v


def parse_terrain(spec: str) -> TerrainDef:
    """Command-line text (``bump:0.02@1.0:0.3``, :data:`TERRAIN_SYNTAX`) to a checked TerrainDef.

    Raises ``ValueError("terrain 'SPEC': what is wrong (e.g. EXAMPLE)")``.
    """
    text = str(spec).strip()
    kind, _, rest = text.partition(":")
    kind = kind.lower()
    if kind not in _EXAMPLES:
        hint = " (a matrix terrain is given in a .wl file)" if kind == "matrix" else ""
        raise ValueError(f"unknown terrain {text!r}{hint}; expected {TERRAIN_SYNTAX}")
    try:
        axis = "Y"
        if kind == "flat":
            if rest:
                raise ValueError("flat takes no parameters")
            p: list[float] = []
        elif kind == "ramp":
            parts = rest.split(":")
            if len(parts) > 2:
                raise ValueError(f"ramp takes SLOPE[:X|Y], got {len(parts)} parameters")
            p = [_spec_number(parts[0], "ramp SLOPE")]
            axis = parts[1].upper() if len(parts) > 1 else "Y"
        elif kind == "bump":
            head, _, width = rest.partition(":")
            if ":" in width:
                raise ValueError("bump takes HEIGHT[@Y][:WIDTH], got more parameters")
            hstr, _, ystr = head.partition("@")
            p = [_spec_number(hstr, "bump HEIGHT"), _spec_number(ystr, "bump Y") if ystr else 1.0,
                 _spec_number(width, "bump WIDTH") if width else 0.3]
        elif kind == "course":
            p = list(_course.encode(_course.parse_items(rest)))
        elif kind == "stairs":
            parts = rest.split(":")
            if not 2 <= len(parts) <= 3:
                raise ValueError(f"stairs takes RISE:TREAD[:N], got {len(parts)} parameters")
            p = [_spec_number(parts[0], "stairs RISE"), _spec_number(parts[1], "stairs TREAD")]
            if len(parts) > 2:
                p.append(_spec_number(parts[2], "stairs N"))
        elif kind in ("bar", "gap"):
            head, _, depth = rest.partition(":")
            size, at, ystr = head.partition("@")
            what = "HEIGHT" if kind == "bar" else "WIDTH"
            if not at:
                raise ValueError(f"{kind} takes {what}@Y" + ("[:DEPTH]" if kind == "bar" else "") +
                                 ": where it stands along the path is not optional")
            if depth and kind == "gap":
                raise ValueError("gap takes WIDTH@Y, got more parameters")
            if ":" in depth:
                raise ValueError("bar takes HEIGHT@Y[:DEPTH], got more parameters")
            p = [_spec_number(size, f"{kind} {what}"), _spec_number(ystr, f"{kind} Y")]
            if depth:
                p.append(_spec_number(depth, "bar DEPTH"))
        else:  # rough
            parts = rest.split(":")
            if len(parts) > 3:
                raise ValueError(f"rough takes RANGE[:CELL[:SEED]], got {len(parts)} parameters")
            p = [_spec_number(parts[0], "rough RANGE"),
                 _spec_number(parts[1], "rough CELL") if len(parts) > 1 and parts[1] else 0.1]
            if len(parts) > 2 and parts[2]:
                p.append(_spec_number(parts[2], "rough SEED"))
        return check_terrain(kind, p, axis)
    except ValueError as e:
        raise ValueError(f"terrain {text!r}: {e} (e.g. {_EXAMPLES[kind]})") from None


def terrain_spec(tdef: TerrainDef) -> str:
    """The command-line text of a TerrainDef (``bump:0.02@1.0:0.3``; ``matrix`` for a matrix)."""
    kind = tdef.kind.lower()
    p = [repr(float(v)) for v in tdef.params]
    if kind == "bump":
        return f"bump:{p[0]}" + (f"@{p[1]}" if len(p) > 1 else "") + (f":{p[2]}" if len(p) > 2 else "")
    if kind == "ramp":
        return f"ramp:{p[0]}:{tdef.axis}"
    if kind in ("bar", "gap"):
        return f"{kind}:{p[0]}@{p[1]}" + (f":{p[2]}" if len(p) > 2 else "")
    if kind == "course":
        return "course:" + _course.text(_course.decode(tdef.params))
    return ":".join([kind, *p]) if kind != "matrix" else "matrix"


def make_terrain(spec: str | TerrainDef | None) -> Terrain:
    """Build a Terrain from CLI text (``bump:0.02@1.0``) or a `.wl` TerrainDef, checked by :func:`check_terrain`."""
    if spec is None:
        return Terrain()
    if isinstance(spec, TerrainDef):
        tdef = check_terrain(spec.kind, spec.params, spec.axis, spec.heights, spec.line)
        text = terrain_spec(tdef)
    else:
        text = str(spec).strip()
        tdef = parse_terrain(text)
    kind, p = tdef.kind, tdef.params
    if kind == "flat":
        return Terrain()
    if kind == "matrix":
        nx, ny, x0, x1, y0, y1 = p
        h = np.asarray(tdef.heights, float).reshape(int(ny), int(nx))
        return Terrain("matrix", h, x0, y0, (x1 - x0) / max(int(nx) - 1, 1), (y1 - y0) / max(int(ny) - 1, 1))
    if kind == "course":
        xs, ys = _grid(EXTENT_X, EXTENT_Y, _course.ROUGH_CELL)
        led, rough, _ = _course.build(_course.decode(p), xs, ys)
        if rough is None:
            return Terrain(text, ledges=led)
        return Terrain(text, rough, xs[0], ys[0], xs[1] - xs[0], ys[1] - ys[0], ledges=led)
    if kind == "stairs":
        return Terrain(text, ledges=_ledges.stairs(p[0], p[1], int(p[2]) if len(p) > 2 else _ledges.STAIRS_N))
    if kind == "bar":
        return Terrain(text, ledges=_ledges.bar(*p))
    if kind == "gap":
        return Terrain(text, ledges=_ledges.gap(*p))
    if kind == "ramp":
        xs, ys = _grid(EXTENT_X, EXTENT_Y, 0.5)
        coord = xs[None, :] if tdef.axis == "X" else ys[:, None]
        h = -np.tan(p[0]) * np.maximum(coord, 0.0) * np.ones((len(ys), len(xs)))
        return Terrain(text, h, xs[0], ys[0], xs[1] - xs[0], ys[1] - ys[0])
    if kind == "bump":
        height = p[0]
        y_at = p[1] if len(p) > 1 else 1.0
        w = p[2] if len(p) > 2 else 0.3
        cell = BUMP_CELL
        ys = np.arange(y_at - 0.1, y_at + w + 0.1 + cell / 2, cell)
        inside = (ys >= y_at - 1e-9) & (ys <= y_at + w + 1e-9)
        h = np.where(inside, height, 0.0)[:, None] * np.ones((1, 2))
        return Terrain(text, h, EXTENT_X[0], ys[0], EXTENT_X[1] - EXTENT_X[0], cell)
    # rough
    rng_range = p[0]
    cell = p[1] if len(p) > 1 else 0.1
    seed = int(p[2]) if len(p) > 2 else 0
    xs, ys = _grid(EXTENT_X, EXTENT_Y, cell)
    h = np.random.default_rng(seed).uniform(0.0, rng_range, size=(len(ys), len(xs)))
    return Terrain(text, h, xs[0], ys[0], cell, cell)


def start_lift(terrain: Terrain, points) -> float:
    """How far [m] to raise a robot whose contact vertices stand at ``points`` [3, n] so that none is under
    the ground: ``max(0, max_k z_g(x_k, y_k) - z_k)``.  The vertex with the most ground above it then touches
    the surface and the others stand on or above it.  0 on flat ground (and for a robot without contacts).

    Without it, a robot whose `.wl` pose stands on z = 0 started with its feet up to RANGE inside a
    ``rough:RANGE`` field: eq. 3.7 pushed them out with ``A d`` (400 N per foot at 4 mm), and in MuJoCo, whose
    heightfield is a union of prisms, a foot sphere whose centre starts below a prism's top is pushed sideways
    by the prism's wall and stays stuck in the ground (docs/crosscheck.md).
    """
    pts = np.asarray(points, float).reshape(3, -1)
    if terrain.flat or pts.shape[1] == 0:
        return 0.0
    zg = terrain.height_np(pts[0], pts[1])
    return float(max(0.0, np.max(zg - pts[2])))


def height_and_normal(terrain: Terrain, x, y):
    """Height z_g(x, y) and unit surface normal (3-tuple) by bilinear interpolation, plus the ledges' level
    (:mod:`cpgjax.sim.ledges`: the tread's, whose normal is vertical)."""
    if terrain.flat:
        z = jnp.zeros_like(x)
        return z, (z, z, z + 1.0)
    if terrain.heights is None:
        z = jnp.zeros_like(x)
        return z + _ledges.ledge_level(terrain.ledges, y), (z, z, z + 1.0)
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
    if terrain.ledges is not None:
        z = z + _ledges.ledge_level(terrain.ledges, y)
    return z, (-gx * inv, -gy * inv, inv)
