"""The contract every optimiser keeps, and the one generation step all drivers share.

An :class:`Algorithm` is a population-based optimiser as pure methods over a typed state (a dataclass
registered as a pytree: :class:`~cpgjax.optim.ga.GAState`, :class:`~cpgjax.optim.baselines.AMCState`,
:class:`~cpgjax.optim.es.ESState`, :class:`~cpgjax.optim.mapelites.MEState`, ...), in evosax's ask / tell
form::

    state          = algo.init(params, k_init)
    genomes, state = algo.ask(params, state, fold_in(k_propose, GEN), GEN)    # GA: the population
    scores         = problem.evaluate(genomes)                                 # one batched simulation
    state          = algo.tell(params, state, genomes, scores,
                               fold_in(k_update, GEN), GEN)                    # GA: ga.reproduce (eq. 6.1)

``params`` are a run's settings as traced arrays (the GA's :class:`~cpgjax.optim.ga.GAParams`; ``()`` for
the others, whose settings are compile-time constants of the algorithm object), so that the runs of one
group are ``jax.vmap``-ed over their params, states and keys.  ``scores`` carries the problem's outputs **by
name** (QDax's ``extra_scores``): ``"fitness"`` [N] float32, ``"diverged"`` [N] bool (the problem's flag or
a non-finite fitness) and every other output of ``problem.evaluate`` as [N] float32 (``distance``,
``speed``..., a repertoire's descriptor dimensions, its fall flag ``down``); an algorithm reads what it
needs (:class:`Scores`).

What a run file stores of the state after each generation is :meth:`Algorithm.save` (arrays by name,
``/state/<name>``; by default the state's fields), and ``--resume`` rebuilds the state with
:meth:`Algorithm.load`.

:func:`generation_step` is one generation for *groups* of runs (each group: runs of one algorithm, vmapped
over its runs; every group's genomes go to ONE ``problem.evaluate`` call).  ``cpgjax evolve`` runs it with
one group of one run, ``cpgjax sweep`` with every run of the sweep; :func:`make_chunk_fn` scans it over
``chunk`` generations.  Because the simulator's result for a robot does not depend on the batch it is in, a
run gives the same numbers bit for bit in either driver.
"""

from __future__ import annotations

import abc
import dataclasses
from collections.abc import Mapping, Sequence
from functools import partial
from typing import Any, ClassVar, Generic, Protocol, TypeVar

import jax
import jax.numpy as jnp

from cpgjax.optim.problem import Problem

Scores = Mapping[str, jax.Array]
"""A generation's scores by name: ``fitness``, ``diverged`` and the problem's other outputs (module docstring)."""

S = TypeVar("S")   # an algorithm's state: a frozen dataclass registered as a pytree


@dataclasses.dataclass(frozen=True, kw_only=True, eq=False)
class Algorithm(abc.ABC, Generic[S]):
    """A population-based optimiser as pure methods over a typed state (see the module docstring).

    Fields: ``kind`` (the run file's kind: ``ga``, ``random``, ``amc``, an evosax method, ``map-elites``...),
    ``population`` (genomes asked per generation), ``generations`` (of a whole run), ``config`` (its settings,
    stored with the run), ``params`` (the traced per-run settings), ``resumable_changes`` (the settings a
    ``--resume`` may change).  Every method is pure and traceable; ``gen`` is an int32 scalar.
    """

    kind: str
    population: int
    generations: int
    config: dict[str, Any]
    params: Any = ()
    resumable_changes: tuple[str, ...] = ("chunk",)
    holds_genes: ClassVar[bool] = False     # honours ``Problem.held`` (``--free``): the GA, the evolution strategies

    @abc.abstractmethod
    def init(self, params: Any, key: jax.Array) -> S:
        """The state before generation 0."""

    @abc.abstractmethod
    def ask(self, params: Any, state: S, key: jax.Array, gen: jax.Array) -> tuple[jax.Array, S]:
        """The genomes [population, G] of generation ``gen``, and the state they leave."""

    @abc.abstractmethod
    def tell(self, params: Any, state: S, genomes: jax.Array, scores: Scores, key: jax.Array,
             gen: jax.Array) -> S:
        """The state after generation ``gen``'s ``genomes`` scored ``scores`` (by name)."""

    def mutation_rate(self, params: Any, gen: jax.Array) -> jax.Array:
        """The run file's ``mutation_rate`` of generation ``gen`` (the GA's eq. 6.1); NaN unless the algorithm
        has one."""
        return jnp.float32(jnp.nan)

    def save(self, state: S) -> dict[str, jax.Array]:
        """The arrays a run file stores of ``state`` after a generation, by name (default: its fields)."""
        return {f.name: getattr(state, f.name) for f in dataclasses.fields(state)}

    def load(self, stored: Mapping[str, Any], like: S) -> S:
        """The state :meth:`save` stored (``--resume``); ``like`` is a state of the right shapes
        (``jax.eval_shape`` of :meth:`init`)."""
        return type(like)(**{k: jnp.asarray(stored[k], s.dtype) for k, s in self.save(like).items()})


class Config(Protocol):
    """A configuration that makes its algorithm (``GAConfig``, ``SearchConfig``, ``ESConfig``, ``MEConfig``)."""

    seed: int
    chunk: int

    def algorithm(self, problem: Problem) -> Algorithm: ...


def make_algorithm(problem: Problem, cfg: Config) -> Algorithm:
    """The :class:`Algorithm` of a configuration on ``problem`` (the GA, a baseline search, an evolution
    strategy, MAP-Elites: each configuration class makes its own).  Only the GA and the evolution strategies
    keep genes held (``problem.held``); the others refuse such a problem."""
    algo = cfg.algorithm(problem)
    if problem.held is not None and not algo.holds_genes:
        raise ValueError(f"--free (genes held at the start's values) applies to the GA (cpgjax evolve) and the "
                         f"evolution strategies (cpgjax search --method cmaes, ...), not to {algo.kind}")
    return algo


