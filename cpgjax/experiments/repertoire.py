"""``cpgjax repertoire``: a MAP-Elites archive of gaits into a run file, and reading it back (beyond the thesis).

The run is MAP-Elites (:mod:`cpgjax.optim.mapelites`) on the optimisers' contract: one generation is
:func:`cpgjax.optim.algorithm.generation_step` (``batch`` children in one batched simulation, with the
behaviour descriptors accumulated in the rollout, :mod:`cpgjax.episode.descriptors`), ``chunk``
generations one jitted ``lax.scan``, with the keys, Ctrl-C handling, run-file lock and compiled chunk of
:mod:`cpgjax.experiments.runner`.

The file is a ``cpgjax-run`` (:mod:`cpgjax.io.results`) of kind ``map-elites`` or ``iso-line``: every
generation's children (genomes, fitness, diverged, the metrics, among them every descriptor dimension),
and per generation ``/state/cells`` [N] (the cell of each child, -1: none), ``/state/filled`` (cells filled
after it) and ``/state/qd_score``.  The archive itself is not stored row by row (thousands of cells x
genes per generation): it is rebuilt from the rows by :func:`cpgjax.optim.mapelites.replay`, which equals
the archive the run held bit for bit (insertion selects, it never computes).  ``--resume`` rebuilds it so
and continues from the next generation: the file then holds the rows an uninterrupted run writes.
The attributes hold the grid (``grid``, JSON: names, lower, upper, bins) and the episode settings
(``meta``: model text, episode length, terrain, pipeline, descriptor, damage, ...).
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import jax
import numpy as np

from cpgjax.errors import ResultsError
from cpgjax.experiments.runner import (
    cached_chunk_fn,
    check_machine,
    check_resume,
    check_stop,
    metrics_spec,
    one_run,
    run_guard,
    run_keys,
    single_run_call,
)
from cpgjax.io.results import Row, RunWriter, create_run, read_attrs, read_run
from cpgjax.optim import mapelites as me
from cpgjax.optim.problem import Problem


def _grid_json(grid: me.Grid) -> str:
    return json.dumps({"names": list(grid.names), "lower": grid.lower.tolist(), "upper": grid.upper.tolist(),
                       "bins": list(grid.bins)})


def grid_of(attrs: dict) -> me.Grid:
    """The grid stored in a repertoire file's attributes."""
    g = json.loads(attrs["grid"])
    return me.Grid(tuple(g["names"]), np.asarray(g["lower"], np.float32), np.asarray(g["upper"], np.float32),
                   tuple(int(b) for b in g["bins"]))


def _valid(run) -> np.ndarray:
    """[G, N]: the children insertion considered (not diverged; not fallen unless the run kept them)."""
    ok = ~np.asarray(run.diverged)
    fall = None if run.config.get("keep_fallen") else run.meta.get("fall_metric")
    if fall:
        ok &= np.asarray(run.metrics[fall]) == 0
    return ok


def _rows_of(run, names):
    d = np.stack([run.metrics[k] for k in names], -1)
    ok = _valid(run)
    for g in range(run.completed):
        yield run.genomes[g], run.fitness[g], d[g], run.state["cells"][g], ok[g]


def run_repertoire(problem: Problem, cfg: me.MEConfig, out: str | os.PathLike[str], *, resume: bool = False,
                   overwrite: bool = False, progress: bool = False, stop_after: int | None = None,
                   callback: Callable[[int, dict[str, float]], None] | None = None,
                   allow_other_machine: bool = False) -> dict[str, Any]:
    """Run MAP-Elites (``cfg``) on ``problem`` into ``out`` (see the module docstring); returns a summary.

    ``resume``: continue the file (its settings must match, ``evaluations`` may grow); ``overwrite``:
    replace it; ``stop_after``: stop after that many generations in this call.  Holds the run-file lock.
    """
    path = os.fspath(out)
    with run_guard(path):
        return _run(problem, cfg, path, resume=resume, overwrite=overwrite, progress=progress,
                    stop_after=stop_after, callback=callback, allow_other_machine=allow_other_machine)


