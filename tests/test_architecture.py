"""The package's layers (docs/architecture.md): imports run one way and nowhere in a cycle.

Read from the source with `ast`, so that imports inside functions count as much as those at the
top of a module (they hide edges, not remove them).
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PKG = Path(__file__).resolve().parents[1] / "cpgjax"

# What each layer may import from (besides itself).  docs/architecture.md has the same table.
ALLOWED: dict[str, set[str]] = {
    "base": set(),
    "sim": {"base"},
    "episode": {"base", "sim"},
    "io": {"base", "sim"},
    "optim": {"base", "sim", "episode", "io"},
    "crosscheck": {"base", "sim", "episode", "io"},
    "render": {"base", "sim", "episode", "io", "crosscheck"},
    "analysis": {"base", "sim", "episode", "io", "optim"},
    "experiments": {"base", "sim", "episode", "io", "optim", "crosscheck", "render", "analysis"},
    "plots": {"base", "sim", "episode", "io", "optim", "analysis"},
    "cli": {"base", "sim", "episode", "io", "optim", "crosscheck", "render", "analysis", "experiments", "plots"},
}
BASE = {"cpgjax", "cpgjax._xla", "cpgjax.errors"}


def module_name(path: Path) -> str:
    parts = list(path.relative_to(PKG.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


MODULES = {module_name(p): p for p in sorted(PKG.rglob("*.py"))}


def layer(mod: str) -> str:
    if mod in BASE:
        return "base"
    return mod.split(".")[1]


def resolve(name: str) -> str:
    """The cpgjax module an imported name lives in (``cpgjax.optim.ga`` for ``from cpgjax.optim import ga``)."""
    while name not in MODULES and "." in name:
        name = name.rsplit(".", 1)[0]
    return name


def imports(mod: str) -> set[str]:
    """Every cpgjax module that ``mod`` imports, anywhere in its source."""
    tree = ast.parse(MODULES[mod].read_text(), str(MODULES[mod]))
    out: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names = [f"{node.module}.{a.name}" for a in node.names]
        else:
            continue
        out |= {resolve(n) for n in names if n == "cpgjax" or n.startswith("cpgjax.")}
    out.discard(mod)
    return out


GRAPH = {m: imports(m) for m in MODULES}


def test_every_module_belongs_to_a_known_layer():
    unknown = sorted(m for m in MODULES if layer(m) not in ALLOWED)
    assert not unknown, f"modules outside the layers of docs/architecture.md: {unknown}"
    assert len(MODULES) > 30      # the walk found the package


@pytest.mark.parametrize("mod", sorted(MODULES))
def test_imports_run_down_the_layers(mod):
    me = layer(mod)
    bad = sorted(i for i in GRAPH[mod] if layer(i) != me and layer(i) not in ALLOWED[me])
    assert not bad, f"{mod} ({me}) imports {bad}; {me} may import only from {sorted(ALLOWED[me])}"


def test_sim_is_pure_physics():
    for mod, deps in GRAPH.items():
        if layer(mod) == "sim":
            assert {layer(d) for d in deps} <= {"sim", "base"}, (mod, deps)


PIPELINES = ("cpgjax.sim.springs", "cpgjax.sim.exact")
HOLDS_THE_PIPELINES = {"cpgjax.sim.model", "cpgjax.sim.pipeline"}     # a pipeline's part of the Model; its step


def _pipeline(mod: str) -> str | None:
    return next((p for p in PIPELINES if mod == p or mod.startswith(p + ".")), None)


def test_the_pipelines_do_not_import_each_other():
    """Inside sim, each pipeline (springs/, exact/) imports the shared modules and itself only; a shared module
    imports a pipeline only to hold its part of the Model (model.py) or to run its step (pipeline.py)."""
    for mod, deps in GRAPH.items():
        if layer(mod) != "sim":
            continue
        mine = _pipeline(mod)
        theirs = sorted(d for d in deps if _pipeline(d) and _pipeline(d) != mine)
        if mine is None and mod in HOLDS_THE_PIPELINES:
            continue
        assert not theirs, f"{mod} imports {theirs}: {'the other pipeline' if mine else 'a pipeline'}"
    assert {_pipeline(d) for d in GRAPH["cpgjax.sim.pipeline"]} >= set(PIPELINES)      # the walk saw them


def test_no_import_cycle():
    state: dict[str, int] = {}        # 1: on the current path, 2: done
    path: list[str] = []

    def visit(m: str) -> None:
        state[m] = 1
        path.append(m)
        for d in sorted(GRAPH[m]):
            if state.get(d) == 1:
                cycle = path[path.index(d):] + [d]
                raise AssertionError("import cycle: " + " -> ".join(cycle))
            if d in GRAPH and d not in state:
                visit(d)
        path.pop()
        state[m] = 2

    for m in sorted(GRAPH):
        if m not in state:
            visit(m)


def test_the_checker_sees_a_cycle_and_a_function_level_import(tmp_path, monkeypatch):
    """The checks above can fail: an upward import hidden inside a function is found."""
    src = "def f():\n    from cpgjax.optim.ga import GAConfig\n    return GAConfig\n"
    p = tmp_path / "probe.py"
    p.write_text(src)
    monkeypatch.setitem(MODULES, "cpgjax.sim.probe", p)
    deps = imports("cpgjax.sim.probe")
    assert deps == {"cpgjax.optim.ga"}
    assert layer("cpgjax.optim.ga") not in ALLOWED["sim"]


MAX_LINES = 450   # the design card: one concept per module, files under 450 lines


def too_long(paths, limit: int = MAX_LINES) -> list[str]:
    return [f"{p.relative_to(PKG.parent)}: {n} lines" for p in paths
            if (n := len(p.read_text().splitlines())) > limit]


def test_no_module_over_450_lines():
    roots = [PKG, PKG.parent / "benchmarks", PKG.parent / "tests"]
    paths = [p for r in roots for p in sorted(r.rglob("*.py"))]
    assert not too_long(paths), too_long(paths)


def test_the_line_count_sees_a_long_file():
    p = PKG / "__init__.py"
    assert too_long([p], limit=1) and not too_long([p], limit=10**6)
