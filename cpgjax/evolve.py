"""Drivers: run the GA (:func:`run_ga`) or a baseline search (:func:`run_search`) into an HDF5 file.

Every algorithm is a pure triple ``init / propose / update`` (:class:`Algorithm`).  One
generation is::

    genomes = propose(params, state, fold_in(k_propose, GEN), GEN)    # GA: the population
    out     = problem.evaluate(genomes)                                 # one vmapped simulation
    state   = update(params, state, genomes, fitness, diverged,
                     fold_in(k_update, GEN), GEN)                       # GA: cpgjax.ga.reproduce

with ``k_init, k_propose, k_update = split(jax.random.key(seed), 3)``.  A chunk of ``chunk``
generations is one jitted ``lax.scan``; generations past the end of the run inside the last
chunk are skipped by a ``lax.cond``, so the *same* compiled program runs every chunk, from
any starting generation.  Between chunks the host appends each generation to the HDF5 file
(flushed per generation; :mod:`cpgjax.results`) and updates the progress bar.

Resume: each row stores the algorithm's state after that generation (``/state/*``; for the
GA the population bred from it).  ``resume=True`` reads the last complete row and continues
the scan from ``completed`` with that state; because keys depend only on (seed, GEN) and the
program is the same, the resumed file holds bit for bit the rows an uninterrupted run would
(wall times aside), provided the chunk size, the machine and the JAX version are the same.
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from cpgjax import ga, search
from cpgjax.problem import Problem
from cpgjax.results import ResultsError, Row, RunWriter, create_run, read_attrs, read_resume_point

State = dict[str, jax.Array]


@dataclass(frozen=True)
class Algorithm:
    """A population-based optimiser as pure functions (see the module docstring)."""

    kind: str
    population: int
    generations: int
    config: dict[str, Any]
    params: Any
    init: Callable[[Any, jax.Array], State]
    propose: Callable[[Any, State, jax.Array, jax.Array], jax.Array]
    update: Callable[[Any, State, jax.Array, jax.Array, jax.Array, jax.Array, jax.Array], State]
    rate: Callable[[Any, jax.Array], jax.Array]
    resumable_changes: tuple[str, ...] = ("chunk",)


def ga_algorithm(problem: Problem, cfg: ga.GAConfig) -> Algorithm:
    """The GA of :mod:`cpgjax.ga` as an :class:`Algorithm` (state: the population)."""
    base, lo, hi = np.asarray(problem.base_genome, np.float32), problem.lower, problem.upper
    if base.shape != (problem.n_genes,):
        raise ValueError(f"base_genome has shape {base.shape}, expected ({problem.n_genes},)")

    def init(params, key):
        return {"population": ga.init_population(key, base, cfg.population, cfg.init_spread, lo, hi)}

    def propose(params, state, key, gen):
        return state["population"]

    def update(params, state, genomes, fitness, diverged, key, gen):
        return {"population": ga.reproduce(key, genomes, fitness, params, gen, diverged)}

    def rate(params, gen):
        return ga.mutation_rate(gen, params.mu_max, params.gamma)

    return Algorithm("ga", cfg.population, cfg.generations, cfg.to_dict(), cfg.params(lo, hi),
                     init, propose, update, rate, resumable_changes=("chunk", "generations"))


def search_algorithm(problem: Problem, cfg: search.SearchConfig) -> Algorithm:
    """Random search or adaptive Monte Carlo (:mod:`cpgjax.search`) as an :class:`Algorithm`."""
    n, g, lo, hi = cfg.population, problem.n_genes, problem.lower, problem.upper
    nan = lambda params, gen: jnp.float32(jnp.nan)  # noqa: E731

    if cfg.method == "random":
        return Algorithm(
            "random", n, cfg.iterations, cfg.to_dict(), (),
            init=lambda params, key: {},
            propose=lambda params, state, key, gen: search.random_propose(key, n, g, lo, hi),
            update=lambda params, state, genomes, f, d, key, gen: state,
            rate=nan)

    K = cfg.iterations

    def init(params, key):
        return {**search.amc_init(cfg.M, g, lo, hi), "width": jnp.float32(0.5 * (hi - lo))}

    def propose(params, state, key, gen):
        w = search.amc_width(gen, K, lo, hi, cfg.width_end)
        return search.amc_propose(state, key, w, cfg.per_variable, lo, hi)

    def update(params, state, genomes, f, d, key, gen):
        new = search.amc_update({"center": state["center"], "best": state["best"]}, genomes, f, d)
        return {**new, "width": search.amc_width(gen, K, lo, hi, cfg.width_end).astype(jnp.float32)}

    return Algorithm("amc", n, K, cfg.to_dict(), (), init, propose, update, nan)


def make_chunk_fn(problem: Problem, algo: Algorithm, chunk: int):
    """The jitted ``(params, state, k_propose, k_update, gen0, n_valid) -> (state, rows)`` of one chunk.

    ``rows`` holds, per generation of the chunk (``[chunk, ...]``): genomes, raw fitness,
    diverged (flag or non-finite fitness), the rate, the metrics and the new state.  Steps
    ``i >= n_valid`` are skipped (zeros) so one compiled program serves every chunk.
    """
    n, g = algo.population, problem.n_genes

    def generation(params, state, k_prop, k_upd, gen):
        genomes = algo.propose(params, state, jax.random.fold_in(k_prop, gen), gen)
        ev = problem.evaluate(genomes)
        fit = jnp.asarray(ev["fitness"], jnp.float32).reshape(n)
        div = jnp.asarray(ev["diverged"], bool).reshape(n) | ~jnp.isfinite(fit)
        new = algo.update(params, state, genomes, fit, div, jax.random.fold_in(k_upd, gen), gen)
        metrics = {k: jnp.asarray(v, jnp.float32).reshape(n) for k, v in ev.items()
                   if k not in ("fitness", "diverged")}
        row = {"genomes": genomes.astype(jnp.float32), "fitness": fit, "diverged": div,
               "rate": jnp.asarray(algo.rate(params, gen), jnp.float32), "metrics": metrics, "state": new}
        return new, row

    def run_chunk(params, state, k_prop, k_upd, gen0, n_valid):
        spec = jax.eval_shape(generation, params, state, k_prop, k_upd, gen0)[1]

        def body(state, i):
            def active(state):
                return generation(params, state, k_prop, k_upd, gen0 + i)

            def idle(state):
                return state, jax.tree.map(lambda s: jnp.zeros(s.shape, s.dtype), spec)

            return jax.lax.cond(i < n_valid, active, idle, state)

        return jax.lax.scan(body, state, jnp.arange(chunk, dtype=jnp.int32))

    del g
    return jax.jit(run_chunk)


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
    """:func:`make_chunk_fn`, reused across calls with the same ``evaluate`` and static settings.

    (Several runs of one problem in a process — tests, resume, sweeps of seeds — compile once.)
    """
    key = (id(problem.evaluate), problem.n_genes, problem.lower, problem.upper, algo.kind,
           algo.population, chunk, static)
    hit = _CHUNK_CACHE.get(key)
    if hit is not None and hit[0] is problem.evaluate:
        return hit[1]
    fn = _CompiledOnFirstCall(make_chunk_fn(problem, algo, chunk))   # same shapes for every hit of the key
    if len(_CHUNK_CACHE) >= 16:
        _CHUNK_CACHE.pop(next(iter(_CHUNK_CACHE)))
    _CHUNK_CACHE[key] = (problem.evaluate, fn)
    return fn


def run_keys(seed: int) -> tuple[jax.Array, jax.Array, jax.Array]:
    """``(k_init, k_propose, k_update)`` of a run: its whole randomness, from the seed alone.

    Every driver (``cpgjax evolve``, ``search``, ``sweep``) takes its keys from here, which is what
    makes a run of a sweep equal, bit for bit, the same run made alone.
    """
    k_init, k_prop, k_upd = jax.random.split(jax.random.key(seed), 3)
    return k_init, k_prop, k_upd


def _check_resume(path: str, algo: Algorithm, problem: Problem) -> None:
    a = read_attrs(path)
    if a.get("kind") != algo.kind:
        raise ResultsError(f"{path} holds a {a.get('kind')!r} run, not {algo.kind!r}")
    stored = json.loads(a["config"])
    diff = [k for k in algo.config if k not in algo.resumable_changes and stored.get(k) != algo.config[k]]
    if diff:
        detail = ", ".join(f"{k}: stored {stored.get(k)!r} != {algo.config[k]!r}" for k in diff)
        raise ResultsError(f"{path}: cannot resume with different settings ({detail})")
    if int(a["n_genes"]) != problem.n_genes or int(a["population"]) != algo.population:
        raise ResultsError(f"{path}: genome or population size differs from the stored run")
    text = str(problem.meta.get("model_text", ""))
    if text and str(a.get("model_text", "")) and text != a.get("model_text"):
        raise ResultsError(f"{path}: the model file changed since the run started")


def metrics_spec(problem: Problem, population: int) -> dict[str, tuple[tuple[int, ...], Any]]:
    """The per-individual metrics ``problem.evaluate`` returns besides fitness (shapes for the run file).

    Traces the simulator once (``eval_shape``): callers with many runs compute it once.
    """
    ev = jax.eval_shape(problem.evaluate, jax.ShapeDtypeStruct((population, problem.n_genes), jnp.float32))
    return {k: ((population,), np.float32) for k in ev if k not in ("fitness", "diverged")}


def open_run(problem: Problem, algo: Algorithm, path: str | None, params: Any, k_init: jax.Array, *,
             resume: bool, overwrite: bool, init: Callable | None = None,
             metrics: dict | None = None) -> tuple[int, State, float]:
    """Where a run starts: ``(completed generations, algorithm state, wall time so far)``.

    ``resume`` and an existing file: its settings are checked against ``algo`` (the number of
    generations may be extended) and the run continues after its last complete row.  Otherwise a
    new file is created (an existing one only with ``overwrite``, else :class:`ResultsError`) and
    the state is ``algo.init`` with the run's ``k_init``.  ``path=None``: nothing on disk.
    ``init`` (a jitted ``algo.init``) and ``metrics`` (:func:`metrics_spec`) may be passed in by
    callers that open many runs of one shape, so that neither is traced again for each.
    """
    state_spec = jax.eval_shape(algo.init, params, k_init)
    if path is not None and resume and os.path.exists(path):
        _check_resume(path, algo, problem)
        completed, stored, wall0 = read_resume_point(path)
        if int(read_attrs(path)["generations"]) != algo.generations:
            with RunWriter(path) as w:
                w.set_attr("generations", algo.generations)
                w.set_attr("cfg_generations", algo.generations)
                w.set_attr("config", json.dumps(algo.config))
        if completed:
            return completed, {k: jnp.asarray(stored[k], state_spec[k].dtype) for k in state_spec}, wall0
    elif path is not None:
        if os.path.exists(path) and not overwrite:
            raise ResultsError(f"{path} exists; use --resume to continue it or --overwrite to replace it")
        if metrics is None:
            metrics = metrics_spec(problem, algo.population)
        states = {k: (tuple(s.shape), s.dtype) for k, s in state_spec.items()}
        create_run(path, kind=algo.kind, config=algo.config, problem=problem, population=algo.population,
                   generations=algo.generations, metrics=metrics, state=states, overwrite=overwrite)
    return 0, (init or jax.jit(algo.init))(params, k_init), 0.0


def _run(problem: Problem, algo: Algorithm, out: str | os.PathLike[str] | None, *, chunk: int,
         seed: int, static: tuple, resume: bool, overwrite: bool, progress: bool, stop_after: int | None,
         callback: Callable[[int, dict[str, float]], None] | None, desc: str) -> dict[str, Any]:
    from tqdm.auto import tqdm

    path = None if out is None else os.fspath(out)
    k_init, k_prop, k_upd = run_keys(seed)
    params = jax.tree.map(jnp.asarray, algo.params)
    chunk_fn = _cached_chunk_fn(problem, algo, chunk, static)

    completed, state, wall0 = open_run(problem, algo, path, params, k_init, resume=resume, overwrite=overwrite)

    target = algo.generations
    if stop_after is not None:
        target = min(target, completed + int(stop_after))
    t_compile = time.perf_counter()
    jax.block_until_ready(chunk_fn(params, state, k_prop, k_upd, jnp.int32(0), jnp.int32(0)))  # compile
    compile_time = time.perf_counter() - t_compile

    history: dict[str, list] = {"genomes": [], "fitness": [], "diverged": [], "mutation_rate": []}
    best = -np.inf
    t_start, evals = time.perf_counter(), 0
    bar = tqdm(total=algo.generations, initial=completed, desc=desc, unit="gen", disable=not progress,
               dynamic_ncols=True)
    try:
        while completed < target:
            n_valid = min(chunk, target - completed)
            t0 = time.perf_counter()
            state, rows = chunk_fn(params, state, k_prop, k_upd, jnp.int32(completed), jnp.int32(n_valid))
            rows = jax.device_get(rows)
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
            bar.set_postfix(best=f"{info['best']:.4g}", mean=f"{info['mean']:.4g}",
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
        from cpgjax.results import read_run

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
           callback: Callable[[int, dict[str, float]], None] | None = None) -> dict[str, Any]:
    """Evolve ``cfg.generations`` generations of the GA on ``problem``, writing ``out`` (HDF5).

    ``resume``: continue the run in ``out`` (a missing file starts a new run); the stored
    settings must match ``cfg`` except ``generations`` (may be extended) and ``chunk``.
    ``overwrite``: replace an existing file (otherwise an existing file is an error).
    ``stop_after``: stop after that many generations in this call (time-limited jobs, tests).
    ``callback(completed, info)`` is called after each chunk.  ``out=None`` keeps the results
    in memory (``summary["history"]``).  Returns a summary dict (best fitness, generation,
    index and genome, evaluations per second, compile time, ...).
    """
    return _run(problem, ga_algorithm(problem, cfg), out, chunk=cfg.chunk, seed=cfg.seed, static=(),
                resume=resume,
                overwrite=overwrite, progress=progress, stop_after=stop_after, callback=callback,
                desc="evolve")


def run_search(problem: Problem, cfg: search.SearchConfig, out: str | os.PathLike[str] | None = None, *,
               resume: bool = False, overwrite: bool = False, progress: bool = False,
               stop_after: int | None = None,
               callback: Callable[[int, dict[str, float]], None] | None = None) -> dict[str, Any]:
    """Run a baseline search (:mod:`cpgjax.search`) with the layout, keys and resume of :func:`run_ga`."""
    static = tuple(sorted((k, v) for k, v in cfg.to_dict().items() if k not in ("seed", "chunk")))
    return _run(problem, search_algorithm(problem, cfg), out, chunk=cfg.chunk, seed=cfg.seed, static=static,
                resume=resume,
                overwrite=overwrite, progress=progress, stop_after=stop_after, callback=callback,
                desc=cfg.method)
