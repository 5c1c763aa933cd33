"""MAP-Elites and its iso+line variant on the :class:`~cpgjax.optim.algorithm.Algorithm` adapter (beyond the thesis).

Quality-diversity search (Mouret & Clune, *Illuminating search spaces by mapping elites*, 2015; Cully et
al., Nature 2015): the behaviour space (:mod:`cpgjax.episode.descriptors`) is cut into a grid of cells and
the archive keeps, in each cell, the best genome found whose behaviour falls in it (its *elite*).  Each
generation draws ``batch`` parents uniformly among the filled cells, varies them, evaluates the children in
one batched simulation and inserts each child whose fitness beats its cell's elite (or fills an empty cell).

Two variation operators:

========== ============================================================================================
method     child of parent ``x_i`` (genes in ``[lower, upper]``, width ``w = upper - lower``)
========== ============================================================================================
map-elites ``x_i + sigma w N(0, I)`` (Mouret & Clune's Gaussian mutation)
iso-line   ``x_i + sigma_iso w N(0, I) + sigma_line (x_j - x_i) N(0, 1)`` with ``x_j`` a second random
           elite (Vassiliades & Mouret, *Discovering the elite hypervolume by leveraging interspecies
           correlation*, GECCO 2018): the line term follows the correlations among the elites
========== ============================================================================================

and children are clipped to the box.  The first ``init_batches`` generations (and any generation while the
archive is still empty) are uniform random genomes in the box.

**Insertion** (:func:`insert`) is the only place the archive changes: per cell, the best valid child of the
batch (finite fitness and descriptor, not diverged; ties to the first) replaces the elite when its fitness
is strictly greater, or fills the cell.  It uses comparisons and selections only, no arithmetic, so an
archive rebuilt from the stored rows (:func:`replay`) equals the one the run held, bit for bit: that is
how ``cpgjax repertoire --resume`` continues a run exactly without storing the archive in every row.

**Coverage** is the share of filled cells; the **QD-score** the sum over filled cells of
``fitness - qd_offset`` (``qd_offset`` a lower bound of the fitness, so every elite adds to it).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from cpgjax.optim.algorithm import Algorithm
from cpgjax.optim.problem import Problem

METHODS = ("map-elites", "iso-line")
# default bounds of each descriptor dimension (duty factors: [0, 1]; speed m/s; turning rate rad/s)
DEFAULT_BOUNDS = {"duty": (0.0, 1.0), "heading_speed": (-0.1, 0.3), "turn": (-0.5, 0.5)}
# what a descriptor dimension measures, and in what unit (figures' axes, the cells a command prints)
UNITS = {"duty": "share of the time the foot is down", "heading_speed": "m/s", "turn": "rad/s"}


def unit(name: str) -> str:
    """The unit of descriptor dimension ``name`` (``duty_AR``: a duty factor)."""
    return UNITS["duty" if name.startswith("duty_") else name] if (name.startswith("duty_") or name in UNITS) else ""


def axis_label(name: str) -> str:
    """``turn [rad/s]``: a descriptor dimension with its unit, for a figure's axis."""
    u = unit(name)
    return f"{name} [{u}]" if u else name


def describe(names, values) -> str:
    """``heading_speed +0.212 m/s, turn -0.048 rad/s`` (duty factors without a unit: ``duty_AR 0.50``)."""
    parts = []
    for n, v in zip(names, np.asarray(values, float), strict=True):
        u = unit(n)
        parts.append(f"{n} {v:.2f}" if n.startswith("duty_") else f"{n} {v:+.3f}" + (f" {u}" if u else ""))
    return ", ".join(parts)


