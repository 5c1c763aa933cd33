"""Controllers that carry their provenance: `best` writes a header, and the commands that replay a `.ctl` take its
pipeline and episode length unless told otherwise, say so first, and refuse a header made for another model or
contradicted by --pipeline (docs/ctl-format.md)."""

from __future__ import annotations

import os
import re

import numpy as np
import pytest

from cpgjax.cli import main
from cpgjax.io.ctl import read_ctl
from cpgjax.io.results import read_run

TROT = "models/quadruped-trot.ctl"


def headed(tmp_path, header: str, name: str = "h.ctl") -> str:
    """The trot's numbers with ``header`` (``key: value`` lines, ``;``-separated) as their header."""
    p = tmp_path / name
    p.write_text("".join(f"# {line}\n" for line in header.split(";"))
                 + "".join(line for line in open(TROT) if not line.startswith("#")))
    return str(p)


def test_best_writes_the_header_and_simulate_replays_on_it(tiny_runs, tmp_path, capsys):
    run = tiny_runs["thesis"]
    ctl = str(tmp_path / "best.ctl")
    assert main(["best", run, "--ctl", ctl]) == 0
    gen, _, fit, _ = read_run(run).best()
    assert (f"replay: the thesis evaluation scores one unperturbed episode, as a replay (cpgjax simulate) does: it "
            f"scores {fit:.6f} again") in capsys.readouterr().out.splitlines()
    h = read_ctl(ctl).header
    assert (h.models, h.pipeline, h.controller, h.time, h.terrain, h.run) == (
        ("quadruped.wl",), "springs", "cpg", 0.3, "flat", run)
    assert h.picked == f"best of generation {gen} (thesis score {fit:.4g}, one unperturbed episode)"
    assert open(ctl).readline() == "# model: quadruped.wl\n"
    # no --time: the header's 0.3 s, the very episode the GA scored (the suite's tiny replay program)
    assert main(["simulate", "models/quadruped.wl", "--ctl", ctl]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0] == f"header    {ctl}: pipeline springs, 0.3 s, terrain flat; from {run}"
    assert "time      0.3 s" in out
    replay = float(re.search(r"fitness\s+([-+0-9.e]+)", "\n".join(out)).group(1))
    assert abs(replay - fit) < 1e-5, (replay, fit)


def test_a_robust_best_says_why_a_replay_scores_otherwise(tiny_runs, tmp_path, capsys):
    run = tiny_runs["robust"]
    assert main(["best", run, "--ctl", str(tmp_path / "b.ctl")]) == 0
    _, _, fit, _ = read_run(run).best()
    assert (f"replay: {fit:.6f} is the robust evaluation's score, the mean of 2 perturbed episodes; a replay (cpgjax "
            "simulate) is one unperturbed episode, so it scores otherwise") in capsys.readouterr().out.splitlines()
    assert read_ctl(tmp_path / "b.ctl").header.picked.endswith(", mean of 2 perturbed episodes)")


@pytest.fixture
def episode(monkeypatch):
    """``cpgjax simulate``'s episode replaced by a record of what it was asked (no physics runs)."""
    import cpgjax.episode.batch as batch

    seen = {}

    def fake(model, coeffs, *, time=None, delta=8.0, record=False, **_):
        seen.update(pipeline=model.pipeline, time=time, terrain=model.terrain.spec)
        zero = np.float32(0.0)
        return {"distance": zero, "speed": zero, "tilt": zero, "fitness": zero, "fallen": np.bool_(False),
                "diverged": np.bool_(False), "pivot_err": zero}

    monkeypatch.setattr(batch, "simulate", fake)
    return seen


def test_simulate_takes_the_pipeline_time_and_terrain_from_the_header(tmp_path, capsys, episode):
    ctl = headed(tmp_path, "model: quadruped.wl;pipeline: exact;time: 5;terrain: bump:0.02;run: runs/q.h5")
    assert main(["simulate", "models/quadruped.wl", "--ctl", ctl]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0] == f"header    {ctl}: pipeline exact, 5 s, terrain bump:0.02; from runs/q.h5"
    assert episode == {"pipeline": "exact", "time": 5.0, "terrain": "bump:0.02"}
    assert main(["simulate", "models/quadruped.wl", "--ctl", ctl, "--time", "1", "--pipeline", "exact"]) == 0
    assert capsys.readouterr().out.splitlines()[0] == (f"header    {ctl}: --time 1 instead of its 5 s, terrain "
                                                       "bump:0.02; from runs/q.h5")
    assert episode["time"] == 1.0
    # a header without settings (the hand-written trot's: any pipeline) changes nothing and says nothing
    assert main(["simulate", "models/quadruped.wl", "--ctl", TROT]) == 0
    assert capsys.readouterr().out.startswith("model     models/quadruped.wl")
    assert episode == {"pipeline": "springs", "time": 10.0, "terrain": "flat"}


