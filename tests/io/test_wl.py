"""The `.wl` description parser (thesis Ch. 3.5.1; docs/wl-format.md)."""

from __future__ import annotations

import dataclasses
import textwrap

import pytest

from cpgjax.io.wl import format_wl, load_wl, parse_wl
from cpgjax.sim.description import Description, DescriptionError, ServoDef

# The excerpt of Ch. 3.5.1, verbatim but for its "..." lines.
THESIS_EXCERPT = """\
ColorDef      Brown  .7 .8 .5
ColorDef      Blue   .4 .5 .7
ColorDef      Silver .7 .7 .8

TimeMax       8.0
Simulate      OFF
Display       ON
LogRate       20
Friction      2.5
Object BodyBase {
    Type       Cube
    Color      Brown
    Mass       2.5
    Dimensions .25 .6 .02
}
Compound Body {
    BodyBase
    GearBoxPR
    GearBoxPL
    GearBoxAR
    GearBoxAL
    Position   .30 -.56 .322
    Orientation .0 .0 .0
}
Joint HipPR {
    Body       .14 -.22 .03
    LegUPR     .0 .0 .09
    Orientation .4 .0 .0
    Limits     -1.5 1.5
    ControlX
}
Log      Body      body.log
"""

# What the "..." lines left out: the four motor units (Ch. 5: 1.9 kg each) and the upper leg.
EXCERPT_FILLER = "".join(
    f"Object GearBox{side} {{\n    Type Cube\n    Color Silver\n    Mass 1.9\n    Dimensions .08 .08 .08\n"
    f"    Position {x} {y} .05\n}}\n"
    for side, x, y in (("PR", .1, -.22), ("PL", -.1, -.22), ("AR", .1, .22), ("AL", -.1, .22))
) + """Object LegUPR {
    Type Cube
    Color Blue
    Mass 0.5
    Dimensions .016 .035 .15
}
"""


SMALL = """\
# A small complete model: a body plate with a motor, one driven leg, a free wheel.
ColorDef Brown .7 .8 .5
ColorDef Silver .7 .7 .8
TimeMax 2.0
TextOnly
LogRate 20
Friction 2.5 2.0
Gravity 9.81
Ground 1e5 1e3
Servo 60 0 1 17.5
Terrain bump 0.02 1.0 0.3
Harmonics 3
Frequency 0.5
Track Body

Object BodyBase {
    Type Cube
    Color Brown
    Mass 2.5
    Dimensions .25 .6 .02
}
Object Motor
{
    Type Cube
    Mass 1.9
    Dimensions .08 .08 .08
    Position 0 .2 .05
}
Compound Body {
    BodyBase
    Motor
    Position 0 0 .3
}
Object Leg {
    Type Cube
    Color Silver
    Mass .5
    Dimensions .016 .035 .15
    Contact 0 0 -.075
}
Object Wheel {
    Type Cylinder
    Mass .1
    Dimensions .03 .01
    RimPoints 8
}
Joint Axle {
    Leg 0 0 -.075
    Wheel 0 0 0
    PassiveX
}
Joint Hip {
    Body .14 .22 0
    Leg 0 0 .075
    Orientation .4 0 0
    Limits -1.5 1.5
    ControlX
    Servo 80 0 2 17.5
}
Object Pole {
    Type Sphere
    Mass 1
    Dimensions .05
    NoContact
    Position 0 -1 .5
    Fixed
}
Log Body body.log
Log Wheel wheel.log
"""

OBJ_A = "Object A {\n    Type Cube\n    Mass 1\n    Dimensions .1 .1 .1\n}\n"  # lines 1-5


def _write(tmp_path, text: str, name: str = "model.wl") -> str:
    p = tmp_path / name
    p.write_text(text)
    return str(p)


# ----------------------------------------------------------------------------- good files

