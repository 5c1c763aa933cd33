"""The command line (cpgjax/cli.py): simulate, logs and bad input."""

import numpy as np
import pytest

from cpgjax.cli import main
from cpgjax.io.logs import read_log


def test_simulate_trot_prints_the_metrics_and_writes_thesis_logs(tmp_path, capsys):
    # the suite's tiny episode (tests/runcases.py: TINY_TIME), recorded: the program of episode/test_rollout.py
    rc = main(["simulate", "models/quadruped.wl", "--ctl", "models/quadruped-trot.ctl", "--time", "0.3",
               "--log", str(tmp_path)])
    out = capsys.readouterr().out
    assert rc == 0
    for word in ("distance", "speed", "tilt", "fitness"):
        assert word in out
    log = tmp_path / "body.log"
    lines = log.read_text().splitlines()
    assert lines[0] == "# Log file for compound Body"
    assert lines[1] == "# quadruped.wl quadruped-trot.ctl"
    rows = read_log(log)
    assert rows.shape == (7, 7)  # LogRate 20 for 0.3 s, from t = 0: T X Y Z theta phi psi
    assert rows[0, 0] == 0.0 and rows[-1, 0] == pytest.approx(0.3, abs=1e-6)
    np.testing.assert_allclose(np.diff(rows[:, 0]), 0.05, atol=1e-4)


def test_malformed_wl_reports_path_and_line(tmp_path, capsys):
    bad = tmp_path / "bad.wl"
    bad.write_text("TimeMax 2\nObject A {\n    Type Cube\n    Mass heavy\n    Dimensions .1 .1 .1\n}\n")
    rc = main(["simulate", str(bad)])
    err = capsys.readouterr().err
    assert rc == 2
    assert f"{bad}:4:" in err


def test_malformed_ctl_reports_path_and_line(tmp_path, capsys):
    bad = tmp_path / "bad.ctl"
    text = open("models/quadruped-trot.ctl").read().splitlines()
    data = [i for i, line in enumerate(text) if line.strip() and not line.startswith("#")]
    i = data[3]                                    # the third coefficient row (after the fitness line)
    text[i] = text[i].replace("0.000000", "zero", 1)
    bad.write_text("\n".join(text) + "\n")
    rc = main(["simulate", "models/quadruped.wl", "--ctl", str(bad), "--time", "0.1"])
    err = capsys.readouterr().err
    assert rc == 2 and f"{bad}:{i + 1}:" in err


def test_wrong_number_of_dofs_in_ctl(tmp_path, capsys):
    bad = tmp_path / "short.ctl"
    bad.write_text("0.0\n" + "0 0 0 0 0\n" * 7)
    rc = main(["simulate", "models/quadruped.wl", "--ctl", str(bad)])
    assert rc == 2 and str(bad) in capsys.readouterr().err


def test_missing_file_is_a_clear_error(capsys):
    assert main(["simulate", "models/nope.wl"]) == 2
    assert "nope.wl" in capsys.readouterr().err


def test_perturb_values_are_read_by_the_type_of_their_field():
    import argparse

    from cpgjax.cli.options import perturbations

    got = perturbations("replicas=3, fall_survival=on, fall-ends=off, jitter=1e-4")
    assert got == {"replicas": 3, "fall_survival": True, "fall_ends": False, "jitter": 1e-4}
    assert type(got["replicas"]) is int and type(got["jitter"]) is float
    for bad, why in (("replicas=2.5", "replicas: expected a whole number"), ("mass=2", "must be < 1"),
                     ("fall_zero=on,fall_survival=on", "exclude each other"), ("wind=3", "KEY in")):
        with pytest.raises(argparse.ArgumentTypeError, match=why):
            perturbations(bad)
