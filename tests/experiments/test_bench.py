"""``cpgjax bench --table-a1``: Table A.1's rows (tiny: one example, a short episode, a small batch)."""

from __future__ import annotations

import json

import pytest

from cpgjax.cli import main


def test_table_a1_json_row(capsys):
    rc = main(["bench", "--table-a1", "--a1-examples", "worm", "--time", "0.05", "--a1-batch", "4", "--json"])
    assert rc == 0
    out = json.loads(capsys.readouterr().out)
    (row,) = out["rows"]
    assert row["example"] == "worm" and row["dofs"] == row["thesis_dofs"] == 4
    assert row["thesis_slowdown"] == 1.0 and row["thesis_time"] == 15.0 and row["batch"] == 4
    assert row["sim_time"] == pytest.approx(0.05)
    assert row["slowdown_one"] > 0 and row["slowdown_per_robot"] == pytest.approx(row["slowdown_batch"] / 4)
    assert "cores" in out["machine"]


def test_table_a1_bad_input(capsys):
    assert main(["bench", "--table-a1", "--a1-examples", "snake", "--time", "0.05"]) == 2
    assert "no example 'snake'" in capsys.readouterr().err
    assert main(["bench", "--json"]) == 2
    assert "--json is only for --table-a1" in capsys.readouterr().err


@pytest.mark.slow  # a program of its own; fast: bench --table-a1, this file
def test_compile_time_is_the_compile_alone(capsys):
    """The compile time is the ahead-of-time compile, timed alone: positive, and not a difference of calls."""
    from cpgjax.experiments.bench import print_table, row
    from cpgjax.io.wl import load_model

    r = row(load_model("models/worm.wl"), 4, 0.02, label="worm", chunk=16)
    assert r["compile_s"] > 0 and r["wall_s"] > 0
    print_table([r])
    assert "compile: the ahead-of-time lower().compile()" in capsys.readouterr().out


@pytest.mark.slow  # a process of its own that compiles; fast: the pools' sizes, tests/test_xla.py
def test_a_row_measured_alone_runs_in_a_process_with_its_own_devices_and_pools():
    """``--tricks``' rows "1 dev, N thr": `measure_alone` times the program in a child whose environment sets what
    XLA reads once per process."""
    from cpgjax.experiments.bench import measure_alone

    compile_s, run_s = measure_alone("models/worm.wl", None, 4, 0.02, chunk=16, CPGJAX_DEVICES="1", PJRT_NPROC="1")
    assert compile_s > 0 and run_s > 0
    with pytest.raises(RuntimeError, match="in a process of its own .*CPGJAX_DEVICES"):   # a failure is not a row
        measure_alone("models/worm.wl", None, 4, 0.02, chunk=16, CPGJAX_DEVICES="many")