def test_thesis_excerpt_parses_with_its_values(tmp_path):
    path = _write(tmp_path, THESIS_EXCERPT + EXCERPT_FILLER)
    d = load_wl(path)
    assert d.path == path and d.text == THESIS_EXCERPT + EXCERPT_FILLER
    assert d.colors == {"Brown": (0.7, 0.8, 0.5), "Blue": (0.4, 0.5, 0.7), "Silver": (0.7, 0.7, 0.8)}
    assert (d.time_max, d.simulate, d.display, d.log_rate, d.friction) == (8.0, False, True, 20.0, 2.5)
    assert d.friction_dynamic is None and d.text_only is False
    base = d.objects["BodyBase"]
    assert (base.type, base.color, base.mass, base.dimensions, base.line) == ("Cube", "Brown", 2.5,
                                                                             (0.25, 0.6, 0.02), 10)
    body = d.compounds["Body"]
    assert body.objects == ("BodyBase", "GearBoxPR", "GearBoxPL", "GearBoxAR", "GearBoxAL")
    assert body.position == (0.30, -0.56, 0.322) and body.orientation == (0.0, 0.0, 0.0) and body.line == 16
    (hip,) = d.joints
    assert (hip.name, hip.body_a, hip.pivot_a, hip.body_b, hip.pivot_b) == (
        "HipPR", "Body", (0.14, -0.22, 0.03), "LegUPR", (0.0, 0.0, 0.09))
    assert (hip.orientation, hip.limits, hip.axis, hip.controlled, hip.control_index, hip.line) == (
        (0.4, 0.0, 0.0), (-1.5, 1.5), "X", True, 0, 25)
    assert hip.servo is None
    assert [(lg.body, lg.file, lg.line) for lg in d.logs] == [("Body", "body.log", 32)]
    assert d.n_controlled == 1


def test_thesis_excerpt_alone_names_its_missing_objects(tmp_path):
    """Verbatim, the excerpt refers to objects defined in its '...' lines: the error says which."""
    path = _write(tmp_path, THESIS_EXCERPT)
    with pytest.raises(DescriptionError) as e:
        load_wl(path)
    assert str(e.value).startswith(f"{path}:18: Compound 'Body' lists 'GearBoxPR', which is not a defined "
                                   "Object")
    assert "more problem" in str(e.value)


def test_small_model_parses(tmp_path):
    d = load_wl(_write(tmp_path, SMALL))
    assert d.text_only is True and d.friction == 2.5 and d.friction_dynamic == 2.0
    assert d.ground == (1e5, 1e3) and d.servo == ServoDef(60.0, 0.0, 1.0, 17.5)
    assert (d.terrain.kind, d.terrain.params, d.terrain.line) == ("bump", (0.02, 1.0, 0.3), 11)
    assert (d.harmonics, d.frequency, d.track) == (3, 0.5, "Body")
    assert list(d.objects) == ["BodyBase", "Motor", "Leg", "Wheel", "Pole"]
    assert list(d.compounds) == ["Body"]
    motor, leg, wheel, pole = (d.objects[n] for n in ("Motor", "Leg", "Wheel", "Pole"))
    assert motor.position == (0.0, 0.2, 0.05) and motor.color is None and motor.contacts is None
    assert leg.contacts == ((0.0, 0.0, -0.075),)
    assert (wheel.type, wheel.dimensions, wheel.rim_points) == ("Cylinder", (0.03, 0.01), 8)
    assert (pole.type, pole.dimensions, pole.contacts, pole.fixed) == ("Sphere", (0.05,), (), True)
    axle, hip = d.joints
    assert (axle.controlled, axle.control_index, axle.axis, axle.limits) == (False, None, "X", None)
    assert (hip.controlled, hip.control_index) == (True, 0)
    assert hip.servo == ServoDef(80.0, 0.0, 2.0, 17.5)
    assert [lg.body for lg in d.logs] == ["Body", "Wheel"]
    assert d.n_controlled == 1


def test_defaults_when_settings_are_absent():
    d = parse_wl("Object A {\n Type Cube\n Mass 1\n Dimensions 1 1 1\n}\n")
    ref = Description()
    for f in ("time_max", "simulate", "display", "text_only", "log_rate", "friction", "friction_dynamic",
              "gravity", "time_step", "exact_time_step", "ground", "joint_spring", "friction_spring", "servo",
              "terrain", "track", "harmonics", "frequency"):
        assert getattr(d, f) == getattr(ref, f), f
    assert d.path == "<string>" and d.joints == [] and d.logs == []


