"""Intelligent Trial and Error (cpgjax.optim.ite): the GP's posterior against its closed form, the search."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cpgjax.optim import ite


def test_matern52_at_known_distances():
    a = np.zeros((1, 2))
    b = np.asarray([[0.0, 0.0], [0.3, 0.4], [3.0, 4.0]])          # distances 0, 0.5, 5
    k = ite.matern52(a, b, rho=0.5, variance=2.0)[0]
    s5 = math.sqrt(5)
    assert k[0] == pytest.approx(2.0, rel=1e-15)
    assert k[1] == pytest.approx(2.0 * (1 + s5 + 5 / 3) * math.exp(-s5), rel=1e-14)
    assert k[2] == pytest.approx(2.0 * (1 + 10 * s5 + 500 / 3) * math.exp(-10 * s5), rel=1e-12)


def test_posterior_with_one_observation_is_the_closed_form():
    """One trial y1 at x1: mu(x) = P(x) + k(x,x1) (y1 - P1) / (s2 (1 + n)), var = s2 - k(x,x1)^2 / (s2 (1 + n))."""
    x = np.asarray([[0.0], [0.2], [1.0]])
    prior = np.asarray([0.1, 0.3, -0.2])
    xs, ys, ps = np.asarray([[0.2]]), np.asarray([0.05]), np.asarray([0.3])
    s2, n, rho = 0.04, 1e-3, 0.4
    mu, var = ite.posterior(x, prior, xs, ys, ps, rho, s2, n)
    k = ite.matern52(x, xs, rho, s2)[:, 0]
    np.testing.assert_allclose(mu, prior + k * (ys[0] - ps[0]) / (s2 * (1 + n)), rtol=1e-13)
    np.testing.assert_allclose(var, s2 - k * k / (s2 * (1 + n)), rtol=1e-12, atol=1e-18)
    assert mu[1] == pytest.approx(0.3 + (0.05 - 0.3) / (1 + n), rel=1e-13)   # at the trial: almost the observation


def test_posterior_with_two_observations_is_the_closed_form():
    """Two trials: the 2x2 inverse written out, [[a, b], [b, a]]^-1 = [[a, -b], [-b, a]] / (a^2 - b^2)."""
    x = np.asarray([[0.1, 0.9], [0.5, 0.5], [0.0, 0.0]])
    prior = np.asarray([0.2, 0.0, 0.1])
    xs = np.asarray([[0.3, 0.3], [0.6, 0.6]])
    ys, ps = np.asarray([0.4, -0.1]), np.asarray([0.1, 0.2])
    s2, n, rho = 1.5, 1e-2, 0.7
    mu, var = ite.posterior(x, prior, xs, ys, ps, rho, s2, n)
    a = s2 * (1 + n)
    b = ite.matern52(xs[:1], xs[1:], rho, s2)[0, 0]
    inv = np.asarray([[a, -b], [-b, a]]) / (a * a - b * b)
    k = ite.matern52(x, xs, rho, s2)
    np.testing.assert_allclose(mu, prior + k @ inv @ (ys - ps), rtol=1e-12)
    np.testing.assert_allclose(var, s2 - np.sum((k @ inv) * k, 1), rtol=1e-10)


def test_no_observation_is_the_prior():
    mu, var = ite.posterior(np.zeros((3, 1)), [1.0, 2.0, 3.0], np.zeros((0, 1)), [], [], 0.4, 0.5, 1e-3)
    np.testing.assert_array_equal(mu, [1.0, 2.0, 3.0])
    np.testing.assert_array_equal(var, [0.5, 0.5, 0.5])


def test_an_undamaged_robot_takes_its_best_gait_at_the_first_trial_and_stops():
    rng = np.random.default_rng(0)
    desc, prior = rng.uniform(size=(200, 2)), rng.uniform(size=200)
    r = ite.ite(desc, prior, lambda i: float(prior[i]))
    assert len(r["trials"]) == 1 and r["best_index"] == int(np.argmax(prior)) and "prediction" in r["stop"]


def test_a_damage_that_ruins_one_region_is_avoided_in_a_few_trials():
    """The damage cuts to 0.3 the fitness of every gait with descriptor x0 > 0.5 (where the prior's best lie):
    IT&E tries the prior's best first, then leaves that region.  Cully's stopping rule (alpha 0.9 of its own
    best prediction, ``stop_z=0``) stops after 4 trials at 0.85 of the best remaining gait; the default rule
    (0.9 of the best prediction + 2 sd) searches on and stops at the best remaining gait itself, in 10."""
    g = np.linspace(0, 1, 21)
    desc = np.stack(np.meshgrid(g, g, indexing="ij"), -1).reshape(-1, 2)
    prior = 0.1 + 0.2 * desc[:, 0] - 0.05 * (desc[:, 1] - 0.5) ** 2
    damaged = np.where(desc[:, 0] > 0.5, 0.3 * prior, prior)
    cully = ite.ite(desc, prior, lambda i: float(damaged[i]), ite.ITEConfig(trials=20, stop_z=0))
    assert len(cully["trials"]) == 4 and 0.85 <= cully["best_fitness"] / damaged.max() < 0.9
    assert cully["stop"] == "best trial >= 0.9 x best prediction"
    r = ite.ite(desc, prior, lambda i: float(damaged[i]), ite.ITEConfig(trials=20))
    assert r["trials"][0]["index"] == int(np.argmax(prior))
    assert r["best_fitness"] == damaged.max() and desc[r["best_index"], 0] <= 0.5
    assert len(r["trials"]) == 10 and "prediction + 2 sd" in r["stop"]
    assert damaged[r["best_index"]] == r["best_fitness"]


def test_bad_settings():
    with pytest.raises(ValueError, match="alpha"):
        ite.ITEConfig(alpha=1.5)
    with pytest.raises(ValueError, match="rho"):
        ite.ITEConfig(rho=0)
    with pytest.raises(ValueError, match="stop_z"):
        ite.ITEConfig(stop_z=-1)


def test_without_the_stopping_rule_it_runs_every_trial_and_never_repeats_one():
    rng = np.random.default_rng(1)
    desc, prior = rng.uniform(size=(30, 3)), rng.uniform(size=30)
    r = ite.ite(desc, prior, lambda i: float(prior[i]), ite.ITEConfig(trials=12), stop=False)
    tried = [t["index"] for t in r["trials"]]
    assert len(tried) == 12 == len(set(tried)) and r["stop"] == "12 trials"
    assert tried[0] == int(np.argmax(prior)) and r["best_index"] == tried[0]


def test_offset_posterior_with_one_observation_is_the_closed_form():
    """An unknown constant in the prior mean (flat prior): one trial y1 at x1 shifts every prediction by
    y1 - P1, and var(x) = s2 + s2 (1 + n) - 2 k(x, x1) (R&W eq. 2.42 written out for t = 1)."""
    x = np.asarray([[0.0], [0.2], [1.0]])
    prior = np.asarray([0.1, 0.3, -0.2])
    xs, ys, ps = np.asarray([[0.2]]), np.asarray([0.05]), np.asarray([0.3])
    s2, n, rho = 0.04, 1e-3, 0.4
    mu, var = ite.posterior(x, prior, xs, ys, ps, rho, s2, n, offset=True)
    k = ite.matern52(x, xs, rho, s2)[:, 0]
    np.testing.assert_allclose(mu, prior + (ys[0] - ps[0]), rtol=1e-13)
    np.testing.assert_allclose(var, s2 + s2 * (1 + n) - 2 * k, rtol=1e-10, atol=1e-15)
    mu0, var0 = ite.posterior(x, prior, xs[:0], [], [], rho, s2, n, offset=True)
    np.testing.assert_array_equal(mu0, prior)
    assert np.isinf(var0).all()


def test_offset_posterior_is_the_limit_of_a_constant_kernel_term():
    """The flat prior on the offset is the limit B -> inf of a kernel k + B (a constant with prior N(0, B))."""
    rng = np.random.default_rng(2)
    x, prior = rng.uniform(size=(40, 3)), rng.uniform(size=40)
    t = [3, 17, 25, 31]
    ys = prior[t] - 0.3 + 0.05 * rng.normal(size=4)
    s2, n, rho, B = 0.1, 1e-2, 0.4, 1e6
    mu, var = ite.posterior(x, prior, x[t], ys, prior[t], rho, s2, n, offset=True)
    K = ite.matern52(x[t], x[t], rho, s2) + B + n * s2 * np.eye(4)
    k = ite.matern52(x, x[t], rho, s2) + B
    mu_b = prior + k @ np.linalg.solve(K, ys - prior[t])
    var_b = s2 + B - np.sum(k * np.linalg.solve(K, k.T).T, 1)
    np.testing.assert_allclose(mu, mu_b, rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(var, var_b, rtol=1e-3, atol=1e-5)


def test_offset_learns_a_damage_that_lowers_every_gait_as_one_shift():
    """A damage that lowers every gait by 0.2: with the offset the posterior mean is the prior - 0.2 at every
    elite after a trial; Cully's prior (no offset) blames the drop on the tried elite's neighbourhood only."""
    g = np.linspace(0, 1, 11)
    desc = np.stack(np.meshgrid(g, g, indexing="ij"), -1).reshape(-1, 2)
    prior = 0.1 + 0.2 * desc[:, 0]
    i = int(np.argmax(prior))
    args = (desc, prior, desc[[i]], [prior[i] - 0.2], prior[[i]], 0.4, float(np.var(prior)), 1e-3)
    mu, _ = ite.posterior(*args, offset=True)
    np.testing.assert_allclose(mu, prior - 0.2, rtol=1e-12)
    mu_c, _ = ite.posterior(*args)
    far = np.linalg.norm(desc - desc[i], axis=1) > 1.0
    assert np.all(mu_c[far] - prior[far] > -0.02) and mu_c[i] == pytest.approx(prior[i] - 0.2, abs=1e-3)


def test_with_the_offset_the_first_trial_is_the_prior_best_and_an_intact_robot_stops():
    rng = np.random.default_rng(0)
    desc, prior = rng.uniform(size=(200, 2)), rng.uniform(size=200)
    r = ite.ite(desc, prior, lambda i: float(prior[i]), ite.ITEConfig(offset=True))
    assert r["trials"][0]["index"] == int(np.argmax(prior)) and len(r["trials"]) == 1
