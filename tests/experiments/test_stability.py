"""Stability under perturbation (cpgjax/experiments/stability.py, ``cpgjax stability``): Figs. 6.13-6.21."""

from __future__ import annotations

import json
import os
from types import SimpleNamespace

import numpy as np
import pytest
from runcases import TINY_TIME

from cpgjax import cli
from cpgjax.experiments.stability import (
    PopulationStudy,
    StabilityConfig,
    StabilityResult,
    choose_stable_unstable,
    fall_threshold,
    perturbation_experiment,
)
from cpgjax.io.ctl import read_ctl
from cpgjax.io.results import Row, RunWriter, create_run
from cpgjax.io.wl import load_model

QUAD = "models/quadruped.wl"
TROT = "models/quadruped-trot.ctl"


@pytest.fixture(scope="module")
def result():
    model = load_model(QUAD)
    trot = read_ctl(TROT, n_dof=8, harmonics=2).coeffs
    # the suite's tiny episode length: its flat-ground program is episode/test_rollout.py's
    cfg = StabilityConfig(bumps=(0.0, 0.03), roughs=(0.02,), seeds=2, time=TINY_TIME)
    return model, perturbation_experiment(model, np.stack([trot, np.zeros_like(trot)]), ["trot", "stand"], cfg)


def test_bump_of_zero_equals_flat_and_the_flat_lane_the_flat_model(result):
    _, r = result
    assert [c.label for c in r.conditions] == ["flat", "bump 0 cm", "bump 3 cm", "rough 2 cm #0", "rough 2 cm #1"]
    np.testing.assert_array_equal(r.S[:, 0], r.S[:, 1])
    np.testing.assert_array_equal(r.proj[:, 0], r.proj[:, 1])
    np.testing.assert_array_equal(r.distance[:, 0], r.distance[:, 1])
    # the course's flat lane walks as on flat ground (not bit for bit: the flat fast path is another program)
    np.testing.assert_allclose(r.distance[:, 0], r.flat_distance, rtol=2e-2, atol=1e-3)
    assert not np.array_equal(r.S[0, 3], r.S[0, 4])                      # two rough fields, two walks


def test_a_standing_robot_has_the_projection_stability_of_its_stance(result):
    model, r = result
    # four feet straight under the hips at x = +-0.14, y = +-0.22: the CM's nearest side is 0.14 m away
    m = model.mass
    h = float((m * model.x0[2]).sum() / m.sum())
    proj = r.proj[1, 0, r.t > 0.15]
    assert np.isfinite(proj).all() and r.proj_undefined[1, 0] == 0
    np.testing.assert_allclose(proj, 0.14 / h, rtol=0.01)
    np.testing.assert_allclose(r.S[1, 0], 1.0, atol=1e-4)               # upright: S(0) = 1 (eq. 6.2)
    assert not r.fell[1].any()
    s = r.summary()
    assert s["stand"]["flat"]["fall_rate"] == 0 and s["trot"]["rough 2 cm"]["episodes"] == 2


def test_choose_stable_unstable():
    fit = np.array([0.1, -0.2, 0.3, 0.2])
    S = np.array([0.99, 1.0, 0.95, 0.90])
    fell = np.array([False, False, True, False])
    assert choose_stable_unstable(fit, S, fell) == (0, 3)   # walkers only; the stable one never fell


def test_time_to_fall_is_the_first_sample_below_the_threshold():
    thr = fall_threshold()
    t = np.arange(1, 6) * 0.5
    S = np.ones((2, 2, 5))
    S[0, 1, 3:] = thr - 0.01          # falls at the 4th sample, t = 2 s
    S[1, 0, 1] = np.nan               # diverged at t = 1 s
    r = StabilityResult(names=["a", "b"], conditions=[], t=t, S=S, proj=S, fell=np.zeros((2, 2), bool),
                        distance=np.zeros((2, 2)), S_mean=np.ones((2, 2)), proj_mean=np.ones((2, 2)),
                        proj_undefined=np.zeros((2, 2)), flat_distance=np.zeros(2), config={"delta": 8.0})
    np.testing.assert_array_equal(r.fall_time(), [[2.5, 2.0], [1.0, 2.5]])


def test_settings_that_all_fall_are_ranked_by_their_time_to_fall():
    one = np.ones((2, 2))
    study = PopulationStudy(labels=["early", "late", "same"], configs=[{}, {}, {}], groups=["flat", "bump 1 cm"],
                            fall=[one, one, one], S_mean=[one, one, one], controllers=1,
                            fall_time=[one * 2.0, one * 7.0, one * 2.0])
    assert study.ranking() == (["late", "early", "same"], "late")
    tie = PopulationStudy(labels=["a", "b"], configs=[{}, {}], groups=["flat", "bump 1 cm"], fall=[one, one],
                          S_mean=[one, one], controllers=1, fall_time=[one, one])
    assert tie.ranking()[1] is None
    fewer = PopulationStudy(labels=["a", "b"], configs=[{}, {}], groups=["flat", "bump 1 cm"],
                            fall=[one, one * 0.5], S_mean=[one, one], controllers=1, fall_time=[one * 9, one])
    assert fewer.ranking() == (["b", "a"], "b")          # fewer falls first, whatever the time


