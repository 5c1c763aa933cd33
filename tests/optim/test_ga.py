"""The GA operators (Ch. 4.3, eq. 6.1): their statistics, NaN safety, vmap over runs, and the GA on a
cheap analytic fitness with a known optimum."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from cpgjax.experiments.evolve import run_ga
from cpgjax.optim import ga
from cpgjax.optim.analytic import analytic_problem, default_optimum

KEY = jax.random.key(1234)
N, G = 20, 10  # one shape for the jitted operators: each new shape costs a compilation
REPRODUCE = jax.jit(ga.reproduce)


def binomial_ok(k: int, n: int, p: float, z: float = 5.0) -> bool:
    return abs(k - n * p) <= z * np.sqrt(n * p * (1 - p)) + 1


def test_mutation_rate_eq_6_1():
    gens = np.arange(150)
    for mu_max, gamma in [(0.2, 0.0), (0.1, 0.01), (0.2, 0.1), (0.2, 1.0)]:
        got = np.asarray(ga.mutation_rate(jnp.asarray(gens, jnp.float32), mu_max, gamma))
        np.testing.assert_allclose(got, mu_max / (1 + gamma * gens), rtol=1e-6)
        np.testing.assert_allclose(ga.expected_mutation_rates(mu_max, gamma, 150), mu_max / (1 + gamma * gens))
    assert float(ga.mutation_rate(0, 0.2, 1.0)) == pytest.approx(0.2)


@pytest.mark.parametrize("mutation", ["gauss", "redraw"])
def test_realised_mutation_rate_follows_eq_6_1(mutation):
    """Through reproduce: identical parents, so every changed gene is a mutation."""
    pop = jnp.full((N, G), 0.123, jnp.float32)
    for gen, gamma in [(0, 0.0), (10, 0.1), (40, 1.0)]:
        params = ga.GAConfig(population=N, mu_max=0.2, gamma=gamma, mutation=mutation).params()
        trials = 150
        changed = 0
        for t in range(trials):
            child = np.asarray(REPRODUCE(jax.random.fold_in(KEY, t), pop, jnp.ones(N), params, gen))
            changed += int(np.sum(child != np.float32(0.123)))
            assert np.all(child >= -0.8) and np.all(child <= 0.8)
        mu = 0.2 / (1 + gamma * gen)
        assert binomial_ok(changed, trials * N * G, mu), (changed / (trials * N * G), mu)


def test_mutation_step_scale_and_clipping():
    n, g = 400, 50
    pop = jnp.zeros((n, g))
    out = np.asarray(ga.mutate(KEY, pop, 1.0, 0.05, False, -0.8, 0.8))
    assert out.std() == pytest.approx(0.05, rel=0.05)
    edge = np.asarray(ga.mutate(KEY, jnp.full((n, g), 0.8), 1.0, 1.0, False, -0.8, 0.8))
    assert edge.max() <= 0.8 and edge.min() >= -0.8
    red = np.asarray(ga.mutate(KEY, pop, 1.0, 0.05, True, -0.8, 0.8))
    assert red.min() >= -0.8 and red.max() <= 0.8 and red.std() == pytest.approx(1.6 / np.sqrt(12), rel=0.05)
    none = np.asarray(ga.mutate(KEY, pop, 0.0, 0.05, False, -0.8, 0.8))
    assert np.all(none == 0)


def test_selection_frequencies_follow_fitness():
    f = jnp.asarray([0.1, 0.2, 0.3, 0.4, 0.0, -0.5])
    w = ga.selection_weights(f, jnp.ones(6, bool), False)
    np.testing.assert_allclose(np.asarray(w), [0.1, 0.2, 0.3, 0.4, 0.0, 0.0], atol=1e-7)
    n = 100_000
    idx = np.asarray(ga.select(KEY, w, n))
    counts = np.bincount(idx, minlength=6)
    p = np.asarray(w) / float(np.sum(w))
    for c, pi in zip(counts, p, strict=True):
        assert binomial_ok(int(c), n, float(pi))
    assert counts[4] == 0 and counts[5] == 0


def test_selection_readings_for_negative_fitness():
    f = jnp.asarray([-0.3, -0.1, 0.2])
    mask = jnp.ones(3, bool)
    np.testing.assert_allclose(np.asarray(ga.selection_weights(f, mask, False)), [0, 0, 0.2], atol=1e-7)
    np.testing.assert_allclose(np.asarray(ga.selection_weights(f, mask, True)), [0, 0.2, 0.5], atol=1e-6)
    # all non-positive with the thesis reading: uniform over the pocket, never stuck
    neg = jnp.asarray([-0.3, -0.1, -0.2])
    np.testing.assert_allclose(np.asarray(ga.selection_weights(neg, mask, False)), [1, 1, 1])
    np.testing.assert_allclose(np.asarray(ga.selection_weights(neg, jnp.asarray([1, 0, 1], bool), False)),
                               [1, 0, 1])
    # the shift is invariant to an offset of the fitness
    a = ga.selection_weights(f, mask, True)
    b = ga.selection_weights(f + 10.0, mask, True)
    np.testing.assert_allclose(np.asarray(a), np.asarray(b), atol=1e-5)


def test_pocket_keeps_exactly_the_best_P():
    rng = np.random.default_rng(0)
    f = jnp.asarray(rng.normal(size=20).astype(np.float32))
    order = np.argsort(-np.asarray(f))
    for P in range(0, 21):
        m = np.asarray(ga.pocket_mask(f, P))
        if P == 0:
            assert m.all()
        else:
            assert m.sum() == P and set(np.flatnonzero(m)) == set(order[:P])
    # ties: lower index first; P traced under jit and vmap
    tied = jnp.asarray([1.0, 2.0, 2.0, 2.0, 0.0])
    assert list(np.flatnonzero(np.asarray(jax.jit(ga.pocket_mask)(tied, 2)))) == [1, 2]
    masks = jax.vmap(ga.pocket_mask, (None, 0))(f, jnp.arange(5))
    assert list(np.asarray(masks).sum(axis=1)) == [20, 1, 2, 3, 4]


@pytest.mark.parametrize("crossover", [False, True])
def test_reproduce_with_pocket_only_breeds_from_the_best(crossover):
    n, g, P = N, G, 4
    pop = jnp.asarray(np.random.default_rng(1).uniform(-0.8, 0.8, (n, g)).astype(np.float32))
    f = jnp.asarray(np.random.default_rng(2).uniform(-1, 1, n).astype(np.float32))
    best = np.argsort(-np.asarray(f))[:P]
    params = ga.GAConfig(population=n, mu_max=0.0, pocket=P, crossover=crossover).params()
    for s in range(20):
        child = np.asarray(REPRODUCE(jax.random.fold_in(KEY, s), pop, f, params, 0))
        src = np.asarray(pop)[best]
        # every gene comes from one of the pocketed parents at that position
        assert np.all(np.any(child[:, None, :] == src[None, :, :], axis=1))


def test_crossover_child_is_prefix_and_suffix():
    n, g = 20, 15
    pop = jnp.asarray(np.random.default_rng(3).uniform(-0.8, 0.8, (n, g)).astype(np.float32))
    w = jnp.asarray(np.random.default_rng(4).uniform(0, 1, n).astype(np.float32))
    mask = jnp.ones(n, bool)
    k = jax.random.fold_in(KEY, 7)
    first, second, cut = (np.asarray(a) for a in ga.crossover_pairs(k, w, mask, n, g))
    child = np.asarray(ga.crossover(k, pop, w, mask))
    p = np.asarray(pop)
    for c in range(n):
        s = cut[c]
        assert 1 <= s <= g
        np.testing.assert_array_equal(child[c, :s], p[first[c], :s])
        np.testing.assert_array_equal(child[c, s:], p[second[c], s:])


def test_crossover_statistics():
    """Pairs ∝ the sum of the parents' weights; cut uniform on {1..N_param}."""
    n_ind, g, draws = 4, 6, 200_000
    w = jnp.asarray([0.0, 1.0, 2.0, 5.0])
    first, second, cut = (np.asarray(a) for a in ga.crossover_pairs(KEY, w, jnp.ones(n_ind, bool), draws, g))
    counts = np.zeros((n_ind, n_ind))
    np.add.at(counts, (first, second), 1)
    wn = np.asarray(w)
    expect = (wn[:, None] + wn[None, :]) / (2 * n_ind * wn.sum())
    assert expect.sum() == pytest.approx(1.0)
    for i in range(n_ind):
        for j in range(n_ind):
            assert binomial_ok(int(counts[i, j]), draws, float(expect[i, j]))
    assert counts[0, 0] == 0
    cc = np.bincount(cut, minlength=g + 1)
    assert cc[0] == 0 and all(binomial_ok(int(c), draws, 1 / g) for c in cc[1:])


