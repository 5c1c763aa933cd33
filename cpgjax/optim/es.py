"""Modern evolution strategies beside the thesis's GA: every call to ``evosax`` in one place (not part of the thesis).

The thesis compared its GA with random search and adaptive Monte Carlo (Figs. 6.10-6.12).  The
strategies people use today are compared here on the same budget (3000 evaluations), the same
genome box (:data:`cpgjax.episode.cpg.GENE_BOX`), the same fitness (eq. 4.5-4.6, or the robust evaluation) and the
same drivers, through the well-kept implementations of ``evosax``; every call to ``evosax`` is in
this module.

========== ================================ =====================================================
method     evosax class                     what it adapts
========== ================================ =====================================================
cmaes      ``CMA_ES``                       mean, step size and full covariance (Hansen 2016)
sep_cmaes  ``Sep_CMA_ES``                   mean, step size and a diagonal covariance
openes     ``Open_ES`` + ``optax.adam(lr)`` mean by a search-gradient step (Salimans et al. 2017)
pgpe       ``PGPE`` + ``optax.adam(lr)``    mean (optax) and per-gene std (Sehnke et al. 2010)
snes       ``SNES``                         mean and per-gene std by natural gradient (Schaul 2011)
========== ================================ =====================================================

Every strategy starts with its mean at the thesis's start genome (one 0.5 Hz sinusoid per joint,
as the GA's population does), or at ``--start``'s, and step size ``sigma``.  With genes held
(``Problem.held``, ``--free``) the strategy searches the free genes only (its mean, step size and covariance
are theirs) and every genome asked carries the start's values in the held ones.  ``evosax`` minimises: it is told
``-fitness``, with a diverged episode as NaN (its rank shaping puts NaN last).

**The box.**  A strategy samples an unbounded Gaussian; the genome evaluated (and written to the
run file) is the sample *mirrored* at the faces of the box (:func:`reflect`), the strategy is told
its own sample with the fitness of that genome, and after each update its mean is projected back
into the box.  Mirroring, not clipping: clipped samples outside the box would all score as the
face does, a flat region in which CMA-ES's step size grows without bound (docs/evolution-strategies.md,
*The box*, has the figure; ``tests/optim/test_es.py``); mirrored ones score worse the further
out they are, so the search settles on the face.

**State, as the GA's.**  :class:`ESState` holds the samples the *next* generation evaluates (as the
GA's state holds its next population) and evosax's own state as evosax keeps it (a pytree).
:class:`EvolutionStrategy` keeps the contract of :class:`cpgjax.optim.algorithm.Algorithm`: ``init`` asks
for generation 0 with the run's ``k_init``; ``ask`` gives the mirrored samples; ``tell`` tells the
strategy a generation's fitness and asks for the next one, with keys split from the run's update key
for that generation.  A run file stores, per generation, the samples and evosax's state as two vectors,
its float leaves and its integer leaves in evosax's order (:meth:`EvolutionStrategy.save`; the layout
of every run file written so far), from which ``--resume`` rebuilds it bit for bit.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

import jax
import jax.numpy as jnp
import numpy as np

from cpgjax.optim.algorithm import Algorithm, Scores
from cpgjax.optim.problem import Problem

METHODS = ("cmaes", "sep_cmaes", "openes", "pgpe", "snes")
NAMES = {"cmaes": "CMA-ES", "sep_cmaes": "sep-CMA-ES", "openes": "OpenAI-ES", "pgpe": "PGPE", "snes": "SNES"}
ANTITHETIC = ("openes", "pgpe")       # mirrored samples: the population must be even
GRADIENT = ("openes", "pgpe")         # mean moved by an optax optimiser with learning rate ``lr``


@dataclass(frozen=True)
class ESConfig:
    """Settings of one evolution-strategy run (defaults: ours, on the GA's 3000-evaluation budget)."""

    method: str = "cmaes"
    samples: int = 3000        # evaluation budget (the GA's 20 x 150)
    population: int = 20       # samples per generation (the GA's N); see README for larger ones
    sigma: float = 0.2         # initial step size (std of the search distribution), genes span 2 GENE_BOX (1.6)
    lr: float = 0.05           # openes / pgpe: learning rate of optax.adam on the mean
    seed: int = 0
    chunk: int = 1             # generations per jitted lax.scan chunk

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise ValueError(f"method must be one of {', '.join(METHODS)}, got {self.method!r}")
        if self.samples < 1 or self.population < 2 or self.chunk < 1:
            raise ValueError("samples and chunk must be >= 1, population >= 2")
        if self.method in ANTITHETIC and self.population % 2:
            raise ValueError(f"{self.method} samples mirrored pairs: the population must be even, "
                             f"got {self.population}")
        if not (self.sigma > 0 and math.isfinite(self.sigma)):
            raise ValueError(f"sigma must be > 0, got {self.sigma}")
        if not (self.lr > 0 and math.isfinite(self.lr)):
            raise ValueError(f"lr must be > 0, got {self.lr}")

    @property
    def generations(self) -> int:
        """Generations (rows) to spend the budget; the last may overshoot ``samples`` by < one population."""
        return math.ceil(self.samples / self.population)

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)

    def algorithm(self, problem: Problem) -> EvolutionStrategy:
        """This strategy on ``problem``, its mean starting at the problem's start genome (in the box)."""
        n = self.population
        base = np.clip(np.asarray(problem.base_genome, np.float32), problem.lower, problem.upper)
        free = None if problem.held is None else np.flatnonzero(~np.asarray(problem.held, bool))
        es, params = strategy(self.method, n, problem.n_genes if free is None else len(free), float(self.sigma),
                              float(self.lr))
        return EvolutionStrategy(kind=self.method, population=n, generations=self.generations,
                                 config=self.to_dict(), strategy=es, strategy_params=params,
                                 mean0=jnp.asarray(base if free is None else base[free], jnp.float32),
                                 lower=problem.lower, upper=problem.upper, base=base, free=free)


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class ESState:
    """An evolution strategy between generations: the next samples and evosax's state."""

    samples: jax.Array   # [N, G] float32: the strategy's (unmirrored) samples for the next generation
    strategy: Any        # evosax's state of the strategy (its own pytree: mean, step size, ...)


