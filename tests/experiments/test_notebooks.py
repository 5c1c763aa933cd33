"""The notebooks execute end to end at tiny scale (cpgjax.experiments.notebook: nbclient, a kernel of this
interpreter).  The stability notebook is marked slow (`make test-all`)."""

from __future__ import annotations

import os

import pytest

from cpgjax import cli

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
NOTEBOOK = os.path.join(ROOT, "notebooks", "thesis_figures.ipynb")


def _thesis_figures_tiny(tmp_path) -> list[str]:
    """Executes notebooks/thesis_figures.ipynb at tiny scale into ``tmp_path``; returns its command's arguments."""
    pytest.importorskip("nbclient")
    pytest.importorskip("ipykernel")
    executed = tmp_path / "executed.ipynb"
    args = ["notebook", NOTEBOOK, "--scale", "tiny", "--sweep-dir", str(tmp_path / "sweep"),
            "--fig-dir", str(tmp_path / "figures"), "--out", str(executed)]
    assert cli.main(args) == 0
    figs = sorted(os.listdir(tmp_path / "figures"))
    assert figs == sorted([f"fig-6-{i}.png" for i in range(5, 13)] + ["best-gait.gif"])   # and the best gait, drawn
    assert all(os.path.getsize(tmp_path / "figures" / f) > 10_000 for f in figs)
    report = (tmp_path / "sweep" / "report.md").read_text()
    assert "more than doubles" in report and "factor of 2" in report
    text = executed.read_text()
    assert "scale tiny" in text and "Traceback" not in text
    assert '"image/gif"' in text                     # the video is shown inline
    assert os.environ.get("CPGJAX_SCALE") is None          # the settings do not leak into this process
    return args


def test_thesis_figures_notebook_tiny(tmp_path):
    _thesis_figures_tiny(tmp_path)


@pytest.mark.slow  # a second kernel (8 s of CPU); `make test-all` runs it
def test_thesis_figures_notebook_run_again_finds_the_sweep_complete_and_only_redraws(tmp_path):
    args = _thesis_figures_tiny(tmp_path)
    sweep_files = {p: os.path.getmtime(p) for p in (tmp_path / "sweep").rglob("*.h5")}
    assert cli.main([*args, "--no-save"]) == 0
    assert {p: os.path.getmtime(p) for p in (tmp_path / "sweep").rglob("*.h5")} == sweep_files   # not one run rewritten


def test_a_notebook_is_saved_under_runs_and_a_failing_one_names_the_error(tmp_path, monkeypatch, capsys):
    nbformat = pytest.importorskip("nbformat")
    pytest.importorskip("ipykernel")
    monkeypatch.chdir(tmp_path)
    (tmp_path / "notebooks").mkdir()
    good = tmp_path / "notebooks" / "good.ipynb"
    nbformat.write(nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell("print(6 * 7)")]), str(good))
    before = good.read_bytes()
    assert cli.main(["notebook", str(good), "--scale", "tiny"]) == 0
    assert good.read_bytes() == before                       # the notebook in notebooks/ is left as it was
    saved = tmp_path / "runs" / "notebooks" / "good-tiny.ipynb"
    assert "42" in saved.read_text() and str(saved.relative_to(tmp_path)) in capsys.readouterr().out
    nb = nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell("x = 1"),
                                         nbformat.v4.new_code_cell("raise ValueError('no sweep here')")])
    path = tmp_path / "bad.ipynb"
    nbformat.write(nb, str(path))
    assert cli.main(["notebook", str(path), "--no-save"]) == 1
    assert "no sweep here" in capsys.readouterr().err


@pytest.mark.slow  # 33 s of CPU, most of it compiling its courses; `make test-all` runs it
def test_stability_notebook_tiny(tmp_path):
    """notebooks/stability.ipynb (Figs. 6.13-6.21, the population study, claims) at tiny scale (its parts run in
    the fast suite: tests/experiments/test_stability.py; the notebook command: the two other notebooks)."""
    pytest.importorskip("nbclient")
    pytest.importorskip("ipykernel")
    executed = tmp_path / "executed.ipynb"
    args = ["notebook", os.path.join(ROOT, "notebooks", "stability.ipynb"), "--scale", "tiny",
            "--sweep-dir", str(tmp_path / "sweep"), "--fig-dir", str(tmp_path / "figures"), "--out", str(executed)]
    assert cli.main(args) == 0
    figs = sorted(os.listdir(tmp_path / "figures"))
    want = [f"fig-6-{i}.png" for i in range(13, 22)] + ["population.png", "population-time.png", "claims.md",
                                                         "population.md"]
    assert figs == sorted(want)
    claims = (tmp_path / "figures" / "claims.md").read_text()
    assert "hexapod" in claims and claims.count("**") >= 16        # a verdict in every row
    text = executed.read_text()
    assert "scale tiny" in text and "Traceback" not in text


@pytest.mark.slow  # 13 s; fast: the thesis notebook (cpgjax notebook), the cut-off in analysis/test_cutoff.py
def test_validation_notebook_tiny(tmp_path):
    """notebooks/validation.ipynb (Figs. 6.1-6.4, Table A.1, claims) at tiny scale."""
    pytest.importorskip("nbclient")
    pytest.importorskip("ipykernel")
    executed = tmp_path / "executed.ipynb"
    args = ["notebook", os.path.join(ROOT, "notebooks", "validation.ipynb"), "--scale", "tiny",
            "--sweep-dir", str(tmp_path / "out"), "--fig-dir", str(tmp_path / "figures"), "--out", str(executed)]
    assert cli.main(args) == 0
    figs = sorted(os.listdir(tmp_path / "figures"))
    assert figs == sorted(["fig-6-1.png", "fig-6-2.png"] + [f"fig-6-{i}-{g}.png" for i in (3, 4)
                                                               for g in ("trot", "evolved")])
    assert all(os.path.getsize(tmp_path / "figures" / f) > 10_000 for f in figs)
    claims = (tmp_path / "out" / "claims.md").read_text()
    assert "0.74 Hz" in claims and "Table A.1" in claims and claims.count("\n|") >= 6
    text = executed.read_text()
    assert "scale tiny" in text and "Traceback" not in text and '"image/png"' in text


@pytest.mark.slow  # 31 s of CPU; the commands it runs are in the fast suite (cli/test_repertoire.py)
def test_repertoire_notebook_tiny(tmp_path):
    """notebooks/repertoire.ipynb (MAP-Elites, elites, follow, adapt) at tiny scale."""
    pytest.importorskip("nbclient")
    pytest.importorskip("ipykernel")
    executed = tmp_path / "executed.ipynb"
    args = ["notebook", os.path.join(ROOT, "notebooks", "repertoire.ipynb"), "--scale", "tiny",
            "--sweep-dir", str(tmp_path / "out"), "--fig-dir", str(tmp_path / "figures"), "--out", str(executed)]
    assert cli.main(args) == 0
    assert sorted(os.listdir(tmp_path / "figures")) == ["best-elite.gif", "follow.png", "repertoire.png"]
    text = executed.read_text()
    assert "scale tiny" in text and "Traceback" not in text and "cells filled after 32 evaluations" in text
    assert "trial 1: cell" in text
