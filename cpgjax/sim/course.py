"""A course: grounds chained along the path (thesis Ch. 7.4: "flat surface, randomly ragged terrain, regular
structures (e.g. stairs)", each its own attractor).

``course:ITEM,ITEM,...`` from y = :data:`COURSE_AT` on, each item starting where the one before ended and at the
height it left (flat at that height after the last one):

- ``flat:LENGTH``;
- ``rough:RANGE:LENGTH[:SEED]``: heights uniform in [0, RANGE] on the rough kind's 0.1 m cells, from one cell
  into the item to one cell before its end (bilinear ramps there: no step into it);
- ``stairs:RISE:TREAD:N``: N steps (N TREAD long; negative RISE: down);
- ``bar:HEIGHT[:DEPTH]`` and ``gap:WIDTH``: as the kinds of those names.

It is built as :mod:`cpgjax.sim.ledges` (the vertical faces: stairs, bars, gaps and the levels they leave)
plus a heightfield of the rough items only (``None`` when there is none).  ``.wl``: ``Terrain course TEXT`` with
the same text (no spaces).  The items are coded as numbers in a TerrainDef's params, :data:`SLOTS` per item.
"""

from __future__ import annotations

import math

import numpy as np

from cpgjax.sim import ledges as L

COURSE_AT = 0.5       # m: where the first item starts (the quadruped's front feet start near y = 0.3)
ROUGH_CELL = 0.1      # m: a rough item's cells (the rough kind's default)
ITEMS = {"flat": (1, 1, "flat:LENGTH"), "rough": (2, 3, "rough:RANGE:LENGTH[:SEED]"),
         "stairs": (3, 3, "stairs:RISE:TREAD:N"), "bar": (1, 2, "bar:HEIGHT[:DEPTH]"), "gap": (1, 1, "gap:WIDTH")}
CODES = tuple(ITEMS)  # an item's kind as a number: its index here
SLOTS = 4             # numbers per item in a TerrainDef's params: the code, then up to 3 parameters (NaN: none)
LENGTH_MAX = 12.0     # m: the whole course at most (the workspace's y reaches 12 m)
SYNTAX = "course:ITEM,ITEM,... with ITEM one of " + ", ".join(v[2] for v in ITEMS.values())


def parse_items(text: str) -> list[tuple[str, tuple[float, ...]]]:
    """``flat:1,stairs:0.04:0.3:3`` to ``[("flat", (1.0,)), ("stairs", (0.04, 0.3, 3.0))]``; ValueError naming the
    item that is wrong."""
    if not text:
        raise ValueError(f"a course needs at least one item; {SYNTAX}")
    items = []
    for k, item in enumerate(text.split(","), 1):
        kind, *parts = item.strip().split(":")
        if kind not in ITEMS:
            raise ValueError(f"course item {k} {item!r}: unknown kind {kind!r}; {SYNTAX}")
        lo, hi, usage = ITEMS[kind]
        if not lo <= len(parts) <= hi:
            raise ValueError(f"course item {k} {item!r}: {kind} takes {usage.split(':', 1)[1]}")
        try:
            p = tuple(float(v) for v in parts)
        except ValueError:
            raise ValueError(f"course item {k} {item!r}: {usage} expects numbers") from None
        items.append((kind, p))
    return items


