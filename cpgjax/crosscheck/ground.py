"""The ground's form in MuJoCo: one surface, our bilinear terrain sampled (``mjcf.hfield_grid``), in one of these forms.

- ``hfield`` (the export's default): a MuJoCo heightfield.  MuJoCo collides a geom with each triangular prism of a
  heightfield on its own; a small sphere that sinks below the top of the prism beside it is pushed out through that
  prism's vertical wall (``docs/crosscheck.md``, *The ground's form in MuJoCo*).
- ``mesh``: every triangle of the heightfield's triangulation (the same two triangles per cell, the same heights) as
  a convex mesh of its own: the triangle and, ``PIECE_DEPTH`` below its lowest corner, a base of the same outline
  (a thin prism; MuJoCo collides a mesh as its convex hull, so one mesh of a rough field would be its hull).
- ``boxes``: every cell of the sampled grid as a thin box, tilted to the plane through the cell's mean height with
  the cell's mean slopes (MuJoCo's analytic sphere-box contact); a box's top differs from the cell's two triangles by
  up to a quarter of the cell's twist: within 0.46 mm of the heightfield on 2 cm roughness sampled 4x finer.

MuJoCo recomputes the pose of every geom at every step, static ones too: a mesh or boxes ground costs time per
piece per step (docs/crosscheck.md, *The ground's form in MuJoCo*), so these forms cover only where the robot
can walk (:func:`walk_region`: its contact vertices' footprint, ``MARGIN`` either side and behind, ``REACH``
ahead); around it lies the heightfield, lowered by ``PIT`` under the region, so that only the pieces touch a
foot inside it.
"""

from __future__ import annotations

import contextvars
import xml.etree.ElementTree as ET

import numpy as np

from cpgjax.crosscheck.scoped import scoped

GROUND_FORMS = ("hfield", "mesh", "boxes")
PIECE_DEPTH = 0.03   # m: a piece's thickness below its lowest corner (3 radii of a foot sphere)
MARGIN = 0.5         # m: the region of pieces beyond the contact vertices' footprint, sideways and behind
REACH = 5.0          # m: ... and ahead (+y): 0.5 m/s for 10 s
PIT = 0.1            # m: how far the heightfield lies below the lowest piece inside the region

_FORM: contextvars.ContextVar[str] = contextvars.ContextVar("mujoco_ground", default="hfield")


def check_form(form: str) -> str:
    """``form`` if it is one of :data:`GROUND_FORMS`, else ValueError naming them."""
    if form not in GROUND_FORMS:
        raise ValueError(f"unknown MuJoCo ground form {form!r}; expected one of {', '.join(GROUND_FORMS)}")
    return form


def current_form() -> str:
    """The form the export uses when none is given: ``hfield``, or the one of an enclosing :func:`ground_form`."""
    return _FORM.get()


def ground_form(form: str | None):
    """Within this block every MuJoCo export (``mjcf.to_mjcf``, ``mjcf.load``) gives the ground this form (None:
    unchanged), so that commands that run MuJoCo (crosscheck, transfer) take it without threading it through."""
    return scoped(_FORM, None if form is None else check_form(form))


def walk_region(model) -> tuple[float, float, float, float]:
    """(x_lo, x_hi, y_lo, y_hi) where the pieces lie: the contact vertices' footprint in the initial pose, widened by
    :data:`MARGIN` and :data:`REACH` ahead."""
    from cpgjax.sim.rotation import quat_to_mat_np

    if len(model.ct_pt) == 0:
        return -MARGIN, MARGIN, -MARGIN, REACH
    b = model.pt_body[model.ct_pt]
    R = quat_to_mat_np(np.asarray(model.q0)[:, b])
    p = np.asarray(model.x0)[:, b] + np.einsum("ij...,j...->i...", R, np.asarray(model.pt_local)[:, model.ct_pt])
    return (float(p[0].min()) - MARGIN, float(p[0].max()) + MARGIN, float(p[1].min()) - MARGIN,
            float(p[1].max()) + REACH)


def _window(n: int, start: float, step: float, lo: float, hi: float) -> tuple[int, int]:
    """Index range [i0, i1] of grid points start + i step (i < n) whose cells cover lo..hi."""
    i0 = int(np.clip(np.floor((lo - start) / step), 0, n - 2))
    i1 = int(np.clip(np.ceil((hi - start) / step), i0 + 1, n - 1))
    return i0, i1


def triangles(H, x0: float, y0: float, dx: float, dy: float, ix=None, iy=None) -> np.ndarray:
    """[n, 3, 3] MuJoCo's triangulation of the heightfield ``H[iy, ix]`` (x = x0 + ix dx, y = y0 + iy dy) over the
    cells of grid points ``ix = (i0, i1)``, ``iy`` (default all): each cell split along its diagonal from
    (ix, iy) to (ix + 1, iy + 1), as MuJoCo splits it (ray casts agree to 1e-9, tests/crosscheck/test_ground.py)."""
    ny, nx = H.shape
    i0, i1 = ix or (0, nx - 1)
    j0, j1 = iy or (0, ny - 1)
    X, Y = np.meshgrid(x0 + dx * np.arange(i0, i1 + 1), y0 + dy * np.arange(j0, j1 + 1))
    P = np.stack([X, Y, H[j0:j1 + 1, i0:i1 + 1]], -1)            # [cy + 1, cx + 1, 3]
    a, b, c, d = P[:-1, :-1], P[:-1, 1:], P[1:, :-1], P[1:, 1:]  # (x, y), (x+, y), (x, y+), (x+, y+)
    t1 = np.stack([a, b, d], -2).reshape(-1, 3, 3)
    t2 = np.stack([a, d, c], -2).reshape(-1, 3, 3)
    return np.concatenate([t1, t2])