@functools.lru_cache(maxsize=64)
def strategy(method: str, population: int, n_genes: int, sigma: float, lr: float) -> tuple[Any, Any]:
    """``(evosax strategy, its params)`` with step size ``sigma`` (cached: one object per setting)."""
    import optax
    from evosax.algorithms import CMA_ES, PGPE, SNES, Open_ES, Sep_CMA_ES

    solution = jnp.zeros(n_genes, jnp.float32)
    if method == "openes":
        es = Open_ES(population, solution, optimizer=optax.adam(lr), std_schedule=optax.constant_schedule(sigma))
        return es, es.default_params
    if method == "pgpe":
        es = PGPE(population, solution, optimizer=optax.adam(lr))
    else:
        es = {"cmaes": CMA_ES, "sep_cmaes": Sep_CMA_ES, "snes": SNES}[method](population, solution)
    return es, es.default_params.replace(std_init=jnp.asarray(sigma, jnp.float32))


def _is_real(leaf) -> bool:
    return jnp.issubdtype(leaf.dtype, jnp.floating)


def _pack(tree) -> tuple[jax.Array, jax.Array]:
    leaves = jax.tree.leaves(tree)
    cat = lambda xs, dt: jnp.concatenate([jnp.ravel(x).astype(dt) for x in xs]) if xs else jnp.zeros(0, dt)  # noqa: E731
    return (cat([x for x in leaves if _is_real(x)], jnp.float32),
            cat([x for x in leaves if not _is_real(x)], jnp.int32))


def _unpacker(template):
    """The inverse of :func:`_pack` for states shaped as ``template`` (a pytree of shape/dtype structs)."""
    leaves, treedef = jax.tree.flatten(template)

    def unpack(real, count):
        out, at = [], {True: 0, False: 0}
        for t in leaves:
            src = real if _is_real(t) else count
            k, n = _is_real(t), int(np.prod(t.shape, dtype=np.int64))
            out.append(src[at[k]:at[k] + n].reshape(t.shape).astype(t.dtype))
            at[k] += n
        return jax.tree.unflatten(treedef, out)

    return unpack


