"""`cpgjax follow --ctl --engine ours|mujoco|both`: the walk in MuJoCo C, its table beside ours, and its bad input."""

from __future__ import annotations

import json

import numpy as np
import pytest

from cpgjax.cli import main

MODEL = "models/quadruped.wl"


def _ctl(path, groups: str, w: float = 0.0) -> str:
    """A closed-loop `.ctl` on the trot's CPG reading ``groups``; ``w``: offsets and modulations per unit of the
    command (the third input), else a policy of zeros."""
    from cpgjax.episode import policy as pol
    from cpgjax.io.ctl import PolicyTable, read_ctl, write_ctl
    from cpgjax.io.wl import load_model

    m = load_model(MODEL)
    fam = pol.parse_controller(groups)
    coeffs = read_ctl("models/quadruped-trot.ctl", n_dof=8, harmonics=2).coeffs
    W = np.zeros((fam.n_out(m), fam.n_in(m)))
    W[:, min(2, fam.n_in(m) - 1)] = w * np.linspace(-0.5, 0.5, fam.n_out(m))
    c = pol.ClosedLoop(fam, coeffs, W.astype(np.float32), np.zeros((), np.float32))
    write_ctl(path, coeffs, policy=PolicyTable(**pol.table_fields(c, m)), exact=True)
    return str(path)


@pytest.mark.parametrize("argv, message", [
    (["--ctl", "models/quadruped-trot.ctl", "--engine", "mujoco"],
     "a controller that reads the commanded turning rate is needed"),
    (["--ctl", "BLIND", "--engine", "both"], "a controller that reads the commanded turning rate is needed"),
    (["--ctl", "a.ctl", "--engine", "warp"], "argument --engine: invalid choice: 'warp'"),
    (["--ctl", "a.ctl", "--mujoco-dt", "0.001"], "--mujoco-dt: with --engine mujoco or both"),
    (["--ctl", "a.ctl", "--mujoco-ground", "mesh"], "--mujoco-ground: with --engine mujoco or both"),
    (["--ctl", "a.ctl", "--engine", "mujoco", "--mujoco-ground", "sand"], "argument --mujoco-ground: invalid choice"),
    (["--repertoire", "r.h5", "--mujoco-ground", "boxes"], "--mujoco-ground: with --ctl only"),
    (["--ctl", "a.ctl", "--mujoco-contact", "per-contact"], "--mujoco-contact: with --engine mujoco or both"),
    (["--ctl", "a.ctl", "--engine", "mujoco", "--mujoco-contact", "soft"], "argument --mujoco-contact: invalid choice"),
    (["--ctl", "a.ctl", "--mujoco-limit", "mujoco"], "--mujoco-limit: with --engine mujoco or both"),
    (["--ctl", "a.ctl", "--engine", "mujoco", "--mujoco-limit", "hard"], "argument --mujoco-limit: invalid choice"),
    (["--repertoire", "r.h5", "--mujoco-limit", "mujoco"], "--mujoco-limit: with --ctl only"),
    (["--ctl", "a.ctl", "--engine", "mujoco", "--mujoco-dt", "0"], "argument --mujoco-dt"),
    (["--ctl", "a.ctl", "--engine", "mujoco", "--video", "VIDEO"], "--video draws our simulator's walk"),
    (["--repertoire", "r.h5", "--engine", "mujoco"], "--engine: with --ctl only"),
    (["--repertoire", "r.h5", "--plot", "w.png"], "--plot: with --ctl only"),
    (["--repertoire", "r.h5", "--mujoco-dt", "0.001"], "--mujoco-dt: with --ctl only"),
    (["--ctl", "HEXAPOD", "--engine", "mujoco"], "made for hexapod.wl, not quadruped.wl"),
    (["--ctl", "SPRINGS", "--engine", "both", "--pipeline", "exact"], "springs"),
])
def test_bad_input_is_one_line_and_writes_nothing(argv, message, tmp_path, capsys):
    blind = _ctl(tmp_path / "blind.ctl", "pmtg:tilt+contact+bias")      # a closed loop that reads no command
    text = open(_ctl(tmp_path / "turn.ctl", "pmtg:tilt+command+steer+bias", 1.0)).read()
    (tmp_path / "turn.ctl").unlink()
    headed = {"HEXAPOD": "# model: hexapod.wl\n", "SPRINGS": "# model: quadruped.wl\n# pipeline: springs\n"}
    for name, head in headed.items():                    # a steering controller whose header names another model
        (tmp_path / f"{name}.ctl").write_text(head + text)                      # or pipeline
    argv = [blind if a == "BLIND" else str(tmp_path / "v.mp4") if a == "VIDEO" else
            str(tmp_path / f"{a}.ctl") if a in headed else a for a in argv]
    rc = main(["follow", MODEL, *argv, "--path", "line:1", "--out", str(tmp_path / "w.json")])
    err = capsys.readouterr().err
    assert rc == 2 and message in err and len(err.strip().splitlines()) == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["HEXAPOD.ctl", "SPRINGS.ctl", "blind.ctl"]


