"""Writing a Description back as `.wl` text (the inverse of :func:`cpgjax.io.wl.parse_wl`).

:func:`format_wl` writes every setting explicitly, with numbers as Python's shortest
round-tripping ``repr``, so that parsing the text gives back an equal Description (apart
from line numbers and the stored text).  Grammar: docs/wl-format.md; thesis Ch. 3.5.1.
"""

from __future__ import annotations

from collections.abc import Sequence

from cpgjax.sim.description import Description
from cpgjax.sim.terrain import terrain_spec

__all__ = ["format_wl"]


def _g(v: float) -> str:
    return repr(float(v))


def _v(v: Sequence[float]) -> str:
    return " ".join(_g(x) for x in v)


def format_wl(desc: Description) -> str:
    """Write a Description back as `.wl` text, every setting explicit (``parse_wl`` reads it back equal,
    apart from line numbers and the stored text)."""
    out: list[str] = [f"# written by cpgjax from {desc.path}"]
    for name, rgb in desc.colors.items():
        out.append(f"ColorDef {name} {_v(rgb)}")
    out += [
        f"TimeMax {_g(desc.time_max)}",
        f"Simulate {'ON' if desc.simulate else 'OFF'}",
        f"Display {'ON' if desc.display else 'OFF'}",
        f"TextOnly {'ON' if desc.text_only else 'OFF'}",
        f"LogRate {_g(desc.log_rate)}",
        f"Friction {_g(desc.friction)}"
        + (f" {_g(desc.friction_dynamic)}" if desc.friction_dynamic is not None else ""),
        f"Gravity {_g(desc.gravity)}",
    ]
    if desc.time_step is not None:
        out.append(f"TimeStep {_g(desc.time_step)}")
    if desc.exact_time_step is not None:
        out.append(f"ExactTimeStep {_g(desc.exact_time_step)}")
    if desc.pipeline is not None:
        out.append(f"Pipeline {desc.pipeline}")
    out.append(f"Ground {_v(desc.ground)}")
    if desc.joint_spring is not None:
        out.append(f"JointSpring {_v(desc.joint_spring)}")
    if desc.friction_spring is not None:
        out.append(f"FrictionSpring {_v(desc.friction_spring)}")
    s = desc.servo
    out.append(f"Servo {_v((s.kp, s.ki, s.kd, s.tau_max))}")
    t = desc.terrain
    if t.kind == "matrix":
        nx, ny = int(t.params[0]), int(t.params[1])
        out.append(f"Terrain matrix {nx} {ny} {_v(t.params[2:])} {{")
        out += [f"    {_v(row)}" for row in (t.heights or ())]
        out.append("}")
    elif t.kind == "course":
        out.append("Terrain " + terrain_spec(t).replace(":", " ", 1))
    elif t.kind == "rough" and len(t.params) > 2:
        out.append(f"Terrain rough {_v(t.params[:2])} {int(t.params[2])}")
    else:
        out.append(f"Terrain {t.kind} {_v(t.params)}".rstrip() + (f" {t.axis}" if t.kind == "ramp" else ""))
    if desc.track is not None:
        out.append(f"Track {desc.track}")
    out += [f"Harmonics {desc.harmonics}", f"Frequency {_g(desc.frequency)}", ""]
    for o in desc.objects.values():
        out.append(f"Object {o.name} {{")
        out += [f"    Type {o.type}", f"    Mass {_g(o.mass)}", f"    Dimensions {_v(o.dimensions)}"]
        if o.color is not None:
            out.append(f"    Color {o.color}")
        out += [f"    Position {_v(o.position)}", f"    Orientation {_v(o.orientation)}"]
        if o.contacts == ():
            out.append("    NoContact")
        out += [f"    Contact {_v(c)}" for c in (o.contacts or ())]
        if o.type == "Cylinder":
            out.append(f"    RimPoints {o.rim_points}")
        if o.fixed:
            out.append("    Fixed")
        out += ["}", ""]
    for c in desc.compounds.values():
        out.append(f"Compound {c.name} {{")
        out += [f"    {m}" for m in c.objects]
        out += [f"    Position {_v(c.position)}", f"    Orientation {_v(c.orientation)}"]
        if c.fixed:
            out.append("    Fixed")
        out += ["}", ""]
    for j in desc.joints:
        out += [f"Joint {j.name} {{", f"    {j.body_a} {_v(j.pivot_a)}", f"    {j.body_b} {_v(j.pivot_b)}",
                f"    Orientation {_v(j.orientation)}"]
        if j.limits is not None:
            out.append(f"    Limits {_v(j.limits)}")
        out.append(f"    {'Control' if j.controlled else 'Passive'}{j.axis}")
        if j.servo is not None:
            out.append(f"    Servo {_v((j.servo.kp, j.servo.ki, j.servo.kd, j.servo.tau_max))}")
        out += ["}", ""]
    out += [f"Log {lg.body} {lg.file}" for lg in desc.logs]
    return "\n".join(out) + "\n"
