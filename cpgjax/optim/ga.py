"""The genetic algorithm of Grasso (2000), Ch. 4.3 and 6.2, as pure JAX functions.

One generation is (a) *evaluate* the population (``Problem.evaluate``, one vmapped
simulation) and (b) :func:`reproduce`, which is pure and jittable and takes every
run-varying setting as a *traced* value in :class:`GAParams`, so that
``jax.vmap(reproduce)`` runs several GA variants (different gamma, pocket size, mu_max,
cross-over on/off, mutation scale) side by side in one XLA program.

:func:`reproduce` does, in order (Ch. 4.3):

1. **sanitise** (:func:`sanitize_fitness`): a diverged or non-finite fitness becomes the
   worst finite fitness of the population (never NaN; 0 when nothing is finite);
2. **pocketing** (Ch. 4.3.5, :func:`pocket_mask`): only the best ``P`` individuals take part
   in reproduction (``P = 0``: all of them).  Implemented as a rank mask so ``P`` is traced;
   ties are broken by the lower index;
3. **selection weights** (Ch. 4.3.2, :func:`selection_weights`): "duplicated with a
   probability proportional to the value of their fitness", relative to the population.
   The thesis draws ``u ~ U[0, 1]`` per individual and duplicates it when ``u < f``,
   repeating passes until ``N`` offspring exist, i.e. offspring are drawn with probability
   ``∝ max(f, 0)``.  Two readings for negative fitness, chosen by ``GAParams.shift``:

   * ``clip`` (default, the literal thesis mechanism): weight ``max(f, 0)``; an individual
     with ``f <= 0`` is never duplicated;
   * ``shift``: weight ``f - min(f)`` (minimum over the whole population), invariant to an
     offset of the fitness; the population's worst is never duplicated.

   If every weight in the pocket is 0 (e.g. all fitness <= 0 with ``clip``) the draw is
   uniform over the pocket (the thesis loop would never terminate);
4. **reproduction**: either duplication (:func:`select`, ``N`` draws with replacement ∝
   weight) or, with the cross-over flag, :func:`crossover` (Ch. 4.3.4): ``N`` children,
   each from an ordered pair of parents drawn with probability ∝ the *sum* of their
   weights, cut ``sigma ~ U{1, ..., N_param}``: the first ``sigma`` genes from the first
   parent, the rest from the second.  Cross-over replaces duplication ("an alternative
   reproduction scheme before mutation takes place");
5. **mutation** (Ch. 4.3.3, :func:`mutate`): each gene changes with probability
   ``mu = mu_max / (1 + gamma GEN)`` (eq. 6.1, :func:`mutation_rate`), GEN the generation
   just evaluated (generation 0 breeds with ``mu_max``).  A changed gene takes a Gaussian
   step ``N(0, sigma^2)`` (``gauss``, default) or is redrawn uniformly in the search range
   (``redraw``); the result is clipped to ``[lower, upper]`` (the problem's box; by default
   ``[-GENE_BOX, GENE_BOX]``, :data:`cpgjax.episode.cpg.GENE_BOX`).

No elitism: the thesis has none; pocketing is its way to keep the best.

:class:`GeneticAlgorithm` (made by :meth:`GAConfig.algorithm`) is the GA on the optimisers' contract
(:class:`cpgjax.optim.algorithm.Algorithm`): ``ask`` gives the population, ``tell`` is :func:`reproduce`.

All randomness comes from explicit ``jax.random`` keys: the drivers take a run's keys from its seed
(:func:`cpgjax.experiments.runner.run_keys`) and use ``fold_in(run_key, GEN)`` for generation GEN, so a run is
reproducible bit for bit from its seed and independent of how generations are chunked.

Choices the thesis leaves open (documented in ``docs/evolution.md``): the mutation step
``sigma = 0.1`` (1/16 of the side of the search box; about 6 degrees on a joint angle),
the initial spread (every gene of the base genome moved by ``U(-0.1, 0.1)``).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, ClassVar

import jax
import jax.numpy as jnp
import numpy as np

from cpgjax.episode.cpg import GENE_BOX
from cpgjax.optim.algorithm import Algorithm, Scores
from cpgjax.optim.problem import Problem

MUTATIONS = ("gauss", "redraw")
SELECTIONS = ("clip", "shift")


@dataclass(frozen=True)
class GAConfig:
    """Settings of one GA run; defaults are the thesis's (Ch. 6.2: Fig. 6.5)."""

    population: int = 20          # N (thesis: 10-20)
    generations: int = 150        # 150 x 20 = 3000 evaluations (Ch. 6.2.5)
    mu_max: float = 0.2           # mutation rate at generation 0 (eq. 6.1)
    gamma: float = 0.0            # decay of the mutation rate, in [0, 1] (eq. 6.1); 0 = fixed
    pocket: int = 0               # P best kept before reproduction (Ch. 4.3.5); 0 = off (thesis: 4)
    crossover: bool = False       # cross-over instead of duplication (Ch. 4.3.4)
    mutation: str = "gauss"       # how a mutated gene changes: "gauss" step or uniform "redraw"
    sigma: float = 0.1            # std of the Gaussian mutation step (our choice)
    init_spread: float = 0.1      # initial genes: base genome + U(-spread, spread) (our choice)
    selection: str = "clip"       # reading of "probability ∝ fitness" for negative fitness
    seed: int = 0
    chunk: int = 1                # generations per jitted lax.scan chunk (host writes in between)

    def __post_init__(self) -> None:
        if self.population < 1 or self.generations < 0:
            raise ValueError("population must be >= 1 and generations >= 0")
        if not 0 <= self.pocket <= self.population:
            raise ValueError(f"pocket must be in [0, population], got {self.pocket}")
        if self.mutation not in MUTATIONS:
            raise ValueError(f"mutation must be one of {MUTATIONS}, got {self.mutation!r}")
        if self.selection not in SELECTIONS:
            raise ValueError(f"selection must be one of {SELECTIONS}, got {self.selection!r}")
        if not 0.0 <= self.mu_max <= 1.0 or self.gamma < 0.0:
            raise ValueError("mu_max must be in [0, 1] and gamma >= 0")
        if self.sigma < 0 or self.init_spread < 0 or self.chunk < 1:
            raise ValueError("sigma and init_spread must be >= 0, chunk >= 1")

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)

    def params(self, lower: float = -GENE_BOX, upper: float = GENE_BOX) -> GAParams:
        """The run-varying settings as a pytree of arrays (what :func:`reproduce` traces)."""
        return GAParams(
            mu_max=jnp.float32(self.mu_max), gamma=jnp.float32(self.gamma),
            pocket=jnp.int32(self.pocket), crossover=jnp.bool_(self.crossover),
            sigma=jnp.float32(self.sigma), redraw=jnp.bool_(self.mutation == "redraw"),
            shift=jnp.bool_(self.selection == "shift"),
            lower=jnp.float32(lower), upper=jnp.float32(upper))

    def algorithm(self, problem: Problem) -> GeneticAlgorithm:
        """This GA on ``problem`` (its start genome and search box)."""
        base = np.asarray(problem.base_genome, np.float32)
        if base.shape != (problem.n_genes,):
            raise ValueError(f"base_genome has shape {base.shape}, expected ({problem.n_genes},)")
        return GeneticAlgorithm(kind="ga", population=self.population, generations=self.generations,
                                config=self.to_dict(), params=self.params(problem.lower, problem.upper),
                                resumable_changes=("chunk", "generations"), base=base,
                                init_spread=self.init_spread, lower=problem.lower, upper=problem.upper,
                                held=None if problem.held is None else np.asarray(problem.held, bool))


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class GAState:
    """The GA's state between generations: the population to evaluate next."""

    population: jax.Array   # [N, G] float32


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class GAParams:
    """Traced per-run settings of :func:`reproduce` (all arrays; stack them to vmap over runs)."""

    mu_max: jax.Array     # float32
    gamma: jax.Array      # float32
    pocket: jax.Array     # int32, 0 = off
    crossover: jax.Array  # bool
    sigma: jax.Array      # float32, Gaussian step
    redraw: jax.Array     # bool: redraw uniformly instead of a Gaussian step
    shift: jax.Array      # bool: selection weight f - min(f) instead of max(f, 0)
    lower: jax.Array      # float32 search range
    upper: jax.Array


