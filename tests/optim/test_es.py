"""The evolution strategies of evosax behind one adapter (cpgjax.optim.es): they optimise, stay in the box,
and their state survives the run file (resume = an uninterrupted run)."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from runcases import same_rows

from cpgjax.cli import evolve as cli_evolve
from cpgjax.experiments.evolve import run_search
from cpgjax.io.results import read_run
from cpgjax.optim import es
from cpgjax.optim.analytic import analytic_problem, default_optimum

KEY = jax.random.key(9)
# f = 1 - mean((g - opt)^2) / 0.25, maximum 1 at opt (|opt| <= 0.5, in the box); a genome with a gene past 0.6
# diverges.  The two tests of each method run the same settings: one compiled chunk per method
PROBLEM = "analytic:diverging:6"
SETTINGS = {"samples": 1200, "population": 20, "chunk": 20}


# cmaes and openes in the fast suite (a covariance and a gradient method), the three others slow: the
# strategies share one adapter (optim/es.py), each its own compiled program
FAST_METHODS = ("cmaes", "openes")


@pytest.mark.parametrize("method", [m if m in FAST_METHODS else pytest.param(m, marks=pytest.mark.slow)
                                    for m in es.METHODS])
def test_each_method_finds_the_optimum_of_a_shifted_sphere(method):
    """From the start genome (all zeros here), 1200 evaluations bring the mean of the search near the optimum."""
    problem = analytic_problem(PROBLEM)
    cfg = es.ESConfig(method=method, **SETTINGS)
    s = run_search(problem, cfg)
    opt = default_optimum(6)
    first = s["history"]["fitness"][0].max()
    last = s["history"]["genomes"][-1]                     # the last generation's samples, clipped to the box
    assert s["completed"] == 60 and s["history"]["genomes"].shape == (60, 20, 6)
    assert s["best_fitness"] > 0.98 > first                # RMS distance of the best < 0.07 (start: 0.33)
    assert np.sqrt(np.mean((last.mean(axis=0) - opt) ** 2)) < 0.08
    assert np.all(np.abs(s["history"]["genomes"]) <= np.float32(0.8))


def test_held_genes_stay_the_starts_bit_for_bit_and_the_strategy_searches_the_others():
    """``Problem.held`` (``search --method cmaes --free``): every sample of every generation keeps the held genes at
    the start's values, the strategy's state is the free genes' only, and the free ones reach the optimum."""
    import dataclasses

    held = np.arange(6) % 3 == 0
    base = np.linspace(-0.3, 0.3, 6).astype(np.float32)
    problem = dataclasses.replace(analytic_problem(PROBLEM), base_genome=base, held=held)
    cfg = es.ESConfig(method="cmaes", **SETTINGS)
    np.testing.assert_array_equal(cfg.algorithm(problem).mean0, base[~held])      # the free genes only
    s = run_search(problem, cfg)
    g = s["history"]["genomes"]
    np.testing.assert_array_equal(g[..., held], np.broadcast_to(base[held], g[..., held].shape))
    assert np.sqrt(np.mean((s["best_genome"][~held] - default_optimum(6)[~held]) ** 2)) < 0.07


def test_reflect_mirrors_into_the_box():
    x = jnp.asarray([0.0, 0.9, -1.0, 2.5, -0.8, 0.8, 4.1])
    np.testing.assert_allclose(np.asarray(es.reflect(x, -0.8, 0.8)), [0.0, 0.7, -0.6, -0.7, -0.8, 0.8, 0.7],
                               atol=1e-6)


def _scores(fitness, diverged):
    return {"fitness": jnp.asarray(fitness, jnp.float32), "diverged": jnp.asarray(diverged, bool)}


