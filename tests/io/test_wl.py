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


# ----------------------------------------------------------------------------- malformed files

OBJ_A = "Object A {\n    Type Cube\n    Mass 1\n    Dimensions .1 .1 .1\n}\n"  # lines 1-5
OBJ_B = OBJ_A.replace("Object A", "Object B")
TWO = OBJ_A + OBJ_B  # lines 1-10


def _joint(name: str, a: str, b: str, extra: str = "ControlX") -> str:
    return f"Joint {name} {{\n    {a} 0 0 0\n    {b} 0 0 .1\n    {extra}\n}}\n"  # 5 lines


BAD = [
    # (id, text, line, what the message must contain)
    ("bad-number", OBJ_A.replace("Mass 1", "Mass abc"), 3,
     "Mass expects 1 number, got 'abc' (usage: Mass KG)"),
    ("too-many-numbers", OBJ_A.replace("Mass 1", "Mass 1 2"), 3, "Mass expects 1 number, got 2: '1 2'"),
    ("keyword-typo", OBJ_A.replace("Mass 1", "Mas 1"), 3,
     "unknown keyword 'Mas' in Object 'A' (did you mean 'Mass'?); allowed here: Type, Color, Mass"),
    ("top-level-typo", "Frction 2.5\n", 1,
     "unknown keyword 'Frction' in the top level (did you mean 'Friction'?)"),
    ("missing-mass", OBJ_A.replace("    Mass 1\n", ""), 1,
     "Object 'A' is missing Mass; add a line 'Mass KG' inside its block"),
    ("undefined-joint-body", TWO + _joint("Hip", "Bdy", "B"), 12,
     "Joint 'Hip' names body 'Bdy' which is not defined (objects/compounds: A, B)"),
    ("joint-body-typo", TWO + _joint("Hip", "A", "Bb"), 13,
     "names body 'Bb' which is not defined (did you mean 'B'?)"),
    ("unterminated-block", OBJ_A.replace("}\n", ""), 4,
     "unterminated block '{' opened at line 1 (Object 'A'): add"),
    ("missing-close-before-next", OBJ_A.replace("}\n", "") + OBJ_B, 5,
     "'Object' inside Object 'A' (block opened at line 1): is a '}' missing above this line?"),
    ("keyword-out-of-place", "Mass 2\n", 1,
     "'Mass' does not belong in the top level: it is allowed in Object blocks"),
    ("joint-keyword-in-object", OBJ_A.replace("Mass 1", "Mass 1\n    ControlX"), 4,
     "'ControlX' does not belong in Object 'A': it is allowed in Joint blocks"),
    ("object-keyword-in-joint", TWO + _joint("J", "A", "B", "ControlX\n    Position 0 0 1"), 15,
     "'Position' does not belong in Joint 'J': it is allowed in Object blocks and Compound blocks"),
    ("stray-close", "TimeMax 1\n}\n", 2, "'}' without a matching '{'"),
    ("header-without-block", "Object A\nType Cube\n", 1, "Object 'A' expects a block: put '{'"),
    ("duplicate-name", OBJ_A + OBJ_A, 6, "duplicate name 'A': already defined as Object at line 1"),
    ("duplicate-compound-name", OBJ_A + "Compound A { A }\n", 6, "duplicate name 'A'"),
    ("object-in-two-compounds", TWO + "Compound C { A }\nCompound D {\n B\n A\n}\n", 14,
     "Object 'A' is already in Compound 'C'; an object can belong to one compound only"),
    ("compound-lists-unknown", OBJ_A + "Compound C {\n A\n Z\n}\n", 8,
     "Compound 'C' lists 'Z', which is not a defined Object (objects: A)"),
    ("cylinder-dimensions", OBJ_A.replace("Cube", "Cylinder"), 4,
     "Object 'A' is a Cylinder, so Dimensions needs 2 numbers (RADIUS LENGTH), got 3"),
    ("sphere-dimensions", OBJ_A.replace("Cube", "Sphere"), 4, "so Dimensions needs 1 number (RADIUS), got 3"),
    ("unknown-type", OBJ_A.replace("Cube", "Cub"), 2, "unknown Type 'Cub' (did you mean 'Cube'?)"),
    ("zero-mass", OBJ_A.replace("Mass 1", "Mass 0"), 3, "Mass of Object 'A' must be positive (kg), got 0"),
    ("negative-dimension", OBJ_A.replace(".1 .1 .1", ".1 -.1 .1"), 4,
     "Dimensions of Object 'A' must be positive"),
    ("limits-reversed", TWO + _joint("Hip", "A", "B", "ControlX\n    Limits 1.5 -1.5"), 15,
     "Limits of Joint 'Hip' need LO < HI (radians), got 1.5 -1.5"),
    ("undefined-color", "ColorDef Brown .7 .8 .5\n" + OBJ_A.replace("Mass 1", "Mass 1\n    Color Brwn"), 5,
     "colour 'Brwn' of Object 'A' is not defined by a ColorDef (did you mean 'Brown'?) (defined: Brown)"),
    ("track-unknown-body", OBJ_A + "Track Body\n", 6, "Track names body 'Body' which is not defined"),
    ("log-object-inside-compound", OBJ_A + "Compound C { A }\nLog A a.log\n", 7,
     "Log names 'A', an object inside Compound 'C'; name the compound 'C' instead"),
    ("joint-object-inside-compound", TWO + "Compound C { A }\n" + _joint("Hip", "A", "B"), 13,
     "Joint 'Hip' names 'A', an object inside Compound 'C'"),
    ("matrix-short-row", "Terrain matrix 3 2 0 1 0 1 {\n 0 0 0\n 0 0\n}\n", 3,
     "matrix row 2 has 2 heights, expected NX = 3"),
    ("matrix-missing-row", "Terrain matrix 3 2 0 1 0 1 {\n 0 0 0\n}\n", 3,
     "matrix has 1 row of heights, expected NY = 2"),
    ("negative-lograte", "LogRate -5\n", 1,
     "LogRate must be positive (samples per simulated second), got -5"),
    ("zero-timemax", "TimeMax 0\n", 1, "TimeMax must be positive (simulated seconds), got 0"),
    ("nan", "Gravity nan\n", 1, "Gravity: 'nan' is not a finite number"),
    ("inf", OBJ_A.replace(".1 .1 .1", ".1 inf .1"), 4, "Dimensions: 'inf' is not a finite number"),
    ("overflow", "TimeMax 1e999\n", 1, "too large to be a finite number"),
    ("second-parent", TWO + _joint("J1", "A", "B") + _joint("J2", "A", "B"), 16,
     "body 'B' is already the second body of Joint 'J1' (line 11); a body can hang from one joint only"),
    ("joint-loop", TWO + _joint("J1", "A", "B") + _joint("J2", "B", "A"), 16,
     "joints form a loop (B -> A -> B); joints must form a tree: remove Joint 'J2'"),
    ("joint-self", OBJ_A + _joint("J", "A", "A"), 8, "Joint 'J' joins body 'A' to itself"),
    ("joint-third-body", TWO + _joint("J", "A", "B", "ControlX\n    A 0 0 0"), 15, "names a third body 'A'"),
    ("joint-one-body", OBJ_A + "Joint J {\n A 0 0 0\n ControlX\n}\n", 6,
     "Joint 'J' names 1 body; it needs two lines"),
    ("joint-no-kind", TWO + _joint("J", "A", "B", "Limits -1 1"), 11, "Joint 'J' has no kind; add ControlX"),
    ("joint-two-kinds", TWO + _joint("J", "A", "B", "ControlX\n    PassiveY"), 15,
     "already has its kind at line 14"),
    ("joint-orientation-off-axis", TWO + _joint("J", "A", "B", "ControlX\n    Orientation .4 .1 0"), 15,
     "Joint 'J' turns about X, so its Orientation may only rotate about X"),
    ("passive-servo", TWO + _joint("J", "A", "B", "PassiveX\n    Servo 1 0 0 1"), 15,
     "Joint 'J' is passive, so its Servo would do nothing"),
    ("joint-keyword-typo", TWO + _joint("J", "A", "B", "ControlX\n    Limit -1 1"), 15,
     "unknown keyword 'Limit' in Joint 'J' (did you mean 'Limits'?)"),
    ("joint-keyword-typo-3-numbers", TWO + _joint("J", "A", "B", "ControlX\n    Orientaton .4 0 0"), 15,
     "names a third body 'Orientaton' (or did you mean the keyword 'Orientation'?)"),
    ("joint-keyword-typo-first-line", TWO + _joint("J", "Orientaton", "B").replace(" 0 0 0", " .4 0 0"), 12,
     "names body 'Orientaton' which is not defined (or did you mean the keyword 'Orientation'?)"),
    ("several-statements-on-a-line", OBJ_A.replace("Type Cube", "Type Cube Mass 1"), 2,
     "Type expects one shape (Cube, Cylinder or Sphere), got 'Cube Mass 1'; write one statement per line"),
    ("duplicate-setting", "TimeMax 1\nTimeMax 2\n", 2, "TimeMax given twice (first at line 1); keep one"),
    ("duplicate-keyword-in-block", OBJ_A.replace("Mass 1", "Mass 1\n    Mass 2"), 4,
     "Mass given twice in Object 'A' (first at line 3)"),
    ("bad-onoff", "Simulate YES\n", 1, "Simulate expects ON or OFF, got 'YES'"),
    ("color-out-of-range", "ColorDef Red 255 0 0\n", 1, "ColorDef components are fractions in [0, 1]"),
    ("harmonics-not-integer", "Harmonics 2.5\n", 1, "Harmonics expects an integer, got '2.5'"),
    ("unknown-terrain", "Terrain rugh 0.02\n", 1, "unknown terrain kind 'rugh' (did you mean 'rough'?)"),
    ("keyword-as-name", "Object Mass {\n Type Cube\n}\n", 1, "Object name 'Mass' is a keyword"),
    ("nested-brace", OBJ_A.replace("Mass 1", "{"), 3, "unexpected '{' inside Object 'A'"),
    ("no-contact-and-contact", OBJ_A.replace("Mass 1", "Mass 1\n NoContact\n Contact 0 0 0"), 4,
     "Object 'A' has both NoContact and Contact lines"),
    ("fixed-inside-compound", OBJ_A.replace("Mass 1", "Mass 1\n Fixed") + "Compound C { A }\n", 4,
     "Object 'A' is Fixed but belongs to Compound 'C'; put Fixed in the compound's block"),
    ("log-file-twice", OBJ_A + OBJ_B + "Log A x.log\nLog B x.log\n", 12,
     "log file 'x.log' is already used at line 11"),
    ("unknown-pipeline", OBJ_A + "Pipeline exakt\n", 6,
     "unknown pipeline 'exakt' (did you mean 'exact'?); choose one of springs, exact (usage: Pipeline springs|exact)"),
    ("pipeline-without-value", "Pipeline\n" + OBJ_A, 1,
     "Pipeline expects one pipeline (springs or exact), got 'nothing'"),
    ("pipeline-twice", "Pipeline exact\nPipeline springs\n" + OBJ_A, 2, "Pipeline given twice (first at line 1)"),
]