def mutation_rate(gen, mu_max, gamma):
    """eq. 6.1: ``mu = mu_max / (1 + gamma GEN)``."""
    return mu_max / (1.0 + gamma * gen)


def init_population(key: jax.Array, base_genome, n: int, spread: float,
                    lower: float = -GENE_BOX, upper: float = GENE_BOX) -> jax.Array:
    """N controllers from one (Ch. 4.3): every gene of ``base_genome`` moved by ``U(-spread, spread)``."""
    base = jnp.asarray(base_genome, jnp.float32)
    noise = jax.random.uniform(key, (n, base.shape[0]), jnp.float32, -1.0, 1.0)
    return jnp.clip(base + spread * noise, lower, upper)


def sanitize_fitness(fitness: jax.Array, diverged: jax.Array) -> tuple[jax.Array, jax.Array]:
    """Replace diverged or non-finite fitness by the worst finite one; return it and the bad count.

    NaN-safe: the result is finite everywhere (0 where no individual has a valid fitness).
    """
    f = jnp.asarray(fitness, jnp.float32)
    bad = jnp.asarray(diverged, bool) | ~jnp.isfinite(f)
    worst = jnp.min(jnp.where(bad, jnp.inf, f))
    worst = jnp.where(jnp.isfinite(worst), worst, 0.0)
    return jnp.where(bad, worst, f), jnp.sum(bad).astype(jnp.int32)


