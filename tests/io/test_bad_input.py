"""Every bad input is one clear line: ``path:line: what is wrong`` (files) or ``terrain 'SPEC': ...``.

Table-driven: malformed `.wl` and `.ctl` files (text or bytes), things that are not files,
and ``--terrain`` specs.  The `.wl` parser and the command line share one terrain check
(:func:`cpgjax.sim.terrain.check_terrain`), so each bad terrain is rejected by both.
"""

from __future__ import annotations

import re

import pytest

from cpgjax.errors import DescriptionError
from cpgjax.io.ctl import read_ctl
from cpgjax.io.textfile import MissingFileError
from cpgjax.io.wl import load_model, load_wl
from cpgjax.sim.terrain import make_terrain, parse_terrain

OBJ = "Object A {\n    Type Cube\n    Mass 1\n    Dimensions .1 .1 .1\n}\n"  # lines 1-5


def _wl_obj(line: str) -> str:
    """OBJ with ``line`` replacing its Mass line (line 3)."""
    return OBJ.replace("    Mass 1\n", f"    {line}\n")


# (id, file content: str or bytes, line, fragment of the message)
BAD_WL = [
    ("empty", "", 1, "the description defines no Object, so there is nothing to simulate"),
    ("comments-only", "# nothing\n\n   # here\n", 1, "defines no Object"),
    ("settings-only", "TimeMax 2\nLogRate 20\n", 1, "defines no Object"),
    ("binary", bytes(range(256)), 2, "not a UTF-8 text file (byte 0x80"),  # byte 10 ends line 1
    ("binary-later-line", b"TimeMax 2\n\xff\xfe\n", 2, "not a UTF-8 text file"),
    ("nul-bytes", "TimeMax 2\nLog\x00Rate 2\n", 2, "not a text file (it holds NUL bytes)"),
    ("latin-1", "# caf\xe9\n".encode("latin-1") + OBJ.encode(), 1, "not a UTF-8 text file"),
    ("friction-spring-zero", "TimeMax 2\nFrictionSpring 0 300\n" + OBJ, 2,
     "FrictionSpring needs K > 0 (bristle spring, N/m) and B >= 0 (its damper, N s/m), got 0 300"),
    ("ramp-too-steep", "Terrain ramp 2\n" + OBJ, 1, "ramp slope is an angle in radians, |SLOPE| < pi/2, got 2"),
    ("bump-zero-width", "Terrain bump 0.1 1 0\n" + OBJ, 1, "bump WIDTH must be positive (metres along y), got 0"),
    ("bump-narrow", "Terrain bump 0.1 1 0.001\n" + OBJ, 1, "bump WIDTH must be between 0.01 m"),
    ("bump-far", "Terrain bump 0.1 1e300 0.3\n" + OBJ, 1, "bump Y must be within +-1000 m, got 1e+300"),
    ("rough-zero-cell", "Terrain rough 0.01 0\n" + OBJ, 1, "rough CELL must be positive (metres), got 0"),
    ("rough-tiny-cell", "Terrain rough 0.01 1e-6\n" + OBJ, 1, "rough CELL must be between 0.005 and 3 m"),
    ("rough-negative-seed", "Terrain rough 0.01 0.1 -3\n" + OBJ, 1, "rough SEED must be a non-negative integer"),
    ("matrix-one-column", "Terrain matrix 1 2 0 1 0 1 {\n 0\n 0\n}\n" + OBJ, 1, "matrix needs NX >= 2"),
    ("mass-tiny", _wl_obj("Mass 5e-324"), 3, "Mass of Object 'A' must be between 1e-06 and 1e+06 kg"),
    ("dimension-huge", OBJ.replace(".1 .1 .1", ".1 2e198 .1"), 4, "Dimensions of Object 'A' must be between"),
    ("contact-far", _wl_obj("Mass 1\n    Contact 1e300 0 0"), 4, "Contact of Object 'A' must be within +-1000 m"),
    ("rim-points-huge", OBJ.replace("Cube", "Cylinder").replace(".1 .1 .1", ".1 .1").replace(
        "Mass 1", "Mass 1\n    RimPoints 99999999999"), 4, "RimPoints must be at most 1000"),
    ("harmonics-huge", "Harmonics 99999999999\n" + OBJ, 1, "Harmonics must be at most 100"),
    ("timestep-tiny", "TimeStep 1e-300\n" + OBJ, 1, "TimeStep must be between 1e-05 and 0.01 s"),
    ("exact-timestep-tiny", "TimeMax 2\nExactTimeStep 1e-300\n" + OBJ, 2,
     "ExactTimeStep must be between 1e-05 and 0.01 s"),
    ("exact-timestep-zero", "ExactTimeStep 0\n" + OBJ, 1, "ExactTimeStep must be positive (seconds), got 0"),
    ("exact-timestep-word", "ExactTimeStep fast\n" + OBJ, 1,
     "ExactTimeStep expects 1 number, got 'fast' (usage: ExactTimeStep SECONDS)"),
    ("timemax-huge", "TimeMax 1e300\n" + OBJ, 1, "TimeMax must be between 0 and 3600 s"),
    ("lograte-tiny", "LogRate 1e-300\n" + OBJ, 1, "LogRate must be between 0.01 and 100000"),
    ("pivot-far", OBJ + OBJ.replace("Object A", "Object B") + "Joint J {\n A 0 -1e300 0\n B 0 0 0\n ControlX\n}\n",
     12, "the pivot on 'A' of Joint 'J' must be within +-1000 m"),
]