def test_keywords_are_case_insensitive_and_blocks_can_sit_anywhere():
    d = parse_wl(textwrap.dedent("""\
        timemax 3   # comment after a value
        SIMULATE on
        textonly off
        object A
        {
          TYPE cube
          mass 1 ; dimensions 1 1 1
        }
        """).replace(" ; ", "\n"))
    assert d.time_max == 3.0 and d.simulate is True and d.text_only is False
    assert d.objects["A"].type == "Cube"


def test_control_index_follows_file_order_of_controlled_joints():
    objs = "".join(f"Object {n} {{\n Type Cube\n Mass 1\n Dimensions .1 .1 .1\n}}\n" for n in "ABCDE")
    joints = "".join(
        f"Joint J{i} {{\n {a} 0 0 0\n {b} 0 0 .1\n {kind}\n}}\n"
        for i, (a, b, kind) in enumerate([("A", "B", "ControlX"), ("B", "C", "PassiveY"),
                                           ("A", "D", "ControlZ"), ("D", "E", "ControlY")]))
    d = parse_wl(objs + joints)
    assert [(j.axis, j.controlled, j.control_index) for j in d.joints] == [
        ("X", True, 0), ("Y", False, None), ("Z", True, 1), ("Y", True, 2)]
    assert d.n_controlled == 3


@pytest.mark.parametrize(("line", "kind", "params", "axis"), [
    ("Terrain flat", "flat", (), "Y"),
    ("Terrain ramp 0.1", "ramp", (0.1,), "Y"),
    ("Terrain ramp -0.2 x", "ramp", (-0.2,), "X"),
    ("Terrain bump 0.03 2.0", "bump", (0.03, 2.0), "Y"),
    ("Terrain ROUGH 0.02", "rough", (0.02,), "Y"),
    ("Terrain rough 0.04 0.2 7", "rough", (0.04, 0.2, 7.0), "Y"),
])
def test_terrain_kinds(line, kind, params, axis):
    t = parse_wl(line + "\n" + OBJ_A).terrain
    assert (t.kind, t.params, t.axis, t.heights, t.line) == (kind, params, axis, None, 1)


def test_terrain_matrix():
    d = parse_wl("Terrain matrix 3 2 -1 1 0 4\n{\n 0 .1 .2\n .3 .4 .5 }\nTimeMax 1\n" + OBJ_A)
    t = d.terrain
    assert t.kind == "matrix" and t.params == (3.0, 2.0, -1.0, 1.0, 0.0, 4.0)
    assert t.heights == ((0.0, 0.1, 0.2), (0.3, 0.4, 0.5))


def _strip(d: Description) -> dict:
    """A Description as plain data, without line numbers, path and text (for round trips)."""
    out = dataclasses.asdict(d)
    out.pop("path"), out.pop("text")

    def drop(x):
        if isinstance(x, dict):
            return {k: drop(v) for k, v in x.items() if k != "line" and not k.endswith("_line")}
        if isinstance(x, list | tuple):
            return [drop(v) for v in x]
        return x

    return drop(out)


@pytest.mark.parametrize("text", [SMALL, THESIS_EXCERPT + EXCERPT_FILLER,
                                  "Terrain matrix 2 2 0 1 0 1 { 0 1\n 2 3 }\nObject A {\n Type Sphere\n Mass 1\n"
                                  " Dimensions .1\n}\n",
                                  "Terrain rough 0.02 0.1 3\nJointSpring 2e4 50\nFrictionSpring 1e5 1e3\n"
                                  "TimeStep 1e-4\nObject A {\n"
                                  " Type Sphere\n Mass 1\n Dimensions .1\n}\n",
                                  "Pipeline EXACT\nObject A {\n Type Sphere\n Mass 1\n Dimensions .1\n}\n",
                                  "TimeStep 2.5e-4\nExactTimeStep 1e-3\nObject A {\n Type Sphere\n Mass 1\n"
                                  " Dimensions .1\n}\n",
                                  "Pipeline springs\n" + SMALL])
def test_format_round_trip(tmp_path, text):
    d = parse_wl(text)
    again = load_wl(_write(tmp_path, format_wl(d), "again.wl"))
    assert _strip(again) == _strip(d)
    assert format_wl(again).splitlines()[1:] == format_wl(d).splitlines()[1:]


