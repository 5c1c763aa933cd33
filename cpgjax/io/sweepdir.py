"""Reading a sweep folder back: its run files (``OUT/<cell>/s<seed>.h5``) and queries over their settings."""

from __future__ import annotations

import json
import math
import os
from typing import Any

from cpgjax.io.results import read_attrs


def find_runs(out_dir: str | os.PathLike[str]) -> dict[str, list[str]]:
    """``{cell: [run files sorted by seed]}`` for the run files under ``out_dir`` (``<cell>/s<seed>.h5``)."""
    root = os.fspath(out_dir)
    cells: dict[str, list[str]] = {}
    if not os.path.isdir(root):
        return cells
    for cell in sorted(os.listdir(root)):
        d = os.path.join(root, cell)
        if not os.path.isdir(d):
            continue
        files = [f for f in os.listdir(d) if f.startswith("s") and f.endswith(".h5")]
        files.sort(key=lambda f: int(f[1:-3]) if f[1:-3].isdigit() else math.inf)
        if files:
            cells[cell] = [os.path.join(d, f) for f in files]
    return cells


def runs_matching(out_dir: str | os.PathLike[str], kind: str | None = None, **settings: Any) -> list[str]:
    """Run files of ``out_dir`` whose kind and stored config match ``settings`` (e.g. ``pocket=0``)."""
    out = []
    for files in find_runs(out_dir).values():
        for p in files:
            a = read_attrs(p)
            cfg = json.loads(a["config"])
            if kind is not None and a["kind"] != kind:
                continue
            if all(same_setting(cfg.get(k), v) for k, v in settings.items()):
                out.append(p)
    return out


def same_setting(a: Any, b: Any) -> bool:
    """A stored setting equals a wanted one (floats within 1e-9; a list/tuple/set wanted: any of them)."""
    if isinstance(b, (list, tuple, set)):
        return any(same_setting(a, x) for x in b)
    if isinstance(b, float) or isinstance(a, float):
        try:
            return math.isclose(float(a), float(b), rel_tol=1e-9, abs_tol=1e-12)
        except (TypeError, ValueError):
            return False
    return a == b


def run_files(paths) -> list[str]:
    """RUN.h5 files, and every run file under each sweep folder given (``cpgjax transfer``, ``stability``...)."""
    out: list[str] = []
    for p in paths:
        p = os.fspath(p)
        if os.path.isdir(p):
            found = [f for fs in find_runs(p).values() for f in fs]
            if not found:
                raise ValueError(f"{p}: no run files (<cell>/s<seed>.h5) in this folder")
            out += found
        else:
            out.append(p)
    return out
