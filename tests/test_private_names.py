"""No module uses another module's private names (docs/architecture.md, "Private names").

A name that starts with ``_`` belongs to its own module: another module of cpgjax or of benchmarks/ that needs
it gets a public name instead.  Read from the source with `ast`: every ``from M import _name`` (one-line or
parenthesised over many lines, anywhere in a module, relative imports included) and every ``alias._name``
where ``alias`` is a cpgjax module (``engines._foot_geoms``, ``cpgjax.sim.exact.tree._slots``).  Allowed:
dunder names (``__version__``), aliases (``import time as _time``, ``from cpgjax.io import results as
_results``: the name imported is public), and private *modules* (``from cpgjax import _xla``: a module file,
whose public names are used).
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FOLDERS = ("cpgjax", "benchmarks")


def module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


FILES = {module_name(p): p for folder in FOLDERS for p in sorted((ROOT / folder).rglob("*.py"))}
MODULES = set(FILES)


def _private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def _package(mod: str, path: str) -> str:
    """The package a module's relative imports start from."""
    return mod if path.endswith("__init__.py") else mod.rpartition(".")[0]


def _absolute(node: ast.ImportFrom, mod: str, path: str) -> str:
    if not node.level:
        return node.module or ""
    base = _package(mod, path).split(".")
    base = base[:len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def _dotted(node: ast.AST) -> list[str] | None:
    """``a.b.c`` -> ``["a", "b", "c"]``; None for anything but names and attributes."""
    parts = []
    while isinstance(node, ast.Attribute):
        parts.append(node.attr)
        node = node.value
    if not isinstance(node, ast.Name):
        return None
    return [node.id, *reversed(parts)]


def private_uses(source: str, mod: str, path: str = "<string>", modules: set[str] = MODULES) -> list[str]:
    """``"PATH:LINE: ..."`` for each use of another module's private name in ``source`` (module ``mod``)."""
    tree = ast.parse(source, path)
    bound: dict[str, str] = {}            # a local name -> the module it is (for modules of ``modules`` only)
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                top = a.name.split(".")[0]
                if a.asname and a.name in modules:
                    bound[a.asname] = a.name
                elif not a.asname and top in {m.split(".")[0] for m in modules}:
                    bound[top] = top
        elif isinstance(node, ast.ImportFrom):
            src = _absolute(node, mod, path)
            for a in node.names:
                full = f"{src}.{a.name}"
                if full in modules:                       # a module (a private one too): its names are checked
                    bound[a.asname or a.name] = full      # where they are used
                elif src in modules and src != mod and _private(a.name):
                    out.append(f"{path}:{getattr(a, 'lineno', node.lineno)}: imports {a.name} from {src}")
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and _private(node.attr):
            parts = _dotted(node.value)
            if parts and parts[0] in bound:
                owner = ".".join([bound[parts[0]], *parts[1:]])
                if owner in modules and owner != mod:
                    out.append(f"{path}:{node.lineno}: uses {owner}.{node.attr}")
    return sorted(set(out), key=lambda s: (s.split(":")[0], int(s.split(":")[1]), s))


def test_no_module_uses_another_modules_private_names():
    found = [u for mod, p in FILES.items()
             for u in private_uses(p.read_text(), mod, str(p.relative_to(ROOT)))]
    assert not found, ("private names used outside their module (make them public):\n" + "\n".join(found))
    assert len(FILES) > 30 and "cpgjax.experiments.runner" in MODULES      # the walk found the package


def test_the_check_catches_each_form_and_allows_aliases_and_dunders():
    modules = {"cpgjax", "cpgjax.sim", "cpgjax.sim.exact", "cpgjax.sim.exact.tree", "cpgjax.sim.exact.contact",
               "cpgjax.crosscheck", "cpgjax.crosscheck.engines", "cpgjax._xla", "cpgjax.io", "cpgjax.io.results"}
    bad = '''
from cpgjax.sim.exact.tree import _slots
from cpgjax.sim.exact.tree import (
    build,
    _walk,
)
from .tree import _relative
import cpgjax.sim.exact.tree
import cpgjax.crosscheck.engines as eng
from cpgjax.crosscheck import engines


def f():
    from cpgjax.crosscheck.engines import _inside
    return engines._foot_geoms(eng._root_slice) + cpgjax.sim.exact.tree._deep
'''
    found = private_uses(bad, "cpgjax.sim.exact.contact", "contact.py", modules)
    assert [u.split(": ", 1)[1] for u in found] == [
        "imports _slots from cpgjax.sim.exact.tree", "imports _walk from cpgjax.sim.exact.tree",
        "imports _relative from cpgjax.sim.exact.tree", "imports _inside from cpgjax.crosscheck.engines",
        "uses cpgjax.crosscheck.engines._foot_geoms", "uses cpgjax.crosscheck.engines._root_slice",
        "uses cpgjax.sim.exact.tree._deep"], found
    assert [int(u.split(":")[1]) for u in found] == [2, 5, 7, 14, 15, 15, 15]

    fine = '''
import time as _time
import numpy as np
from cpgjax import __version__, _xla
from cpgjax.io import results as _results
from cpgjax.io.results import read_run as _read_run
from cpgjax.sim.exact.contact import _own


class A:
    def __init__(self):
        self._x = np._NoValue
        _xla.configure()
        _time.sleep(0)
        _results.read_run.__doc__
        _own()
'''
    assert private_uses(fine, "cpgjax.sim.exact.contact", "contact.py", modules) == []