BAD_CTL = [
    ("empty", "", None, 1, "empty control file"),
    ("binary", bytes(range(128, 256)), None, 1, "not a UTF-8 text file"),
    ("nul-bytes", "0.1\n0 0 0\x00 0 0\n", None, 2, "not a text file (it holds NUL bytes)"),
    ("word", "0.1\n0 x 0 0 0\n", None, 2, "'x' is not a number"),
    ("nan", "0.1\n0 nan 0 0 0\n", None, 2, "'nan' is not a finite number"),
    ("overflow", "0.1\n0 1e309 0 0 0\n", None, 2, "'1e309' is not a finite number"),
    ("no-fitness", "0 0 0 0 0\n0 0 0 0 0\n", None, 1, "the first line must be the fitness"),
    ("even-count", "0.1\n0 0 0 0\n", None, 2, "a DOF line has 2K+1 numbers"),
    ("ragged", "0.1\n0 0 0 0 0\n0 0 0\n", None, 3, "found a line of 3 numbers"),
    ("wrong-dofs", "0.1\n0 0 0 0 0\n", (2, 2), 2, "expected 2 DOF lines of 5 coefficients (K=2), found 1"),
    ("wrong-harmonics", "0.1\n0 0 0\n", (1, 2), 2, "expected 1 DOF line of 5 coefficients (K=2)"),
]

# (spec, fragment of the message); every one also names the spec and gives an example
BAD_TERRAIN = [
    ("ramp:2", "ramp slope is an angle in radians, |SLOPE| < pi/2, got 2"),
    ("ramp:-1.6", "|SLOPE| < pi/2, got -1.6"),
    ("ramp:0.1:Z", "ramp axis must be X or Y, got 'Z'"),
    ("ramp:0.1:X:3", "ramp takes SLOPE[:X|Y]"),
    ("ramp:nan", "ramp SLOPE: 'nan' is not a finite number"),
    ("ramp:1e309", "'1e309' is not a finite number"),
    ("bump:0.1:0", "bump WIDTH must be positive (metres along y), got 0"),
    ("bump:0.1:-0.2", "bump WIDTH must be positive"),
    ("bump:0.1@1:1e6", "bump WIDTH must be between 0.01 m"),
    ("bump:0.1@1e300", "bump Y must be within +-1000 m"),
    ("bump:x", "bump HEIGHT expects a number, got 'x'"),
    ("bump:0.1:0.2:0.3", "bump takes HEIGHT[@Y][:WIDTH]"),
    ("rough:0.01:0", "rough CELL must be positive (metres), got 0"),
    ("rough:0.01:-1", "rough CELL must be positive"),
    ("rough:0.01:1e-5", "rough CELL must be between 0.005 and 3 m"),
    ("rough:0.01:100", "rough CELL must be between 0.005 and 3 m"),
    ("rough:-0.01", "rough RANGE must be >= 0 (metres), got -0.01"),
    ("rough:0.01:0.1:2.5", "rough SEED must be a non-negative integer, got 2.5"),
    ("rough:0.01:0.1:-1", "rough SEED must be a non-negative integer, got -1"),
    ("rough:", "rough RANGE expects a number, got ''"),
    ("flat:1", "flat takes no parameters"),
    ("hill:1", "unknown terrain 'hill:1'; expected flat | ramp:SLOPE[:X|Y]"),
    ("matrix", "a matrix terrain is given in a .wl file"),
    ("", "unknown terrain ''"),
]


def _one_line(msg: str) -> None:
    assert "\n" not in msg and "Traceback" not in msg, msg


@pytest.mark.parametrize(("content", "line", "fragment"), [b[1:] for b in BAD_WL], ids=[b[0] for b in BAD_WL])
def test_bad_wl_is_one_line_naming_file_and_line(tmp_path, content, line, fragment):
    path = tmp_path / "bad.wl"
    path.write_bytes(content if isinstance(content, bytes) else content.encode("utf-8"))
    with pytest.raises(DescriptionError) as e:
        load_model(path)  # parse and build: what `cpgjax simulate` does
    msg = str(e.value)
    _one_line(msg)
    assert msg.startswith(f"{path}:{line}: "), msg
    assert fragment in msg, msg


