"""Run files record their physics pipeline; resume refuses a change of it; whatever rebuilds a run's model uses it."""

from __future__ import annotations

import json
import shutil

import h5py
import pytest
from runcases import TINY_GA, TINY_TIME

from cpgjax.cli import main
from cpgjax.errors import ResultsError
from cpgjax.experiments.runner import check_problem
from cpgjax.io.results import read_attrs, read_run
from cpgjax.optim.factory import make_problem

WL = "models/quadruped.wl"
TINY = TINY_GA


@pytest.fixture(scope="module")
def run_path(tiny_runs):
    """The suite's tiny thesis run (tests/runcases.py), read only: a test that changes it works on a copy."""
    from pathlib import Path

    return Path(tiny_runs["thesis"])


def _as_exact(src, dst):
    """A copy of the run file that says it was evolved on the exact pipeline (its attributes only)."""
    shutil.copy(src, dst)
    with h5py.File(dst, "r+") as f:
        meta = json.loads(f.attrs["meta"])
        meta["pipeline"] = "exact"
        f.attrs["meta"], f.attrs["pipeline"] = json.dumps(meta), "exact"
    return dst


def test_a_run_records_its_pipeline(run_path):
    a = read_attrs(run_path)
    assert a["pipeline"] == "springs" and json.loads(a["meta"])["pipeline"] == "springs"
    assert read_run(run_path).pipeline == "springs"
    problem = make_problem(WL, time=TINY_TIME, pipeline="exact")      # builds the model, traces nothing
    assert problem.meta["pipeline"] == "exact" and json.loads(problem.meta["cli_problem_args"])["pipeline"] == "exact"


