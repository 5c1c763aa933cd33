"""A smoke run of ``benchmarks/open_vs_closed.py`` (docs/results/closed-loop.md): two families on two seeds and
two grounds, its tables and its figure.  The ``cpgjax`` commands it runs are stood in for by one that parses each
with cpgjax's own parser (each option and its value checked as ``cpgjax`` checks them) and writes what the command
would (the run file; ``transfer.json`` of `cpgjax transfer`'s fields): for real, each evolution and each replay
compiles an exact-joint program of its own (tens of seconds on 2 cores), and the commands are tested in their own
files (tests/cli, tests/crosscheck/test_transfer.py)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from benchcases import load_benchmark

from cpgjax.cli import build_parser


@pytest.fixture(scope="module")
def bench():
    return load_benchmark("open_vs_closed")


def _replay(run: str, speed: float, fell_there: bool) -> dict:
    """What `cpgjax transfer` writes of one run (`crosscheck.transfer.Replay`'s fields)."""
    from cpgjax.crosscheck.transfer import Replay

    here = {"fitness": speed, "speed": speed, "distance": 5 * speed, "fallen": False}
    there = {"fitness": 0.9 * speed, "speed": 0.9 * speed, "distance": 4.5 * speed, "fallen": fell_there}
    return Replay(run=run, evaluation="robust", cell="c", seed=0, fitness_in_run=speed, ours=here, mujoco=there,
                  ours_jit={"mean": speed, "sd": 0.0, "falls": 0},
                  mujoco_jit={"mean": 0.9 * speed, "sd": 0.0, "falls": 32 if fell_there else 1}).__dict__


def test_each_family_seed_and_ground_its_tables_and_figure(bench, tmp_path, monkeypatch, capsys):
    out, figure = tmp_path / "ovc", tmp_path / "speed.png"
    commands = []

    def cpgjax(cmd):
        args = build_parser().parse_args(cmd)
        commands.append(args)
        if args.command == "evolve":
            Path(args.out).write_bytes(b"")
        else:
            name = Path(args.out).name                                   # FAMILY-sSEED-TERRAIN
            seed = int(name.split("-s")[1].split("-")[0])
            Path(args.out).mkdir()
            (Path(args.out) / "transfer.json").write_text(json.dumps(
                {"summary": {}, "runs": [_replay(args.runs[0], 0.1 * seed, "rough" in name)]}))
        return 10.0 * len(commands), 20.0

    monkeypatch.setattr(bench, "run", cpgjax)
    argv = ["--seeds", "1-2", "--families", "open,closedmirror", "--terrains", "flat,rough:0.02", "--out", str(out)]
    assert bench.main([*argv, "--figure", str(figure)]) == 0
    assert [c.command for c in commands] == ["evolve", "transfer", "transfer"] * 4
    evolve = commands[3]                                                  # closedmirror, seed 1
    assert (evolve.seed, evolve.population, evolve.generations, evolve.time, evolve.pipeline) == (1, 20, 15, 5.0,
                                                                                                  "exact")
    assert evolve.controller == "pmtg:tilt+contact+bias:mirror" and evolve.perturb["latency"] == 1
    assert commands[5].terrain == "rough:0.02" and commands[4].terrain is None
    text = capsys.readouterr().out
    assert "| 1 | 0.100 / 0.090, 0 / 1, yes | 0.100 / 0.090, 0 / 1, yes |" in text
    assert "| open | rough 2 cm | 2 | 0.150 | 0.135 | 2 | 0 | 0 of 2 |" in text
    assert "| closedmirror | flat | 2 | 0.150 | 0.135 | 2 | 2 | 2 of 2 |" in text
    assert "open-loop 40 s wall (10-70), 20 s CPU; closedmirror-loop 70 s wall (40-100)" in text
    assert figure.stat().st_size > 0
    # again: everything is on disk, nothing is run, the same tables
    commands.clear()
    assert bench.main(argv) == 0 and not commands and capsys.readouterr().out == text.replace(
        f"\nwrote {figure}\n", "\n")


def test_an_unknown_family_is_one_line(bench, capsys):
    with pytest.raises(SystemExit) as e:
        bench.main(["--families", "open,closedx"])
    assert e.value.code == 2 and "--families: unknown closedx" in capsys.readouterr().err
