"""Baselines of Ch. 6.2.5-6.2.6 on the GA's budget: uniform random search and adaptive Monte Carlo.

Both keep the GA's contract (:class:`cpgjax.optim.algorithm.Algorithm`: :class:`RandomSearch`,
:class:`AdaptiveMonteCarlo`, made by :meth:`SearchConfig.algorithm`): pure ``ask`` and ``tell`` over a
typed state, driven by :func:`cpgjax.experiments.evolve.run_search` with the same chunked ``lax.scan``,
the same keys (``fold_in(run_key, gen)``) and the same HDF5 layout (a "generation" is one batch of
evaluations).

**Random search** (Fig. 6.10): every sample uniform in the problem's box ``[lower, upper]^G`` (by
default ``[-GENE_BOX, GENE_BOX]^G``, the hypercube of side 1.6: :data:`cpgjax.episode.cpg.GENE_BOX`), in
batches of ``batch`` (default 20, the GA's population) until ``samples`` (default 3000 = 20 x 150) have been
evaluated.

**Adaptive Monte Carlo** (Fig. 6.11; Calvin 1996, "Adaptive Monte Carlo global search with
bounded memory", thesis ref. [44]).  The thesis only says: "an array of M independent random
variables is used to search the space of the parameters.  The estimates of parameter values
is based on a fixed number of previous estimates.  Successive estimates distributions are
restricted around the best estimate of the previous ones."  Our reading:

* M independent searchers ("random variables"), m = 1..M, each with its own centre ``c_m``
  and its best fitness so far ``b_m`` — a bounded memory of one estimate per variable;
* iteration k draws ``B = ceil(batch / M)`` samples per variable, uniform in the box
  ``[c_m - w_k, c_m + w_k]`` intersected with the hypercube (sampled uniformly inside the
  intersection, so no mass piles up on the faces);
* iteration 0 has ``c_m`` = the centre of the cube and ``w_0`` = half its side: the whole
  cube, i.e. one round of random search;
* the box contracts geometrically, ``w_k = w_0 (w_end / w_0)^(k / (K - 1))`` over the K
  iterations of the budget (``w_end`` = ``width_end``, default 0.02);
* after each iteration ``c_m`` moves to the variable's best sample if it beats ``b_m``
  (diverged or non-finite samples never do).  Searchers never share information, so M
  trades exploration (many independent searches) for refinement (more samples each).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import jax
import jax.numpy as jnp

from cpgjax.optim.algorithm import Algorithm, Scores
from cpgjax.optim.problem import Problem

METHODS = ("random", "amc")


@dataclass(frozen=True)
class SearchConfig:
    """Settings of a baseline search (Ch. 6.2.5-6.2.6)."""

    method: str = "random"
    samples: int = 3000        # evaluation budget (the GA's 20 x 150)
    batch: int = 20            # evaluations per iteration (rounded up to a multiple of M for amc)
    M: int = 5                 # independent random variables of the adaptive Monte Carlo search
    width_end: float = 0.02    # half-width of the amc sampling box at the last iteration
    seed: int = 0
    chunk: int = 1             # iterations per jitted lax.scan chunk

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise ValueError(f"method must be one of {METHODS}, got {self.method!r}")
        if self.samples < 1 or self.batch < 1 or self.M < 1 or self.chunk < 1:
            raise ValueError("samples, batch, M and chunk must be >= 1")
        if self.width_end <= 0:
            raise ValueError("width_end must be > 0")

    @property
    def per_variable(self) -> int:
        """amc: samples per random variable per iteration."""
        return math.ceil(self.batch / self.M)

    @property
    def population(self) -> int:
        """Evaluations per iteration (one row of the results file)."""
        return self.batch if self.method == "random" else self.M * self.per_variable

    @property
    def iterations(self) -> int:
        """Iterations (rows) to spend the budget; the last may overshoot ``samples`` by < one batch."""
        return math.ceil(self.samples / self.population)

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)

    def algorithm(self, problem: Problem) -> RandomSearch | AdaptiveMonteCarlo:
        """This search on ``problem`` (its genome size and search box)."""
        cls = RandomSearch if self.method == "random" else AdaptiveMonteCarlo
        return cls(kind=self.method, population=self.population, generations=self.iterations,
                    config=self.to_dict(), cfg=self, n_genes=problem.n_genes, lower=problem.lower,
                    upper=problem.upper)


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class RandomState:
    """Random search keeps no state."""


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class AMCState:
    """Adaptive Monte Carlo: each variable's centre and best fitness, and the current box half-width."""

    center: jax.Array   # [M, G] float32
    best: jax.Array     # [M] float32, -inf before the first valid sample
    width: jax.Array    # [] float32


