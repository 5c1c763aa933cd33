"""`cpgjax simulate --engine mujoco`: one episode of a `.ctl` in MuJoCo C, printed as ours is, and its bad input."""

from __future__ import annotations

import re

import numpy as np
import pytest
from runcases import one_line_error

from cpgjax.cli import main

MODEL = "models/quadruped.wl"


def _printed(out: str) -> dict[str, float]:
    """distance, speed and fitness as ``simulate`` prints them, and fallen as 1.0 / 0.0."""
    num = {k: float(re.search(rf"^{k}\s+([-+]?\d+\.\d+)", out, re.M).group(1))
           for k in ("distance", "speed", "fitness")}
    num["fallen"] = float(re.search(r"^fallen\s+(yes|no)", out, re.M).group(1) == "yes")
    return num


def test_mujoco_prints_what_mujoco_run_gives_for_the_same_controller(capsys):
    """The trot for 1 s at MuJoCo's 1 ms step: the command's figures are MuJoCo C's own rollout of the controller
    (crosscheck.engines.mujoco_run on the exported model), to the digits printed."""
    from cpgjax.cli.controllers import load_controller
    from cpgjax.crosscheck.engines import mujoco_run
    from cpgjax.crosscheck.mjcf import load
    from cpgjax.episode.policy import stack
    from cpgjax.io.wl import load_model

    assert main(["simulate", MODEL, "--ctl", "models/quadruped-trot.ctl", "--time", "1", "--engine", "mujoco",
                 "--mujoco-dt", "0.001"]) == 0
    out = capsys.readouterr().out
    assert "MuJoCo C, step 0.001 s" in out
    m = load_model(MODEL)
    c, _ = load_controller("models/quadruped-trot.ctl", m)
    r, _, _ = mujoco_run(m, stack([c], m), time=1.0, mj=load(m, timestep=0.001))
    got = _printed(out)
    for k in ("distance", "speed", "fitness"):
        assert got[k] == pytest.approx(float(r[k][0]), abs=1e-4 if k != "fitness" else 1e-6)
    assert got["fallen"] == float(r["fallen"][0]) == 0.0
    assert abs(got["distance"]) > 0.01                 # the trot moves in MuJoCo C too


def test_a_closed_loop_of_zeros_walks_in_mujoco_as_its_open_loop_cpg(tmp_path, capsys):
    """A closed-loop `.ctl` whose policy is all zeros does what its CPG does: in MuJoCo C, where the closed loop is
    stepped one control period at a time with the policy read from MuJoCo's sensors and the open loop is MuJoCo's
    threaded rollout of precomputed controls, the two episodes agree to 1 mm (measured: they agree to the 4 printed
    digits)."""
    from cpgjax.episode import policy as pol
    from cpgjax.io.ctl import PolicyTable, read_ctl, write_ctl
    from cpgjax.io.wl import load_model

    m = load_model(MODEL)
    fam = pol.parse_controller("pmtg:tilt+contact+bias")
    coeffs = read_ctl("models/quadruped-trot.ctl", n_dof=8, harmonics=2).coeffs
    W = np.zeros((fam.n_out(m), fam.n_in(m)), np.float32)
    c = pol.ClosedLoop(fam, coeffs, W, np.zeros((), np.float32))
    path = tmp_path / "zeros.ctl"
    write_ctl(path, coeffs, policy=PolicyTable(**pol.table_fields(c, m)), exact=True)
    runs = []
    for ctl in ("models/quadruped-trot.ctl", str(path)):
        assert main(["simulate", MODEL, "--ctl", ctl, "--time", "1", "--engine", "mujoco", "--pipeline", "exact"]) == 0
        runs.append(_printed(capsys.readouterr().out))
    assert runs[0]["distance"] == pytest.approx(runs[1]["distance"], abs=1e-3)
    assert runs[0]["fallen"] == runs[1]["fallen"] == 0.0


@pytest.mark.parametrize("argv, message", [
    (["--engine", "warp"], "argument --engine: invalid choice: 'warp'"),
    (["--mujoco-dt", "0.001"], "--mujoco-dt: with --engine mujoco"),
    (["--mujoco-ground", "mesh"], "--mujoco-ground: with --engine mujoco"),
    (["--engine", "mujoco", "--mujoco-dt", "0"], "argument --mujoco-dt"),
    (["--engine", "mujoco", "--log", "LOG"], "--log: with --engine ours only"),
    (["--engine", "mujoco", "--gravity", "5"], "--gravity: with --engine ours only"),
])
def test_bad_input_is_one_line_and_writes_nothing(argv, message, tmp_path, capsys):
    argv = [str(tmp_path / "logs") if a == "LOG" else a for a in argv]
    assert main(["simulate", MODEL, "--ctl", "models/quadruped-trot.ctl", "--time", "0.1", *argv]) == 2
    one_line_error(capsys.readouterr().err, "simulate", expect=(message,))
    assert not (tmp_path / "logs").exists()
