"""The adapter every optimiser goes through, and the one generation step all drivers share.

An :class:`Algorithm` is a population-based optimiser as pure functions over a typed state
(:class:`cpgjax.optim.ga.GAState`, :class:`cpgjax.optim.baselines.AMCState`,
:class:`cpgjax.optim.es.ESState`, ...)::

    genomes = propose(params, state, fold_in(k_propose, GEN), GEN)    # GA: the population
    out     = problem.evaluate(genomes)                                 # one batched simulation
    state   = update(params, state, genomes, fitness, diverged,
                     fold_in(k_update, GEN), GEN)                       # GA: ga.reproduce (eq. 6.1)

:func:`generation_step` is that generation for *groups* of runs (each group: runs of one
algorithm shape, vmapped over its runs; every group's proposals go to ONE ``problem.evaluate``
call).  ``cpgjax evolve`` runs it with one group of one run, ``cpgjax sweep`` with every run
of the sweep; :func:`make_chunk_fn` scans it over ``chunk`` generations.  Because the
simulator's result for a robot does not depend on the batch it is in, a run gives the same
numbers bit for bit in either driver.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import partial
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from cpgjax.optim import baselines, es, ga
from cpgjax.optim.problem import Problem


@dataclass(frozen=True)
class Algorithm:
    """A population-based optimiser as pure functions (see the module docstring)."""

    kind: str
    population: int
    generations: int
    config: dict[str, Any]
    params: Any
    init: Callable[[Any, jax.Array], Any]
    propose: Callable[[Any, Any, jax.Array, jax.Array], jax.Array]
    update: Callable[[Any, Any, jax.Array, jax.Array, jax.Array, jax.Array, jax.Array], Any]
    rate: Callable[[Any, jax.Array], jax.Array]
    resumable_changes: tuple[str, ...] = ("chunk",)
    # the problem's metrics an update also needs, stacked [N, D] and passed after ``gen`` (a quality-diversity
    # archive's behaviour descriptors, :mod:`cpgjax.optim.mapelites`); empty: update gets none
    descriptor: tuple[str, ...] = ()


def ga_algorithm(problem: Problem, cfg: ga.GAConfig) -> Algorithm:
    """The GA of :mod:`cpgjax.optim.ga` as an :class:`Algorithm` (state: the population)."""
    base, lo, hi = np.asarray(problem.base_genome, np.float32), problem.lower, problem.upper
    if base.shape != (problem.n_genes,):
        raise ValueError(f"base_genome has shape {base.shape}, expected ({problem.n_genes},)")

    def init(params, key):
        return ga.GAState(ga.init_population(key, base, cfg.population, cfg.init_spread, lo, hi))

    def propose(params, state, key, gen):
        return state.population

    def update(params, state, genomes, fitness, diverged, key, gen):
        return ga.GAState(ga.reproduce(key, genomes, fitness, params, gen, diverged))

    def rate(params, gen):
        return ga.mutation_rate(gen, params.mu_max, params.gamma)

    return Algorithm("ga", cfg.population, cfg.generations, cfg.to_dict(), cfg.params(lo, hi),
                     init, propose, update, rate, resumable_changes=("chunk", "generations"))


def search_algorithm(problem: Problem, cfg: baselines.SearchConfig) -> Algorithm:
    """Random search or adaptive Monte Carlo (:mod:`cpgjax.optim.baselines`) as an :class:`Algorithm`."""
    n, g, lo, hi = cfg.population, problem.n_genes, problem.lower, problem.upper
    nan = lambda params, gen: jnp.float32(jnp.nan)  # noqa: E731

    if cfg.method == "random":
        return Algorithm(
            "random", n, cfg.iterations, cfg.to_dict(), (),
            init=lambda params, key: baselines.RandomState(),
            propose=lambda params, state, key, gen: baselines.random_propose(key, n, g, lo, hi),
            update=lambda params, state, genomes, f, d, key, gen: state,
            rate=nan)

    K = cfg.iterations

    def init(params, key):
        return baselines.amc_init(cfg.M, g, lo, hi)

    def propose(params, state, key, gen):
        w = baselines.amc_width(gen, K, lo, hi, cfg.width_end)
        return baselines.amc_propose(state, key, w, cfg.per_variable, lo, hi)

    def update(params, state, genomes, f, d, key, gen):
        new = baselines.amc_update(state, genomes, f, d)
        return new._replace(width=baselines.amc_width(gen, K, lo, hi, cfg.width_end).astype(jnp.float32))

    return Algorithm("amc", n, K, cfg.to_dict(), (), init, propose, update, nan)


def es_algorithm(problem: Problem, cfg: es.ESConfig) -> Algorithm:
    """An evolution strategy of ``evosax`` (:mod:`cpgjax.optim.es`) as an :class:`Algorithm`.

    Its parameters are compile-time settings (every run of a sweep group shares them), so ``params``
    is empty; the "mutation rate" column holds NaN, as for the other baselines.
    """
    base = np.asarray(problem.base_genome, np.float32)
    init, propose, update = es.make_es(cfg, base, problem.lower, problem.upper)
    return Algorithm(cfg.method, cfg.population, cfg.generations, cfg.to_dict(), (),
                     init=lambda params, key: init(key),
                     propose=lambda params, state, key, gen: propose(state),
                     update=lambda params, state, genomes, f, d, key, gen: update(state, f, d, key),
                     rate=lambda params, gen: jnp.float32(jnp.nan))


Config = ga.GAConfig | baselines.SearchConfig | es.ESConfig


def make_algorithm(problem: Problem, cfg: Config) -> Algorithm:
    """The :class:`Algorithm` of a configuration (GA, a baseline search, or an evolution strategy)."""
    if isinstance(cfg, ga.GAConfig):
        return ga_algorithm(problem, cfg)
    if isinstance(cfg, es.ESConfig):
        return es_algorithm(problem, cfg)
    return search_algorithm(problem, cfg)


def stack_params(algo: Algorithm, params: Sequence[Any]) -> Any:
    """Per-run params of one group stacked along a new leading axis (for ``jax.vmap`` over runs)."""
    return ga.stack_params(list(params)) if algo.kind == "ga" else ()


def _keep(active, new, old):
    """``new`` for the runs where ``active`` (leading axis), else ``old``."""
    return jnp.where(active.reshape(active.shape + (1,) * (new.ndim - 1)), new, old)


EVAL_STREAM = 0x5EED   # folded into a run's update key: the stream of its evaluation keys


def eval_keys(k_update: jax.Array, gen, n: int) -> jax.Array:
    """The keys [n] of generation ``gen``'s ``n`` evaluations of one run (a stochastic problem's perturbations).

    Derived from the run's update key (so from its seed alone), the generation and the individual's
    index: the same in ``cpgjax evolve`` and ``cpgjax sweep``, on resume, and for any batch.
    """
    k = jax.random.fold_in(jax.random.fold_in(k_update, gen), EVAL_STREAM)
    return jax.vmap(lambda i: jax.random.fold_in(k, i))(jnp.arange(n, dtype=jnp.uint32))


def generation_step(problem: Problem, algos: Sequence[Algorithm], sizes: Sequence[int]):
    """One generation of groups of runs: ``(params, states, kps, kus, gens, targets) -> (states, rows)``.

    Per group (lists, one entry per group of ``sizes[i]`` runs of ``algos[i]``): ``params`` and
    ``states`` stacked over its runs, ``kps``/``kus`` ``[R]`` keys, ``gens``/``targets`` ``[R]``
    int32 (the generation being made and the end of each run).  Every group's proposals go to one
    ``problem.evaluate``; a run with ``gen >= target`` keeps its state.  ``rows`` per group:
    genomes ``[R, N, G]``, raw fitness and diverged (flag or non-finite fitness) ``[R, N]``, the
    mutation rate ``[R]``, the metrics ``[R, N]`` and the new state.
    """
    G = problem.n_genes
    # The evaluation as a jitted function of its own, whose constants (the model's arrays) stay literals
    # inside it.  Why: `make_chunk_fn` runs this generation in a `lax.cond`, and JAX passes a cond branch's
    # closed-over constants to XLA as operands of the conditional.  XLA sinks constant operands into while
    # loops but not into conditional branches, so on ONE host device (no `shard_map`, whose partitioning
    # happened to put them back) expressions of the model's constants (1/m, c / (1 + dt c / I)) were
    # computed at run time rather than folded at compile time as in ``jax.jit(problem.evaluate)`` alone,
    # and a robot's score differed in its last bits from the same robot evaluated alone
    # (tests/experiments/test_sweep.py).  With two or more devices it changes no result.
    evaluate = jax.jit(problem.evaluate)

    def generation(params, states, kps, kus, gens, targets):
        proposals = []
        for a, p, s, kp, gen in zip(algos, params, states, kps, gens, strict=True):
            keys = jax.vmap(jax.random.fold_in)(kp, gen)
            proposals.append(jax.vmap(a.propose)(p, s, keys, gen))
        # the barrier keeps XLA from fusing (and re-rounding) the proposals into the simulation
        proposals = jax.lax.optimization_barrier(proposals)
        flat = jnp.concatenate([x.reshape(-1, G) for x in proposals], axis=0)
        if problem.stochastic:
            keys = [jax.vmap(partial(eval_keys, n=a.population))(ku, gen).reshape(-1)
                    for a, ku, gen in zip(algos, kus, gens, strict=True)]
            ev = evaluate(flat, jnp.concatenate(keys))
        else:
            ev = evaluate(flat)
        new_states, rows, off = [], [], 0
        for a, p, s, ku, gen, tgt, x, r in zip(algos, params, states, kus, gens, targets, proposals, sizes,
                                              strict=True):
            n = a.population
            part = {k: jax.lax.slice_in_dim(v, off, off + r * n) for k, v in ev.items()}
            off += r * n
            fit = jnp.asarray(part["fitness"], jnp.float32).reshape(r, n)
            div = jnp.asarray(part["diverged"], bool).reshape(r, n) | ~jnp.isfinite(fit)
            keys = jax.vmap(jax.random.fold_in)(ku, gen)
            if a.descriptor:
                d = jnp.stack([jnp.asarray(part[k], jnp.float32).reshape(r, n) for k in a.descriptor], -1)
                upd = jax.vmap(a.update)(p, s, x, fit, div, keys, gen, d)
            else:
                upd = jax.vmap(a.update)(p, s, x, fit, div, keys, gen)
            new = jax.tree.map(partial(_keep, gen < tgt), upd, s)
            metrics = {k: jnp.asarray(v, jnp.float32).reshape(r, n) for k, v in part.items()
                       if k not in ("fitness", "diverged")}
            rate = jnp.broadcast_to(jnp.asarray(jax.vmap(a.rate)(p, gen), jnp.float32), (r,))
            rows.append({"genomes": x.astype(jnp.float32), "fitness": fit, "diverged": div, "rate": rate,
                         "metrics": metrics, "state": new})
            new_states.append(new)
        return new_states, rows

    return generation


def make_chunk_fn(problem: Problem, algos: Sequence[Algorithm], sizes: Sequence[int], chunk: int):
    """Jitted ``(params, states, kps, kus, gen0, targets) -> (states, rows)``: ``chunk`` generations in a scan.

    Arguments as :func:`generation_step`'s, with ``gen0`` the next generation of each run; ``rows``
    per group are ``[chunk, R, ...]``.  A step in which no run is active (past every target, in the
    last chunk) is skipped by a ``lax.cond`` (zeros), so one compiled program serves every chunk.
    """
    generation = generation_step(problem, algos, sizes)

    def run_chunk(params, states, kps, kus, gen0, targets):
        spec = jax.eval_shape(generation, params, states, kps, kus, gen0, targets)[1]

        def body(states, i):
            gens = [g + i for g in gen0]
            busy = jnp.any(jnp.stack([jnp.any(g < t) for g, t in zip(gens, targets, strict=True)]))

            def active(states):
                return generation(params, states, kps, kus, gens, targets)

            def idle(states):
                return states, jax.tree.map(lambda s: jnp.zeros(s.shape, s.dtype), spec)

            return jax.lax.cond(busy, active, idle, states)

        return jax.lax.scan(body, states, jnp.arange(chunk, dtype=jnp.int32))

    return jax.jit(run_chunk)