def test_resume_with_another_pipeline_exits_2_in_one_line_and_changes_nothing(run_path, tmp_path, capsys):
    path = tmp_path / "r.h5"
    shutil.copy(run_path, path)
    before = path.read_bytes()
    assert main(["evolve", WL, *TINY, "--generations", "3", "--out", str(path), "--resume", "--pipeline", "exact"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert f"{path}: cannot resume: --pipeline exact differs from the run's springs (drop the option" in err
    assert path.read_bytes() == before


def test_a_sweep_refuses_to_add_runs_of_another_pipeline(run_path):
    with pytest.raises(ResultsError, match="cannot add runs to this sweep: --pipeline exact differs from the run's "
                                           "springs"):
        check_problem(str(run_path), make_problem(WL, time=TINY_TIME, pipeline="exact"), verb="add runs to this sweep")


def test_runs_made_before_the_pipeline_was_recorded_ran_on_springs(run_path):
    a = dict(read_attrs(run_path))
    meta = json.loads(a["meta"])
    del meta["pipeline"]
    a["meta"] = json.dumps(meta)
    check_problem(str(run_path), make_problem(WL, time=TINY_TIME), a)            # no refusal: the same physics
    with pytest.raises(ResultsError, match="--pipeline exact differs from the run's springs"):
        check_problem(str(run_path), make_problem(WL, time=TINY_TIME, pipeline="exact"), a)


def test_a_runs_model_is_rebuilt_on_the_pipeline_it_recorded(run_path, tmp_path, monkeypatch):
    from cpgjax.crosscheck import transfer
    from cpgjax.experiments import stability, validate
    from cpgjax.render.poses import load_run

    exact = read_run(_as_exact(run_path, tmp_path / "exact.h5"))
    springs = read_run(run_path)
    assert exact.pipeline == "exact"
    # render
    assert load_run(exact.path)[0].pipeline == "exact"
    assert load_run(springs.path)[0].pipeline == "springs"
    assert load_run(springs.path, pipeline="exact")[0].pipeline == "exact"       # --pipeline overrides
    # stability (the population study)
    assert stability.model_of(exact)[0].pipeline == "exact"
    assert stability.model_of(springs)[0].pipeline == "springs"
    with pytest.raises(ValueError, match="physics pipeline"):
        stability.population_study([springs.path, exact.path])

    # validation and transfer: the model they build (stopped there, before any physics)
    class Built(Exception):
        pass

    def built(path, model, *a, **k):
        raise Built(model.pipeline)

    monkeypatch.setattr(validate, "robust_problem", built)
    validate._program.cache_clear()
    for run, want in ((exact, "exact"), (springs, "springs")):
        with pytest.raises(Built, match=want):
            validate.validate(run, validate.Validation(candidates=2, episodes=1))

    monkeypatch.setattr(transfer, "simulate", lambda model, *a, **k: (_ for _ in ()).throw(Built(model.pipeline)))
    for path, override, want in ((exact.path, None, "exact"), (springs.path, None, "springs"),
                                 (springs.path, "exact", "exact")):
        with pytest.raises(Built, match=want):
            transfer.replay_runs([path], replays=1, pipeline=override)


def test_report_and_transfer_name_the_pipeline(run_path):
    from cpgjax.analysis.report import evaluation_line
    from cpgjax.crosscheck import transfer

    assert evaluation_line([str(run_path)]) == "Evaluation: thesis (one exact episode per controller) on the springs " \
                                               "pipeline."

    def replay(seed, pipeline):
        d = {"fitness": 0.1, "speed": 0.1, "distance": 0.5, "fallen": False}
        j = {"mean": 0.1, "sd": 0.0, "falls": 0, "speed": 0.1}
        return transfer.Replay(run=f"c/s{seed}.h5", evaluation="thesis", cell="c", seed=seed, fitness_in_run=0.1,
                               ours=d, mujoco=d, ours_jit=j, mujoco_jit=j, pipeline=pipeline)

    rs = [replay(0, "springs"), replay(1, "exact")]
    s = transfer.summary(rs)
    assert s["thesis"]["runs"] == 1 and s["thesis, exact pipeline"]["runs"] == 1
    text = transfer.table(rs, 1)
    assert "| c/s0 | thesis (springs) |" in text and "| c/s1 | thesis (exact) |" in text
    assert text.index("| thesis | 1 |") < text.index("| thesis, exact pipeline | 1 |")


# ----------------------------------------------------------------------------- end to end on the exact pipeline
# (slow: the exact pipeline's programs took 1-2 min each to compile on the 2 shared cores; `make test-all` runs them)

@pytest.mark.slow
def test_simulate_runs_on_the_exact_pipeline(capsys):
    assert main(["simulate", WL, "--time", "0.1", "--pipeline", "exact"]) == 0
    out = capsys.readouterr().out
    assert "exact pipeline, dt 0.002 s" in out and "diverged  no" in out


@pytest.mark.slow
def test_evolve_two_generations_on_the_exact_pipeline(tmp_path, capsys):
    from cpgjax.render.poses import load_run

    out = tmp_path / "exact.h5"
    assert main(["evolve", WL, "--time", "0.1", "--population", "4", "--generations", "2", "--pipeline", "exact",
                 "--out", str(out), "--quiet"]) == 0
    a, run = read_attrs(out), read_run(out)
    assert (a["pipeline"], a["dt"], run.completed, run.pipeline) == ("exact", 0.002, 2, "exact")
    assert load_run(str(out))[0].pipeline == "exact"                     # rebuilt on the pipeline it recorded
    capsys.readouterr()
    assert main(["evolve", WL, "--time", "0.1", "--population", "4", "--generations", "3", "--pipeline", "springs",
                 "--out", str(out), "--resume", "--quiet"]) == 2
    assert "--pipeline springs differs from the run's exact" in capsys.readouterr().err
    assert read_run(out).completed == 2


@pytest.mark.parametrize(("pipeline", "dt"), [("exact", 2e-3), ("springs", 2.5e-4)])
def test_adapt_rebuilds_a_repertoires_model_on_its_pipeline_and_step(pipeline, dt):
    """`cpgjax adapt` has no --pipeline: the damaged robot runs on the repertoire's (its meta), at the step the
    model file gives that pipeline (models/hexapod.wl: ExactTimeStep 2e-3, TimeStep 2.5e-4)."""
    from types import SimpleNamespace

    from cpgjax.experiments.adapt import damaged_problem
    from cpgjax.io.wl import load_wl

    meta = {"model_text": load_wl("models/hexapod.wl").text, "descriptor": "duty", "time": 0.2,
            "pipeline": pipeline, "cli_problem_args": "{}"}
    problem = damaged_problem("models/hexapod.wl", SimpleNamespace(path="r.h5", meta=meta), "leg=CR")
    assert (problem.meta["pipeline"], problem.meta["dt"], problem.meta["damage"]) == (pipeline, dt, "leg=CR")
