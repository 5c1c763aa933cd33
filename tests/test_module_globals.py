"""No module sets another module's globals (issue 52: settings go in as arguments, e.g. ``cpgjax bench --tricks``'s
variants as model fields, not as flipped module flags).  Read from the source with `ast`: every assignment to
``alias.NAME`` (``=``, ``+=``, annotated) where ``alias`` is a cpgjax module other than the one assigning."""

from __future__ import annotations

import ast

from test_private_names import FILES, MODULES, ROOT, _absolute


def foreign_assignments(source: str, mod: str, path: str = "<string>", modules: set[str] = MODULES) -> list[str]:
    tree = ast.parse(source, path)
    bound: dict[str, str] = {}
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                if a.name in modules:
                    bound[a.asname or a.name.split(".")[0]] = a.name if a.asname else a.name.split(".")[0]
        elif isinstance(node, ast.ImportFrom):
            src = _absolute(node, mod, path)
            for a in node.names:
                if f"{src}.{a.name}" in modules:
                    bound[a.asname or a.name] = f"{src}.{a.name}"
    out = []
    for node in ast.walk(tree):
        targets = (node.targets if isinstance(node, ast.Assign) else
                   [node.target] if isinstance(node, (ast.AugAssign, ast.AnnAssign)) else [])
        for t in targets:
            if isinstance(t, ast.Attribute):
                parts, base = [t.attr], t.value
                while isinstance(base, ast.Attribute):
                    parts.append(base.attr)
                    base = base.value
                if isinstance(base, ast.Name) and base.id in bound:
                    owner = ".".join([bound[base.id], *reversed(parts[1:])])
                    if owner in modules and owner != mod:
                        out.append(f"{path}:{node.lineno}: sets {owner}.{t.attr}")
    return out


def test_no_module_sets_another_modules_globals():
    found = [u for mod, p in FILES.items() for u in foreign_assignments(p.read_text(), mod, str(p.relative_to(ROOT)))]
    assert not found, "module globals set from outside (pass the setting as an argument):\n" + "\n".join(found)


def test_the_check_catches_a_flipped_flag():
    modules = {"cpgjax", "cpgjax.sim", "cpgjax.sim.rotation", "cpgjax.experiments", "cpgjax.experiments.bench"}
    src = ("from cpgjax.sim import rotation\nimport cpgjax.sim.rotation as rot\nimport cpgjax\n"
           "rotation.POLY_ATAN2 = True\nrot.FLAG += 1\ncpgjax.sim.rotation.X: int = 2\nlocal = object()\nlocal.y = 1\n")
    found = foreign_assignments(src, "cpgjax.experiments.bench", "b.py", modules)
    assert found == ["b.py:4: sets cpgjax.sim.rotation.POLY_ATAN2", "b.py:5: sets cpgjax.sim.rotation.FLAG",
                     "b.py:6: sets cpgjax.sim.rotation.X"]