@pytest.mark.parametrize(("text", "line", "message"), [b[1:] for b in BAD], ids=[b[0] for b in BAD])
def test_malformed_file_reports_path_line_and_fix(tmp_path, text, line, message):
    path = _write(tmp_path, text, "bad.wl")
    with pytest.raises(DescriptionError) as e:
        load_wl(path)
    err = e.value
    assert str(err).startswith(f"{path}:{line}: "), str(err)
    assert message in err.message, err.message
    assert (err.path, err.line) == (path, line)


def test_bad_ids_are_unique_and_many():
    assert len({b[0] for b in BAD}) == len(BAD) >= 12


def test_first_problem_in_file_order_is_reported_with_a_count():
    text = OBJ_A.replace("Mass 1", "Color Nope") + OBJ_B.replace("Cube", "Sphere")
    with pytest.raises(DescriptionError) as e:
        parse_wl(text, "x.wl")
    assert str(e.value).startswith("x.wl:1: Object 'A' is missing Mass")
    assert str(e.value).endswith("(and 1 more problem)")


def test_parse_string_default_path():
    with pytest.raises(DescriptionError, match=r"^<string>:1: unknown keyword"):
        parse_wl("Bogus 1\n")


def test_non_utf8_file(tmp_path):
    p = tmp_path / "bin.wl"
    p.write_bytes(b"\xff\xfe\x00junk")
    with pytest.raises(DescriptionError, match=r"bin\.wl:1: not a UTF-8 text file"):
        load_wl(p)


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