def _f(v) -> str:
    return " ".join(f"{x:.9g}" for x in np.ravel(np.asarray(v, float)).tolist())


def hfield_geom(asset, world, grid, *, radius: float, attrs: dict) -> None:
    """The ``hfield`` asset and the ``ground`` geom of the sampled ``grid`` = (H, x0, y0, dx, dy), ``radius`` lower than
    it, with the contact ``attrs``, into the MJCF ``asset`` and ``world`` elements."""
    H, x0, y0, dx, dy = grid
    ny, nx = H.shape
    hmin, hmax = float(H.min()), float(H.max())
    span = max(hmax - hmin, 1e-6)
    ET.SubElement(asset, "hfield", name="terrain", nrow=str(ny), ncol=str(nx),
                  size=f"{dx * (nx - 1) / 2:.9g} {dy * (ny - 1) / 2:.9g} {span:.9g} 0.1",
                  # MuJoCo's first elevation row is at +y, ours (heights[iy]) at -y: flip the rows
                  elevation=" ".join(f"{v:.7g}" for v in ((H - hmin) / span)[::-1].ravel()))
    cx, cy = x0 + dx * (nx - 1) / 2, y0 + dy * (ny - 1) / 2
    ET.SubElement(world, "geom", name="ground", type="hfield", hfield="terrain",
                  pos=f"{cx:.9g} {cy:.9g} {hmin - radius:.9g}", **attrs)


def add_ground(asset, world, model, form: str, grid, *, radius: float, attrs: dict) -> None:
    """Write the ground of ``form`` (``mesh`` or ``boxes``) for the sampled ``grid`` = (H, x0, y0, dx, dy) into the
    MJCF ``asset`` and ``world`` elements: the pieces over :func:`walk_region`, a heightfield with a pit beyond.
    ``radius``: the foot spheres' (the ground lies that much lower); ``attrs``: the ground's contact attributes."""
    H, x0, y0, dx, dy = grid
    ny, nx = H.shape
    xl, xh, yl, yh = walk_region(model)
    ix, iy = _window(nx, x0, dx, xl, xh), _window(ny, y0, dy, yl, yh)
    if check_form(form) == "mesh":
        tri = triangles(H, x0, y0, dx, dy, ix, iy)
        base = tri.copy()
        base[..., 2] = tri[..., 2].min(-1, keepdims=True) - PIECE_DEPTH
        pieces = np.concatenate([tri, base], 1) - [0, 0, radius]          # [n, 6, 3]
        for k, piece in enumerate(pieces):
            ET.SubElement(asset, "mesh", name=f"ground{k}", vertex=_f(piece))
            ET.SubElement(world, "geom", name=f"ground_m{k}", type="mesh", mesh=f"ground{k}", **attrs)
    else:
        sub = H[iy[0]:iy[1] + 1, ix[0]:ix[1] + 1]
        h = (sub[:-1, :-1] + sub[:-1, 1:] + sub[1:, :-1] + sub[1:, 1:]) / 4
        sx = (sub[:-1, 1:] + sub[1:, 1:] - sub[:-1, :-1] - sub[1:, :-1]) / (2 * dx)   # mean slopes of each cell
        sy = (sub[1:, :-1] + sub[1:, 1:] - sub[:-1, :-1] - sub[:-1, 1:]) / (2 * dy)
        # each cell's frame, all cells at once: x along the cell's x slope, z its normal, y = z x x
        ex = np.stack([np.ones_like(sx), np.zeros_like(sx), sx], -1)
        n = np.stack([-sx, -sy, np.ones_like(sx)], -1)
        ex, n = ex / np.linalg.norm(ex, axis=-1, keepdims=True), n / np.linalg.norm(n, axis=-1, keepdims=True)
        ey = np.cross(n, ex)
        # half-sizes: the top face covers the cell's footprint (ey leans along x by ey[0] / ey[1])
        hx, hy = (dx + np.abs(ey[..., 0] / ey[..., 1]) * dy) / 2 / ex[..., 0], dy / 2 / ey[..., 1]
        jj, ii = np.meshgrid(np.arange(h.shape[0]), np.arange(h.shape[1]), indexing="ij")
        c = np.stack([x0 + dx * (ix[0] + ii + 0.5), y0 + dy * (iy[0] + jj + 0.5), h - radius], -1)
        pos, axes = c - n * PIECE_DEPTH / 2, np.concatenate([ex, ey], -1)
        for k, (j, i) in enumerate(np.ndindex(h.shape)):
            ET.SubElement(world, "geom", name=f"ground_b{k}", type="box",
                          size=f"{hx[j, i]:.9g} {hy[j, i]:.9g} {PIECE_DEPTH / 2:.9g}", pos=_f(pos[j, i]),
                          xyaxes=_f(axes[j, i]), **attrs)
    pit = H.copy()
    inner = pit[iy[0] + 1:iy[1], ix[0] + 1:ix[1]]
    inner[...] = H.min() - PIT
    hfield_geom(asset, world, (pit, x0, y0, dx, dy), radius=radius, attrs=attrs)


