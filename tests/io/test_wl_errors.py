"""The `.wl` parser on malformed files: one line naming the file, the line and the fix (docs/wl-format.md)."""

from __future__ import annotations

import pytest

from cpgjax.io.wl import load_wl, parse_wl
from cpgjax.sim.description import DescriptionError


def _write(tmp_path, text: str, name: str = "model.wl") -> str:
    p = tmp_path / name
    p.write_text(text)
    return str(p)


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
