"""The simulator's studies (cpgjax/experiments/studies.py): the friction bristle study at tiny scale."""

from __future__ import annotations

import json

import numpy as np
import pytest

from cpgjax import cli


@pytest.fixture(scope="module")
def run_file(tmp_path_factory):
    p = tmp_path_factory.mktemp("fr") / "r.h5"
    assert cli.main(["evolve", "models/quadruped.wl", "--time", "0.3", "--population", "4", "--generations", "1",
                     "--out", str(p), "--quiet"]) == 0
    return p


@pytest.mark.slow  # 15 s with its run; fast: the bristle scale in sim/test_variation.py
def test_friction_study_reports_each_bristle(run_file, tmp_path, capsys):
    out = tmp_path / "friction.md"
    argv = ["study-friction", "--runs", str(run_file), "--springs", "1e3:300,1e5:1e3", "--replays", "3",
            "--random", "2", "--perturbed", "2", "--time", "0.3"]
    assert cli.main(argv + ["--json"]) == 0
    rows = json.loads(capsys.readouterr().out)["rows"]
    assert [(r["k"], r["b"]) for r in rows] == [(1e3, 300.0), (1e5, 1e3)]
    for r in rows:
        assert r["runs"] == 1 and r["replays"] == 3 and r["crosscheck"] == 5
        assert np.isfinite(r["trot_sd"]) and r["trot_falls"] == 0 and -1 <= r["rho"] <= 1
    # the bristle reaches the physics: the stiffer one gives another score
    assert rows[0]["trot_mean"] != rows[1]["trot_mean"]
    assert cli.main(argv + ["--out", str(out)]) == 0
    assert "| 100000 | 1000 |" in out.read_text() and "Spearman" in capsys.readouterr().out


def test_friction_study_rejects_a_bad_bristle(capsys):
    assert cli.main(["study-friction", "--springs", "1e3:-1"]) == 2
    assert "a bristle needs K > 0 and B >= 0" in capsys.readouterr().err
