"""An evolved controller replays exactly: evolve -> best --ctl -> simulate gives the GA's fitness."""

import re

import numpy as np
import pytest
from runcases import TINY_TIME

from cpgjax.cli import main
from cpgjax.io.ctl import read_ctl
from cpgjax.io.results import read_run
from cpgjax.optim.factory import wl_problem as make_problem


def test_best_controller_replays_with_the_fitness_the_ga_gave_it(tiny_runs, tmp_path, capsys):
    run = tiny_runs["thesis"]
    ctl = tmp_path / "best.ctl"
    assert main(["best", run, "--ctl", str(ctl)]) == 0
    capsys.readouterr()
    _, _, fit, genome = read_run(run).best()
    c = read_ctl(ctl, n_dof=8, harmonics=2)
    np.testing.assert_array_equal(c.coeffs.astype(np.float32).reshape(-1), np.asarray(genome, np.float32))
    assert main(["simulate", "models/quadruped.wl", "--ctl", str(ctl), "--time", str(TINY_TIME)]) == 0
    out = capsys.readouterr().out
    replay = float(re.search(r"fitness\s+([-+0-9.e]+)", out).group(1))
    assert abs(replay - fit) < 1e-5, (replay, fit)


@pytest.mark.slow   # 40 s of CPU: a closed loop's GA and its replay compile; fast: its .ctl round trip (io/test_ctl.py)
def test_a_closed_loop_best_replays_with_the_fitness_the_ga_gave_it(tmp_path, capsys):
    run = tmp_path / "r.h5"
    ctl = tmp_path / "best.ctl"
    assert main(["evolve", "models/quadruped.wl", "--controller", "pmtg", "--population", "6", "--generations", "2",
                 "--time", "1", "--out", str(run), "--quiet"]) == 0
    assert main(["best", str(run), "--ctl", str(ctl)]) == 0
    assert "policy pmtg: 10 outputs x 20 inputs" in capsys.readouterr().out
    _, _, fit, genome = read_run(str(run)).best()
    c = read_ctl(ctl, n_dof=8, harmonics=2)
    np.testing.assert_array_equal(c.coeffs.astype(np.float32).reshape(-1), np.asarray(genome, np.float32)[:40])
    assert c.policy is not None and c.policy.weights.shape == (10, 20)
    assert main(["simulate", "models/quadruped.wl", "--ctl", str(ctl), "--time", "1"]) == 0
    out = capsys.readouterr().out
    replay = float(re.search(r"fitness\s+([-+0-9.e]+)", out).group(1))
    assert abs(replay - fit) < 1e-5, (replay, fit)


def test_replicas_average_jittered_episodes():
    import jax

    from cpgjax.episode.batch import simulate
    from cpgjax.io.ctl import genome_to_coeffs
    from cpgjax.io.wl import load_model

    p3 = make_problem("models/quadruped.wl", time=TINY_TIME, replicas=3)
    g = np.tile(p3.base_genome, (6, 1)).astype(np.float32)
    f3 = np.asarray(jax.jit(p3.evaluate)(g)["fitness"])       # jitted: eagerly the episode runs op by op
    # the genome alone, unjittered: one robot, the suite's tiny episode (episode/test_rollout.py's program)
    m = load_model("models/quadruped.wl")
    f1 = simulate(m, genome_to_coeffs(p3.base_genome, m.n_ctrl, m.episode.harmonics), time=TINY_TIME)["fitness"]
    assert f3.shape == (6,) and np.isfinite(f3).all()
    assert f3[0] == f3[1] and f3[0] != f1 and abs(f3[0] - f1) < 0.05


@pytest.mark.slow   # 40 s of CPU, as the test above: a mirror run's GA and its replay compile
def test_a_mirror_best_replays_with_the_fitness_the_ga_gave_it(tmp_path, capsys):
    """A mirror-symmetric run (`--controller pmtg:mirror`: the right legs evolved, the left derived) through the CLI:
    its `.ctl` is the expanded plain controller, and replaying it gives the GA's fitness."""
    from cpgjax.episode.policy import family_from_meta, from_genomes
    from cpgjax.io.wl import load_model

    run = tmp_path / "r.h5"
    ctl = tmp_path / "best.ctl"
    assert main(["evolve", "models/quadruped.wl", "--controller", "pmtg:mirror", "--population", "6",
                 "--generations", "2", "--time", "1", "--out", str(run), "--quiet"]) == 0
    assert main(["best", str(run), "--ctl", str(ctl)]) == 0
    assert "policy pmtg:mirror: 10 outputs x 20 inputs" in capsys.readouterr().out
    r = read_run(str(run))
    _, _, fit, genome = r.best()
    assert len(genome) == 118                      # 240 genes of the plain family, halved but the shared rows
    expanded = from_genomes(family_from_meta(r.meta), load_model("models/quadruped.wl"), np.asarray(genome)[None])
    c = read_ctl(ctl, n_dof=8, harmonics=2)
    np.testing.assert_array_equal(c.coeffs.astype(np.float32), np.asarray(expanded.coeffs, np.float32)[0])
    np.testing.assert_array_equal(c.policy.weights.astype(np.float32), np.asarray(expanded.weights, np.float32)[0])
    assert main(["simulate", "models/quadruped.wl", "--ctl", str(ctl), "--time", "1"]) == 0
    out = capsys.readouterr().out
    replay = float(re.search(r"fitness\s+([-+0-9.e]+)", out).group(1))
    assert abs(replay - fit) < 1e-5, (replay, fit)