def test_the_walks_in_mujoco_are_measured_and_written_as_ours(tmp_path, capsys):
    """Two paths, 1 s, in MuJoCo C at a step of 1 ms: one row per walk with its engine named, the summary line, and
    the JSON of our walks' fields with the engine and MuJoCo's step."""
    ctl = _ctl(tmp_path / "turn.ctl", "pmtg:tilt+command+steer+bias", 1.0)
    out = tmp_path / "w.json"
    rc = main(["follow", MODEL, "--ctl", ctl, "--path", "line:0.1", "--path", "points:-1,1", "--time", "1",
               "--engine", "mujoco", "--mujoco-dt", "0.001", "--out", str(out)])
    text = capsys.readouterr().out.splitlines()
    assert rc == 0 and len(text) == 3
    assert text[0].startswith(f"{ctl} line:0.1 [MuJoCo C]: finished in 0.0 s, mean distance from the path ")
    assert text[1].startswith(f"{ctl} points:-1,1 [MuJoCo C]: ") and "waypoints 0 of 1" in text[1]
    assert text[2] == "1 of 2 walks finished without a fall in MuJoCo C"
    w = json.loads(out.read_text())
    assert [(x["engine"], x["path"], x["mujoco_dt"]) for x in w] == [("mujoco", "line:0.1", 0.001),
                                                                     ("mujoco", "points:-1,1", 0.001)]
    assert w[0]["finished"] and len(w[0]["trajectory"]) == 1 and len(w[1]["trajectory"]) == 21   # 1 s at 20 Hz
    assert w[1]["command_mean_abs"] == pytest.approx(0.3, abs=1e-9)      # the waypoint 45 deg left: clipped to 0.3


def test_the_plot_draws_each_walk_in_its_panel(tmp_path, capsys):
    """``--plot``: a panel per path, the path's waypoints from the origin and the walk's CM path as written, a
    cross where it fell and a dot where it finished."""
    from cpgjax.plots.steering import walks_figure

    ctl = _ctl(tmp_path / "turn.ctl", "pmtg:tilt+command+steer+bias", 1.0)
    out, png = tmp_path / "w.json", tmp_path / "w.png"
    assert main(["follow", MODEL, "--ctl", ctl, "--path", "line:0.1", "--path", "points:-1,1", "--time", "1",
                 "--engine", "mujoco", "--mujoco-dt", "0.001", "--out", str(out), "--plot", str(png)]) == 0
    assert capsys.readouterr().out.splitlines()[-1] == f"wrote {png}"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    walks = json.loads(out.read_text())
    axes = walks_figure(walks).axes
    assert [a.get_title().split("\n")[0] for a in axes] == ["line:0.1", "points:-1,1"]
    for ax, w in zip(axes, walks, strict=True):
        path, walk = ax.lines[0], ax.lines[1]
        np.testing.assert_array_equal(path.get_xydata(), [[0.0, 0.0], *w["waypoint_xy"]])
        np.testing.assert_array_equal(walk.get_xydata(), w["trajectory"])
        assert walk.get_label() == "MuJoCo C"
    assert axes[0].lines[2].get_marker() == "o" and len(axes[1].lines) == 2       # finished; ran out of time
    assert "MuJoCo C: finished" in axes[0].get_title() and "did not finish" in axes[1].get_title()
    fell = walks[1] | {"fell": 0.5}
    assert walks_figure([fell]).axes[0].lines[2].get_marker() == "x"
    with pytest.raises(ValueError, match="no walks"):
        walks_figure([])