def stack_params(algo: Algorithm, params: Sequence[Any]) -> Any:
    """Per-run params of one group stacked along a new leading axis (for ``jax.vmap`` over runs)."""
    return jax.tree.map(lambda *xs: jnp.stack(xs), *params)


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
    """One generation of groups of runs: ``(params, states, kps, kus, gens, targets[, length]) -> (states, rows)``.

    Per group (lists, one entry per group of ``sizes[i]`` runs of ``algos[i]``): ``params`` and
    ``states`` stacked over its runs, ``kps``/``kus`` ``[R]`` keys, ``gens``/``targets`` ``[R]``
    int32 (the generation being made and the end of each run).  Every group's genomes go to one
    ``problem.evaluate``; a run with ``gen >= target`` keeps its state.  ``rows`` per group:
    genomes ``[R, N, G]``, raw fitness and diverged (flag or non-finite fitness) ``[R, N]``, the
    mutation rate ``[R]``, the problem's other outputs (``metrics``, by name) ``[R, N]`` and what the
    run file stores of the new state (``state``: :meth:`Algorithm.save`, by name).  ``length``: the episode's
    length as data (``problem.length``, passed to ``problem.evaluate``), None for the problem's own compiled in.
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

    def generation(params, states, kps, kus, gens, targets, length=None):
        span = {} if length is None else {"length": length}
        proposals, asked = [], []
        for a, p, s, kp, gen in zip(algos, params, states, kps, gens, strict=True):
            keys = jax.vmap(jax.random.fold_in)(kp, gen)
            x, s_asked = jax.vmap(a.ask)(p, s, keys, gen)
            proposals.append(x)
            asked.append(s_asked)
        # the barrier keeps XLA from fusing (and re-rounding) the proposals into the simulation
        proposals = jax.lax.optimization_barrier(proposals)
        flat = jnp.concatenate([x.reshape(-1, G) for x in proposals], axis=0)
        if problem.stochastic:
            keys = [jax.vmap(partial(eval_keys, n=a.population))(ku, gen).reshape(-1)
                    for a, ku, gen in zip(algos, kus, gens, strict=True)]
            ev = evaluate(flat, jnp.concatenate(keys), **span)
        else:
            ev = evaluate(flat, **span)
        new_states, rows, off = [], [], 0
        for a, p, s, s_asked, ku, gen, tgt, x, r in zip(algos, params, states, asked, kus, gens, targets,
                                                        proposals, sizes, strict=True):
            n = a.population
            part = {k: jax.lax.slice_in_dim(v, off, off + r * n) for k, v in ev.items()}
            off += r * n
            fit = jnp.asarray(part["fitness"], jnp.float32).reshape(r, n)
            div = jnp.asarray(part["diverged"], bool).reshape(r, n) | ~jnp.isfinite(fit)
            metrics = {k: jnp.asarray(v, jnp.float32).reshape(r, n) for k, v in part.items()
                       if k not in ("fitness", "diverged")}
            keys = jax.vmap(jax.random.fold_in)(ku, gen)
            told = jax.vmap(a.tell)(p, s_asked, x, {"fitness": fit, "diverged": div, **metrics}, keys, gen)
            new = jax.tree.map(partial(_keep, gen < tgt), told, s)
            rate = jnp.broadcast_to(jnp.asarray(jax.vmap(a.mutation_rate)(p, gen), jnp.float32), (r,))
            rows.append({"genomes": x.astype(jnp.float32), "fitness": fit, "diverged": div, "rate": rate,
                         "metrics": metrics, "state": jax.vmap(a.save, axis_size=r)(new)})
            new_states.append(new)
        return new_states, rows

    return generation


def make_chunk_fn(problem: Problem, algos: Sequence[Algorithm], sizes: Sequence[int], chunk: int):
    """Jitted ``(params, states, kps, kus, gen0, targets[, length]) -> (states, rows)``: ``chunk`` generations in a
    scan.

    Arguments as :func:`generation_step`'s, with ``gen0`` the next generation of each run; ``rows``
    per group are ``[chunk, R, ...]``.  A step in which no run is active (past every target, in the
    last chunk) is skipped by a ``lax.cond`` (zeros), so one compiled program serves every chunk.  Pass
    ``problem.length`` as ``length`` (an argument of the program, not a constant in it): one program then serves
    every episode length of the model and population (:func:`chunk_args` appends it).
    """
    generation = generation_step(problem, algos, sizes)

    def run_chunk(params, states, kps, kus, gen0, targets, length=None):
        spec = jax.eval_shape(generation, params, states, kps, kus, gen0, targets, length)[1]

        def body(states, i):
            gens = [g + i for g in gen0]
            busy = jnp.any(jnp.stack([jnp.any(g < t) for g, t in zip(gens, targets, strict=True)]))

            def active(states):
                return generation(params, states, kps, kus, gens, targets, length)

            def idle(states):
                return states, jax.tree.map(lambda s: jnp.zeros(s.shape, s.dtype), spec)

            return jax.lax.cond(busy, active, idle, states)

        return jax.lax.scan(body, states, jnp.arange(chunk, dtype=jnp.int32))

    return jax.jit(run_chunk)


def chunk_args(problem: Problem) -> tuple:
    """What a chunk program of ``problem`` takes after its six arguments (:func:`make_chunk_fn`): the episode's
    length as data where the problem has one (``problem.length``), else nothing."""
    return () if problem.length is None else (problem.length,)
