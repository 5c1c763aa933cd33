"""``--pipeline springs|exact`` on every command that takes a model (parsed only: no physics runs here)."""

from __future__ import annotations

import pytest

from cpgjax.cli import build_parser, main

# each command that takes a model (or run files), with the positional arguments it needs
COMMANDS = {
    "simulate": ["m.wl"],
    "robustness": ["m.wl", "--ctl", "c.ctl"],
    "evolve": ["m.wl"],
    "search": ["m.wl"],
    "sweep": ["m.wl", "--out", "d"],
    "crosscheck": ["m.wl"],
    "transfer": ["r.h5"],
    "stability": ["m.wl", "--ctl", "c.ctl"],
    "servo": ["m.wl"],
    "render": ["m.wl"],
    "best": ["r.h5", "--validate"],
    "bench": [],
    "study-dt": [],
    "study-friction": [],
    "notebook": ["n.ipynb"],
}


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_every_command_that_takes_a_model_accepts_pipeline(command):
    parser = build_parser()
    argv = [command, *COMMANDS[command]]
    assert parser.parse_args(argv).pipeline is None          # left out: the model file's, or the run's
    for name in ("springs", "exact"):
        assert parser.parse_args([*argv, "--pipeline", name]).pipeline == name


@pytest.mark.parametrize("command", ["simulate", "evolve", "transfer"])
def test_an_unknown_pipeline_is_one_line_and_exit_2(command, capsys):
    assert main([command, *COMMANDS[command], "--pipeline", "rigid"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--pipeline" in err and "'springs', 'exact'" in err


def test_help_says_what_each_pipeline_is(capsys):
    with pytest.raises(SystemExit):
        build_parser().parse_args(["simulate", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "springs (the thesis's" in text and "exact (generalized coordinates" in text


def test_best_refuses_pipeline_without_validate(capsys):
    assert main(["best", "r.h5", "--pipeline", "exact"]) == 2
    assert "--pipeline is for --validate" in capsys.readouterr().err


def test_notebook_passes_the_pipeline_to_the_kernel(monkeypatch, tmp_path, capsys):
    import cpgjax.experiments.notebook as nb

    seen = {}
    monkeypatch.setattr(nb, "execute", lambda path, *, env, cwd, out: seen.update(env))
    book = tmp_path / "n.ipynb"
    book.write_text("{}")
    assert main(["notebook", str(book), "--pipeline", "exact", "--no-save"]) == 0
    assert seen["CPGJAX_PIPELINE"] == "exact"


def test_sweep_gives_every_shard_the_pipeline(tmp_path):
    from cpgjax.cli.sweep import build_specs
    from cpgjax.experiments.sweep import sweep_problem

    args = build_parser().parse_args(["sweep", "models/quadruped.wl", "--out", str(tmp_path), "--pipeline", "exact",
                                      "--population", "4", "--generations", "1", "--seeds", "1"])
    _, pa = build_specs(args)
    assert pa["pipeline"] == "exact"        # the dict every shard (in process or a Ray task) builds its problem from
    problem = sweep_problem(pa)             # builds the model; traces nothing
    assert problem.meta["pipeline"] == "exact"


def test_pivot_springs_belong_to_the_springs_pipeline(tmp_path, capsys):
    from cpgjax.crosscheck.transfer import variant
    from cpgjax.io.wl import load_model

    assert variant(load_model("models/quadruped.wl"), joint_spring=(1e5, 100)).springs.alpha == 1e5
    with pytest.raises(ValueError, match="exact pipeline, whose joints have none"):
        variant(load_model("models/quadruped.wl", pipeline="exact"), joint_spring=(1e5, 100))
    assert main(["crosscheck", "models/quadruped.wl", "--pipeline", "exact", "--joint-spring", "1e5", "100",
                 "--out", str(tmp_path / "out")]) == 2
    assert "--joint-spring sets the pivot springs" in capsys.readouterr().err