def _through_stored(strategy):
    """evosax's state through the two vectors a run file stores (:func:`_pack`, and back) behind an optimisation
    barrier, as :meth:`EvolutionStrategy.tell` takes it in and gives it out.

    Why (compiler behaviour, jax 0.10.2): the strategy's state used to be carried from one generation to the next
    in this packed form.  Carried as its own pytree, XLA fused evosax's arithmetic otherwise and rounded some of
    it differently (by how much: docs/reproducibility.md), so that runs no longer gave the numbers of the runs
    made before; without the barrier XLA folds the round trip away.  With it, the program between the barriers
    is the one compiled before, and so is every number of a run.
    """
    real, count = jax.lax.optimization_barrier(_pack(strategy))
    return _unpacker(strategy)(real, count)


def reflect(x: jax.Array, lower: float, upper: float) -> jax.Array:
    """``x`` mirrored into ``[lower, upper]`` at its faces (periodically: a mirror of a mirror ...)."""
    w = upper - lower
    y = jnp.mod(x - lower, 2 * w)
    return jnp.clip(lower + (w - jnp.abs(y - w)), lower, upper)


@dataclass(frozen=True, kw_only=True, eq=False)
class EvolutionStrategy(Algorithm[ESState]):
    """A strategy of ``evosax`` as an :class:`~cpgjax.optim.algorithm.Algorithm` (module docstring).

    Its settings are compile-time constants (every run of a sweep group shares them), so ``params`` is
    empty; the "mutation rate" column holds NaN, as for the other baselines.
    """

    holds_genes: ClassVar[bool] = True
    strategy: Any          # the evosax object (:func:`strategy`)
    strategy_params: Any   # its params
    mean0: jax.Array       # [F] the start of the mean: the start genome's free genes (all G of them by default)
    lower: float
    upper: float
    base: np.ndarray | None = None   # [G] the start genome: the held genes' values
    free: np.ndarray | None = None   # [F] int: the genes searched (``Problem.held``'s others); None: every gene

    def _ask(self, key: jax.Array, s) -> ESState:
        x, s = self.strategy.ask(key, s, self.strategy_params)
        return ESState(jnp.asarray(x, jnp.float32), s)

    def init(self, params, key: jax.Array) -> ESState:
        k_init, k_ask = jax.random.split(key)
        return self._ask(k_ask, self.strategy.init(k_init, self.mean0, self.strategy_params))

    def ask(self, params, state: ESState, key: jax.Array, gen) -> tuple[jax.Array, ESState]:
        x = reflect(state.samples, self.lower, self.upper)
        if self.free is None:
            return x, state
        full = jnp.broadcast_to(jnp.asarray(self.base, jnp.float32), (x.shape[0], len(self.base)))
        return full.at[:, jnp.asarray(self.free)].set(x), state

    def tell(self, params, state: ESState, genomes: jax.Array, scores: Scores, key: jax.Array, gen) -> ESState:
        k_tell, k_ask = jax.random.split(key)
        fitness = scores["fitness"]
        loss = jnp.where(scores["diverged"] | ~jnp.isfinite(fitness), jnp.nan, -fitness)
        s, _ = self.strategy.tell(k_tell, state.samples, loss, _through_stored(state.strategy), self.strategy_params)
        s = s.replace(mean=jnp.clip(s.mean, self.lower, self.upper))
        new = self._ask(k_ask, s)
        return ESState(new.samples, _through_stored(new.strategy))

    def save(self, state: ESState) -> dict[str, jax.Array]:
        """``samples``, and evosax's state as ``real`` [S] float32 (its float leaves, flattened in evosax's
        order) and ``count`` [C] int32 (its integer leaves: generation counters, optimiser steps)."""
        real, count = _pack(state.strategy)
        return {"samples": state.samples, "real": real, "count": count}

    def load(self, stored: Mapping[str, Any], like: ESState) -> ESState:
        return ESState(jnp.asarray(stored["samples"], jnp.float32),
                       _unpacker(like.strategy)(jnp.asarray(stored["real"]), jnp.asarray(stored["count"])))
