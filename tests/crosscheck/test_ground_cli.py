"""``export --ground``, ``crosscheck --mujoco-ground`` and ``transfer --mujoco-ground``: the ground's form reaches
every MuJoCo C model those commands build, and MJX keeps the heightfield."""

from __future__ import annotations

import json

import numpy as np
import pytest

from cpgjax import cli
from cpgjax.crosscheck import engines
from cpgjax.crosscheck.ground import current_form


def test_export_writes_the_form_asked_for(tmp_path, capsys):
    out = tmp_path / "q.xml"
    # the boxes: MuJoCo loads them in a quarter of the mesh form's time (docs/crosscheck.md); every form's surface is
    # crosscheck/test_ground.py's
    assert cli.main(["export", "models/quadruped.wl", "--terrain", "rough:0.02", "--ground", "boxes",
                     "--out", str(out)]) == 0
    text = out.read_text()
    assert 'name="ground_b0" type="box"' in text and 'name="ground"' in text      # the pieces, the field around them
    assert cli.main(["export", "models/quadruped.wl", "--terrain", "rough:0.02", "--out", str(tmp_path / "h.xml")]) == 0
    assert 'name="ground_b0"' not in (tmp_path / "h.xml").read_text()
    capsys.readouterr()
    assert cli.main(["export", "models/quadruped.wl", "--ground", "plane", "--out", str(tmp_path / "p.xml")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--ground" in err and "'plane'" in err


def _spy(monkeypatch, module):
    """Record the ground form in effect at every ``load`` of ``module``."""
    seen, real = [], module.load

    def load(model, **kw):
        mj = real(model, **kw)
        seen.append("mesh" if mj.nmesh else "boxes" if "ground_b0" in [mj.geom(i).name for i in range(min(
            mj.ngeom, 400))] else current_form())
        return mj
    monkeypatch.setattr(module, "load", load)
    return seen


@pytest.mark.slow
def test_crosscheck_runs_mujoco_on_the_form_asked_for(tmp_path, capsys, monkeypatch):
    """MuJoCo C on boxes: the crosscheck's MuJoCo distance is the one of a direct run on boxes (0.2 s)."""
    from cpgjax.crosscheck.mjcf import load
    from cpgjax.io.ctl import read_ctl
    from cpgjax.io.wl import load_model

    seen = _spy(monkeypatch, engines)
    out = tmp_path / "cc"
    assert cli.main(["crosscheck", "models/quadruped.wl", "--ctl", "models/quadruped-trot.ctl", "--random", "0",
                     "--perturbed", "0", "--no-mjx", "--no-ceiling", "--time", "0.2", "--terrain", "rough:0.02",
                     "--mujoco-ground", "boxes", "--mujoco-dt", "0.002", "--pipeline", "exact",
                     "--out", str(out)]) == 0
    assert "MuJoCo C's ground: boxes" in capsys.readouterr().out
    assert seen and set(seen) == {"boxes"}
    row = json.loads((out / "crosscheck.json").read_text())["controllers"][0]
    m = load_model("models/quadruped.wl", terrain="rough:0.02", pipeline="exact")
    trot = read_ctl("models/quadruped-trot.ctl", n_dof=8, harmonics=2).coeffs
    met, _, _ = engines.mujoco_run(m, trot[None], time=0.2, mj=load(m, ground="boxes"))
    assert row["mujoco_distance"] == pytest.approx(float(met["distance"][0]), abs=1e-9)
    assert current_form() == "hfield"                       # the block ended with the command


@pytest.fixture(scope="module")
def runs(tiny_runs):
    tiny_runs["thesis"]
    return tiny_runs.folder


@pytest.mark.slow
def test_transfer_replays_mujoco_on_the_form_asked_for(runs, capsys, monkeypatch):
    from cpgjax.crosscheck import transfer

    seen = _spy(monkeypatch, transfer)
    assert cli.main(["transfer", str(runs / "thesis.h5"), "--replays", "1", "--terrain", "rough:0.02",
                     "--mujoco-dt", "0.002", "--mujoco-ground", "mesh", "--json"]) == 0
    summary = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert summary["mujoco_ground"] == "mesh" and seen and set(seen) == {"mesh"}
    assert np.isfinite(summary["runs"])
