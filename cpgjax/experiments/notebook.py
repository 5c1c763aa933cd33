"""Execute a notebook of ``notebooks/`` end to end (``cpgjax notebook``; the notebook tests).

The kernel is this very interpreter (a kernelspec made on the fly in a temporary
``JUPYTER_PATH``), so the notebook sees the same installed cpgjax and packages as the command,
with no ``jupyter kernelspec install`` step.  Settings reach the notebook through environment
variables (the notebook reads ``CPGJAX_SCALE``, ``CPGJAX_SWEEP_DIR``, ``CPGJAX_FIG_DIR`` and ``CPGJAX_PIPELINE``,
the physics pipeline of every model it builds or evolves: unset, each model's own, springs for the shipped ones).
Needs ``nbclient``, ``nbformat`` and ``ipykernel`` (the ``dev`` extra: ``pip install -e '.[dev]'``).
"""

from __future__ import annotations

import json
import os
import sys
import tempfile
from collections.abc import Mapping
from typing import Any

KERNEL = "cpgjax-here"


def _kernelspec(root: str) -> str:
    d = os.path.join(root, "kernels", KERNEL)
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, "kernel.json"), "w") as f:
        json.dump({"argv": [sys.executable, "-m", "ipykernel_launcher", "-f", "{connection_file}"],
                   "display_name": "cpgjax (this interpreter)", "language": "python"}, f)
    return root


def execute(path: str | os.PathLike[str], *, env: Mapping[str, str] | None = None, cwd: str | None = None,
            out: str | os.PathLike[str] | None = None, timeout: int | None = None) -> Any:
    """Run every cell of the notebook ``path`` in order; returns the executed notebook.

    ``env``: variables set for the kernel (e.g. ``{"CPGJAX_SCALE": "tiny"}``); ``cwd``: its working
    directory (default: the notebook's folder); ``out``: where to save the executed notebook
    (outputs included; may be ``path`` itself); ``timeout``: seconds per cell (None: no limit).
    A failing cell raises ``nbclient.exceptions.CellExecutionError`` naming the cell and the error.
    """
    try:
        import nbclient
        import nbformat
    except ImportError as e:  # pragma: no cover - the dev extra is installed by make
        raise RuntimeError(f"executing notebooks needs the dev extra ({e.name} is missing): "
                           "pip install -e '.[dev]'") from e
    p = os.fspath(path)
    nb = nbformat.read(p, as_version=4)
    saved = {k: os.environ.get(k) for k in (*(env or {}), "JUPYTER_PATH")}
    workdir = cwd or os.path.dirname(os.path.abspath(p))
    with tempfile.TemporaryDirectory() as tmp:
        try:
            os.environ.update(env or {})
            jp = os.environ.get("JUPYTER_PATH")
            os.environ["JUPYTER_PATH"] = _kernelspec(tmp) + (os.pathsep + jp if jp else "")
            client = nbclient.NotebookClient(nb, kernel_name=KERNEL, timeout=timeout,
                                             resources={"metadata": {"path": workdir}})
            client.execute()
        finally:
            for k, v in saved.items():
                if v is None:
                    os.environ.pop(k, None)
                else:
                    os.environ[k] = v
    if out is not None:
        folder = os.path.dirname(os.fspath(out))
        if folder:
            os.makedirs(folder, exist_ok=True)
        nbformat.write(nb, os.fspath(out))
    return nb