LEDGE_X = 5.0        # m: a ledge box's half-width across the path (the walking area is x -3..3)
LEDGE_Y = (-5.0, 15.0)   # m: the first and last level reach this far along the path (the walking area: y -3..12)
LEDGE_BASE = 0.1     # m: how far the boxes reach below the lowest level


def ledge_boxes(world, ledges, *, radius: float, attrs: dict) -> None:
    """A ground of ledges (:mod:`cpgjax.sim.ledges`) as one box per level into the MJCF ``world`` element: the solid
    our vertices meet, shrunk by the foot spheres' ``radius`` (the tops ``radius`` lower, and a riser's face
    ``radius`` further into the higher level), so that a sphere's centre touches it where our vertex touches the
    profile (but at a riser's top edge, which the sphere rolls over on a radius).  A level's box reaches under a
    higher neighbour by ``radius`` as well: no seam."""
    e = np.concatenate([[LEDGE_Y[0]], np.asarray(ledges.edges, float), [LEDGE_Y[1]]])
    lv = np.asarray(ledges.levels, float)
    bottom = lv.min() - radius - LEDGE_BASE
    for i, top in enumerate(lv):
        lo, hi = e[i], e[i + 1]
        if i > 0:
            lo += radius if lv[i - 1] < top else -radius
        if i < len(lv) - 1:
            hi += -radius if lv[i + 1] < top else radius
        zt = top - radius
        ET.SubElement(world, "geom", name=f"ledge{i}", type="box",
                      size=f"{LEDGE_X:.9g} {(hi - lo) / 2:.9g} {(zt - bottom) / 2:.9g}",
                      pos=_f([0.0, (lo + hi) / 2, (zt + bottom) / 2]), **attrs)


def course_ground(asset, world, terrain, spans, *, radius: float, attrs: dict, sub: int = 4) -> None:
    """A course with rough items (:mod:`cpgjax.sim.course`) into the MJCF ``asset`` and ``world`` elements: the ledges'
    boxes (:func:`ledge_boxes`), cut at each rough item's ``spans`` (y from, to) and :data:`PIT` lower there, and over
    each item a heightfield of our surface sampled ``sub`` times per cell, a radius beyond the item's ends, where
    the boxes beside it end (a radius short of an end where the ground beyond it drops; ``radius`` lower than ours,
    as every form)."""
    led = terrain.ledges
    edges, levels = list(np.asarray(led.edges, float)), list(np.asarray(led.levels, float))
    tops = list(levels)
    for a, b in spans:                       # each span as a piece of its own, PIT lower
        for y in (a, b):
            if np.isclose(edges, y, rtol=0, atol=1e-9).any():
                continue
            i = int(np.searchsorted(edges, y, side="right"))
            edges.insert(i, y)
            levels.insert(i, levels[i])
            tops.insert(i, tops[i])
        i = int(np.searchsorted(edges, a, side="right"))
        tops[i] = levels[i] - PIT
    from cpgjax.sim.ledges import Ledges

    ledge_boxes(world, Ledges(np.asarray(edges), np.asarray(tops)), radius=radius, attrs=attrs)
    for k, (a, b) in enumerate(spans):
        inside = float(led.level_np((a + b) / 2))             # a radius beyond each end, unless the ground drops
        y0 = a - (radius if led.level_np(a - 1e-6) >= inside else -radius)
        y1 = b + (radius if led.level_np(b + 1e-6) >= inside else -radius)
        ny = int(np.ceil((y1 - y0) / terrain.dy * sub)) + 1
        nx = int(np.ceil((LEDGE_X * 2) / terrain.dx * sub)) + 1
        ys, xs = np.linspace(y0, y1, ny), np.linspace(-LEDGE_X, LEDGE_X, nx)
        X, Y = np.meshgrid(xs, ys)
        H = terrain.height_np(X, np.clip(Y, a, b))            # beyond the item: its level (the rough part is 0 there)
        hmin, span = float(H.min()), max(float(H.max() - H.min()), 1e-6)
        ET.SubElement(asset, "hfield", name=f"rough{k}", nrow=str(ny), ncol=str(nx),
                      size=f"{LEDGE_X:.9g} {(y1 - y0) / 2:.9g} {span:.9g} 0.1",
                      elevation=" ".join(f"{v:.7g}" for v in ((H - hmin) / span)[::-1].ravel()))
        ET.SubElement(world, "geom", name=f"rough{k}", type="hfield", hfield=f"rough{k}",
                      pos=f"0 {(y0 + y1) / 2:.9g} {hmin - radius:.9g}", **attrs)
