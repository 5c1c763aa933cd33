"""A smoke run of ``benchmarks/ground_forms.py`` (the table of docs/crosscheck.md, *The ground's form in MuJoCo*)."""

from __future__ import annotations

import importlib.util
import io
from pathlib import Path

import pytest


@pytest.fixture(scope="module")
def bench():
    path = Path(__file__).resolve().parents[2] / "benchmarks" / "ground_forms.py"
    spec = importlib.util.spec_from_file_location("ground_forms", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_the_table_has_a_row_per_controller_field_step_and_form(bench):
    out = io.StringIO()
    # 20 cm cells: a mesh of 6,344 pieces, where the docs' 10 cm field has 25,376 (5 s per MuJoCo load)
    rows = bench.run(["rough:0.02:0.2:1"], [0.002], ["hfield", "mesh"], 0.1, out=out)
    assert len(rows) == 4 and len(out.getvalue().splitlines()) == 2 + 4
    for r in rows:
        assert not r["fell"] and 0.0 < r["depth99"] <= r["depth_max"] < 0.02       # feet on the ground, not through
    # the same triangles as meshes: the same first 0.1 s as the heightfield (measured equal to 1e-9 m)
    assert rows[0]["distance"] == pytest.approx(rows[1]["distance"], abs=1e-4)


def test_bad_arguments_exit_2_with_one_line(bench, capsys):
    assert bench.main(["--forms", "plane"]) == 2
    assert bench.main(["--time", "0"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 2 and "unknown MuJoCo ground form 'plane'" in err[0] and "--time" in err[1]