def check_items(items) -> None:
    """ValueError naming the first item out of range, or a course longer than :data:`LENGTH_MAX`."""
    total = 0.0
    for k, (kind, p) in enumerate(items, 1):
        if not all(math.isfinite(v) for v in p):
            raise ValueError(f"course item {k} ({kind}): its numbers must be finite")
        if kind in ("flat", "rough") and not 0 < p[kind == "rough"] <= LENGTH_MAX:
            raise ValueError(f"course item {k} ({kind}): its LENGTH must be positive and at most {LENGTH_MAX:g} m, "
                             f"got {p[kind == 'rough']:g}")
        if kind == "rough":
            if p[0] < 0:
                raise ValueError(f"course item {k} (rough): RANGE must be >= 0 m, got {p[0]:g}")
            if len(p) > 2 and (p[2] < 0 or not p[2].is_integer()):
                raise ValueError(f"course item {k} (rough): SEED must be a non-negative integer, got {p[2]:g}")
        elif kind in ("stairs", "bar", "gap"):
            try:
                L.check(kind, p)
            except ValueError as e:
                raise ValueError(f"course item {k}: {e}") from None
        total += _length(kind, p)
    if total > LENGTH_MAX:
        raise ValueError(f"the course is {total:g} m long; at most {LENGTH_MAX:g} m (the workspace's y ends at 12 m)")


def _length(kind: str, p) -> float:
    return {"flat": lambda: p[0], "rough": lambda: p[1], "stairs": lambda: p[1] * p[2],
            "bar": lambda: p[1] if len(p) > 1 else L.BAR_DEPTH, "gap": lambda: p[0]}[kind]()


def encode(items) -> tuple[float, ...]:
    """The items as a TerrainDef's params: :data:`SLOTS` numbers each."""
    out: list[float] = []
    for kind, p in items:
        out += [float(CODES.index(kind)), *p, *([math.nan] * (SLOTS - 1 - len(p)))]
    return tuple(out)


def decode(params) -> list[tuple[str, tuple[float, ...]]]:
    """The inverse of :func:`encode`."""
    p = list(params)
    return [(CODES[int(p[i])], tuple(v for v in p[i + 1:i + SLOTS] if not math.isnan(v)))
            for i in range(0, len(p), SLOTS)]


def _g(v: float) -> str:
    return str(int(v)) if float(v).is_integer() else f"{v:g}"


def text(items) -> str:
    """The course's text (``flat:1,stairs:0.04:0.3:3``)."""
    return ",".join(":".join([kind, *map(_g, p)]) for kind, p in items)


def build(items, xs: np.ndarray, ys: np.ndarray):
    """(ledges, rough heights [len(ys), len(xs)] or None, the rough items' y ranges) of a course, the heightfield on
    the grid ``xs`` x ``ys`` (:data:`ROUGH_CELL` apart)."""
    edges: list[float] = []
    levels = [0.0]
    rough = np.zeros((len(ys), len(xs)))
    spans = []
    y, level = COURSE_AT, 0.0

    def step_to(at, new):
        if edges and abs(edges[-1] - at) < 1e-9:      # two faces at one place (a gap, then a bar): one face
            edges.pop()
            levels.pop()
        if new != levels[-1]:
            edges.append(at)
            levels.append(new)

    for kind, p in items:
        length = _length(kind, p)
        if kind == "stairs":
            for k in range(int(p[2])):
                step_to(y + k * p[1], level + (k + 1) * p[0])
            level += int(p[2]) * p[0]
        elif kind in ("bar", "gap"):
            step_to(y, level + (p[0] if kind == "bar" else -L.GAP_DEPTH))
            step_to(y + length, level)
        elif kind == "rough":
            inside = (ys >= y + ROUGH_CELL - 1e-9) & (ys <= y + length - ROUGH_CELL + 1e-9)
            draw = np.random.default_rng(int(p[2]) if len(p) > 2 else 0).uniform(0.0, p[0], (int(inside.sum()),
                                                                                              len(xs)))
            rough[inside] = draw
            spans.append((y, y + length))
        y += length
    led = L.Ledges(np.asarray(edges, float), np.asarray(levels, float))
    return led, (rough if spans else None), spans


def rough_spans(spec: str) -> list[tuple[float, float]]:
    """The y ranges (from, to) of a course's rough items, from its text (``course:...``)."""
    y, spans = COURSE_AT, []
    for kind, p in parse_items(spec.split(":", 1)[1]):
        if kind == "rough":
            spans.append((y, y + p[1]))
        y += _length(kind, p)
    return spans
