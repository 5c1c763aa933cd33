"""`cpgjax crosscheck` and `cpgjax export` end to end (cpgjax/crosscheck.py)."""

import os

import mujoco
import pytest
from runcases import TINY_TIME

from cpgjax.cli import main


def test_export_writes_loadable_mjcf(tmp_path, capsys):
    out = tmp_path / "q.xml"
    assert main(["export", "models/quadruped.wl", "--out", str(out)]) == 0
    mj = mujoco.MjModel.from_xml_path(str(out))
    assert mj.nu == 8 and abs(mj.body_mass.sum() - 13.8) < 1e-6
    assert "13.800" in capsys.readouterr().out


def test_crosscheck_reports_every_engine_and_writes_plots(tmp_path, capsys):
    # the suite's tiny episode (0.3 s) and the model's own step and springs: the recorded programs of the tiny
    # episodes elsewhere (options that change the model: tests/cli/test_pipeline_option.py, crosscheck/test_transfer.py)
    rc = main(["crosscheck", "models/quadruped.wl", "--ctl", "models/quadruped-trot.ctl", "--random", "2",
               "--perturbed", "1", "--time", str(TINY_TIME), "--no-mjx", "--out", str(tmp_path)])
    out = capsys.readouterr().out
    assert rc == 0
    assert "Our simulator: step 0.5 ms, pivot springs 300000 N/m, 300 N s/m" in out
    assert "penalty vs mujoco" in out and "quadruped-trot.ctl" in out and "4 controllers, 0.3 s each" in out
    assert "mujoco vs mujoco at half its step (1 ms)" in out  # the ceiling, on by default
    assert "penalty vs penalty at half its step (0.25 ms)" in out  # ours against itself
    for f in ("crosscheck.md", "joints.png", "cm_path.png"):
        assert os.path.getsize(tmp_path / f) > 0


def test_crosscheck_runs_mujoco_at_the_step_it_is_given(tmp_path, capsys):
    """`--mujoco-dt`: MuJoCo C's side at another step than the export's (rough ground is judged at 0.25 ms), named
    in the table and recorded in the JSON."""
    import json

    rc = main(["crosscheck", "models/quadruped.wl", "--ctl", "models/quadruped-trot.ctl", "--random", "2",
               "--perturbed", "1", "--time", str(TINY_TIME), "--no-mjx", "--no-ceiling", "--mujoco-dt", "0.001",
               "--out", str(tmp_path)])
    out = capsys.readouterr().out
    assert rc == 0 and "MuJoCo C's step 1 ms (the export's 2 ms)" in out
    summary = json.loads((tmp_path / "crosscheck.json").read_text())["summary"]
    assert summary["mujoco_dt"] == 0.001 and summary["n"] == 4


def test_rough_ground_at_mujocos_default_step_gets_a_note():
    """`crosscheck` and `transfer` say on standard error to judge rough ground at 0.25 ms when MuJoCo would run at
    the export's 2 ms there (docs/results/engine-agreement.md, *MuJoCo's step on rough ground*)."""
    from cpgjax.cli.crosscheck import ROUGH_STEP_NOTE, rough_step_note
    from cpgjax.crosscheck.transfer import evolved_terrain  # what `transfer` reads of a run without --terrain

    assert rough_step_note(["rough:0.02:0.1:1"], None) == ROUGH_STEP_NOTE
    assert rough_step_note([None, "rough:0.02"], None) == ROUGH_STEP_NOTE      # a run evolved on rough ground
    assert rough_step_note(["rough:0.02"], 0.00025) is None
    assert rough_step_note(["flat", None, "bump:0.02", "ramp:0.1"], None) is None
    assert "--mujoco-dt 0.00025" in ROUGH_STEP_NOTE
    assert evolved_terrain({"cli_problem_args": '{"terrain": "rough:0.02", "time": 2}'}) == "rough:0.02"
    assert evolved_terrain({"cli_problem_args": '{"time": 2}'}) is None and evolved_terrain({}) is None


@pytest.mark.slow
def test_crosscheck_with_mjx(tmp_path, capsys):
    rc = main(["crosscheck", "models/quadruped.wl", "--ctl", "models/quadruped-trot.ctl", "--random", "2",
               "--perturbed", "0", "--time", "1", "--out", str(tmp_path)])
    assert rc == 0 and "mujoco vs mjx" in capsys.readouterr().out
