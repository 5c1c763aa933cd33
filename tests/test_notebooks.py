"""The notebooks execute end to end at tiny scale (nbclient, a kernel of this very interpreter)."""

from __future__ import annotations

import json
import os
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
NOTEBOOK = os.path.join(ROOT, "notebooks", "thesis_figures.ipynb")


def _kernel_here(tmp_path) -> str:
    """A kernelspec that runs ipykernel with ``sys.executable`` (the test's interpreter and packages)."""
    d = tmp_path / "jupyter" / "kernels" / "cpgjax-test"
    d.mkdir(parents=True)
    (d / "kernel.json").write_text(json.dumps({
        "argv": [sys.executable, "-m", "ipykernel_launcher", "-f", "{connection_file}"],
        "display_name": "cpgjax test", "language": "python"}))
    return str(tmp_path / "jupyter")


def test_thesis_figures_notebook_tiny(tmp_path, monkeypatch):
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    pytest.importorskip("ipykernel")
    monkeypatch.setenv("JUPYTER_PATH", _kernel_here(tmp_path))
    monkeypatch.setenv("CPGJAX_SCALE", "tiny")
    monkeypatch.setenv("CPGJAX_SWEEP_DIR", str(tmp_path / "sweep"))
    monkeypatch.setenv("CPGJAX_FIG_DIR", str(tmp_path / "figures"))
    monkeypatch.setenv("PYTHONPATH", ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))
    nb = nbformat.read(NOTEBOOK, as_version=4)
    client = nbclient.NotebookClient(nb, kernel_name="cpgjax-test", timeout=300,
                                     resources={"metadata": {"path": ROOT}})
    client.execute()
    figs = sorted(os.listdir(tmp_path / "figures"))
    assert figs == sorted(f"fig-6-{i}.png" for i in range(5, 13))
    report = (tmp_path / "sweep" / "report.md").read_text()
    assert "more than doubles" in report and "factor of 2" in report
    # the notebook reads SCALE from the environment, and a second run finds the results complete
    out = "".join(o.get("text", "") for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", []))
    assert "scale tiny" in out