def ranks(fitness: jax.Array) -> jax.Array:
    """Rank of each individual, 0 = best; ties broken by the lower index."""
    order = jnp.argsort(-fitness, stable=True)
    return jnp.zeros(fitness.shape[0], jnp.int32).at[order].set(jnp.arange(fitness.shape[0], dtype=jnp.int32))


def pocket_mask(fitness: jax.Array, pocket) -> jax.Array:
    """Ch. 4.3.5: True for the best ``pocket`` individuals (all when ``pocket == 0``); may be traced."""
    return (ranks(fitness) < pocket) | (pocket <= 0)


def selection_weights(fitness: jax.Array, mask: jax.Array, shift) -> jax.Array:
    """Ch. 4.3.2: non-negative weights ∝ fitness relative to the population, 0 outside ``mask``.

    ``shift`` False: ``max(f, 0)`` (thesis); True: ``f - min(f)``.  Uniform over ``mask`` if all are 0.
    """
    w = jnp.where(shift, fitness - jnp.min(fitness), jnp.maximum(fitness, 0.0))
    w = jnp.where(mask, w, 0.0)
    return jnp.where(jnp.sum(w) > 0, w, mask.astype(w.dtype))


def _probs(w: jax.Array) -> jax.Array:
    return w / jnp.sum(w)


def select(key: jax.Array, weights: jax.Array, n: int) -> jax.Array:
    """Stochastic selection (Ch. 4.3.2): indices of ``n`` duplicates drawn with replacement ∝ ``weights``."""
    return jax.random.choice(key, weights.shape[0], (n,), replace=True, p=_probs(weights))


def crossover_pairs(key: jax.Array, weights: jax.Array, mask: jax.Array, n: int, n_genes: int):
    """Parents and cuts for ``n`` cross-over children (Ch. 4.3.4).

    An ordered pair (i, j) of the pool (the individuals where ``mask`` is set, i.e. the pocket)
    is drawn with probability ∝ ``w_i + w_j``: with probability 1/2 the first parent is drawn
    ∝ w and the second uniformly from the pool, otherwise the reverse (that mixture has
    exactly this law: ``P(i, j) = (w_i + w_j) / (2 |pool| sum(w))``).  Parents stay in the
    pool (drawn with replacement; i = j is allowed and gives a duplicate).
    The cut is ``sigma ~ U{1, ..., n_genes}``.  Returns ``(first, second, sigma)``, each ``[n]`` int32.
    """
    k_coin, k_w, k_u, k_cut = jax.random.split(key, 4)
    by_w = jax.random.choice(k_w, weights.shape[0], (n,), p=_probs(weights))
    by_u = jax.random.choice(k_u, weights.shape[0], (n,), p=_probs(mask.astype(weights.dtype)))
    coin = jax.random.bernoulli(k_coin, 0.5, (n,))
    first, second = jnp.where(coin, by_w, by_u), jnp.where(coin, by_u, by_w)
    sigma = jax.random.randint(k_cut, (n,), 1, n_genes + 1)
    return first.astype(jnp.int32), second.astype(jnp.int32), sigma.astype(jnp.int32)


