"""A smoke run of ``benchmarks/steering.sh`` (docs/results/steering.md), with a stand-in for the ``cpgjax``
executable that records each command and creates the files it names: every command is parsed by cpgjax's own
parser (each option and its value checked as ``cpgjax`` checks them), the settings in the environment reach the
options they name, and a seed whose controller exists is not evolved again.  Run for real, at any size, its
commands compile two exact-joint programs (about 40 s on 2 cores); the commands themselves are tested in their own
files (tests/cli)."""

from __future__ import annotations

import os
import shlex
import subprocess
from pathlib import Path

import pytest

from cpgjax.cli import build_parser

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "benchmarks" / "steering.sh"
STAND_IN = """#!/bin/sh
printf '%s\\n' "$*" >> "$LOG"
prev=
for a in "$@"; do
    case "$prev" in --out|--ctl) touch "$a" ;; esac
    prev=$a
done
"""

pytestmark = pytest.mark.skipif(not os.path.exists("/usr/bin/time"), reason="the script times with /usr/bin/time")


def _run(tmp_path, out, seeds, **env) -> list:
    """The parsed commands of one run of the script."""
    log = tmp_path / "commands.log"
    log.unlink(missing_ok=True)
    stand_in = tmp_path / "cpgjax"
    stand_in.write_text(STAND_IN)
    stand_in.chmod(0o755)
    env = {**os.environ, "CPGJAX": str(stand_in), "LOG": str(log), **env}
    r = subprocess.run(["sh", str(SCRIPT), str(out), seeds], cwd=ROOT, env=env, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return [build_parser().parse_args(shlex.split(line)) for line in log.read_text().splitlines()]


def test_the_recipe_its_settings_and_the_walks(tmp_path):
    out = tmp_path / "steer"
    cmds = _run(tmp_path, out, "5 6", MIRROR="1", SPEED="0.12", COMMAND="0.4", LIMIT="0.4", REPLICAS="8",
                PERTURB="bristle=2,bristle_from=1", INPUTS="tilt+contact+command+steer+turn+bias")
    assert [c.command for c in cmds] == ["evolve", "best", "evolve", "best", "follow"]
    for seed, (evolve, best) in zip((5, 6), (cmds[0:2], cmds[2:4]), strict=True):
        assert (evolve.seed, evolve.population, evolve.generations, evolve.time) == (seed, 40, 150, 10.0)
        assert evolve.pipeline == "exact" and evolve.evaluation == "robust" and evolve.delta == 1.0
        assert evolve.controller == "pmtg:tilt+contact+command+steer+turn+bias:mirror"
        assert evolve.perturb == {"command": 0.4, "fall_zero": True, "replicas": 8, "speed": 0.12, "bristle": 2.0,
                                  "bristle_from": 1.0}
        assert best.run == evolve.out == str(out / f"s{seed}.h5") and best.ctl == str(out / f"s{seed}.ctl")
    follow = cmds[-1]
    assert follow.ctl == [str(out / "s5.ctl"), str(out / "s6.ctl")] and follow.pipeline == "exact"
    assert (follow.limit, follow.time) == (0.4, 120.0)
    assert follow.path == ["line:3", "circle:0.5", "square:1.0", "figure8:0.5"]
    # run again (the defaults now): the controllers on disk are walked, nothing is evolved again
    again = _run(tmp_path, out, "5 6")
    assert [c.command for c in again] == ["follow"] and again[0].limit == 0.3


def test_the_defaults_and_the_help(tmp_path):
    (evolve, _best, follow) = _run(tmp_path, tmp_path / "plain", "7")
    assert evolve.controller == "pmtg:tilt+contact+command+steer+bias"
    assert evolve.perturb == {"command": 0.3, "fall_zero": True}
    assert follow.limit == 0.3
    text = subprocess.run(["sh", str(SCRIPT), "--help"], capture_output=True, text=True, check=True).stdout
    assert text.startswith("Steering without an oracle") and "set -e" not in text