@pytest.mark.parametrize("argv,says", [
    (["simulate", "models/quadruped.wl", "--pipeline", "springs", "--log", "logs"],
     "h.ctl:2: its header says pipeline exact; --pipeline springs contradicts it (leave --pipeline out to use the "
     "header's)"),
    (["simulate", "models/hexapod.wl", "--log", "logs"],
     "h.ctl:1: made for quadruped.wl, not hexapod.wl (its header's '# model:' line; model files are compared by "
     "name)"),
    (["robustness", "models/quadruped.wl", "--pipeline", "springs"], "contradicts it"),
    (["render", "models/hexapod.wl", "--out", "w.mp4"], "made for quadruped.wl, not hexapod.wl"),
    (["crosscheck", "models/quadruped.wl", "--pipeline", "springs", "--out", "cc"], "contradicts it"),
    (["follow", "models/quadruped.wl", "--path", "line:1", "--pipeline", "springs"], "contradicts it"),
    (["study-dt", "models/hexapod.wl"], "made for quadruped.wl, not hexapod.wl"),
])
def test_a_header_made_for_another_model_or_pipeline_is_refused_in_one_line(argv, says, tmp_path, monkeypatch,
                                                                            capsys):
    monkeypatch.chdir(tmp_path)
    os.symlink(os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))), "models"),
               "models")
    headed(tmp_path, "model: quadruped.wl;pipeline: exact")
    assert main([*argv, "--ctl", "h.ctl"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and says in err, err
    assert sorted(os.listdir(tmp_path)) == ["h.ctl", "models"]       # nothing written


def test_controllers_with_headers_that_disagree_are_cross_checked_separately(tmp_path, capsys):
    a = headed(tmp_path, "pipeline: exact", "a.ctl")
    b = headed(tmp_path, "pipeline: springs", "b.ctl")
    assert main(["crosscheck", "models/quadruped.wl", "--ctl", a, b, "--out", str(tmp_path / "cc")]) == 2
    assert "disagree on the pipeline" in capsys.readouterr().err
    assert not os.path.exists(tmp_path / "cc")


def test_render_and_follow_take_the_header_pipeline(tmp_path, capsys, monkeypatch):
    import cpgjax.experiments.steer as steer
    import cpgjax.render.movie as movie

    seen = {}

    def video(model, coeffs, out, *, time=None, **_):
        seen.update(pipeline=model.pipeline, time=time)
        open(out, "wb").close()
        return {"frames": 1, "size": (16, 16), "fps": 30.0, "seconds": time, "backend": "-", "episodes": []}

    monkeypatch.setattr(movie, "render_video", video)
    ctl = headed(tmp_path, "model: quadruped.wl;pipeline: exact;time: 2")
    assert main(["render", "models/quadruped.wl", "--ctl", ctl, "--out", str(tmp_path / "w.mp4")]) == 0
    assert capsys.readouterr().out.splitlines()[0] == f"header: {ctl}: pipeline exact, 2 s"
    assert seen == {"pipeline": "exact", "time": 2.0}
    monkeypatch.setattr(steer, "walks", lambda *a, pipeline=None, time=None, **k: seen.update(follow=(pipeline, time))
                        or [])
    assert main(["follow", "models/quadruped.wl", "--ctl", ctl, "--path", "line:1"]) == 0
    assert capsys.readouterr().out.splitlines()[0] == f"header: {ctl}: pipeline exact"      # its time: the walk's
    assert seen["follow"] == ("exact", steer.TIME)
    monkeypatch.setattr(steer, "walks", lambda *a, limit=None, **k: seen.update(limit=limit) or [])
    assert main(["follow", "models/quadruped.wl", "--ctl", ctl, "--path", "line:1"]) == 0
    assert seen["limit"] == steer.LIMIT                                   # no command range said: the default
    steering = headed(tmp_path, "model: quadruped.wl;pipeline: exact;command: 0.4")
    capsys.readouterr()
    assert main(["follow", "models/quadruped.wl", "--ctl", steering, "--path", "line:1"]) == 0
    assert capsys.readouterr().out.splitlines()[0] == f"header: {steering}: pipeline exact, --limit 0.4 rad/s (its " \
                                                      "command range)"
    assert seen["limit"] == 0.4
    assert main(["follow", "models/quadruped.wl", "--ctl", steering, "--path", "line:1", "--limit", "0.2"]) == 0
    assert seen["limit"] == 0.2


def test_transfer_points_a_controller_to_its_run(tmp_path, capsys):
    ctl = headed(tmp_path, "model: quadruped.wl;run: runs/quickstart.h5")
    assert main(["transfer", ctl]) == 2
    assert capsys.readouterr().err.strip().endswith("its header names its run: cpgjax transfer runs/quickstart.h5")