@dataclass(frozen=True)
class MEConfig:
    """Settings of one MAP-Elites run (defaults: Mouret & Clune's operator, Vassiliades & Mouret's iso+line)."""

    method: str = "map-elites"
    descriptor: str = "duty"
    cells: tuple[int, ...] = (5,)          # bins per dimension (one number: the same for every dimension)
    bounds: tuple[tuple[float, float], ...] = ()   # (lo, hi) per dimension; () = DEFAULT_BOUNDS
    evaluations: int = 10_000
    batch: int = 128                       # children per generation (one batched simulation)
    init_batches: int = 2                  # generations of uniform random genomes first
    sigma: float = 0.05                    # map-elites: mutation std, in box widths
    sigma_iso: float = 0.01                # iso-line: isotropic std, in box widths
    sigma_line: float = 0.2                # iso-line: std along the line between two elites
    qd_offset: float = -1.0                # fitness lower bound for the QD-score (m/s: no gait is slower)
    keep_fallen: bool = False              # insert robots that fell too (the problem's ``meta["fall_metric"]``)
    seed: int = 0
    chunk: int = 4                         # generations per jitted lax.scan chunk

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise ValueError(f"method must be one of {', '.join(METHODS)}, got {self.method!r}")
        if self.evaluations < 1 or self.batch < 1 or self.chunk < 1 or self.init_batches < 0:
            raise ValueError("evaluations, batch and chunk must be >= 1, init_batches >= 0")
        if not self.cells or any(int(c) < 1 for c in self.cells):
            raise ValueError(f"cells must be >= 1 per dimension, got {self.cells}")
        for name in ("sigma", "sigma_iso", "sigma_line"):
            v = getattr(self, name)
            if not (v >= 0 and math.isfinite(v)):
                raise ValueError(f"{name} must be >= 0, got {v}")
        for lo, hi in self.bounds:
            if not (math.isfinite(lo) and math.isfinite(hi) and hi > lo):
                raise ValueError(f"bounds must be finite with lo < hi, got {lo}:{hi}")

    @property
    def generations(self) -> int:
        return -(-self.evaluations // self.batch)

    def to_dict(self) -> dict[str, Any]:
        d = dataclasses.asdict(self)
        d["cells"], d["bounds"] = list(self.cells), [list(b) for b in self.bounds]
        return d


class Grid(NamedTuple):
    """The cells of the behaviour space: ``bins`` per dimension between ``lower`` and ``upper``."""

    names: tuple[str, ...]
    lower: np.ndarray
    upper: np.ndarray
    bins: tuple[int, ...]

    @property
    def n_cells(self) -> int:
        return int(np.prod(self.bins))


def make_grid(cfg: MEConfig, names: tuple[str, ...]) -> Grid:
    """The grid of ``cfg`` over the descriptor dimensions ``names`` (``duty_AR`` ..., or ``speed``, ``turn``)."""
    D = len(names)
    bins = tuple(int(c) for c in cfg.cells) * (D if len(cfg.cells) == 1 else 1)
    if len(bins) != D:
        raise ValueError(f"--cells gives {len(cfg.cells)} numbers for a descriptor of {D} dimensions "
                         f"({', '.join(names)}): give one, or {D}")
    if cfg.bounds:
        bounds = tuple(cfg.bounds) * (D if len(cfg.bounds) == 1 else 1)
        if len(bounds) != D:
            raise ValueError(f"--bounds gives {len(cfg.bounds)} ranges for a descriptor of {D} dimensions: "
                             f"give one, or {D}")
    else:
        bounds = tuple(DEFAULT_BOUNDS["duty" if n.startswith("duty_") else n] for n in names)
    lo = np.asarray([b[0] for b in bounds], np.float32)
    hi = np.asarray([b[1] for b in bounds], np.float32)
    return Grid(tuple(names), lo, hi, bins)


def cell_index(grid: Grid, desc):
    """The cell [N] int32 of descriptors [N, D] (row-major over the bins; outside the bounds: the edge cell).

    A descriptor that is not finite gets -1 (no cell).
    """
    desc = jnp.asarray(desc, jnp.float32)
    lo, hi = jnp.asarray(grid.lower), jnp.asarray(grid.upper)
    bins = jnp.asarray(grid.bins, jnp.int32)
    u = (desc - lo) / (hi - lo) * bins.astype(jnp.float32)
    k = jnp.clip(jnp.floor(jnp.where(jnp.isfinite(u), u, 0.0)).astype(jnp.int32), 0, bins - 1)
    idx = jnp.zeros(desc.shape[:-1], jnp.int32)
    for d in range(len(grid.bins)):
        idx = idx * grid.bins[d] + k[..., d]
    return jnp.where(jnp.all(jnp.isfinite(desc), -1), idx, -1)


def cell_centres(grid: Grid) -> np.ndarray:
    """The centre [C, D] of every cell, in :func:`cell_index`'s order."""
    axes = [grid.lower[d] + (np.arange(b) + 0.5) * (grid.upper[d] - grid.lower[d]) / b
            for d, b in enumerate(grid.bins)]
    mesh = np.meshgrid(*axes, indexing="ij")
    return np.stack([m.reshape(-1) for m in mesh], -1).astype(np.float32)


class MEState(NamedTuple):
    """The archive (per cell: elite genome, fitness, descriptor, filled) and the cells of the last batch."""

    genomes: jax.Array       # [C, G]
    fitness: jax.Array       # [C]
    descriptors: jax.Array   # [C, D]
    filled: jax.Array        # [C] bool
    cells: jax.Array         # [N] int32: the cell of each child of the last generation (-1: none)


def empty_archive(n_cells: int, n_genes: int, n_desc: int, batch: int) -> MEState:
    return MEState(jnp.zeros((n_cells, n_genes), jnp.float32), jnp.full((n_cells,), -jnp.inf, jnp.float32),
                   jnp.zeros((n_cells, n_desc), jnp.float32), jnp.zeros((n_cells,), bool),
                   jnp.full((batch,), -1, jnp.int32))


def insert(state: MEState, genomes, fitness, descriptors, cells, valid) -> MEState:
    """The archive with a batch inserted: per cell the best valid child (ties: the first) if strictly better.

    ``genomes`` [N, G], ``fitness`` [N], ``descriptors`` [N, D], ``cells`` [N] int32 (-1: none),
    ``valid`` [N] bool.  Comparisons and selections only (see the module docstring).
    """
    C, N = state.fitness.shape[0], fitness.shape[0]
    ok = valid & (cells >= 0) & jnp.isfinite(fitness)
    c = jnp.where(ok, cells, C)                              # C: the bucket of the invalid
    f = jnp.where(ok, fitness, -jnp.inf)
    best = jax.ops.segment_max(f, c, num_segments=C + 1)
    i = jnp.arange(N, dtype=jnp.int32)
    top = ok & (f == best[c])
    first = jax.ops.segment_min(jnp.where(top, i, N), c, num_segments=C + 1)
    cc = jnp.minimum(c, C - 1)
    take = top & (i == first[c]) & (~state.filled[cc] | (f > state.fitness[cc]))
    at = jnp.where(take, c, C)                               # C: out of range, dropped
    return MEState(state.genomes.at[at].set(jnp.asarray(genomes, jnp.float32), mode="drop"),
                   state.fitness.at[at].set(f, mode="drop"),
                   state.descriptors.at[at].set(jnp.asarray(descriptors, jnp.float32), mode="drop"),
                   state.filled.at[at].set(True, mode="drop"),
                   jnp.asarray(cells, jnp.int32))


def vary(cfg: MEConfig, state: MEState, key, gen, batch: int, lo: float, hi: float):
    """The ``batch`` children [N, G] of generation ``gen`` (random genomes first, then varied elites)."""
    C, G = state.genomes.shape
    k_rand, k_par, k_par2, k_iso, k_line = jax.random.split(key, 5)
    w = hi - lo
    rand = jax.random.uniform(k_rand, (batch, G), jnp.float32, lo, hi)
    n = jnp.sum(state.filled)
    p = state.filled.astype(jnp.float32) / jnp.maximum(n, 1).astype(jnp.float32)
    par = state.genomes[jax.random.choice(k_par, C, (batch,), p=p)]
    if cfg.method == "iso-line":
        other = state.genomes[jax.random.choice(k_par2, C, (batch,), p=p)]
        child = (par + cfg.sigma_iso * w * jax.random.normal(k_iso, (batch, G))
                 + cfg.sigma_line * (other - par) * jax.random.normal(k_line, (batch, 1)))
    else:
        child = par + cfg.sigma * w * jax.random.normal(k_iso, (batch, G))
    child = jnp.clip(child, lo, hi)
    return jnp.where((gen < cfg.init_batches) | (n == 0), rand, child)


def fall_metric(problem: Problem, cfg: MEConfig) -> str | None:
    """The metric that flags a robot that fell (``meta["fall_metric"]``), unless ``cfg.keep_fallen``."""
    return None if cfg.keep_fallen else problem.meta.get("fall_metric")


def mapelites_algorithm(problem: Problem, cfg: MEConfig, grid: Grid) -> Algorithm:
    """MAP-Elites (``cfg.method``) on ``problem`` over ``grid`` as an :class:`Algorithm`.

    The problem's metrics named ``grid.names`` are the descriptors (``Algorithm.descriptor``).  The state
    is the archive (:class:`MEState`); ``propose`` varies it (:func:`vary`), ``update`` inserts the batch.
    A child that fell (the problem's :func:`fall_metric` non-zero) is never inserted: a robot lying on its
    side "turns" and "moves" as it tumbles, and its descriptor says nothing of a gait.
    """
    lo, hi, G, N = float(problem.lower), float(problem.upper), problem.n_genes, cfg.batch
    D = len(grid.names)
    fall = fall_metric(problem, cfg)

    def init(params, key):
        return empty_archive(grid.n_cells, G, D, N)

    def propose(params, state, key, gen):
        return vary(cfg, state, key, gen, N, lo, hi)

    def update(params, state, genomes, fitness, diverged, key, gen, desc):
        valid = ~diverged if fall is None else ~diverged & (desc[:, D] == 0)
        desc = desc[:, :D]
        cells = cell_index(grid, desc)
        return insert(state, genomes, fitness, desc, cells, valid)

    return Algorithm(cfg.method, N, cfg.generations, cfg.to_dict(), (), init, propose, update,
                     rate=lambda params, gen: jnp.float32(jnp.nan),
                     resumable_changes=("chunk", "evaluations"),
                     descriptor=tuple(grid.names) + ((fall,) if fall else ()))


_insert_jit = jax.jit(insert)


def replay(n_cells: int, n_genes: int, rows) -> MEState:
    """The archive after inserting stored rows in order: ``rows`` yields ``(genomes [N, G], fitness [N],
    descriptors [N, D], cells [N], valid [N])`` per generation (see :func:`insert`)."""
    state = None
    for g, f, d, c, v in rows:
        if state is None:
            state = empty_archive(n_cells, n_genes, d.shape[-1], f.shape[0])
        state = _insert_jit(state, g, f, d, c, v)
    return state


def coverage(filled) -> float:
    """The share of filled cells."""
    filled = np.asarray(filled)
    return float(filled.mean()) if filled.size else 0.0


def qd_score(fitness, filled, offset: float) -> float:
    """Sum over filled cells of ``fitness - offset`` (float64, on the host)."""
    f, m = np.asarray(fitness, np.float64), np.asarray(filled, bool)
    return float(np.sum(f[m] - offset))