def test_nan_and_diverged_fitness_are_replaced_by_the_worst_finite():
    f = jnp.asarray([0.5, jnp.nan, 0.2, jnp.inf, -jnp.inf, 0.7])
    div = jnp.asarray([False, False, False, False, False, True])
    out, bad = ga.sanitize_fitness(f, div)
    np.testing.assert_allclose(np.asarray(out), [0.5, 0.2, 0.2, 0.2, 0.2, 0.2])
    assert int(bad) == 4
    out, bad = ga.sanitize_fitness(jnp.full(3, jnp.nan), jnp.zeros(3, bool))
    assert np.all(np.asarray(out) == 0) and int(bad) == 3
    pop = jnp.zeros((N, G))
    f20 = jnp.concatenate([f, jnp.full(N - 6, jnp.nan)])
    # float32, not weakly typed: the program of the mutation-rate test above (another input type is another)
    for fit in (jnp.asarray(f20, jnp.float32), jnp.full(N, jnp.nan, jnp.float32)):
        for cross in (False, True):
            for shift in ("clip", "shift"):
                params = ga.GAConfig(crossover=cross, selection=shift, pocket=2).params()
                child = REPRODUCE(KEY, pop, fit, params, 3)
                assert np.all(np.isfinite(np.asarray(child)))


