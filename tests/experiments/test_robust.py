"""The robust evaluation in the drivers (evolve, sweep): fresh perturbations each generation, elites re-scored,
deterministic given the seed, resumable bit for bit, a sweep's run equal to the same run made alone."""

from __future__ import annotations

import numpy as np
import pytest
from runcases import TINY_TIME, same_rows

from cpgjax import cli
from cpgjax.experiments.evolve import run_ga
from cpgjax.io.results import read_run
from cpgjax.optim.factory import make_problem
from cpgjax.optim.ga import GAConfig

WL = "models/quadruped.wl"
# no mutation: every individual of generation g+1 is a copy of a pocketed one of generation g
COPY = GAConfig(population=6, generations=3, pocket=2, mu_max=0.0, seed=4)


# the robust evaluation of the suite's tiny runs (tests/runcases.py): their compiled programs are shared
ROBUST = {"replicas": 2, "fall_survival": True, "bristle": 3.0}


@pytest.fixture(scope="module")
def robust():
    return make_problem(WL, time=TINY_TIME, evaluation="robust", perturb=ROBUST)


@pytest.fixture(scope="module")
def robust_run(tiny_runs):
    """The suite's tiny robust run (tests/runcases.py: TINY_GA with TINY_ROBUST, made by `cpgjax evolve`), whose
    compiled GA program the transfer and validation tests share."""
    return read_run(tiny_runs["robust"])


# the tiny robust run's settings (tests/runcases.py: TINY_GA), as the GA's config
TINY = GAConfig(population=6, generations=2, pocket=2, seed=3)


def test_pocketed_elites_are_rescored_with_fresh_perturbations(robust, robust_run, tmp_path):
    """No mutation: every individual of generation g+1 is a copy of a pocketed one of generation g, scored again.
    (mu_max is a traced setting of the GA: the tiny robust run's compiled program.)"""
    path = tmp_path / "copies.h5"
    run_ga(robust, COPY, path)
    run = read_run(path)
    g, f = run.genomes, run.fitness
    for gen in range(1, run.completed):
        for i in range(g.shape[1]):
            parents = np.nonzero((g[gen - 1] == g[gen, i]).all(-1))[0]
            assert len(parents), "with mu_max 0 every child is a copy of a pocketed parent"
            # the same genome, scored again: another draw of the perturbations, another score
            assert np.all(f[gen - 1, parents] != f[gen, i])
    assert run.meta["evaluation"] == "robust" and run.meta["replicas"] == 2


def test_the_thesis_evaluation_scores_a_copy_exactly_as_its_parent(tmp_path):
    thesis = make_problem(WL, time=TINY_TIME)
    run_ga(thesis, COPY, tmp_path / "t.h5")
    run = read_run(tmp_path / "t.h5")
    g, f = run.genomes, run.fitness
    i = 0
    parent = np.nonzero((g[0] == g[1, i]).all(-1))[0][0]
    assert f[1, i] == f[0, parent]


def test_deterministic_given_the_seed_and_resumable_bit_for_bit(robust, robust_run, tmp_path):
    """The run made again through the library, stopped after a generation and resumed, is the command line's run
    bit for bit."""
    again = tmp_path / "again.h5"
    run_ga(robust, TINY, again, stop_after=1)
    run_ga(robust, TINY, again, resume=True)
    same_rows(read_run(again), robust_run)


@pytest.mark.slow  # 9 s; fast: the same for the thesis evaluation, experiments/test_sweep.py
def test_a_sweep_run_equals_the_same_run_made_alone(robust, tmp_path):
    out = tmp_path / "sweep"
    argv = ["sweep", WL, "--time", str(TINY_TIME), "--evaluation", "robust", "--perturb",
            "replicas=2,fall_survival=on,bristle=3", "--population", "6",
            "--generations", "2", "--pocket", "2", "--gamma", "0,1", "--seeds", "1", "--out", str(out), "--quiet"]
    assert cli.main(argv) == 0
    alone = tmp_path / "alone.h5"
    run_ga(robust, GAConfig(population=6, generations=2, pocket=2, gamma=1.0, seed=0), alone)
    same_rows(read_run(out / "ga_n6_mu0.2_g1_p2_xoff" / "s0.h5"), read_run(alone))


def test_a_report_names_the_robust_evaluation_it_was_scored_with(robust_run):
    from cpgjax.analysis.report import evaluation_line
    line = evaluation_line([robust_run.path])
    assert line.startswith("Evaluation: robust (`--perturb replicas=2,") and "fall_ends=on" in line
