"""`cpgjax transfer` (cpgjax/crosscheck/transfer.py): each run's best replayed here and in MuJoCo C, at tiny scale."""

from __future__ import annotations

import json

import numpy as np
import pytest

from cpgjax import cli
from cpgjax.crosscheck import transfer

# the robust run's mode as the tables name it: a fall scales its score, its foot stiffened up to 10^3
ROBUST = f"{transfer.SCALES}, bristle up to 10^3"


@pytest.fixture(scope="module")
def runs(tiny_runs):
    """The folder of the suite's tiny thesis and robust runs (tests/runcases.py)."""
    tiny_runs["thesis"], tiny_runs["robust"]
    return tiny_runs.folder


def test_transfer_table_json_and_figure(runs, tmp_path, capsys):
    out = tmp_path / "out"
    files = [str(runs / "thesis.h5"), str(runs / "robust.h5")]
    assert cli.main(["transfer", *files, "--replays", "2", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "| thesis |" in text and f"| {ROBUST} |" in text and "carries over" in text
    data = json.loads((out / "transfer.json").read_text())
    assert data["summary"]["runs"] == 2 and set(data["summary"]) >= {"thesis", ROBUST}
    assert (out / "transfer.png").stat().st_size > 10_000 and (out / "transfer.md").exists()
    assert cli.main(["transfer", *files, "--replays", "2", "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    for mode in ("thesis", ROBUST):
        assert summary[mode]["runs"] == 1 and summary[mode]["mujoco_falls_mean"] <= 2


def test_each_run_is_replayed_on_its_stored_model_and_settings(runs):
    (r,) = transfer.replay_runs([runs / "thesis.h5"], replays=2)
    # the same controller in our simulator scores what the GA recorded for it (thesis evaluation: exact replay)
    assert r.ours["fitness"] == pytest.approx(r.fitness_in_run, abs=1e-7)
    assert r.evaluation == "thesis" and r.ours_jit["falls"] + r.mujoco_jit["falls"] <= 4


def test_our_side_can_be_replayed_with_another_step_and_stiffer_joints(runs):
    args = cli.build_parser().parse_args(["transfer", str(runs), "--dt", "1.25e-4", "--joint-spring", "3e6", "1000"])
    assert args.dt == 1.25e-4 and args.joint_spring == [3e6, 1000.0]
    run = transfer.read_run(str(runs / "thesis.h5"))
    m = transfer.cached_model(str(run.meta["model_text"]), "q.wl", None, args.dt, tuple(args.joint_spring))
    assert (m.dt, m.springs.alpha, m.springs.beta) == (1.25e-4, 3e6, 1000.0)
    base = transfer.cached_model(str(run.meta["model_text"]), "q.wl", None)
    assert (base.dt, *base.joint_spring) == (5e-4, 3e5, 300.0)   # the thesis's defaults
    # MuJoCo's side does not depend on them: the same MJCF
    from cpgjax.crosscheck.mjcf import to_mjcf
    assert to_mjcf(m) == to_mjcf(base)
    assert "Here: step 0.125 ms" in transfer.table([], 2, here="step 0.125 ms")


def test_bad_inputs_are_named(tmp_path, capsys):
    assert cli.main(["transfer", str(tmp_path)]) == 2
    assert "no run files" in capsys.readouterr().err


def test_runs_whose_falls_forfeit_are_a_mode_of_their_own():
    class Run:
        def __init__(self, meta):
            self.meta = meta
    robust = {"evaluation": "robust", "time": 10.0, "perturbations": {"fall_zero": False}}
    assert transfer.run_setting(Run(robust))[0] == "robust"
    assert transfer.run_setting(Run(robust | {"perturbations": {"fall_zero": True}}))[0] == "robust, a fall forfeits"
    survival = robust | {"perturbations": {"fall_survival": True}}
    assert transfer.run_setting(Run(survival))[0] == "robust, a fall scales the score"
    assert transfer.run_setting(Run({"time": 10.0}))[0] == "thesis"
    stiff = robust | {"perturbations": {"fall_survival": True, "bristle": 2.0}}
    assert transfer.run_setting(Run(stiff))[0] == "robust, a fall scales the score, bristle up to 10^2"
    assert transfer.run_setting(Run(robust | {"perturbations": {"bristle": 0.0}}))[0] == "robust"


def test_every_evaluation_mode_has_its_summary_row():
    def replay(mode, seed, ours, theirs, falls):
        jit = {"mean": theirs, "sd": 0.0, "falls": falls, "speed": theirs}
        return transfer.Replay(run=f"r{seed}.h5", evaluation=mode, cell="c", seed=seed, fitness_in_run=ours,
                               ours={"fitness": ours, "speed": ours, "distance": 0.0, "fallen": False},
                               mujoco={"fitness": theirs, "speed": theirs, "distance": 0.0, "fallen": falls > 16},
                               ours_jit=jit | {"mean": ours, "falls": 0}, mujoco_jit=jit)
    rs = [replay("thesis", 0, 0.2, 0.05, 30), replay("robust, a fall forfeits", 1, 0.2, 0.18, 1),
          replay("robust, a fall forfeits", 2, 0.1, 0.03, 0)]
    text = transfer.table(rs, 32)
    assert "| thesis | 1 | 0.200 | 0.050 | 0.25 | 30.0 | 0.0 | 0 of 1 |" in text
    assert "| robust, a fall forfeits | 2 | 0.150 | 0.105 | 0.60 | 0.5 | 0.0 | 1 of 2 |" in text
    assert text.index("| thesis | 1") < text.index("| robust, a fall forfeits | 2")


def test_a_sweeps_runs_can_be_summarised_per_setting(runs, capsys):
    def replay(cell, seed, ours, theirs, falls):
        jit = {"mean": theirs, "sd": 0.0, "falls": falls, "speed": theirs}
        return transfer.Replay(run=f"{cell}/s{seed}.h5", evaluation="robust", cell=cell, seed=seed,
                               fitness_in_run=ours, ours={"fitness": ours, "speed": ours, "distance": 0.0,
                                                          "fallen": False},
                               mujoco={"fitness": theirs, "speed": theirs, "distance": 0.0, "fallen": False},
                               ours_jit=jit | {"mean": ours, "falls": 0}, mujoco_jit=jit)
    rs = [replay("ga_g0", 0, 0.2, 0.18, 0), replay("amc_M5", 0, 0.3, 0.03, 20), replay("ga_g0", 1, 0.1, 0.02, 3)]
    text = transfer.table(rs, 32, by="cell")
    assert "| setting | runs |" in text
    assert "| ga_g0 | 2 | 0.150 | 0.100 | 0.55 | 1.5 | 0.0 | 1 of 2 |" in text
    assert "| amc_M5 | 1 | 0.300 | 0.030 | 0.10 | 20.0 | 0.0 | 0 of 1 |" in text
    assert text.index("| ga_g0 | 2") < text.index("| amc_M5 | 1")            # the sweep's order, not sorted
    assert set(transfer.summary(rs, "cell")) == {"runs", "ga_g0", "amc_M5", "spearman_fitness",
                                                 "spearman_fitness_interval"}
    with pytest.raises(ValueError, match="by must be one of"):
        transfer.summary(rs, "seed")
    # the command line: a run's folder is its cell (2 replays: the programs of the first test of this file)
    files = [str(runs / "thesis.h5"), str(runs / "robust.h5")]
    assert cli.main(["transfer", *files, "--replays", "2", "--by", "cell", "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary[runs.name]["runs"] == 2


def test_a_run_is_named_by_its_sweep_cell_and_seed_or_else_by_its_file():
    def replay(path, cell, seed):
        r = {"fitness": 0.1, "speed": 0.1, "fallen": False}
        j = {"mean": 0.1, "sd": 0.0, "falls": 0}
        return transfer.Replay(run=path, evaluation="thesis", cell=cell, seed=seed, fitness_in_run=0.1, ours=r,
                               mujoco=r, ours_jit=j, mujoco_jit=j)

    assert replay("runs/thesis/g0.01-p4/s3.h5", "g0.01-p4", 3).label == "g0.01-p4/s3"
    assert replay("runs/quickstart.h5", "runs", 0).label == "quickstart"        # not "runs/s0"
    assert replay("s7.h5", "", 0).label == "s7"


def _replay(here=0.25, speed=0.25, fell=False, there=0.24, falls=0):
    jit = {"mean": there, "sd": 0.0, "falls": falls, "speed": there}
    return transfer.Replay(run="r.h5", evaluation="robust", cell="c", seed=0, fitness_in_run=here,
                           ours={"fitness": here, "speed": speed, "distance": 10 * speed, "fallen": fell},
                           mujoco={"fitness": there, "speed": there, "distance": 10 * there, "fallen": False},
                           ours_jit=jit | {"mean": here, "falls": 0}, mujoco_jit=jit)


@pytest.mark.parametrize("changes, failed", [
    ({}, []),                                                     # walks here, 96 % in MuJoCo, no falls
    ({"fell": True}, ["fell here"]),                              # fell here (it still went 0.25 m/s)
    ({"speed": 0.05, "here": 0.04, "there": 0.04}, ["0.05 m/s here"]),   # barely moves, alike in both
    ({"there": 0.15}, ["MuJoCo 60%"]),                            # slower in MuJoCo
    ({"falls": 3}, ["3 MuJoCo falls"]),                           # falls in 3 of the jittered MuJoCo replays
    ({"speed": 0.1, "falls": 2, "there": 0.175}, []),             # each bound itself carries over
])
def test_a_gait_carries_over_when_it_walks_here_and_in_mujoco(changes, failed):
    r = _replay(**changes)
    assert r.failures == failed and r.carries_over == (not failed)
    row = transfer.table([r], 32).splitlines()[2]
    assert row.endswith(f"| {'yes' if not failed else 'no: ' + ', '.join(failed)} |"), row


def test_one_run_is_summed_up_in_a_sentence():
    """`make run`'s last line: the speed and the falls in each engine, and the verdict with its reasons."""
    assert transfer.sentence(_replay(), 32) == (
        "r: 0.250 m/s here, stays up as it is, 0 of 32 jittered replays fall; 0.240 m/s in MuJoCo C, stays up as "
        "it is, 0 of 32 jittered replays fall: it carries over")
    s = transfer.sentence(_replay(fell=True, falls=5), 32)
    assert "here, falls as it is, 0 of 32" in s and "stays up as it is, 5 of 32 jittered replays fall" in s
    assert s.endswith(": it does not carry over (fell here, 5 MuJoCo falls)")


def test_a_gait_that_fell_here_and_walks_in_mujoco_no_longer_carries_over():
    """The case the rule was changed for: fitness 0.001 here (fell), 0.207 in MuJoCo, ratio 181."""
    r = _replay(here=0.001, speed=-0.02, fell=True, there=0.207)
    assert r.ratio > 100 and r.failures == ["fell here", "-0.02 m/s here"]
    assert transfer.failures(-0.03, 0.2, False, 0.1, 0) == ["MuJoCo -"]     # no score here: no ratio


def test_a_table_is_restated_by_todays_rule(tmp_path, capsys):
    runs = [_replay(), _replay(here=0.001, speed=-0.02, fell=True, there=0.207), _replay(falls=9)]
    text = transfer.table(runs, 32).replace("| no: fell here, -0.02 m/s here |", "| yes |")   # the old verdict
    rows = transfer.read_table("Here: exact pipeline.\n\n" + text)
    assert [(r["fitness_here"], r["fell_here"], r["speed_here"], r["mujoco_falls"], r["carried"]) for r in rows] == [
        (0.25, False, 0.25, 0, True), (0.001, True, -0.02, 0, True), (0.25, False, 0.25, 9, False)]
    assert [r["failures"] for r in transfer.restate(rows)] == [[], ["fell here", "-0.02 m/s here"], ["9 MuJoCo falls"]]
    path = tmp_path / "transfer.md"
    path.write_text(text)
    assert cli.main(["transfer", "--restate", str(path)]) == 0
    out = capsys.readouterr().out
    assert "was yes, now no: fell here, -0.02 m/s here" in out and "carry over: 1 of 3" in out and "said 2 of 3" in out
    (tmp_path / "empty.md").write_text("no table here\n")
    assert cli.main(["transfer", "--restate", str(tmp_path / "empty.md")]) == 2
    assert "empty.md: no per-run rows of a transfer table" in capsys.readouterr().err


def _walks(n):
    """A replay's results where every robot walks (0.2 m/s, no fall): the engines faked."""
    return {"fitness": np.full(n, 0.2), "speed": np.full(n, 0.2), "distance": np.full(n, 2.0),
            "fallen": np.zeros(n, bool)}


def test_transfer_replays_on_a_given_terrain_in_both_engines(runs, capsys, monkeypatch):
    """--terrain reaches both engines' models (the simulations themselves: the slow test below)."""
    seen = []

    def fake_simulate(model, C, time):
        seen.append(("ours", model.terrain.spec))
        return _walks(len(C))

    def fake_mujoco(model, C, time, mj):
        seen.append(("mujoco", model.terrain.spec))
        return _walks(len(C)), None, 0.0

    monkeypatch.setattr(transfer, "simulate", fake_simulate)
    monkeypatch.setattr(transfer, "mujoco_run", fake_mujoco)
    monkeypatch.setattr(transfer, "load", lambda model: None)
    (r,) = transfer.replay_runs([runs / "thesis.h5"], replays=1, terrain="rough:0.01:0.1:3")
    assert seen == [("ours", "rough:0.01:0.1:3"), ("mujoco", "rough:0.01:0.1:3")] and r.carries_over
    parser = cli.build_parser()
    assert "rough:0.02:0.1:SEED" in parser._subparsers._group_actions[0].choices["transfer"].format_help()
    assert cli.main(["transfer", str(runs), "--terrain", "rough:-1"]) == 2
    assert "--terrain" in capsys.readouterr().err



def test_mujocos_step_can_be_set_and_is_named(runs, capsys, monkeypatch):
    """--mujoco-dt reaches MuJoCo's model (its step) and the table; our side keeps the run's step."""
    import mujoco

    seen = []

    def fake_simulate(model, C, time):
        seen.append(("ours", model.dt))
        return _walks(len(C))

    def fake_mujoco(model, C, time, mj):
        assert isinstance(mj, mujoco.MjModel)
        seen.append(("mujoco", mj.opt.timestep))
        return _walks(len(C)), None, 0.0

    monkeypatch.setattr(transfer, "simulate", fake_simulate)
    monkeypatch.setattr(transfer, "mujoco_run", fake_mujoco)
    (r,) = transfer.replay_runs([runs / "thesis.h5"], replays=1, mujoco_dt=5e-4)
    (d,) = transfer.replay_runs([runs / "thesis.h5"], replays=1)
    assert seen == [("ours", 5e-4), ("mujoco", 5e-4), ("ours", 5e-4), ("mujoco", 2e-3)] and r.carries_over
    assert cli.main(["transfer", str(runs / "thesis.h5"), "--replays", "1", "--mujoco-dt", "2.5e-4"]) == 0
    assert "MuJoCo's step 0.25 ms" in capsys.readouterr().out
    assert cli.main(["transfer", str(runs), "--mujoco-dt", "0"]) == 2
    assert "--mujoco-dt" in capsys.readouterr().err

@pytest.mark.slow
def test_a_run_replayed_on_a_rough_field_scores_otherwise_than_on_its_own(runs):
    (r,) = transfer.replay_runs([runs / "thesis.h5"], replays=1, terrain="rough:0.01:0.1:3")
    assert r.ours["fitness"] != pytest.approx(r.fitness_in_run, abs=1e-4)
    assert np.isfinite(r.mujoco["fitness"]) and r.pipeline == "springs"


def test_on_stairs_a_replay_that_stays_up_short_of_the_finish_counts_against_the_gait():
    """With ledges (stairs, a bar, a gap) a jittered replay that stays up but ends before the finish line (the last
    face plus the hind legs' reach, ``sim.ledges.finish_line``) is counted ``short``, and more such than the falls
    allowed fail the gait; without ledges nothing is counted."""
    from cpgjax.sim.ledges import FINISH_BEHIND, finish_line
    from cpgjax.sim.terrain import make_terrain

    finish = finish_line(make_terrain("course:flat:0.5,stairs:0.04:0.3:5").ledges)
    assert finish == pytest.approx(0.5 + 0.5 + 4 * 0.3 + FINISH_BEHIND)
    assert finish_line(make_terrain("rough:0.02").ledges) is None
    res = {"fitness": [0.1, 0.2, 0.3, 0.1], "speed": [0.1, 0.2, 0.3, 0.1], "fallen": [True, False, False, False],
           "distance": [0.5, 1.0, 3.0, finish - 0.01]}
    assert transfer._stats(res, finish)["short"] == 2 and "short" not in transfer._stats(res)
    assert transfer.failures(0.2, 0.2, False, 0.2, 0, 3) == ["3 MuJoCo short"]
    assert transfer.failures(0.2, 0.2, False, 0.2, 0, 2) == []
