"""cpgjax.experiments.adapt: the damaged robot is the repertoire's problem (its pipeline among the rest)."""

from __future__ import annotations

import json
import types

import pytest

from cpgjax.errors import ResultsError
from cpgjax.experiments.adapt import damaged_problem
from cpgjax.io.wl import load_wl

MODEL = "models/quadruped.wl"


def _rep(**meta):
    m = {"model_text": load_wl(MODEL).text, "descriptor": "duty", "time": 0.2, "terrain": "flat",
         "cli_problem_args": json.dumps({}), **meta}
    return types.SimpleNamespace(meta=m, path="rep.h5")


@pytest.mark.parametrize("pipeline", ["springs", "exact"])
def test_the_damaged_robot_runs_on_the_repertoires_pipeline(pipeline):
    p = damaged_problem(MODEL, _rep(pipeline=pipeline), "leg=AR")
    assert p.meta["pipeline"] == pipeline and p.meta["damage"] == "leg=AR" and p.meta["time"] == 0.2


def test_an_old_repertoire_without_a_pipeline_is_springs_and_another_model_is_refused():
    assert damaged_problem(MODEL, _rep(), "none").meta["pipeline"] == "springs"
    with pytest.raises(ResultsError, match="not the model the repertoire"):
        damaged_problem(MODEL, _rep(model_text="other"), "none")
