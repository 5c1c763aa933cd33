"""Drivers: run the GA (:func:`run_ga`) or a baseline search (:func:`run_search`) into an HDF5 file.

Every algorithm keeps the contract of :mod:`cpgjax.optim.algorithm` (pure ``init / ask / tell``
over a typed state) and one generation is its shared
:func:`~cpgjax.optim.algorithm.generation_step` (the sweep runs the same one), with
``k_init, k_propose, k_update = split(jax.random.key(seed), 3)`` (:func:`run_keys`).  A chunk
of ``chunk`` generations is one jitted ``lax.scan``; generations past the end of the run inside
the last chunk are skipped by a ``lax.cond``, so the *same* compiled program runs every chunk,
from any starting generation.  Between chunks the host appends each generation to the HDF5 file
(flushed per generation; :mod:`cpgjax.io.results`) and updates the progress bar.

Ctrl-C: while a driver runs (or inside :func:`deferred_sigint`, which the command line wraps around a
whole command), the first SIGINT only asks to stop: the driver finishes the generation in flight,
writes it, and raises ``KeyboardInterrupt`` at a clean point (never inside XLA's compiler); a second
SIGINT interrupts at once.  Either way the file holds only complete generations.

Resume: each row stores the algorithm's state after that generation (``/state/*``, by name:
:meth:`~cpgjax.optim.algorithm.Algorithm.save`; for the GA the population bred from it).
``resume=True`` reads the last complete row, rebuilds the state (``Algorithm.load``) and continues
the scan from ``completed`` with that state; because keys depend only on (seed, GEN) and the
program is the same, the resumed file holds bit for bit the rows an uninterrupted run would
(wall times aside), provided the chunk size, the machine and the JAX version are the same.  What refuses to
continue a run (other settings, another machine, another stored state): :mod:`cpgjax.experiments.resume`.
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import sys
import threading
import time
from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from cpgjax.errors import ResultsError
from cpgjax.experiments.resume import (  # noqa: F401  (check_problem re-exported)
    check_machine,
    check_problem,
    check_resume,
    check_stored_state,
)
from cpgjax.io import runlock
from cpgjax.io.results import Row, RunWriter, create_run, read_attrs, read_resume_point, read_run
from cpgjax.optim import baselines, es, ga
from cpgjax.optim.algorithm import Algorithm, make_algorithm, make_chunk_fn
from cpgjax.optim.problem import Problem


def compile_ahead(fn, args: tuple) -> Callable:
    """Compile the jitted ``fn`` for ``args`` now; returns a callable that always runs that executable.

    Why (compiler behaviour, jax 0.10.2): the state a chunk returns comes back placed (sharded over
    the host devices) other than the initial one, so the *second* call of a jitted chunk traced and
    compiled the whole program again (measured: 7 s more at thesis scale for a sweep, about 5 s for
    one ``cpgjax evolve`` run).  Calling the ahead-of-time executable, with the arguments first put
    where it expects them (``device_put`` does nothing when they already are), compiles exactly once.
    """
    compiled = fn.lower(*args).compile()
    shardings = compiled.input_shardings[0]
    return lambda *a: compiled(*jax.device_put(a, shardings))


class _CompiledOnFirstCall:
    """A jitted function compiled ahead of time (:func:`compile_ahead`) for the arguments of its first call."""

    def __init__(self, fn: Callable):
        self.fn, self.call = fn, None

    def __call__(self, *args):
        if self.call is None:
            self.call = compile_ahead(self.fn, args)
        return self.call(*args)


_CHUNK_CACHE: dict[tuple, tuple[Callable, Callable]] = {}


def _cached_chunk_fn(problem: Problem, algo: Algorithm, chunk: int, static: tuple) -> Callable:
    """The jitted chunk of one run (:func:`cpgjax.optim.algorithm.make_chunk_fn` with one group of one run).

    Reused across calls with the same ``evaluate`` and static settings (several runs of one problem
    in a process, tests, resume, compile once).  Compiled ahead of time on first use
    (:func:`compile_ahead`).
    """
    key = (id(problem.evaluate), problem.n_genes, problem.lower, problem.upper, algo.kind,
           algo.population, chunk, static)
    hit = _CHUNK_CACHE.get(key)
    if hit is not None and hit[0] is problem.evaluate:
        return hit[1]
    fn = _CompiledOnFirstCall(make_chunk_fn(problem, [algo], [1], chunk))   # same shapes for every hit of the key
    if len(_CHUNK_CACHE) >= 16:
        _CHUNK_CACHE.pop(next(iter(_CHUNK_CACHE)))
    _CHUNK_CACHE[key] = (problem.evaluate, fn)
    return fn


def _one(tree):
    """A leading axis of 1 on every leaf (one run of a group)."""
    return jax.tree.map(lambda a: jnp.asarray(a)[None], tree)


def run_keys(seed: int) -> tuple[jax.Array, jax.Array, jax.Array]:
    """``(k_init, k_propose, k_update)`` of a run: its whole randomness, from the seed alone.

    Every driver (``cpgjax evolve``, ``search``, ``sweep``) takes its keys from here, which is what
    makes a run of a sweep equal, bit for bit, the same run made alone.
    """
    k_init, k_prop, k_upd = jax.random.split(jax.random.key(seed), 3)
    return k_init, k_prop, k_upd


_SIGINT = {"active": False, "requested": False}


@contextlib.contextmanager
def deferred_sigint():
    """Within: the first Ctrl-C (SIGINT) only sets a flag that the drivers check between generations.

    Does nothing outside the main thread, or when someone else already handles SIGINT.  The first
    SIGINT puts the default handler back, so a second one raises ``KeyboardInterrupt`` at once.
    """
    if (_SIGINT["active"] or threading.current_thread() is not threading.main_thread()
            or signal.getsignal(signal.SIGINT) is not signal.default_int_handler):
        yield
        return

    def handler(signum, frame):
        _SIGINT["requested"] = True
        signal.signal(signal.SIGINT, signal.default_int_handler)
        print("\nCtrl-C: stopping at the next safe point, after the compilation or generation in flight "
              "(Ctrl-C again to stop at once)",
              file=sys.stderr, flush=True)

    old = signal.signal(signal.SIGINT, handler)
    _SIGINT.update(active=True, requested=False)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old)
        _SIGINT.update(active=False, requested=False)


def stop_requested() -> bool:
    """True once a Ctrl-C arrived inside :func:`deferred_sigint`."""
    return bool(_SIGINT["requested"])


def check_stop() -> None:
    """Raise ``KeyboardInterrupt`` if a Ctrl-C arrived inside :func:`deferred_sigint` (a clean point to stop)."""
    if stop_requested():
        raise KeyboardInterrupt


def metrics_spec(problem: Problem, population: int) -> dict[str, tuple[tuple[int, ...], Any]]:
    """The per-individual metrics ``problem.evaluate`` returns besides fitness (shapes for the run file).

    Traces the simulator once (``eval_shape``): callers with many runs compute it once.
    """
    genomes = jax.ShapeDtypeStruct((population, problem.n_genes), jnp.float32)
    if problem.stochastic:     # the robust evaluation also takes one key per genome
        keys = jax.eval_shape(lambda: jax.random.split(jax.random.key(0), population))
        ev = jax.eval_shape(problem.evaluate, genomes, keys)
    else:
        ev = jax.eval_shape(problem.evaluate, genomes)
    return {k: ((population,), np.float32) for k in ev if k not in ("fitness", "diverged")}


def open_run(problem: Problem, algo: Algorithm, path: str | None, params: Any, k_init: jax.Array, *,
             resume: bool, overwrite: bool, init: Callable | None = None,
             metrics: dict | None = None, allow_other_machine: bool = False) -> tuple[int, Any, float]:
    """Where a run starts: ``(completed generations, algorithm state, wall time so far)``.

    ``resume`` and an existing file: its settings are checked against ``algo`` (the number of
    generations may be extended) and the run continues after its last complete row.  Otherwise a
    new file is created (an existing one only with ``overwrite``, else :class:`ResultsError`) and
    the state is ``algo.init`` with the run's ``k_init``.  ``path=None``: nothing on disk.
    ``init`` (a jitted ``algo.init``) and ``metrics`` (:func:`metrics_spec`) may be passed in by
    callers that open many runs of one shape, so that neither is traced again for each.
    The stored state must have the names and shapes this algorithm stores (:meth:`Algorithm.save`), else
    :class:`ResultsError`.
    A run to continue that was computed on another machine or with other versions (the CPU, its vector
    ISA, cpgjax, jax, jaxlib, mujoco: :func:`cpgjax.io.machine.machine`) is refused unless
    ``allow_other_machine``; then the file records from which generation on this machine computed it.
    """
    state_spec = jax.eval_shape(algo.init, params, k_init)
    saved_spec = jax.eval_shape(algo.save, state_spec)
    if path is not None and resume and os.path.exists(path):
        check_resume(path, algo, problem)
        completed, stored, wall0 = read_resume_point(path)
        if completed < algo.generations:
            check_machine(path, completed, allow_other_machine)
        if int(read_attrs(path)["generations"]) != algo.generations:
            with RunWriter(path) as w:
                w.set_attr("generations", algo.generations)
                w.set_attr("cfg_generations", algo.generations)
                w.set_attr("config", json.dumps(algo.config))
        if completed:
            check_stored_state(path, stored, saved_spec)
            return completed, algo.load(stored, state_spec), wall0
    elif path is not None:
        if os.path.exists(path) and not overwrite:
            raise ResultsError(f"{path} exists; use --resume to continue it or --overwrite to replace it")
        if metrics is None:
            metrics = metrics_spec(problem, algo.population)
        states = {k: (tuple(s.shape), s.dtype) for k, s in saved_spec.items()}
        create_run(path, kind=algo.kind, config=algo.config, problem=problem, population=algo.population,
                   generations=algo.generations, metrics=metrics, state=states, overwrite=overwrite)
    return 0, (init or jax.jit(algo.init))(params, k_init), 0.0


def _run(problem: Problem, algo: Algorithm, out: str | os.PathLike[str] | None, **kw: Any) -> dict[str, Any]:
    # one writer per run file: the lock is taken before anything is created, replaced or read for --resume,
    # and held until the last generation is written (cpgjax.io.runlock)
    with deferred_sigint(), runlock.hold(None if out is None else os.fspath(out)):
        return _run_deferred(problem, algo, out, **kw)


def _run_deferred(problem: Problem, algo: Algorithm, out: str | os.PathLike[str] | None, *, chunk: int,
                  seed: int, static: tuple, resume: bool, overwrite: bool, progress: bool, stop_after: int | None,
                  callback: Callable[[int, dict[str, float]], None] | None, desc: str,
                  allow_other_machine: bool = False) -> dict[str, Any]:
    from tqdm.auto import tqdm

    path = None if out is None else os.fspath(out)
    k_init, k_prop, k_upd = run_keys(seed)
    params = jax.tree.map(jnp.asarray, algo.params)
    chunk_fn = _cached_chunk_fn(problem, algo, chunk, static)

    completed, state, wall0 = open_run(problem, algo, path, params, k_init, resume=resume, overwrite=overwrite,
                                       allow_other_machine=allow_other_machine)

    target = algo.generations
    if stop_after is not None:
        target = min(target, completed + int(stop_after))
    t_compile = time.perf_counter()
    # one group of one run: params, state and keys get a leading run axis of 1
    params1, k_prop1, k_upd1 = [_one(params)], [k_prop[None]], [k_upd[None]]
    state1 = [_one(state)]

    def call(state1, gen0, target):
        return chunk_fn(params1, state1, k_prop1, k_upd1, [jnp.full((1,), gen0, jnp.int32)],
                        [jnp.full((1,), target, jnp.int32)])

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