def crossover(key: jax.Array, population: jax.Array, weights: jax.Array, mask: jax.Array) -> jax.Array:
    """Ch. 4.3.4: ``N`` children, each the first ``sigma`` genes of one parent and the rest of the other."""
    n, g = population.shape
    first, second, sigma = crossover_pairs(key, weights, mask, n, g)
    prefix = jnp.arange(g)[None, :] < sigma[:, None]
    return jnp.where(prefix, population[first], population[second])


def mutate(key: jax.Array, population: jax.Array, rate, sigma, redraw, lower, upper) -> jax.Array:
    """Ch. 4.3.3: each gene changes with probability ``rate``; Gaussian step or uniform redraw; clipped."""
    k_m, k_g, k_u = jax.random.split(key, 3)
    hit = jax.random.uniform(k_m, population.shape) < rate
    stepped = population + sigma * jax.random.normal(k_g, population.shape, population.dtype)
    drawn = jax.random.uniform(k_u, population.shape, population.dtype, lower, upper)
    changed = jnp.where(redraw, drawn, stepped)
    return jnp.clip(jnp.where(hit, changed, population), lower, upper)


def reproduce(key: jax.Array, population: jax.Array, fitness: jax.Array, params: GAParams,
              gen, diverged: jax.Array | None = None) -> jax.Array:
    """The next generation from an evaluated one: sanitise, pocket, select or cross over, mutate.

    Pure and jittable; every setting in ``params`` (and ``gen``) may be traced, so
    ``jax.vmap(reproduce)`` over stacked keys, populations, fitness and params runs several
    GA variants at once.  ``fitness`` may contain NaN (treated as diverged).
    """
    n = population.shape[0]
    div = jnp.zeros(n, bool) if diverged is None else diverged
    f, _ = sanitize_fitness(fitness, div)
    k_sel, k_x, k_mut = jax.random.split(key, 3)
    mask = pocket_mask(f, params.pocket)
    w = selection_weights(f, mask, params.shift)
    duplicated = population[select(k_sel, w, n)]
    crossed = crossover(k_x, population, w, mask)
    offspring = jnp.where(params.crossover, crossed, duplicated)
    mu = mutation_rate(gen, params.mu_max, params.gamma)
    return mutate(k_mut, offspring, mu, params.sigma, params.redraw, params.lower, params.upper)


@dataclass(frozen=True, kw_only=True, eq=False)
class GeneticAlgorithm(Algorithm[GAState]):
    """The GA as an :class:`~cpgjax.optim.algorithm.Algorithm`: ask for the population, tell :func:`reproduce`.

    Made by :meth:`GAConfig.algorithm`; its run-varying settings are ``params`` (:class:`GAParams`), so runs of
    one population size and initial spread share one compiled program.
    """

    holds_genes: ClassVar[bool] = True
    base: np.ndarray      # [G] the start genome (Ch. 4.3)
    init_spread: float
    lower: float
    upper: float
    held: np.ndarray | None = None   # [G] bool: genes kept at ``base`` in every individual (None: all evolve)

    def _hold(self, population: jax.Array) -> jax.Array:
        """``population`` with the held genes put back to the start's (exactly: nothing else changes)."""
        if self.held is None:
            return population
        return jnp.where(jnp.asarray(self.held), jnp.asarray(self.base, population.dtype), population)

    def init(self, params: GAParams, key: jax.Array) -> GAState:
        return GAState(self._hold(init_population(key, self.base, self.population, self.init_spread, self.lower,
                                                  self.upper)))

    def ask(self, params: GAParams, state: GAState, key: jax.Array, gen) -> tuple[jax.Array, GAState]:
        return state.population, state

    def tell(self, params: GAParams, state: GAState, genomes: jax.Array, scores: Scores, key: jax.Array,
             gen) -> GAState:
        return GAState(self._hold(reproduce(key, genomes, scores["fitness"], params, gen, scores["diverged"])))

    def mutation_rate(self, params: GAParams, gen) -> Any:
        return mutation_rate(gen, params.mu_max, params.gamma)


def stack_params(params: list[GAParams]) -> GAParams:
    """Stack per-run params along a new leading axis (for ``jax.vmap`` over runs)."""
    return jax.tree.map(lambda *xs: jnp.stack(xs), *params)


def expected_mutation_rates(mu_max: float, gamma: float, generations: int) -> np.ndarray:
    """eq. 6.1 over generations 0..generations-1 (numpy, for plots and checks)."""
    return mu_max / (1.0 + gamma * np.arange(generations, dtype=np.float64))
