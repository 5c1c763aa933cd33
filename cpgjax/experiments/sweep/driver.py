"""The batched sweep driver: many GA / baseline runs (settings x seeds) in one XLA program.

A *cell* is one setting (e.g. GA with gamma 0.1, pocket 4, no cross-over; or AMC with M = 5);
a *run* is a cell with one seed.  Every run is written to its own HDF5 file in the layout
of :mod:`cpgjax.io.results` (``OUT/<cell>/s<seed>.h5``), so ``cpgjax plot`` and ``cpgjax best``
work on any of them, and ``OUT/sweep.json`` records the plan.

**Batching.**  Runs are grouped by what their algorithm compiles to (GA: population and
initial spread, every other GA setting is a traced :class:`cpgjax.optim.ga.GAParams` field, the
cross-over flag included; a search: its whole configuration but the seed).  One generation
of the sweep is one jitted function: for every group ``vmap(ask)`` over its runs, the
``[R, N, G]`` genomes of *all* groups are concatenated to ``[sum R*N, G]`` for ONE
``problem.evaluate`` call (which splits the batch across the host devices, i.e. the CPU
cores, with ``shard_map``), split back, and ``vmap(tell)`` per group.  ``chunk``
generations run in one ``lax.scan``; the host writes chunk k while chunk k+1 computes.

**Same numbers as single runs.**  A run uses the keys of :func:`cpgjax.experiments.runner.run_keys` for
its seed (``k_init, k_propose, k_update = split(key(seed), 3)``, ``fold_in(k, GEN)``), its
initial state is made by the same jitted ``init``, and the simulator's result for a robot
does not depend on the batch it is in, so a run of a sweep holds bit for bit the rows of
``cpgjax evolve`` / ``cpgjax search`` with the same settings (``tests/test_sweep.py``).

**Resume, cell by cell.**  A run whose file is complete is skipped; a partially written one
continues from its last complete generation (its stored state, as ``--resume`` does); a
missing one starts.  Runs at different generations share a batch: every run carries its
own generation counter, and a run past its end is computed but neither updated nor
written.  Stored settings must match the plan (else :class:`ResultsError`), except the
number of generations, which may be extended.
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable, Sequence
from functools import partial
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from cpgjax.experiments.runner import (
    check_problem,
    check_stop,
    compile_ahead,
    deferred_sigint,
    metrics_spec,
    open_run,
    run_keys,
    stop_requested,
)
from cpgjax.experiments.sweep.plan import MANIFEST, RunSpec
from cpgjax.io import runlock
from cpgjax.io.results import Row, RunWriter
from cpgjax.io.sweepdir import find_runs
from cpgjax.optim.algorithm import chunk_args, make_algorithm, make_chunk_fn, stack_params
from cpgjax.optim.factory import make_problem
from cpgjax.optim.problem import Problem


def _group_key(spec: RunSpec) -> tuple:
    c = spec.cfg
    if spec.kind == "ga":
        return ("ga", c.population, c.init_spread)
    return ("search",) + tuple(sorted((k, v) for k, v in c.to_dict().items() if k not in ("seed", "chunk")))


def eval_chunk(n: int, devices: int | None = None, max_chunk: int = 256, lanes: int = 16) -> int:
    """A simulator chunk size that pads a batch of ``n`` robots little (the simulator pads to whole chunks)."""
    nd = devices or len(jax.devices())
    per_dev = max(-(-n // nd), 1)
    k = -(-per_dev // max_chunk)          # chunks per device
    per_chunk = -(-per_dev // k)
    return max(lanes, -(-per_chunk // lanes) * lanes)


def write_manifest(out_dir: str | os.PathLike[str], specs: Sequence[RunSpec], problem_args: dict[str, Any]) -> str:
    """``OUT/sweep.json``: the problem and every run (merged with an existing manifest)."""
    path = os.path.join(os.fspath(out_dir), MANIFEST)
    old: dict[str, Any] = {}
    if os.path.exists(path):
        with open(path) as f:
            old = json.load(f)
    runs = {r["path"]: r for r in old.get("runs", [])}
    for s in specs:
        rel = os.path.relpath(s.path, os.fspath(out_dir))
        runs[rel] = {"path": rel, "cell": s.cell, "kind": s.kind, "seed": s.seed, "config": s.cfg.to_dict()}
    data = {"format": "cpgjax-sweep", "problem": problem_args, "runs": sorted(runs.values(), key=lambda r: r["path"])}
    os.makedirs(os.fspath(out_dir), exist_ok=True)
    with open(path + ".tmp", "w") as f:
        json.dump(data, f, indent=1)
    os.replace(path + ".tmp", path)
    return path


def check_sweep_problem(out_dir: str | os.PathLike[str], problem: Problem) -> None:
    """A sweep folder holds runs of one problem: refuse to add runs (new seeds, new settings) scored otherwise
    than the runs already in it (another evaluation, episode length, terrain, model...), so that a cell never
    mixes seeds of two evaluations.  Checks one run file (each run added since passed this check)."""
    for files in find_runs(out_dir).values():
        check_problem(files[0], problem, verb="add runs to this sweep")
        return


def check_new_runs(problem: Problem, specs: Sequence[RunSpec]) -> None:
    """:func:`check_sweep_problem` for the folders where ``specs`` add runs (existing runs are checked as they are
    resumed)."""
    for root in dict.fromkeys(os.path.dirname(os.path.dirname(s.path)) for s in specs if not os.path.exists(s.path)):
        check_sweep_problem(root, problem)


def run_sweep(problem: Problem, specs: Sequence[RunSpec], *, chunk: int = 1, overwrite: bool = False,
              progress: bool = True, stop_after: int | None = None, group: str = "all",
              callback: Callable[[int, dict[str, Any]], None] | None = None,
              allow_other_machine: bool = False) -> dict[str, Any]:
    """Run every spec (skipping complete files, continuing partial ones); returns a summary.

    ``group``: ``"all"`` puts every run in one XLA program (one evaluate call per generation);
    ``"kind"`` makes one program per group of same-shaped runs, run one after the other.
    ``stop_after``: stop after that many sweep generations (tests of resume).  Unless ``overwrite``, the runs must
    be scored as those already in their sweep folder are (:func:`check_sweep_problem`).  A Ctrl-C stops after
    the chunk in flight, once every computed generation is written (``KeyboardInterrupt``).
    ``allow_other_machine``: continue runs computed on another machine or with other versions (else refused,
    :func:`cpgjax.experiments.runner.open_run`).  Every run file is locked while it is written
    (:mod:`cpgjax.io.runlock`): another process writing one of them is refused at once.
    """
    locks: dict[str, int] = {}          # run file -> its lock (cpgjax.io.runlock), held while the run is written
    try:
        with deferred_sigint():
            return _run_sweep(problem, specs, chunk=chunk, overwrite=overwrite, progress=progress,
                              stop_after=stop_after, group=group, callback=callback, locks=locks,
                              allow_other_machine=allow_other_machine)
    finally:
        for path, fd in locks.items():
            runlock.release(path, fd)


def _run_sweep(problem: Problem, specs: Sequence[RunSpec], *, chunk: int, overwrite: bool, progress: bool,
               stop_after: int | None, group: str, callback: Callable[[int, dict[str, Any]], None] | None,
               locks: dict[str, int], allow_other_machine: bool) -> dict[str, Any]:
    from tqdm.auto import tqdm

    t_begin = time.perf_counter()
    # one writer per run file (a lock per run, not per folder: several sweeps, or Ray's workers, may write
    # different runs of one folder), every one taken before any file is created, replaced or resumed
    for s in specs:
        locks[s.path] = runlock.acquire(s.path)
    if not overwrite:
        check_new_runs(problem, specs)
    by_group: dict[tuple, list[RunSpec]] = {}
    for s in specs:
        by_group.setdefault(_group_key(s), []).append(s)

    todo: list[dict[str, Any]] = []     # per group: algo, specs, params, states, keys, completed, targets, wall0
    skipped = 0
    metrics: dict[int, dict] = {}
    for key, members in by_group.items():
        algo0 = make_algorithm(problem, members[0].cfg)
        init = jax.jit(algo0.init)
        if algo0.population not in metrics:
            metrics[algo0.population] = metrics_spec(problem, algo0.population)
        live, states, params, keys, comp, walls, tgts = [], [], [], [], [], [], []
        for s in members:
            # the same keys, init and file handling as cpgjax evolve / search (init and metric shapes
            # are traced once per group: every run of a group has the same ones, the seed apart)
            algo = make_algorithm(problem, s.cfg)
            p = jax.tree.map(jnp.asarray, algo.params)
            k = run_keys(s.seed)
            completed, state, wall0 = open_run(problem, algo, s.path, p, k[0], resume=not overwrite, overwrite=True,
                                               init=init, metrics=metrics[algo0.population],
                                               allow_other_machine=allow_other_machine)
            if completed >= algo.generations:
                runlock.release(s.path, locks.pop(s.path))      # complete: nothing to write
                skipped += 1
                continue
            live.append(s)
            states.append(state)
            params.append(p)
            keys.append(k)
            comp.append(completed)
            walls.append(wall0)
            tgts.append(algo.generations)
        if not live:
            continue
        todo.append({
            "key": key, "algo": algo0, "specs": live,
            "params": stack_params(algo0, params),
            "states": jax.tree.map(lambda *xs: jnp.stack(xs), *states),
            "k_prop": jnp.stack([k[1] for k in keys]), "k_upd": jnp.stack([k[2] for k in keys]),
            "completed": np.asarray(comp, np.int64), "targets": np.asarray(tgts, np.int64),
            "wall0": np.asarray(walls, np.float64)})

    batches = ([todo] if todo else []) if group == "all" else [[g] for g in todo]
    total_evals = sum(int(np.sum((g["targets"] - g["completed"]) * g["algo"].population)) for g in todo)
    bar = tqdm(total=total_evals, desc="sweep", unit="eval", unit_scale=True, disable=not progress,
               dynamic_ncols=True)
    evals_done, compile_time, sim_evals = 0, 0.0, 0
    # Speed is measured in the steady state, from the end of each program's first chunk to the end of
    # its last (the first chunk carries one-off costs: buffer allocation, the first HDF5 writes).
    steady = {"wall": 0.0, "cpu": 0.0, "evals": 0}
    t_run = time.perf_counter()
    try:
        for groups in batches:
            algos = [g["algo"] for g in groups]
            sizes = [len(g["specs"]) for g in groups]
            fn = make_chunk_fn(problem, algos, sizes, chunk)
            args = partial(_chunk_args, groups, chunk_args(problem))
            check_stop()
            t0 = time.perf_counter()
            fn = compile_ahead(fn, args())
            compile_time += time.perf_counter() - t0
            t_start = time.perf_counter()
            steps = 0
            pending = None
            first = None                                   # (wall, cpu, evaluations) at the end of chunk 1
            new_evals = 0
            while any(np.any(g["completed"] < g["targets"]) for g in groups):
                if (stop_after is not None and steps >= stop_after) or stop_requested():
                    break
                gen0 = [g["completed"].copy() for g in groups]
                out = fn(*args())                          # dispatched asynchronously
                if pending is not None:
                    evals_done += _write(pending, t_start)
                new_states, rows = out
                rows = jax.device_get(rows)
                t_now = time.perf_counter()
                for g, st in zip(groups, new_states, strict=True):
                    g["states"] = st
                    g["completed"] = np.minimum(g["completed"] + chunk, g["targets"])
                sim_evals += chunk * sum(a.population * r for a, r in zip(algos, sizes, strict=True))
                pending = (groups, rows, gen0, t_now)
                steps += 1
                n_new = sum(int(np.sum((g["completed"] - g0) * g["algo"].population))
                            for g, g0 in zip(groups, gen0, strict=True))
                new_evals += n_new
                if first is None:
                    first = (t_now, time.process_time(), new_evals)
                bar.update(n_new)
                if callback is not None:
                    callback(steps, {"evaluations": evals_done})
            if pending is not None:
                evals_done += _write(pending, t_start)
            check_stop()                                   # a Ctrl-C: every computed generation is written
            if first is not None and steps > 1:
                steady["wall"] += time.perf_counter() - first[0]
                steady["cpu"] += time.process_time() - first[1]
                steady["evals"] += new_evals - first[2]
    finally:
        bar.close()
    wall = time.perf_counter() - t_run
    if steady["wall"] > 0:
        rate, cores_busy = steady["evals"] / steady["wall"], steady["cpu"] / steady["wall"]
    else:                                                  # one chunk per program: no steady state to time
        rate, cores_busy = evals_done / max(wall - compile_time, 1e-9), float("nan")
    return {"runs": len(specs), "skipped": skipped, "evaluations": evals_done, "evaluated": sim_evals,
            "wall_time": time.perf_counter() - t_begin, "compile_time": compile_time,
            "evals_per_second": rate, "cores_busy": cores_busy}


def _chunk_args(groups, tail=()):
    return ([g["params"] for g in groups], [g["states"] for g in groups],
            [g["k_prop"] for g in groups], [g["k_upd"] for g in groups],
            [jnp.asarray(g["completed"], jnp.int32) for g in groups],
            [jnp.asarray(g["targets"], jnp.int32) for g in groups]) + tail


def _write(pending, t_start: float) -> int:
    """Append the rows of one chunk to every run's file; returns the evaluations written."""
    groups, rows, gen0, t_now = pending
    n = 0
    for g, grows, g0 in zip(groups, rows, gen0, strict=True):
        chunk = grows["fitness"].shape[0]
        for r, spec in enumerate(g["specs"]):
            n_valid = int(min(chunk, g["targets"][r] - g0[r]))
            if n_valid <= 0:
                continue
            with RunWriter(spec.path) as w:
                for i in range(n_valid):
                    w.append(Row(genomes=grows["genomes"][i, r], fitness=grows["fitness"][i, r],
                                 diverged=grows["diverged"][i, r], mutation_rate=float(grows["rate"][i, r]),
                                 wall_time=float(g["wall0"][r] + t_now - t_start),
                                 metrics={k: v[i, r] for k, v in grows["metrics"].items()},
                                 state={k: v[i, r] for k, v in grows["state"].items()}))
            n += n_valid * g["algo"].population
    return n


def sweep_problem(problem_args: dict[str, Any], batch: int | None = None) -> Problem:
    """The Problem of a sweep (``{"model", "time", "terrain", "delta", "evaluation", "perturb", "pipeline"}``) from the
    one factory (every shard, in process or on Ray, builds it from the same dict).

    ``batch``: the sweep's evaluations per generation; the simulator's chunk is chosen to pad it
    little (results do not depend on the chunk; the robust evaluation's replicas ride in the batch).
    """
    args = {k: problem_args.get(k) for k in ("time", "terrain", "delta", "evaluation", "perturb", "pipeline",
                                             "controller")}
    if batch and args["evaluation"] == "robust":
        from cpgjax.episode.perturb import Perturbations

        batch *= Perturbations.from_settings(args["perturb"]).replicas
    return make_problem(problem_args["model"], **args, chunk=eval_chunk(batch) if batch else None)