def _fake_run(path, genomes, gamma, seed):
    text = open(QUAD).read()
    meta = {"model_path": QUAD, "model_text": text, "time": 0.5, "n_dof": 8, "harmonics": 2,
            "cli_problem_args": json.dumps({"time": None, "terrain": None})}
    problem = SimpleNamespace(name="quadruped", n_genes=40, lower=-0.8, upper=0.8, meta=meta)
    n = len(genomes)
    create_run(path, kind="ga", config={"seed": seed, "population": n, "gamma": gamma, "pocket": 0,
                                        "crossover": False},
               problem=problem, population=n, generations=1, metrics={}, state={})
    with RunWriter(path) as w:
        w.append(Row(genomes=genomes.astype(np.float32), fitness=np.arange(n, dtype=np.float32),
                     diverged=np.zeros(n, bool), mutation_rate=0.2, wall_time=1.0))


@pytest.mark.slow  # 10 s; also in the stability notebook (slow); fast: the stability experiments of this file
def test_population_study_of_a_sweep_folder(tmp_path, capsys):
    trot = read_ctl(TROT, n_dof=8, harmonics=2).coeffs.reshape(-1)
    rng = np.random.default_rng(0)
    for gamma in (0.0, 1.0):
        for seed in (0, 1):
            g = np.stack([trot, trot + rng.normal(0, 0.01, trot.shape)])
            _fake_run(tmp_path / "sweep" / f"g{gamma:g}" / f"s{seed}.h5", g, gamma, seed)
    out = tmp_path / "out"
    assert cli.main(["stability", str(tmp_path / "sweep"), "--bump", "0.03", "--rough", "none",
                     "--json", "--out", str(out)]) == 0
    s = json.loads(capsys.readouterr().out)
    assert s["groups"] == ["flat", "bump 3 cm"] and s["controllers_per_run"] == 2
    assert set(s["settings"]) == {"γ=0", "γ=1"}
    for v in s["settings"].values():
        assert v["runs"] == 2 and 0 <= v["fall"]["bump 3 cm"]["mean"] <= 1
    assert sorted(os.listdir(out)) == ["population-time.png", "population.json", "population.md", "population.png",
                                       "stable.ctl", "unstable.ctl"]
    for v in s["settings"].values():
        assert 0 < v["time_to_fall"]["flat"]["mean"] <= 0.5 + 1e-9      # the fake runs' 0.5 s episodes
    assert s["ranking"][0] == s["most_robust"] or s["most_robust"] is None
    assert s["picks"]["stable"]["ga_fitness"] > 0


def test_bad_input_is_one_line_and_exit_2(tmp_path, capsys):
    assert cli.main(["stability", QUAD, "--out", str(tmp_path / "x")]) == 2
    assert "--ctl" in capsys.readouterr().err
    assert cli.main(["stability", QUAD, "--ctl", TROT, "--bump", "-0.01", "--out", str(tmp_path / "x")]) == 2


@pytest.mark.slow  # a program per stair and bar; fast: their grounds and placement, episode/test_courses.py
def test_stairs_and_bars_stand_beside_the_thesis_bump(tmp_path, capsys):
    """``--stair`` and ``--bar`` add a flight of stairs and a bar halfway, each a ground of its own, with their
    panels beside the bump's; the trot on exact joints climbs a 2 cm flight and steps over a 3 cm bar in 10 s."""
    out = tmp_path / "st"
    assert cli.main(["stability", QUAD, "--ctl", TROT, "--pipeline", "exact", "--bump", "none", "--rough", "none",
                     "--stair", "0.02", "--bar", "0.03", "--time", "10", "--out", str(out), "--json"]) == 0
    s = json.loads((out / "summary.json").read_text())["conditions"]["quadruped-trot"]
    assert set(s) == {"flat", "stair 2 cm", "bar 3 cm"}
    assert s["stair 2 cm"]["fall_rate"] == 0 and s["bar 3 cm"]["fall_rate"] == 0
    assert s["stair 2 cm"]["distance"] < s["flat"]["distance"] and s["bar 3 cm"]["distance"] < s["flat"]["distance"]
    assert (out / "quadruped-trot-vestibular-stair.png").exists()
    assert (out / "quadruped-trot-projection-bar.png").exists()