def test_init_population():
    base = np.linspace(-0.75, 0.75, 10).astype(np.float32)
    pop = np.asarray(ga.init_population(KEY, base, 50, 0.1))
    assert pop.shape == (50, 10)
    assert np.all(np.abs(pop - base) <= 0.1 + 1e-6) and np.all(np.abs(pop) <= 0.8)
    assert len({tuple(r) for r in pop}) == 50
    assert np.all(pop.std(axis=0) > 0.02)


# slow: four GA variants, two programs; fast: a sweep's run (the vmapped GA) equals it made alone (test_sweep.py)
@pytest.mark.slow
def test_reproduce_vmaps_over_runs():
    """Several GA variants in one program: vmapped == one call per run, bit for bit."""
    n, g = N, G
    cfgs = [ga.GAConfig(gamma=0.0), ga.GAConfig(gamma=0.1, pocket=4), ga.GAConfig(crossover=True, pocket=2),
            ga.GAConfig(mutation="redraw", mu_max=0.5, selection="shift", sigma=0.3)]
    params = ga.stack_params([c.params() for c in cfgs])
    keys = jax.random.split(KEY, len(cfgs))
    pops = jax.random.uniform(KEY, (len(cfgs), n, g), minval=-0.8, maxval=0.8)
    fits = jax.random.normal(jax.random.fold_in(KEY, 1), (len(cfgs), n))
    batched = jax.jit(jax.vmap(ga.reproduce, (0, 0, 0, 0, None)))(keys, pops, fits, params, 5)
    single = REPRODUCE
    for r, c in enumerate(cfgs):
        np.testing.assert_array_equal(np.asarray(batched[r]), np.asarray(single(keys[r], pops[r], fits[r],
                                                                                c.params(), 5)))


def test_config_validation():
    with pytest.raises(ValueError):
        ga.GAConfig(pocket=21)
    with pytest.raises(ValueError):
        ga.GAConfig(mutation="cauchy")
    with pytest.raises(ValueError):
        ga.GAConfig(selection="rank")
    d = ga.GAConfig()
    assert (d.population, d.generations, d.mu_max, d.gamma, d.pocket, d.crossover) == (20, 150, 0.2, 0.0, 0, False)


def test_ga_finds_the_known_optimum():
    """Sphere fitness (max 1 at a known point): the GA with pocketing gets close to it."""
    problem = analytic_problem("analytic:sphere:10")
    s = run_ga(problem, ga.GAConfig(generations=120, pocket=4, chunk=6, seed=3))
    hist = s["history"]
    best_by_gen = hist["fitness"].max(axis=1)
    assert best_by_gen[0] < 0.7 and s["best_fitness"] > 0.95
    assert np.sqrt(np.mean((s["best_genome"] - default_optimum(10)) ** 2)) < 0.05
    np.testing.assert_allclose(hist["mutation_rate"], 0.2)


def test_ga_is_reproducible_from_its_seed_and_independent_of_chunking():
    problem = analytic_problem("analytic:sphere:10")
    runs = [run_ga(problem, ga.GAConfig(generations=25, crossover=True, pocket=5, seed=s, chunk=c, gamma=0.1))
            for s, c in [(7, 1), (7, 1), (7, 6), (8, 6)]]
    h = [r["history"] for r in runs]
    for k in ("genomes", "fitness", "diverged", "mutation_rate"):
        np.testing.assert_array_equal(h[0][k], h[1][k])
        np.testing.assert_array_equal(h[0][k], h[2][k])
    assert not np.array_equal(h[0]["genomes"], h[3]["genomes"])


def test_held_genes_stay_the_starts_bit_for_bit_and_the_others_still_find_the_optimum():
    """``Problem.held`` (``evolve --free``): every individual of every generation keeps the held genes at the start's
    values, and the free ones converge as an unheld GA's do (the sphere's optimum, in those genes)."""
    import dataclasses

    problem = analytic_problem("analytic:sphere:10")
    held = np.arange(10) % 2 == 0
    base = np.linspace(-0.3, 0.3, 10).astype(np.float32)
    s = run_ga(dataclasses.replace(problem, base_genome=base, held=held),
               ga.GAConfig(generations=120, pocket=4, chunk=6, seed=3, crossover=True, mutation="redraw"))
    g = s["history"]["genomes"]
    np.testing.assert_array_equal(g[..., held], np.broadcast_to(base[held], g[..., held].shape))
    assert np.sqrt(np.mean((s["best_genome"][~held] - default_optimum(10)[~held]) ** 2)) < 0.05