def random_propose(key: jax.Array, n: int, n_genes: int, lower: float, upper: float) -> jax.Array:
    """Fig. 6.10: ``n`` genomes uniform in the hypercube."""
    return jax.random.uniform(key, (n, n_genes), jnp.float32, lower, upper)


def amc_width(gen, iterations: int, lower: float, upper: float, width_end: float):
    """Half-width of the sampling box at iteration ``gen``: geometric from the whole cube to ``width_end``."""
    w0 = 0.5 * (upper - lower)
    frac = jnp.asarray(gen, jnp.float32) / max(iterations - 1, 1)
    return w0 * (width_end / w0) ** jnp.minimum(frac, 1.0)


def amc_init(M: int, n_genes: int, lower: float, upper: float) -> AMCState:
    """Every variable starts at the centre of the cube with no best estimate; the box is the whole cube."""
    return AMCState(center=jnp.full((M, n_genes), 0.5 * (lower + upper), jnp.float32),
                    best=jnp.full((M,), -jnp.inf, jnp.float32), width=jnp.float32(0.5 * (upper - lower)))


def amc_propose(state: AMCState, key: jax.Array, width, per_variable: int,
                lower: float, upper: float) -> jax.Array:
    """``M * per_variable`` samples, uniform in each variable's box around its centre (within the cube)."""
    c = state.center
    lo = jnp.maximum(c - width, lower)[:, None, :]
    hi = jnp.minimum(c + width, upper)[:, None, :]
    u = jax.random.uniform(key, (c.shape[0], per_variable, c.shape[1]), jnp.float32)
    return (lo + u * (hi - lo)).reshape(-1, c.shape[1])


def amc_update(state: AMCState, genomes: jax.Array, fitness: jax.Array, diverged: jax.Array) -> AMCState:
    """Each variable moves its centre to its best new sample if that beats its best so far."""
    M = state.center.shape[0]
    bad = diverged | ~jnp.isfinite(fitness)
    f = jnp.where(bad, -jnp.inf, fitness).reshape(M, -1)
    g = genomes.reshape(M, f.shape[1], -1)
    i = jnp.argmax(f, axis=1)
    fb = jnp.take_along_axis(f, i[:, None], axis=1)[:, 0]
    gb = jnp.take_along_axis(g, i[:, None, None], axis=1)[:, 0]
    better = fb > state.best
    return dataclasses.replace(state, center=jnp.where(better[:, None], gb, state.center),
                               best=jnp.where(better, fb, state.best))


@dataclass(frozen=True, kw_only=True, eq=False)
class RandomSearch(Algorithm[RandomState]):
    """Fig. 6.10 as an :class:`~cpgjax.optim.algorithm.Algorithm`: every batch uniform in the hypercube."""

    cfg: SearchConfig
    n_genes: int
    lower: float
    upper: float

    def init(self, params, key: jax.Array) -> RandomState:
        return RandomState()

    def ask(self, params, state: RandomState, key: jax.Array, gen) -> tuple[jax.Array, RandomState]:
        return random_propose(key, self.population, self.n_genes, self.lower, self.upper), state

    def tell(self, params, state: RandomState, genomes: jax.Array, scores: Scores, key: jax.Array,
             gen) -> RandomState:
        return state


@dataclass(frozen=True, kw_only=True, eq=False)
class AdaptiveMonteCarlo(Algorithm[AMCState]):
    """Fig. 6.11 as an :class:`~cpgjax.optim.algorithm.Algorithm` (the module docstring's reading)."""

    cfg: SearchConfig
    n_genes: int
    lower: float
    upper: float

    def _width(self, gen):
        return amc_width(gen, self.generations, self.lower, self.upper, self.cfg.width_end)

    def init(self, params, key: jax.Array) -> AMCState:
        return amc_init(self.cfg.M, self.n_genes, self.lower, self.upper)

    def ask(self, params, state: AMCState, key: jax.Array, gen) -> tuple[jax.Array, AMCState]:
        return amc_propose(state, key, self._width(gen), self.cfg.per_variable, self.lower, self.upper), state

    def tell(self, params, state: AMCState, genomes: jax.Array, scores: Scores, key: jax.Array, gen) -> AMCState:
        new = amc_update(state, genomes, scores["fitness"], scores["diverged"])
        return dataclasses.replace(new, width=self._width(gen).astype(jnp.float32))
