"""The notebooks execute end to end at tiny scale (cpgjax.experiments.notebook: nbclient, a kernel of this
interpreter), marked slow (`make test-slow`); the fast suite checks that every notebook's code parses and that
every name it takes from cpgjax exists, and runs the `cpgjax notebook` command on a small notebook."""

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


@pytest.mark.slow  # 45 s of CPU, most of it the tiny sweep compiled in the kernel; fast: the check below
def test_thesis_figures_notebook_tiny(tmp_path):
    _thesis_figures_tiny(tmp_path)


def _cpgjax_names(tree) -> list[tuple[str, str, int]]:
    """(module, name, line) of every name a notebook's code takes from cpgjax: ``from cpgjax.m import n`` and
    ``alias.n`` for a module imported as ``alias``."""
    import ast

    names, aliases = [], {}
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("cpgjax"):
            for a in node.names:
                names.append((node.module, a.name, node.lineno))
                aliases[a.asname or a.name] = f"{node.module}.{a.name}"
        elif isinstance(node, ast.Import):
            for a in node.names:
                if a.name.startswith("cpgjax.") and a.asname:
                    aliases[a.asname] = a.name
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id in aliases:
            names.append((aliases[node.value.id], node.attr, node.lineno))
    return names


def _missing(tree) -> list[str]:
    """The names of :func:`_cpgjax_names` that cpgjax does not have, each as ``line: module has no name``."""
    import importlib

    missing = []
    for module, attr, line in _cpgjax_names(tree):
        try:
            obj = importlib.import_module(module)
        except ImportError:                                 # ``alias.n`` of a name imported from a module
            parent, _, last = module.rpartition(".")
            obj = getattr(importlib.import_module(parent), last, None)
            if obj is None:
                missing.append(f"line {line}: no module {module}")
                continue
        ok = hasattr(obj, attr)
        if not ok:
            try:
                importlib.import_module(f"{module}.{attr}")        # a submodule not imported yet
                ok = True
            except ImportError:
                pass
        if not ok:
            missing.append(f"line {line}: {module} has no {attr}")
    return missing


def test_every_notebook_parses_and_takes_only_names_cpgjax_has():
    """The notebooks' code against the package as it is now, without a kernel (their execution: the slow tests
    above): each code cell parses, and each module, function or constant it takes from cpgjax exists."""
    import ast
    import json

    bad = ast.parse("from cpgjax.plots import thesis\nfrom cpgjax.io.nothing import x\nthesis.fig_6_99()\n")
    assert _missing(bad) == ["line 2: no module cpgjax.io.nothing", "line 3: cpgjax.plots.thesis has no fig_6_99"]
    for name in sorted(os.listdir(os.path.join(ROOT, "notebooks"))):
        if not name.endswith(".ipynb"):
            continue
        nb = json.load(open(os.path.join(ROOT, "notebooks", name)))
        cells = ["".join(c["source"]) for c in nb["cells"] if c["cell_type"] == "code"]
        assert cells, name
        for i, src in enumerate(cells):
            code = "\n".join("" if line.lstrip().startswith(("%", "!")) else line for line in src.splitlines())
            tree = ast.parse(code, f"notebooks/{name}, code cell {i + 1}")
            assert not _missing(tree), f"notebooks/{name}, code cell {i + 1}: {_missing(tree)}"



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
                                                         "population.md", "stair-stable.png", "bar-stable.png"]
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


def test_the_notebooks_in_the_repository_hold_no_outputs_and_every_cell_an_id():
    """notebooks/ holds the notebooks' source; `cpgjax notebook` saves executed copies under runs/notebooks/ and the
    figures and tables go to docs/ (outputs kept here would go stale with the code that made them)."""
    import json

    for name in sorted(os.listdir(os.path.join(ROOT, "notebooks"))):
        if name.endswith(".ipynb"):
            nb = json.load(open(os.path.join(ROOT, "notebooks", name)))
            held = [i for i, c in enumerate(nb["cells"]) if c.get("outputs") or c.get("execution_count")]
            assert not held, f"notebooks/{name}: cells {held} hold outputs (clear them: the source only)"
            # nbformat 4.5 gives every cell an id; nbformat warns of a missing one now, and will refuse it
            bare = [i for i, c in enumerate(nb["cells"]) if "id" not in c]
            assert not bare, f"notebooks/{name}: cells {bare} have no id (nbformat.validator.normalize adds them)"
