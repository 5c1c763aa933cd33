"""``cpgjax servo``: the summary as one JSON object, the files, and bad input."""

from __future__ import annotations

import json

from cpgjax.cli import main


def test_servo_json_and_files(tmp_path, capsys):
    out = tmp_path / "servo"
    rc = main(["servo", "models/quadruped.wl", "--freqs", "1,8,16,24,32,48", "--amps", "0.2", "--settle", "0.2",
               "--periods", "1", "--json", "--out", str(out)])
    assert rc == 0
    s = json.loads(capsys.readouterr().out)
    assert s["joint"] == "KneeAR" and s["thesis_cutoff_hz"] == 0.74 and s["amps"] == [0.2]
    assert 5.0 < s["penalty_cutoff_hz"][0] < 60.0 and 5.0 < s["mujoco_cutoff_hz"][0] < 60.0
    assert s["tau_max"] == 17.5 and s["kp"] == 60.0
    for f in ("servo.json", "servo.md", "fig-6-1.png", "fig-6-2.png"):
        assert (out / f).stat().st_size > 0
    assert "cut-off" in (out / "servo.md").read_text()


def test_servo_bad_input(tmp_path, capsys):
    assert main(["servo", "models/quadruped.wl", "--joint", "Elbow", "--no-mujoco"]) == 2
    err = capsys.readouterr().err
    assert "no joint 'Elbow'" in err and len(err.strip().splitlines()) == 1
    assert main(["servo", "models/quadruped.wl", "--freqs", "0.005,1,2", "--no-mujoco"]) == 2
    assert "0.005 Hz needs a 400.5 s episode" in capsys.readouterr().err
    assert main(["servo", "--freqs", "1,-2"]) == 2