@pytest.mark.parametrize(("line", "pipeline"), [("", None), ("Pipeline springs\n", "springs"),
                                                ("pipeline Exact\n", "exact")])
def test_pipeline_keyword(line, pipeline):
    d = parse_wl("TimeMax 2\n" + line + OBJ_A)
    assert (d.pipeline, d.pipeline_line) == (pipeline, 2 if line else 0)
    written = [w for w in format_wl(d).splitlines() if w.startswith("Pipeline")]
    assert written == ([f"Pipeline {pipeline}"] if pipeline else [])


def test_pipeline_keyword_chooses_the_models_pipeline_and_the_command_overrides_it():
    from cpgjax.sim.model import DEFAULT_DT, DEFAULT_DT_EXACT, build_model

    plain, exact = parse_wl(OBJ_A), parse_wl("Pipeline exact\n" + OBJ_A)
    assert (build_model(plain).pipeline, build_model(plain).dt) == ("springs", DEFAULT_DT)
    assert (build_model(exact).pipeline, build_model(exact).dt) == ("exact", DEFAULT_DT_EXACT)
    assert build_model(exact, pipeline="springs").pipeline == "springs"
    assert build_model(plain, pipeline="exact").pipeline == "exact"


def test_load_wl_accepts_pathlib(tmp_path):
    p = tmp_path / "m.wl"
    p.write_text("TimeMax 4\nObject A {\n Type Sphere\n Mass 1\n Dimensions .1\n}\n")
    assert load_wl(p).time_max == 4.0 and load_wl(p).path == str(p)


def test_docs_example_parses():
    """The complete example of docs/wl-format.md §7 is a valid file."""
    from pathlib import Path

    doc = (Path(__file__).resolve().parents[2] / "docs" / "wl-format.md").read_text()
    section = doc.split("## 7.", 1)[1]
    example = section.split("```\n", 2)[1]
    d = parse_wl(example, "one-leg.wl")
    assert list(d.compounds) == ["Body"] and [j.name for j in d.joints] == ["Hip", "Axle"]
    assert d.n_controlled == 1 and d.text_only and d.track == "Body"


def test_exact_time_step_keyword():
    d = parse_wl("TimeStep 2.5e-4\nexacttimestep 1E-3  # the exact pipeline's\n" + OBJ_A)
    assert (d.time_step, d.exact_time_step) == (2.5e-4, 1e-3)
    assert parse_wl(OBJ_A).exact_time_step is None
    written = [w for w in format_wl(d).splitlines() if "TimeStep" in w]
    assert written == ["TimeStep 0.00025", "ExactTimeStep 0.001"]
    assert not [w for w in format_wl(parse_wl(OBJ_A)).splitlines() if "TimeStep" in w]


@pytest.mark.parametrize(("head", "springs", "exact"), [
    ("", "DEFAULT_DT", "DEFAULT_DT_EXACT"),
    ("TimeStep 1e-4\n", 1e-4, 1e-4),                          # models/car.wl: one step on both
    ("ExactTimeStep 1e-3\n", "DEFAULT_DT", 1e-3),
    ("TimeStep 2.5e-4\nExactTimeStep 2e-3\n", 2.5e-4, 2e-3),  # models/hexapod.wl
    ("ExactTimeStep 2e-3\nTimeStep 2.5e-4\n", 2.5e-4, 2e-3),  # order does not matter
])
def test_exact_time_step_sets_the_exact_pipelines_step_only(head, springs, exact):
    from cpgjax.sim import model as m

    want = [getattr(m, v) if isinstance(v, str) else v for v in (springs, exact)]
    d = parse_wl(head + OBJ_A)
    assert [m.build_model(d, pipeline=p).dt for p in ("springs", "exact")] == want
    assert m.build_model(parse_wl("Pipeline exact\n" + head + OBJ_A)).dt == want[1]
    # an explicit step (the commands' --dt) wins on both pipelines
    assert [m.build_model(d, dt=3e-4, pipeline=p).dt for p in ("springs", "exact")] == [3e-4, 3e-4]