def test_mujocos_contact_law_reaches_the_walk_and_ends_with_it(tmp_path, monkeypatch):
    """``--mujoco-contact per-contact``: MuJoCo C's run steps under that law (crosscheck.impedance), and the
    export's law is back once the command has ended."""
    from cpgjax.crosscheck import engines
    from cpgjax.crosscheck.impedance import current_law

    seen, real = [], engines.stepper
    monkeypatch.setattr(engines, "stepper", lambda *a: seen.append(current_law()) or real(*a))
    ctl = _ctl(tmp_path / "turn.ctl", "pmtg:tilt+command+steer+bias", 1.0)
    out = tmp_path / "w.json"
    assert main(["follow", MODEL, "--ctl", ctl, "--path", "line:0.1", "--time", "0.2", "--engine", "mujoco",
                 "--mujoco-dt", "0.001", "--mujoco-contact", "per-contact", "--out", str(out)]) == 0
    assert seen == ["per-contact"] and current_law() == "resting"
    assert json.loads(out.read_text())[0]["mujoco_contact"] == "per-contact"


@pytest.mark.slow   # 20 s of CPU, most of it compiling our steered episode
def test_both_engines_walk_each_path_side_by_side(tmp_path, capsys):
    """`--engine both`: per walk our row, then MuJoCo's; our walk as `--engine ours` writes it, bit for bit."""
    ctl = _ctl(tmp_path / "turn.ctl", "pmtg:tilt+command+steer+bias", 1.0)
    args = ["follow", MODEL, "--ctl", ctl, "--path", "circle:1", "--path", "points:1,1", "--time", "1"]
    assert main([*args, "--out", str(tmp_path / "ours.json")]) == 0
    capsys.readouterr()
    assert main([*args, "--engine", "both", "--out", str(tmp_path / "both.json")]) == 0
    text = capsys.readouterr().out.splitlines()
    assert [line.split(": ", 1)[0] for line in text[:4]] == [
        f"{ctl} circle:1 [ours]", f"{ctl} circle:1 [MuJoCo C]", f"{ctl} points:1,1 [ours]",
        f"{ctl} points:1,1 [MuJoCo C]"]
    assert text[4].endswith("walks finished without a fall in our simulator") and text[5].endswith("in MuJoCo C")
    ours, both = json.loads((tmp_path / "ours.json").read_text()), json.loads((tmp_path / "both.json").read_text())
    assert [x["engine"] for x in both] == ["ours", "mujoco", "ours", "mujoco"]
    assert [{k: v for k, v in x.items() if k != "engine"} for x in both[::2]] == ours


def test_on_rough_ground_mujocos_default_step_is_flagged(tmp_path, capsys):
    """The model's own rough field in MuJoCo C at the export's 2 ms: the note that names 0.00025 s, as `transfer`'s;
    given a step, no note."""
    from pathlib import Path

    wl = tmp_path / "rough.wl"
    wl.write_text(Path(MODEL).read_text().replace("Terrain       flat", "Terrain       rough 0.02"))
    ctl = _ctl(tmp_path / "turn.ctl", "pmtg:tilt+command+steer+bias")
    for dt, noted in ((None, True), ("0.001", False)):
        rc = main(["follow", str(wl), "--ctl", ctl, "--path", "line:0.1", "--time", "0.1", "--engine", "mujoco",
                   *(["--mujoco-dt", dt] if dt else [])])
        out = capsys.readouterr()
        assert rc == 0 and ("--mujoco-dt 0.00025" in out.err) == noted and "[MuJoCo C]: finished in 0.0 s" in out.out