def _run(problem, cfg, path, *, resume, overwrite, progress, stop_after, callback, allow_other_machine):
    from tqdm.auto import tqdm

    algo = cfg.algorithm(problem)
    grid = algo.grid
    k_init, k_prop, k_upd = run_keys(cfg.seed)
    static = (("grid", _grid_json(grid)),) + tuple(sorted((k, json.dumps(v)) for k, v in cfg.to_dict().items()
                                                          if k not in ("seed", "chunk", "evaluations")))
    chunk_fn = cached_chunk_fn(problem, algo, cfg.chunk, static)
    N = cfg.batch
    if resume and os.path.exists(path):
        check_resume(path, algo, problem)
        attrs = read_attrs(path)
        if attrs.get("grid") != _grid_json(grid):
            raise ResultsError(f"{path}: cannot resume: the grid {_grid_json(grid)} differs from the run's "
                               f"{attrs.get('grid')} (drop the option, or start anew with --overwrite)")
        run = read_run(path)
        completed = run.completed
        if completed < algo.generations:
            check_machine(path, completed, allow_other_machine)
        if int(attrs["generations"]) != algo.generations:
            with RunWriter(path) as w:
                w.set_attr("generations", algo.generations)
                w.set_attr("config", json.dumps(algo.config))
        state = me.replay(grid.n_cells, problem.n_genes, _rows_of(run, grid.names)) if completed else None
        wall0 = float(run.wall_time[-1]) if completed else 0.0
        best = float(np.nanmax(run.valid_fitness())) if completed else -np.inf
    else:
        if os.path.exists(path) and not overwrite:
            raise ResultsError(f"{path} exists; use --resume to continue it or --overwrite to replace it")
        metrics = metrics_spec(problem, N)
        create_run(path, kind=algo.kind, config=algo.config, problem=problem, population=N,
                   generations=algo.generations, metrics=metrics,
                   state={"cells": ((N,), np.int32), "filled": ((), np.int32), "qd_score": ((), np.float64)},
                   overwrite=overwrite)
        with RunWriter(path) as w:
            w.set_attr("grid", _grid_json(grid))
        completed, state, wall0, best = 0, None, 0.0, -np.inf
    if state is None:
        state = jax.jit(algo.init)((), k_init)

    target = algo.generations if stop_after is None else min(algo.generations, completed + int(stop_after))
    state1 = [one_run(state)]
    call = single_run_call(chunk_fn, (), k_prop, k_upd)           # MAP-Elites has no traced settings

    t0 = time.perf_counter()
    check_stop()
    jax.block_until_ready(call(state1, 0, 0))          # compile (every step idle)
    compile_time = time.perf_counter() - t0
    t_start, evals = time.perf_counter(), 0
    info: dict[str, float] = {}
    bar = tqdm(total=algo.generations * N, initial=completed * N, desc=algo.kind, unit="eval",
               disable=not progress, dynamic_ncols=True)
    try:
        while completed < target:
            check_stop()
            n_valid = min(cfg.chunk, target - completed)
            t1 = time.perf_counter()
            state1, rows = call(state1, completed, completed + n_valid)
            rows = jax.tree.map(lambda a: a[:, 0], jax.device_get(rows[0]))
            t2 = time.perf_counter()
            done = []
            for i in range(n_valid):
                st = rows["state"]                         # the archive after generation i, by name
                filled = st["filled"][i]
                qd = me.qd_score(st["fitness"][i], filled, cfg.qd_offset)
                fit, div = rows["fitness"][i], rows["diverged"][i]
                if np.any(~div):
                    best = max(best, float(np.max(fit[~div])))
                done.append(Row(genomes=rows["genomes"][i], fitness=fit, diverged=div,
                                mutation_rate=float("nan"),
                                wall_time=wall0 + (t1 - t_start) + (t2 - t1) * (i + 1) / n_valid,
                                metrics={k: v[i] for k, v in rows["metrics"].items()},
                                state={"cells": st["cells"][i], "filled": np.int32(filled.sum()),
                                       "qd_score": np.float64(qd)}))
                info = {"filled": int(filled.sum()), "coverage": me.coverage(filled), "qd_score": qd,
                        "best": best}
            with RunWriter(path) as w:
                for row in done:
                    w.append(row)
            completed += n_valid
            evals += n_valid * N
            bar.set_postfix(cells=info["filled"], coverage=f"{info['coverage']:.1%}", qd=f"{info['qd_score']:.4g}",
                            best=f"{best:.4g}", refresh=False)
            bar.update(n_valid * N)
            if callback is not None:
                callback(completed, info)
    finally:
        bar.close()
    elapsed = time.perf_counter() - t_start
    return {"path": path, "kind": algo.kind, "completed": completed, "generations": algo.generations,
            "evaluations_this_call": evals, "wall_time_this_call": elapsed, "compile_time": compile_time,
            "evals_per_second": evals / elapsed if elapsed > 0 else float("nan"), **info,
            "cells": grid.n_cells, "archive": jax.tree.map(lambda a: np.asarray(a)[0], jax.device_get(state1[0]))}


