"""cpgjax.experiments.adapt: the damaged robot is the repertoire's problem (its pipeline among the rest)."""

from __future__ import annotations

import json
import types

import pytest

from cpgjax.errors import ResultsError
from cpgjax.experiments.adapt import damaged_problem
from cpgjax.io.wl import load_wl

MODEL = "models/quadruped.wl"


def _rep(**meta):
    m = {"model_text": load_wl(MODEL).text, "descriptor": "duty", "time": 0.2, "terrain": "flat",
         "cli_problem_args": json.dumps({}), **meta}
    return types.SimpleNamespace(meta=m, path="rep.h5")


@pytest.mark.parametrize("pipeline", ["springs", "exact"])
def test_the_damaged_robot_runs_on_the_repertoires_pipeline(pipeline):
    p = damaged_problem(MODEL, _rep(pipeline=pipeline), "leg=AR")
    assert p.meta["pipeline"] == pipeline and p.meta["damage"] == "leg=AR" and p.meta["time"] == 0.2


def test_an_old_repertoire_without_a_pipeline_is_springs_and_another_model_is_refused():
    assert damaged_problem(MODEL, _rep(), "none").meta["pipeline"] == "springs"
    with pytest.raises(ResultsError, match="not the model the repertoire"):
        damaged_problem(MODEL, _rep(model_text="other"), "none")


def test_the_genome_space_scales_each_gene_by_its_sd_over_the_elites():
    """Three elites of two genes: gene 0 = 0, 2, 4 (mean 2, sd sqrt(8/3)); gene 1 constant (centred only)."""
    import numpy as np

    from cpgjax.experiments.adapt import genome_space

    x = genome_space(np.asarray([[[0.0, 1.0]], [[2.0, 1.0]], [[4.0, 1.0]]]))
    np.testing.assert_allclose(x, [[-2 / np.sqrt(8 / 3), 0], [0, 0], [2 / np.sqrt(8 / 3), 0]], rtol=1e-12)


def test_the_joint_space_weighs_the_genome_and_the_descriptor_the_same():
    """Four genes and one descriptor dimension: the genes standardised (sd 1), the descriptor standardised and
    scaled by sqrt(4 / 1) = 2, so that each group's variance sums to 4."""
    import numpy as np

    from cpgjax.experiments.adapt import joint_space

    rng = np.random.default_rng(2)
    g, d = rng.normal(3.0, 5.0, (50, 2, 2)), rng.uniform(0.2, 0.4, (50, 1))
    x = joint_space(g, d)
    assert x.shape == (50, 5)
    np.testing.assert_allclose(x.std(0), [1, 1, 1, 1, 2], rtol=1e-12)
    np.testing.assert_allclose(x[:, 4], 2 * (d[:, 0] - d.mean()) / d.std(), rtol=1e-12)
    np.testing.assert_allclose((x[:, :4] ** 2).sum(1).mean(), (x[:, 4:] ** 2).sum(1).mean(), rtol=1e-12)


@pytest.mark.parametrize("rho", [0.5, 4.0])
def test_the_fitted_length_scale_is_the_one_the_data_were_drawn_with(rho):
    """y drawn from the Matérn-5/2 GP of length scale rho (noise 1e-2 of the variance) over 300 points in
    [0, 8]^2: the marginal likelihood over the grid picks rho (the grid 0.25 ... 8 has both) and a small noise
    (measured: 1e-2 for rho 0.5, 0.1 for rho 4, of 1e-3 ... 1), and pure noise
    (iid y) picks the largest noise."""
    import numpy as np

    from cpgjax.experiments.adapt import fit_kernel
    from cpgjax.optim.ite import matern52

    rng = np.random.default_rng(3)
    x = rng.uniform(0, 8, (300, 2))
    K = matern52(x, x, rho) + 1e-2 * np.eye(300)
    y = np.linalg.cholesky(K) @ rng.standard_normal(300)
    grid = (0.25, 0.5, 1.0, 2.0, 4.0, 8.0)
    got_rho, got_noise = fit_kernel(x, y, rhos=grid, noises=(1e-3, 1e-2, 0.1, 1.0))
    assert got_rho == rho and got_noise <= 0.1
    _, noise = fit_kernel(x, rng.standard_normal(300), rhos=grid, noises=(1e-3, 1e-2, 0.1, 1.0))
    assert noise == 1.0


def test_search_space_fits_in_the_genome_space_only_and_keeps_the_given_settings_without_fit():
    import numpy as np

    from cpgjax.experiments.adapt import search_space
    from cpgjax.optim.ite import ITEConfig

    rng = np.random.default_rng(0)
    rep = types.SimpleNamespace(genomes=rng.normal(size=(40, 3, 2)), fitness=rng.normal(size=40),
                                descriptors=rng.uniform(size=(40, 2)).astype(np.float32),
                                grid=types.SimpleNamespace(lower=np.zeros(2), upper=np.full(2, 2.0)))
    idx = np.arange(0, 40, 2)
    cfg = ITEConfig(rho=0.3, noise=0.01)
    x, c = search_space(rep, idx, "descriptor", cfg)
    assert c == cfg and np.allclose(x, rep.descriptors[idx] / 2.0)
    x, c = search_space(rep, idx, "genome", cfg, fit=False)
    assert c == cfg and x.shape == (20, 6)
    x, c = search_space(rep, idx, "genome", cfg)
    assert c.noise in (1e-3, 0.01, 0.03, 0.1, 0.3) and c.rho >= 1 and c.kappa == cfg.kappa
    x, c = search_space(rep, idx, "both", cfg, fit=False)
    assert c == cfg and x.shape == (20, 8)
    with pytest.raises(ValueError, match="unknown space"):
        search_space(rep, idx, "other", cfg)


def test_the_studys_medians_per_damage_count_a_level_not_reached_as_infinite():
    """Three repertoires per damage: a count not reached (None) is infinite in the median, and the median is "not
    reached" (None) once at least half of the counts are; the GA's median only where the GA ran."""
    from cpgjax.experiments.adapt import median_count, study_medians

    assert median_count([3, None, 5]) == 5.0 and median_count([3, None, None]) is None
    assert median_count([4, None]) is None and median_count([2, 7]) == 4.5 and median_count([]) is None

    def row(damage, trials, ga, stop, share):
        return {"damage": damage, "ite_trials": trials, "ga_evaluations": ga, "ga_budget": 1000,
                "ite_stop_trial": stop, "ite_stop_share": share}

    rows = [row("leg=AR", 4, None, 6, 0.9), row("leg=PL", None, 300, 20, 0.5), row("leg=AR", 9, 700, 3, 0.7),
            row("leg=PL", None, None, 11, 0.6), row("leg=AR", None, None, 8, 0.95)]
    ar, pl = study_medians(rows)
    assert ar == {"damage": "leg=AR", "repertoires": 3, "ite_trials": 9.0, "ga_evaluations": None,
                  "ite_stop_trial": 6.0, "ite_stop_share": 0.9}
    assert pl == {"damage": "leg=PL", "repertoires": 2, "ite_trials": None, "ga_evaluations": None,
                  "ite_stop_trial": 15.5, "ite_stop_share": 0.55}
    no_ga = [{k: v for k, v in r.items() if not k.startswith("ga_")} for r in rows]
    assert "ga_evaluations" not in study_medians(no_ga)[0]
