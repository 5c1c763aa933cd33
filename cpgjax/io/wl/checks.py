"""Cross-reference checks of a parsed `.wl` file, and the assembled Description (thesis Ch. 3.5.1).

The parser (:mod:`cpgjax.io.wl.parser`) reads each block on its own into a raw record
(:class:`RawObject`, :class:`RawCompound`, :class:`RawJoint`), checking only what one
statement can tell.  :func:`assemble` then checks what needs the whole file
(docs/wl-format.md §4-6): required keywords, names that refer to other blocks (colours,
compound members, joint and ``Track``/``Log`` bodies), and that the joints form a forest.
It collects every problem and reports the first in file order with the count of the
others; only when there is none it returns the :class:`~cpgjax.sim.description.Description`.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

from cpgjax.errors import DescriptionError
from cpgjax.io.wl.lexer import (
    COMPOUND_KEYWORDS,
    JOINT_KEYWORDS,
    OBJECT_KEYWORDS,
    did_you_mean,
    fmt_list,
    plural,
    suggest,
)
from cpgjax.sim.description import CompoundDef, Description, JointDef, ObjectDef, Vec3

_DIMS = {
    "Cube": (3, "DX DY DZ (full edge lengths)"),
    "Cylinder": (2, "RADIUS LENGTH"),
    "Sphere": (1, "RADIUS"),
}


# ----------------------------------------------------------------------------- raw records

@dataclass
class RawObject:
    name: str
    line: int
    fields: dict[str, Any] = field(default_factory=dict)
    lines: dict[str, int] = field(default_factory=dict)  # keyword -> line where given
    contacts: list[Vec3] = field(default_factory=list)


@dataclass
class RawCompound:
    name: str
    line: int
    members: list[tuple[str, int]] = field(default_factory=list)
    fields: dict[str, Any] = field(default_factory=dict)
    lines: dict[str, int] = field(default_factory=dict)


@dataclass
class RawJoint:
    name: str
    line: int
    bodies: list[tuple[str, Vec3, int]] = field(default_factory=list)
    fields: dict[str, Any] = field(default_factory=dict)
    lines: dict[str, int] = field(default_factory=dict)


@dataclass
class RawDescription:
    """What the parser read: the settings (already in ``desc``) and the blocks, unchecked."""

    desc: Description
    objects: dict[str, RawObject] = field(default_factory=dict)
    compounds: dict[str, RawCompound] = field(default_factory=dict)
    joints: dict[str, RawJoint] = field(default_factory=dict)
    track_line: int = 0


def _vec(v: object) -> Vec3:
    if v is None:
        return (0.0, 0.0, 0.0)
    x, y, z = v
    return (float(x), float(y), float(z))


# ----------------------------------------------------------------------------- checks and assembly

def assemble(raw: RawDescription) -> Description:
    """Check the raw records against each other and assemble the Description (all or nothing)."""
    errors: list[tuple[int, str]] = []

    def bad(line: int, message: str) -> None:
        errors.append((line, message))

    d = raw.desc
    holder = _check_compounds(raw, bad)
    objects = _objects(raw, holder, bad)
    compounds = {
        c.name: CompoundDef(
            name=c.name, objects=tuple(m for m, _ in c.members), line=c.line,
            position=_vec(c.fields.get("position")), orientation=_vec(c.fields.get("orientation")),
            fixed=bool(c.fields.get("fixed", False)),
        )
        for c in raw.compounds.values()
    }
    bodies = [o for o in raw.objects if o not in holder] + list(raw.compounds)

    def check_body(name: str, line: int, what: str, keywords: Iterable[str] = ()) -> bool:
        if name in raw.compounds or (name in raw.objects and name not in holder):
            return True
        if name in holder:
            bad(line, f"{what} names '{name}', an object inside Compound '{holder[name]}'; name the "
                      f"compound '{holder[name]}' instead (pivots are in its frame)")
        else:
            hint = did_you_mean(name, bodies)
            if not hint and (kw := suggest(name, keywords)):
                hint = f" (or did you mean the keyword '{kw}'?)"
            bad(line, f"{what} names body '{name}' which is not defined{hint} "
                      f"(objects/compounds: {fmt_list(bodies)})")
        return False

    joints = _joints(raw, check_body, bad)
    _check_forest(joints, bad)
    if d.track is not None:
        check_body(d.track, raw.track_line, "Track")
    for lg in d.logs:
        check_body(lg.body, lg.line, "Log")

    if not raw.objects and not errors:
        bad(1, "the description defines no Object, so there is nothing to simulate; add at least one "
               "block 'Object NAME { Type Cube  Mass KG  Dimensions DX DY DZ }', one statement per line "
               "(docs/wl-format.md §4, §7)")
    if errors:
        errors.sort(key=lambda e: e[0])
        line, msg = errors[0]
        more = len(errors) - 1
        raise DescriptionError(d.path, line, msg + (f" (and {plural(more, 'more problem')})" if more else ""))
    d.objects, d.compounds, d.joints = objects, compounds, joints
    return d


def _check_compounds(raw: RawDescription, bad) -> dict[str, str]:
    """Check compound members; return object -> the compound that holds it."""
    holder: dict[str, str] = {}
    for c in raw.compounds.values():
        if not c.members:
            bad(c.line, f"Compound '{c.name}' lists no objects; add one object name per line inside "
                        "its block")
        seen: dict[str, int] = {}
        for m, line in c.members:
            where = f"Compound '{c.name}' lists '{m}'"
            if m in raw.compounds:
                bad(line, f"{where}, which is a compound; compounds hold objects only")
            elif m not in raw.objects:
                hint = did_you_mean(m, raw.objects) or did_you_mean(m, COMPOUND_KEYWORDS)
                bad(line, f"{where}, which is not a defined Object{hint} "
                          f"(objects: {fmt_list(raw.objects)})")
            elif m in seen:
                bad(line, f"{where} twice (first at line {seen[m]})")
            elif m in holder:
                bad(line, f"Object '{m}' is already in Compound '{holder[m]}'; an object can belong to "
                          "one compound only (define a copy with another name)")
            else:
                holder[m] = c.name
                seen[m] = line
    return holder


def _objects(raw: RawDescription, holder: dict[str, str], bad) -> dict[str, ObjectDef]:
    colors = raw.desc.colors
    objects: dict[str, ObjectDef] = {}
    for o in raw.objects.values():
        what = f"Object '{o.name}'"
        missing = [k for k in ("Type", "Mass", "Dimensions") if k not in o.lines]
        for k in missing:
            bad(o.line, f"{what} is missing {k}; add a line '{OBJECT_KEYWORDS[k]}' inside its block")
        if missing:
            continue
        typ = str(o.fields["type"])
        dims = tuple(o.fields["dimensions"])
        n, meaning = _DIMS[typ]
        if len(dims) != n:
            bad(o.lines["Dimensions"], f"{what} is a {typ}, so Dimensions needs {plural(n, 'number')} "
                                       f"({meaning}), got {len(dims)}")
            continue
        color = o.fields.get("color")
        if color is not None and color not in colors:
            bad(o.lines["Color"], f"colour '{color}' of {what} is not defined by a ColorDef"
                                  f"{did_you_mean(color, colors)} (defined: {fmt_list(colors)}); "
                                  f"add 'ColorDef {color} R G B'")
        if "NoContact" in o.lines and o.contacts:
            bad(o.lines["NoContact"], f"{what} has both NoContact and Contact lines; keep one")
        if "RimPoints" in o.lines and typ != "Cylinder":
            bad(o.lines["RimPoints"], f"RimPoints applies to cylinders only; {what} is a {typ}")
        if o.fields.get("fixed") and o.name in holder:
            bad(o.lines["Fixed"], f"{what} is Fixed but belongs to Compound '{holder[o.name]}'; put "
                                  "Fixed in the compound's block instead")
        contacts = () if "NoContact" in o.lines else (tuple(o.contacts) if o.contacts else None)
        objects[o.name] = ObjectDef(
            name=o.name, type=typ, mass=float(o.fields["mass"]), dimensions=dims, line=o.line,
            color=color, position=_vec(o.fields.get("position")),
            orientation=_vec(o.fields.get("orientation")),
            contacts=contacts, rim_points=int(o.fields.get("rim_points", 12)),
            fixed=bool(o.fields.get("fixed", False)),
        )
    return objects


def _joints(raw: RawDescription, check_body, bad) -> list[JointDef]:
    joints: list[JointDef] = []
    n_ctrl = 0
    for j in raw.joints.values():
        what = f"Joint '{j.name}'"
        ok = True
        if len(j.bodies) < 2:
            bad(j.line, f"{what} names {len(j.bodies)} bod{'y' if len(j.bodies) == 1 else 'ies'}; it "
                        "needs two lines 'BODY X Y Z': body_a (parent) first, then body_b (child)")
            ok = False
        for b, _, line in j.bodies:
            ok = check_body(b, line, what, JOINT_KEYWORDS) and ok
        if "kind" not in j.lines:
            bad(j.line, f"{what} has no kind; add ControlX|ControlY|ControlZ (driven by the CPG) or "
                        "PassiveX|PassiveY|PassiveZ (free revolute)")
            ok = False
        if not ok:
            continue
        (a, pa, _), (b, pb, line_b) = j.bodies
        if a == b:
            bad(line_b, f"{what} joins body '{a}' to itself; name two different bodies")
            continue
        controlled, axis = bool(j.fields["controlled"]), str(j.fields["axis"])
        orient = _vec(j.fields.get("orientation"))
        k = "XYZ".index(axis)
        if any(v != 0.0 for i, v in enumerate(orient) if i != k):
            got = " ".join(f"{v:g}" for v in orient)
            bad(j.lines["Orientation"], f"{what} turns about {axis}, so its Orientation may only rotate "
                                        f"about {axis} (the initial joint angle), got {got}; set the "
                                        "other angles to 0")
        if "Servo" in j.lines and not controlled:
            bad(j.lines["Servo"], f"{what} is passive, so its Servo would do nothing; remove it or use "
                                  f"Control{axis}")
        joints.append(JointDef(
            name=j.name, body_a=a, pivot_a=pa, body_b=b, pivot_b=pb, line=j.line, axis=axis,
            controlled=controlled, control_index=n_ctrl if controlled else None, orientation=orient,
            limits=j.fields.get("limits"), servo=j.fields.get("servo"),
        ))
        n_ctrl += controlled
    return joints


def _check_forest(joints: list[JointDef], bad) -> None:
    """The joints must form a forest: one parent per body, no loops."""
    parent: dict[str, JointDef] = {}
    for jd in joints:
        if jd.body_b in parent:
            first = parent[jd.body_b]
            bad(jd.line, f"body '{jd.body_b}' is already the second body of Joint '{first.name}' "
                         f"(line {first.line}); a body can hang from one joint only: swap the two body "
                         f"lines of Joint '{jd.name}' or remove it")
        else:
            parent[jd.body_b] = jd
    reported: set[str] = set()
    for jd in joints:
        if parent.get(jd.body_b) is not jd or jd.name in reported:
            continue
        chain, name = [jd.body_b], jd.body_a  # walk up from body_a; meeting body_b again is a loop
        while name in parent and name not in chain:
            chain.append(name)
            name = parent[name].body_a
        if name == jd.body_b:
            loop = [parent[n] for n in chain]
            last = max(loop, key=lambda x: x.line)
            reported.update(x.name for x in loop)
            cycle = " -> ".join([jd.body_b, *reversed(chain[1:]), jd.body_b])
            bad(last.line, f"joints form a loop ({cycle}); joints must form a tree: remove Joint "
                           f"'{last.name}' or change its bodies")