@pytest.mark.parametrize(("content", "shape", "line", "fragment"), [b[1:] for b in BAD_CTL],
                         ids=[b[0] for b in BAD_CTL])
def test_bad_ctl_is_one_line_naming_file_and_line(tmp_path, content, shape, line, fragment):
    path = tmp_path / "bad.ctl"
    path.write_bytes(content if isinstance(content, bytes) else content.encode("utf-8"))
    with pytest.raises(DescriptionError) as e:
        read_ctl(path, *(shape or (None, None)))
    msg = str(e.value)
    _one_line(msg)
    assert msg.startswith(f"{path}:{line}: "), msg
    assert fragment in msg, msg


@pytest.mark.parametrize("read", [load_wl, read_ctl], ids=["wl", "ctl"])
def test_a_directory_is_named_with_the_files_in_it(tmp_path, read):
    ext = ".wl" if read is load_wl else ".ctl"
    (tmp_path / f"robot{ext}").write_text("x")
    with pytest.raises(DescriptionError) as e:
        read(tmp_path)
    msg = str(e.value)
    _one_line(msg)
    assert msg.startswith(f"{tmp_path}: is a directory, not a {ext} file; name one of its {ext} files, e.g. "
                          f"{tmp_path / ('robot' + ext)}"), msg


@pytest.mark.parametrize("read", [load_wl, read_ctl], ids=["wl", "ctl"])
def test_a_missing_file_is_still_a_file_not_found_error(tmp_path, read):
    ext = ".wl" if read is load_wl else ".ctl"
    (tmp_path / f"quadruped{ext}").write_text("x")
    with pytest.raises(FileNotFoundError) as e:
        read(tmp_path / f"quadrupd{ext}")
    assert isinstance(e.value, MissingFileError) and isinstance(e.value, DescriptionError)
    assert str(e.value) == f"{tmp_path / ('quadrupd' + ext)}: no such file (did you mean " \
                           f"'{tmp_path / ('quadruped' + ext)}'?)"
    with pytest.raises(MissingFileError, match=r"nowhere/x\.\w+: no such file; the directory '.*nowhere' does not"):
        read(tmp_path / "nowhere" / f"x{ext}")


@pytest.mark.parametrize(("spec", "fragment"), BAD_TERRAIN, ids=[b[0] or "empty" for b in BAD_TERRAIN])
def test_bad_terrain_spec_names_the_spec(spec, fragment):
    for build in (parse_terrain, make_terrain):
        with pytest.raises(ValueError) as e:
            build(spec)
        msg = str(e.value)
        _one_line(msg)
        assert msg.startswith(("terrain ", "unknown terrain ")) and repr(spec.strip()) in msg, msg
        assert fragment in msg, msg
        if msg.startswith("terrain "):
            example = re.search(r"\(e\.g\. (\S+)\)$", msg)
            assert example and parse_terrain(example.group(1)), msg  # the example is itself valid


@pytest.mark.parametrize("spec", ["flat", "ramp:0.2", "ramp:-0.2:x", "bump:0.02", "bump:0.02@1.5",
                                  "bump:0.02@1.5:0.3", "bump:-0.05@2:0.01", "bump:0.1@:0.2", "rough:0.02",
                                  "rough:0.02::7", "rough:0.02:0.1:7", "rough:0:3", " rough:0.02:0.005 "])
def test_good_terrain_specs(spec):
    assert make_terrain(spec).spec == spec.strip()
    assert make_terrain("FLAT").flat and make_terrain("Ramp:0.1:y").spec == "Ramp:0.1:y"


@pytest.mark.parametrize(("cli", "wl"), [
    ("ramp:2", "ramp 2"), ("ramp:-1.6:X", "ramp -1.6 X"), ("bump:0.1@1:0", "bump 0.1 1 0"),
    ("bump:0.1@1:0.001", "bump 0.1 1 0.001"), ("bump:0.1@2000", "bump 0.1 2000"),
    ("rough:-1", "rough -1"), ("rough:0.01:0", "rough 0.01 0"), ("rough:0.01:1e-6", "rough 0.01 1e-6"),
    ("rough:0.01:0.1:-1", "rough 0.01 0.1 -1"),
])
def test_cli_and_wl_reject_a_terrain_with_the_same_words(tmp_path, cli, wl):
    with pytest.raises(ValueError) as cli_err:
        parse_terrain(cli)
    path = tmp_path / "t.wl"
    path.write_text(f"Terrain {wl}\n" + OBJ)
    with pytest.raises(DescriptionError) as wl_err:
        load_wl(path)
    assert wl_err.value.line == 1
    # "terrain 'SPEC': <the shared message> (e.g. ...)"
    assert f": {wl_err.value.message} (e.g. " in str(cli_err.value), (str(cli_err.value), wl_err.value.message)
