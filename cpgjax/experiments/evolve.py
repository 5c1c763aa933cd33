"""Drivers: run the GA (:func:`run_ga`) or a baseline search (:func:`run_search`) into an HDF5 file.

Every algorithm keeps the contract of :mod:`cpgjax.optim.algorithm` (pure ``init / ask / tell``
over a typed state) and one generation is its shared
:func:`~cpgjax.optim.algorithm.generation_step` (the sweep runs the same one), with
``k_init, k_propose, k_update = split(jax.random.key(seed), 3)`` (:func:`~cpgjax.experiments.runner.run_keys`).  A chunk
of ``chunk`` generations is one jitted ``lax.scan``; generations past the end of the run inside
the last chunk are skipped by a ``lax.cond``, so the *same* compiled program runs every chunk,
from any starting generation.  Between chunks the host appends each generation to the HDF5 file
(flushed per generation; :mod:`cpgjax.io.results`) and updates the progress bar.

Ctrl-C, resume, the run file, the keys and the compiled chunk are the runner's
(:mod:`cpgjax.experiments.runner`, shared with the sweep and the repertoire): a Ctrl-C stops after the generation
in flight, with every generation so far written; ``resume=True`` continues a run file from its last complete row,
bit for bit as an uninterrupted run would (wall times aside), provided the chunk size, the machine and the JAX
version are the same.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from cpgjax.experiments.runner import (
    cached_chunk_fn,
    check_stop,
    one_run,
    open_run,
    run_guard,
    run_keys,
    single_run_call,
)
from cpgjax.io.results import Row, RunWriter, read_run
from cpgjax.optim import baselines, es, ga
from cpgjax.optim.algorithm import Algorithm, make_algorithm
from cpgjax.optim.problem import Problem


def _run(problem: Problem, algo: Algorithm, out: str | os.PathLike[str] | None, **kw: Any) -> dict[str, Any]:
    with run_guard(None if out is None else os.fspath(out)):          # Ctrl-C deferred, the run file locked
        return _run_deferred(problem, algo, out, **kw)


def _run_deferred(problem: Problem, algo: Algorithm, out: str | os.PathLike[str] | None, *, chunk: int,
                  seed: int, static: tuple, resume: bool, overwrite: bool, progress: bool, stop_after: int | None,
                  callback: Callable[[int, dict[str, float]], None] | None, desc: str,
                  allow_other_machine: bool = False) -> dict[str, Any]:
    from tqdm.auto import tqdm

    path = None if out is None else os.fspath(out)
    k_init, k_prop, k_upd = run_keys(seed)
    params = jax.tree.map(jnp.asarray, algo.params)
    chunk_fn = cached_chunk_fn(problem, algo, chunk, static)

    completed, state, wall0 = open_run(problem, algo, path, params, k_init, resume=resume, overwrite=overwrite,
                                       allow_other_machine=allow_other_machine)

    target = algo.generations
    if stop_after is not None:
        target = min(target, completed + int(stop_after))
    t_compile = time.perf_counter()
    # one group of one run: params, state and keys get a leading run axis of 1
    call = single_run_call(chunk_fn, params, k_prop, k_upd)
    state1 = [one_run(state)]

    check_stop()
    jax.block_until_ready(call(state1, 0, 0))  # compile (every step idle: nothing is computed)
    compile_time = time.perf_counter() - t_compile

    history: dict[str, list] = {"genomes": [], "fitness": [], "diverged": [], "mutation_rate": []}
    best = -np.inf
    t_start, evals = time.perf_counter(), 0
    bar = tqdm(total=algo.generations, initial=completed, desc=desc, unit="gen", disable=not progress,
               dynamic_ncols=True)
    try:
        while completed < target:
            check_stop()                       # a Ctrl-C: stop here, with every generation so far written
            n_valid = min(chunk, target - completed)
            t0 = time.perf_counter()
            state1, rows = call(state1, completed, completed + n_valid)
            rows = jax.tree.map(lambda a: a[:, 0], jax.device_get(rows[0]))    # [chunk, 1, ...] -> [chunk, ...]
            t1 = time.perf_counter()
            done = []
            for i in range(n_valid):
                fit, div = rows["fitness"][i], rows["diverged"][i]
                wall = wall0 + (t0 - t_start) + (t1 - t0) * (i + 1) / n_valid
                row = Row(genomes=rows["genomes"][i], fitness=fit, diverged=div,
                          mutation_rate=float(rows["rate"][i]), wall_time=wall,
                          metrics={k: v[i] for k, v in rows["metrics"].items()},
                          state={k: v[i] for k, v in rows["state"].items()})
                done.append(row)
                valid = fit[~div]
                gbest = float(valid.max()) if valid.size else float("nan")
                best = max(best, gbest) if valid.size else best
                info = {"best": gbest, "mean": float(valid.mean()) if valid.size else float("nan"),
                        "best_so_far": float(best), "n_diverged": int(div.sum())}
                if path is None:
                    for k, v in (("genomes", row.genomes), ("fitness", fit), ("diverged", div),
                                 ("mutation_rate", row.mutation_rate)):
                        history[k].append(v)
            if path is not None:
                with RunWriter(path) as w:
                    for row in done:
                        w.append(row)
            completed += n_valid
            evals += n_valid * algo.population
            elapsed = time.perf_counter() - t_start
            bar.set_postfix(gen_best=f"{info['best']:.4g}", gen_mean=f"{info['mean']:.4g}",
                            best_so_far=f"{info['best_so_far']:.4g}",
                            evals_s=f"{evals / max(elapsed, 1e-9):.3g}", refresh=False)
            bar.update(n_valid)
            if callback is not None:
                callback(completed, info)
    finally:
        bar.close()
    elapsed = time.perf_counter() - t_start
    summary: dict[str, Any] = {
        "path": path, "kind": algo.kind, "completed": completed, "generations": algo.generations,
        "evaluations_this_call": evals, "wall_time_this_call": elapsed, "compile_time": compile_time,
        "evals_per_second": evals / elapsed if elapsed > 0 else float("nan")}
    if path is None:
        hist = {k: np.asarray(v) for k, v in history.items()}
        summary["history"] = hist
        fit = np.where(hist["diverged"], np.nan, hist["fitness"]) if completed else np.zeros((0, 0))
    else:
        run = read_run(path)
        fit, hist = run.valid_fitness(), {"genomes": run.genomes}
    if fit.size and np.any(np.isfinite(fit)):
        gen, idx = np.unravel_index(int(np.nanargmax(fit)), fit.shape)
        summary.update(best_fitness=float(fit[gen, idx]), best_generation=int(gen), best_index=int(idx),
                       best_genome=np.asarray(hist["genomes"][gen][idx]))
    return summary


def run_ga(problem: Problem, cfg: ga.GAConfig, out: str | os.PathLike[str] | None = None, *,
           resume: bool = False, overwrite: bool = False, progress: bool = False,
           stop_after: int | None = None,
           callback: Callable[[int, dict[str, float]], None] | None = None,
           allow_other_machine: bool = False) -> dict[str, Any]:
    """Evolve ``cfg.generations`` generations of the GA on ``problem``, writing ``out`` (HDF5).

    ``resume``: continue the run in ``out`` (a missing file starts a new run); the stored
    settings must match ``cfg`` except ``generations`` (may be extended) and ``chunk``.
    ``overwrite``: replace an existing file (otherwise an existing file is an error).
    ``stop_after``: stop after that many generations in this call (time-limited jobs, tests).
    ``callback(completed, info)`` is called after each chunk.  ``out=None`` keeps the results
    in memory (``summary["history"]``).  ``allow_other_machine``: resume a run computed on another
    machine or with other versions (recorded in the file; otherwise refused).  Returns a summary dict
    (best fitness, generation, index and genome, evaluations per second, compile time, ...).
    """
    return _run(problem, make_algorithm(problem, cfg), out, chunk=cfg.chunk, seed=cfg.seed, static=(),
                resume=resume,
                overwrite=overwrite, progress=progress, stop_after=stop_after, callback=callback,
                desc="evolve", allow_other_machine=allow_other_machine)


def run_search(problem: Problem, cfg: baselines.SearchConfig | es.ESConfig,
               out: str | os.PathLike[str] | None = None, *,
               resume: bool = False, overwrite: bool = False, progress: bool = False,
               stop_after: int | None = None,
               callback: Callable[[int, dict[str, float]], None] | None = None,
               allow_other_machine: bool = False) -> dict[str, Any]:
    """Run a baseline search (:mod:`cpgjax.optim.baselines`) or an evolution strategy (:mod:`cpgjax.optim.es`)
    with the layout, keys and resume of :func:`run_ga`."""
    static = tuple(sorted((k, v) for k, v in cfg.to_dict().items() if k not in ("seed", "chunk")))
    return _run(problem, make_algorithm(problem, cfg), out, chunk=cfg.chunk, seed=cfg.seed, static=static,
                resume=resume,
                overwrite=overwrite, progress=progress, stop_after=stop_after, callback=callback,
                desc=cfg.method, allow_other_machine=allow_other_machine)
