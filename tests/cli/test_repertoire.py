"""The repertoire, adapt, follow and repertoire-plot commands, at tiny scale (0.2 s episodes, 32 evaluations)."""

from __future__ import annotations

import json

import pytest

from cpgjax.cli import main

MODEL = "models/quadruped.wl"
TINY = ["--time", "0.2", "--evaluations", "32", "--batch", "16", "--chunk", "2", "--quiet"]


@pytest.fixture(scope="module")
def duty(tmp_path_factory):
    out = tmp_path_factory.mktemp("rep") / "duty.h5"
    assert main(["repertoire", MODEL, "--cells", "3", *TINY, "--out", str(out)]) == 0
    return out


def test_repertoire_writes_a_file_that_adapt_plot_and_resume_read(duty, tmp_path, capsys):
    capsys.readouterr()
    rc = main(["adapt", MODEL, "--repertoire", str(duty), "--damage", "leg=AR", "--trials", "3",
               "--out", str(tmp_path / "a.json")])
    out = capsys.readouterr().out
    assert rc == 0 and "trial  1: cell" in out and "leg=AR: best" in out
    r = json.loads((tmp_path / "a.json").read_text())
    assert 1 <= len(r["trials"]) <= 3 and r["damage"] == "leg=AR"
    assert r["best_fitness"] == max(t["fitness"] for t in r["trials"])
    assert main(["repertoire-plot", str(duty), "--out", str(tmp_path / "f.png")]) == 0
    assert (tmp_path / "f.png").stat().st_size > 1000
    # --resume with a larger budget continues it; with another grid it is refused
    assert main(["repertoire", MODEL, "--evaluations", "48", "--out", str(duty), "--resume", "--quiet"]) == 0
    assert "3 generations x 16 evaluations" in capsys.readouterr().out
    assert main(["repertoire", MODEL, "--cells", "4", "--out", str(duty), "--resume", "--quiet"]) == 2
    assert "cannot resume: --cells" in capsys.readouterr().err


def test_adapt_takes_the_offset_option(duty, tmp_path):
    for flag, want in (("--offset", True), ("--no-offset", False)):
        out = tmp_path / f"{flag}.json"
        assert main(["adapt", MODEL, "--repertoire", str(duty), "--damage", "leg=AR", "--trials", "2", flag,
                     "--out", str(out)]) == 0
        r = json.loads(out.read_text())
        assert r["config"]["offset"] is want and 1 <= len(r["trials"]) <= 2


def test_adapt_takes_the_space_option_and_fits_rho_outside_the_descriptor_space_unless_given(duty, tmp_path):
    from cpgjax.experiments.adapt import FIT_NOISES, FIT_RHOS

    out = tmp_path / "g.json"
    assert main(["adapt", MODEL, "--repertoire", str(duty), "--damage", "leg=AR", "--trials", "2", "--space",
                 "genome", "--out", str(out)]) == 0
    r = json.loads(out.read_text())
    assert r["space"] == "genome" and r["config"]["rho"] in FIT_RHOS and r["config"]["noise"] in FIT_NOISES
    assert main(["adapt", MODEL, "--repertoire", str(duty), "--damage", "leg=AR", "--trials", "2", "--space",
                 "genome", "--rho", "0.77", "--out", str(out)]) == 0
    r = json.loads(out.read_text())
    assert r["config"]["rho"] == 0.77 and r["config"]["noise"] == 1e-3 and 1 <= len(r["trials"]) <= 2
    assert main(["adapt", MODEL, "--repertoire", str(duty), "--damage", "leg=AR", "--trials", "2", "--space",
                 "both", "--out", str(out)]) == 0
    r = json.loads(out.read_text())
    assert r["space"] == "both" and r["config"]["rho"] in FIT_RHOS


@pytest.mark.slow
def test_the_study_compares_ite_with_the_ga_from_scratch(duty, tmp_path, capsys):
    capsys.readouterr()
    rc = main(["adapt", MODEL, "--repertoire", str(duty), "--damage", "leg=AR", "--damage", "weak=KneePL:0.2",
               "--study", "--ga-generations", "2", "--out", str(tmp_path / "s.json")])
    out = capsys.readouterr().out
    assert rc == 0 and "median IT&E trials" in out and "median GA evaluations" in out
    rows = json.loads((tmp_path / "s.json").read_text())["rows"]
    assert [r["damage"] for r in rows] == ["leg=AR", "weak=KneePL:0.2"]
    for r in rows:
        assert r["ite_best"] <= r["R"] and r["ga_budget"] == 40 and r["ite_trials"] is not None
        assert len(r["scores"]) == r["elites"] and max(v for v in r["scores"] if v is not None) == r["R"]