@pytest.mark.parametrize("method", ["cmaes", pytest.param("snes", marks=pytest.mark.slow)])
def test_an_optimum_outside_the_box_brings_the_search_to_its_face(method):
    """Genes 0 and 2 want to leave the box: the genomes evaluated stay in it, the search settles on its faces
    with a small step size (no flat region outside the box for the step size to grow in)."""
    target = jnp.asarray([1.5, 0.0, -2.0])
    algo = es.ESConfig(method=method, population=10, sigma=0.3).algorithm(analytic_problem("analytic:sphere:3"))

    def step(s, k):
        x, s = algo.ask((), s, k, 0)
        s = algo.tell((), s, x, _scores(-jnp.sum((x - target) ** 2, axis=1), jnp.zeros(10, bool)), k, 0)
        return s, jnp.max(jnp.abs(algo.ask((), s, KEY, 0)[0]))      # the genomes it would evaluate next

    # 60 generations in one compiled program (a scan: one compile, where a loop of jitted steps took two)
    state = algo.init((), jax.random.key(0))
    first = jnp.max(jnp.abs(algo.ask((), state, KEY, 0)[0]))
    state, widest = jax.jit(lambda s: jax.lax.scan(step, s, jax.vmap(jax.random.key)(jnp.arange(1, 61))))(state)
    assert float(first) <= np.float32(0.8) and float(jnp.max(widest)) <= np.float32(0.8)
    np.testing.assert_allclose(np.asarray(algo.ask((), state, KEY, 0)[0]), np.broadcast_to([0.8, 0.0, -0.8], (10, 3)),
                               atol=0.05)


def test_diverged_samples_never_pull_the_search():
    """A diverged sample (NaN fitness, the flag set) ranks last, whatever its stored fitness."""
    algo = es.ESConfig(method="snes", population=4, sigma=0.1).algorithm(analytic_problem("analytic:sphere:2"))
    state = algo.init((), jax.random.key(1))
    x = algo.ask((), state, KEY, 0)[0]
    flagged = algo.tell((), state, x, _scores([0.1, 0.2, 9.0, jnp.nan], [False, False, True, True]),
                        jax.random.key(2), 0)
    honest = algo.tell((), state, x, _scores([0.1, 0.2, -1e9, -1e9], [False] * 4), jax.random.key(2), 0)
    a, b = jax.tree.leaves(flagged), jax.tree.leaves(honest)
    for u, v in zip(a, b, strict=True):
        np.testing.assert_array_equal(np.asarray(u), np.asarray(v))
    assert all(np.all(np.isfinite(np.asarray(u))) for u in a if jnp.issubdtype(u.dtype, jnp.floating))


@pytest.mark.parametrize("method", [m if m in FAST_METHODS else pytest.param(m, marks=pytest.mark.slow)
                                    for m in es.METHODS])
def test_stop_and_resume_equals_uninterrupted(tmp_path, method):
    problem = analytic_problem(PROBLEM)        # diverged samples along the way, too
    cfg = es.ESConfig(method=method, seed=3, **SETTINGS)
    full, part = tmp_path / "full.h5", tmp_path / "part.h5"
    run_search(problem, cfg, full)
    assert run_search(problem, cfg, part, stop_after=25)["completed"] == 25    # a chunk of 20 and 5 more
    assert run_search(problem, cfg, part, resume=True)["completed"] == 60
    a, b = read_run(full), read_run(part)
    same_rows(a, b)
    # the run file keeps its layout: evosax's state as its float and its integer leaves (EvolutionStrategy.save)
    assert a.kind == method and a.diverged.any() and set(a.state) == {"samples", "real", "count"}
    assert a.state["real"].dtype == np.float32 and a.state["count"].dtype == np.int32


def test_config_is_checked():
    assert es.ESConfig().generations == 150 and es.ESConfig(population=64).generations == 47
    for bad in ({"method": "nes"}, {"method": "openes", "population": 7}, {"sigma": 0.0}, {"lr": -1.0},
                {"population": 1}):
        with pytest.raises(ValueError):
            es.ESConfig(**bad)


def test_the_command_line_knows_every_method():
    assert cli_evolve.ES_METHODS == es.METHODS