@dataclass
class Repertoire:
    """A repertoire file read back: the archive rebuilt from its rows, its grid, its history."""

    path: str
    grid: me.Grid
    genomes: np.ndarray       # [C, G] elites (zeros where empty)
    fitness: np.ndarray       # [C] (-inf where empty)
    descriptors: np.ndarray   # [C, D]
    filled: np.ndarray        # [C] bool
    meta: dict
    config: dict
    evaluations: np.ndarray   # [generations] evaluations after each generation
    n_filled: np.ndarray      # [generations]
    qd_score: np.ndarray      # [generations]
    metrics: dict             # name -> [C]: the problem's metrics of each elite's own evaluation (NaN where empty)

    @property
    def cells(self) -> np.ndarray:
        """The indices of the filled cells."""
        return np.flatnonzero(self.filled)

    def cell(self, spec: str) -> int:
        """A cell from text: ``best`` (the fittest elite), an index (``417``), or a descriptor
        (``0.5,0.5,0.5,0.5``: the cell it falls in).  An empty cell is an error."""
        s = spec.strip()
        if s == "best":
            return int(np.argmax(np.where(self.filled, self.fitness, -np.inf)))
        try:
            if "," in s or "." in s:
                d = np.asarray([float(v) for v in s.split(",")], np.float32)
                if d.shape != (len(self.grid.names),):
                    raise ResultsError(f"{self.path}: cell {spec!r}: a descriptor needs {len(self.grid.names)} "
                                       f"values ({', '.join(self.grid.names)})")
                c = int(np.asarray(me.cell_index(self.grid, d[None]))[0])
            else:
                c = int(s)
        except ValueError:
            raise ResultsError(f"{self.path}: cell {spec!r}: expected best, a cell index or a descriptor "
                               "(comma-separated values)") from None
        if not 0 <= c < self.grid.n_cells:
            raise ResultsError(f"{self.path}: cell {c} is outside the grid (0..{self.grid.n_cells - 1})")
        if not self.filled[c]:
            raise ResultsError(f"{self.path}: cell {c} is empty ({int(self.filled.sum())} of {self.grid.n_cells} "
                               "are filled)")
        return c


def read_repertoire(path: str | os.PathLike[str]) -> Repertoire:
    """Read a ``cpgjax repertoire`` file and rebuild its archive (:func:`cpgjax.optim.mapelites.replay`)."""
    run = read_run(path)
    if "grid" not in run.attrs or run.kind not in me.METHODS:
        raise ResultsError(f"{os.fspath(path)}: not a repertoire (a {run.kind!r} run); make one with "
                           "cpgjax repertoire")
    grid = grid_of(run.attrs)
    G = int(run.attrs["n_genes"])
    if run.completed == 0:
        raise ResultsError(f"{os.fspath(path)}: the repertoire has no generation yet")
    st = me.replay(grid.n_cells, G, _rows_of(run, grid.names))
    N = int(run.attrs["population"])
    src = elite_sources(run, grid.n_cells)
    ok = src >= 0
    metrics = {}
    for k, v in run.metrics.items():
        m = np.full(grid.n_cells, np.nan, np.float32)
        m[ok] = v.reshape(-1)[src[ok]]
        metrics[k] = m
    return Repertoire(os.fspath(path), grid, np.asarray(st.genomes), np.asarray(st.fitness),
                      np.asarray(st.descriptors), np.asarray(st.filled), run.meta, run.config,
                      N * np.arange(1, run.completed + 1), np.asarray(run.state["filled"]),
                      np.asarray(run.state["qd_score"]), metrics)


def elite_sources(run, n_cells: int) -> np.ndarray:
    """[C]: the flat index (generation x batch + child) of each cell's elite in the run's rows (-1: empty).

    The elite of a cell is the first child, in the order of the rows, with the highest fitness of the valid
    children that fell in it (insertion replaces only on a strictly higher fitness, ties to the first).
    """
    cells = np.asarray(run.state["cells"]).reshape(-1)
    fit = np.asarray(run.fitness, np.float32).reshape(-1)
    ok = _valid(run).reshape(-1) & np.isfinite(fit) & (cells >= 0)
    i = np.flatnonzero(ok)
    order = np.lexsort((i, -fit[i], cells[i]))        # by cell, then fitness descending, then first
    i = i[order]
    first = np.r_[True, cells[i][1:] != cells[i][:-1]]
    out = np.full(n_cells, -1, np.int64)
    out[cells[i][first]] = i[first]
    return out
