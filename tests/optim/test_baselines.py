"""The baselines of Ch. 6.2.5-6.2.6: uniform random search and adaptive Monte Carlo."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from cpgjax.experiments.evolve import run_search
from cpgjax.io.results import read_run
from cpgjax.optim import baselines
from cpgjax.optim.analytic import analytic_problem

KEY = jax.random.key(5)


def test_random_samples_fill_the_hypercube():
    x = np.asarray(baselines.random_propose(KEY, 4000, 10, -0.8, 0.8))
    assert x.min() >= -0.8 and x.max() <= 0.8
    assert abs(x.mean()) < 0.01 and x.std() == pytest.approx(1.6 / np.sqrt(12), rel=0.02)


def test_amc_width_contracts_from_the_whole_cube():
    K = 150
    w = np.asarray([float(baselines.amc_width(k, K, -0.8, 0.8, 0.02)) for k in range(K)])
    assert w[0] == pytest.approx(0.8) and w[-1] == pytest.approx(0.02, rel=1e-4)
    assert np.all(np.diff(w) < 0)


def test_amc_samples_stay_in_the_box_and_the_cube():
    state = baselines.AMCState(center=jnp.asarray([[0.75, 0.0, -0.8], [0.0, 0.1, 0.2]], jnp.float32),
                               best=jnp.zeros(2), width=jnp.float32(0.1))
    x = np.asarray(baselines.amc_propose(state, KEY, 0.1, 500, -0.8, 0.8)).reshape(2, 500, 3)
    c = np.asarray(state.center)
    assert np.all(np.abs(x - c[:, None, :]) <= 0.1 + 1e-6)
    assert x.min() >= -0.8 and x.max() <= 0.8
    # uniform inside box ∩ cube: gene 0 of variable 0 lives in [0.65, 0.8]
    assert x[0, :, 0].min() >= 0.65 - 1e-6 and x[0, :, 0].mean() == pytest.approx(0.725, abs=0.01)


def test_amc_update_keeps_the_best_and_ignores_diverged():
    state = baselines.amc_init(2, 3, -0.8, 0.8)
    g = jnp.arange(12, dtype=jnp.float32).reshape(4, 3) / 20
    f = jnp.asarray([0.1, 0.3, jnp.nan, 0.2])
    div = jnp.asarray([False, False, False, True])
    new = baselines.amc_update(state, g, f, div)
    np.testing.assert_allclose(np.asarray(new.best), [0.3, -np.inf])
    np.testing.assert_allclose(np.asarray(new.center[0]), np.asarray(g[1]))
    np.testing.assert_allclose(np.asarray(new.center[1]), 0.0)
    worse = baselines.amc_update(new, g, jnp.asarray([0.0, 0.05, 0.5, 0.4]), jnp.zeros(4, bool))
    np.testing.assert_allclose(np.asarray(worse.best), [0.3, 0.5])
    np.testing.assert_allclose(np.asarray(worse.center[0]), np.asarray(g[1]))


def test_config():
    c = baselines.SearchConfig(method="amc", M=3)
    assert c.per_variable == 7 and c.population == 21 and c.iterations == 143
    r = baselines.SearchConfig()
    assert (r.population, r.iterations, r.samples) == (20, 150, 3000)
    with pytest.raises(ValueError):
        baselines.SearchConfig(method="annealing")


def test_searches_on_the_budget_with_the_ga_layout(tmp_path):
    problem = analytic_problem("analytic:sphere:10")
    out = {}
    for method in ("random", "amc"):
        cfg = baselines.SearchConfig(method=method, samples=600, batch=20, M=5, seed=2, chunk=10)
        s = run_search(problem, cfg, tmp_path / f"{method}.h5")
        run = read_run(tmp_path / f"{method}.h5")
        assert run.kind == method and run.completed == 30 and run.genomes.shape == (30, 20, 10)
        assert np.all(np.isnan(run.mutation_rate))
        assert np.all(np.abs(run.genomes) <= 0.8)
        out[method] = (s, run)
    rnd, amc = out["random"][1], out["amc"][1]
    assert "state/center" not in rnd.state and set(amc.state) == {"center", "best", "width"}
    # adaptive Monte Carlo refines around its best estimates: higher best, positive mean (Fig. 6.11)
    assert amc.best()[2] > rnd.best()[2] + 0.2
    assert np.nanmean(amc.valid_fitness()[10:]) > np.nanmean(rnd.valid_fitness())
    # the first amc iteration is one round of random search over the whole cube
    # and the last samples of each variable lie in a box of half-width width_end around its centre
    assert np.ptp(amc.genomes[0]) > 1.0
    last = amc.genomes[-1].reshape(5, 4, 10)
    assert np.ptp(last, axis=1).max() <= 2 * 0.02 + 1e-6