@pytest.mark.parametrize("argv, message", [
    (["repertoire", MODEL, "--cells", "0"], "argument --cells: expected bins per dimension"),
    (["repertoire", MODEL, "--bounds", "1:0"], "argument --bounds: expected LO:HI"),
    (["repertoire", MODEL, "--cells", "3x3", "--evaluations", "16", "--batch", "16"], "--cells gives 2 numbers"),
    (["repertoire", MODEL, "--damage", "leg=ZZ", *TINY], "no leg 'ZZ'; the model's legs are AR, AL, PR, PL"),
    (["adapt", MODEL, "--repertoire", "missing.h5", "--damage", "leg=AR"], "missing.h5: no such file"),
    (["follow", MODEL, "--repertoire", "r.h5", "--path", "line:1", "--lookahead", "-1"], "argument --lookahead"),
    (["follow", MODEL, "--repertoire", "r.h5", "--path", "line:1", "--safe-tilt", "0"], "argument --safe-tilt"),
    (["follow", MODEL, "--ctl", "models/quadruped-trot.ctl", "--path", "line:1"],
     "a controller that reads the commanded turning rate is needed"),
    (["follow", MODEL, "--repertoire", "r.h5", "--path", "line:1", "--gain", "2"], "--gain: with --ctl only"),
    (["follow", MODEL, "--ctl", "a.ctl", "--path", "line:1", "--lookahead", "4"],
     "--lookahead: with --repertoire only"),
    (["follow", MODEL, "--ctl", "a.ctl", "--path", "line:1", "--limit", "0"], "argument --limit"),
    (["evolve", MODEL, "--evaluation", "robust", "--perturb", "command=0.4", "--generations", "1"],
     "perturbation command: the controller must read the command"),
])
def test_bad_input_is_one_line(argv, message, tmp_path, capsys):
    rc = main([*argv, "--out", str(tmp_path / "x.h5")] if argv[0] in ("repertoire", "evolve") else argv)
    err = capsys.readouterr().err
    assert rc == 2 and message in err and len(err.strip().splitlines()) == 1


def test_follow_needs_a_speed_turn_repertoire(duty, capsys):
    assert main(["follow", MODEL, "--repertoire", str(duty), "--path", "square:1"]) == 2
    assert "needs a speed-turn repertoire" in capsys.readouterr().err


@pytest.mark.slow
def test_follow_walks_with_a_speed_turn_repertoire(tmp_path, capsys):
    rep = tmp_path / "st.h5"
    assert main(["repertoire", MODEL, "--descriptor", "speed-turn", "--cells", "4", *TINY, "--out", str(rep)]) == 0
    for la in ("0", "16"):      # the nearest-turn rule, and the look-ahead over 16 candidates
        rc = main(["follow", MODEL, "--repertoire", str(rep), "--path", "line:5", "--cycles", "1",
                   "--lookahead", la, "--out", str(tmp_path / "w.json")])
        out = capsys.readouterr().out
        assert rc == 0 and "line:5: did not finish" in out
        w = json.loads((tmp_path / "w.json").read_text())
        g = w["gaits"][0]
        assert w["cycles"] == 1 and len(w["trajectory"]) == 41 and g["want_turn"] == pytest.approx(0, abs=1e-3)
        assert w["lookahead"] == int(la) and (g["safe"] is None if la == "0" else 0 <= g["safe"] <= 16)
    from cpgjax.experiments.follow import follow

    r = follow(MODEL, str(rep), "line:5", cycles=1, lookahead=16, replay=True)     # the chosen gait walked alone
    assert r["cycles"] == 1 and len(r["trajectory"]) == 41 and r["gaits"][0]["cell"] == w["gaits"][0]["cell"]
    r = follow(MODEL, str(rep), "line:5", cycles=1, lookahead=8, copies=2)       # judged by the worse of 2 copies
    assert r["cycles"] == 1 and 0 <= r["gaits"][0]["safe"] <= 8


@pytest.mark.slow   # 20 s of CPU, most of it compiling the steered episode
def test_follow_walks_every_path_with_every_steering_controller_in_one_episode(tmp_path, capsys):
    """`cpgjax follow --ctl`: two controllers x two paths, each walk one robot of one batch, measured and written."""
    import numpy as np

    from cpgjax.episode import policy as pol
    from cpgjax.io.ctl import PolicyTable, read_ctl, write_ctl
    from cpgjax.io.wl import load_model

    m = load_model(MODEL)
    fam = pol.parse_controller("pmtg:tilt+command+steer+bias")
    coeffs = read_ctl("models/quadruped-trot.ctl", n_dof=8, harmonics=2).coeffs
    for name, w in (("zero", 0.0), ("turn", 1.0)):
        W = np.zeros((fam.n_out(m), fam.n_in(m)))
        W[:, 2] = w * np.linspace(-0.5, 0.5, fam.n_out(m))         # offsets and modulations per unit of command
        c = pol.ClosedLoop(fam, coeffs, W.astype(np.float32), np.zeros((), np.float32))
        write_ctl(tmp_path / f"{name}.ctl", coeffs, policy=PolicyTable(**pol.table_fields(c, m)), exact=True)
    out = tmp_path / "walks.json"
    rc = main(["follow", MODEL, "--ctl", str(tmp_path / "zero.ctl"), "--ctl", str(tmp_path / "turn.ctl"),
               "--path", "line:0.1", "--path", "circle:2", "--time", "1", "--out", str(out)])
    text = capsys.readouterr().out
    assert rc == 0 and "of 4 walks finished without a fall" in text
    w = json.loads(out.read_text())
    assert [(x["ctl"].endswith("zero.ctl"), x["path"]) for x in w] == [
        (True, "line:0.1"), (True, "circle:2"), (False, "line:0.1"), (False, "circle:2")]
    assert w[0]["finished"] and w[0]["reached"] == 1 and w[0]["time"] < 1.0      # 0.1 m: passed at once
    assert w[1]["command_mean_abs"] > 0.1 and len(w[1]["trajectory"]) == 21       # 1 s at 20 Hz, t = 0 included
