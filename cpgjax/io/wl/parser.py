"""Parser for the `.wl` description file (thesis Ch. 3.5.1), producing :mod:`cpgjax.sim.description` records.

The thesis shows only an excerpt of the format (Ch. 3.5.1: ``ColorDef``, ``TimeMax``,
``Simulate``, ``Display``, ``LogRate``, ``Friction``, ``Object``, ``Compound``, ``Joint``,
``Log``; Ch. 3.5.3: ``TextOnly``).  The rest of the grammar (``Gravity``, ``Ground``,
``Terrain``, ``Servo``, ...) completes it so that one file describes a whole experiment;
docs/wl-format.md is the reference.

The format is line oriented: ``#`` starts a comment, keywords are case-insensitive, names
(objects, compounds, colours) are case-sensitive, and blocks are written ``{ ... }`` with
the ``{`` on the header line or on the next line.  Parsing is all-or-nothing: the text is
read fully, then checked, and only then a :class:`~cpgjax.sim.description.Description` is
returned.  Every problem raises :class:`~cpgjax.errors.DescriptionError`, whose text
is ``path:line: what is wrong and how to fix it``.

Public API: :func:`parse_wl`, :func:`load_wl`, :func:`format_wl`.
"""

from __future__ import annotations

import difflib
import math
import os
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any

from cpgjax.sim.description import (
    CompoundDef,
    Description,
    DescriptionError,
    JointDef,
    LogDef,
    ObjectDef,
    ServoDef,
    TerrainDef,
    Vec3,
)
from cpgjax.sim.model import Model, build_model

__all__ = ["parse_wl", "load_wl", "format_wl", "TOP_KEYWORDS", "OBJECT_KEYWORDS", "COMPOUND_KEYWORDS",
           "JOINT_KEYWORDS"]

# ----------------------------------------------------------------------------- keywords

#: Top-level keywords and their usage (the canonical spelling is the dict key).
TOP_KEYWORDS: dict[str, str] = {
    "ColorDef": "ColorDef NAME R G B",
    "TimeMax": "TimeMax SECONDS",
    "Simulate": "Simulate ON|OFF",
    "Display": "Display ON|OFF",
    "TextOnly": "TextOnly [ON|OFF]",
    "LogRate": "LogRate SAMPLES_PER_SECOND",
    "Friction": "Friction MU_STATIC [MU_DYNAMIC]",
    "Gravity": "Gravity M_PER_S2",
    "TimeStep": "TimeStep SECONDS",
    "Ground": "Ground A B",
    "JointSpring": "JointSpring ALPHA BETA",
    "Servo": "Servo KP KI KD TAUMAX",
    "Terrain": ("Terrain flat | ramp SLOPE [X|Y] | bump HEIGHT Y [WIDTH] | rough RANGE [CELL [SEED]] | "
                "matrix NX NY X0 X1 Y0 Y1 { rows }"),
    "Track": "Track BODY",
    "Harmonics": "Harmonics K",
    "Frequency": "Frequency HZ",
    "Log": "Log BODY FILE",
    "Object": "Object NAME { ... }",
    "Compound": "Compound NAME { ... }",
    "Joint": "Joint NAME { ... }",
}

#: Keywords inside ``Object NAME { }``.
OBJECT_KEYWORDS: dict[str, str] = {
    "Type": "Type Cube|Cylinder|Sphere",
    "Color": "Color NAME",
    "Mass": "Mass KG",
    "Dimensions": "Dimensions DX DY DZ (Cube) | RADIUS LENGTH (Cylinder) | RADIUS (Sphere)",
    "Position": "Position X Y Z",
    "Orientation": "Orientation RX RY RZ",
    "Contact": "Contact X Y Z",
    "NoContact": "NoContact",
    "RimPoints": "RimPoints N",
    "Fixed": "Fixed",
}

#: Keywords inside ``Compound NAME { }`` (other lines name member objects).
COMPOUND_KEYWORDS: dict[str, str] = {
    "Position": "Position X Y Z",
    "Orientation": "Orientation RX RY RZ",
    "Fixed": "Fixed",
}

#: Keywords inside ``Joint NAME { }`` (other lines are ``BODY X Y Z`` pivots).
JOINT_KEYWORDS: dict[str, str] = {
    "Orientation": "Orientation RX RY RZ",
    "Limits": "Limits LO HI",
    **{f"Control{a}": f"Control{a}" for a in "XYZ"},
    **{f"Passive{a}": f"Passive{a}" for a in "XYZ"},
    "Servo": "Servo KP KI KD TAUMAX",
}

_BLOCK_KEYWORDS = ("object", "compound", "joint")
_ALL_KEYWORDS = {k.lower() for k in (*TOP_KEYWORDS, *OBJECT_KEYWORDS, *COMPOUND_KEYWORDS, *JOINT_KEYWORDS)}
_TYPES = {"cube": "Cube", "cylinder": "Cylinder", "sphere": "Sphere"}
_DIMS = {
    "Cube": (3, "DX DY DZ (full edge lengths)"),
    "Cylinder": (2, "RADIUS LENGTH"),
    "Sphere": (1, "RADIUS"),
}
_TERRAINS = ("flat", "ramp", "bump", "rough", "matrix")

_NUM_RE = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?\Z")
_INT_RE = re.compile(r"[+-]?\d+\Z")
_NONFINITE = {"nan", "+nan", "-nan", "inf", "+inf", "-inf", "infinity", "+infinity", "-infinity"}
_TOKEN_RE = re.compile(r"[{}]|[^\s{}]+")


# ----------------------------------------------------------------------------- tokens

@dataclass
class _Stmt:
    """One statement: the tokens of one line (``{`` and ``}`` are statements of their own)."""

    line: int
    toks: list[str]

    @property
    def head(self) -> str:
        return self.toks[0]

    @property
    def args(self) -> list[str]:
        return self.toks[1:]


def _tokenize(text: str) -> list[_Stmt]:
    out: list[_Stmt] = []
    for n, raw in enumerate(text.splitlines(), start=1):
        code = raw.split("#", 1)[0]
        cur: list[str] = []
        for tok in _TOKEN_RE.findall(code):
            if tok in "{}":
                if cur:
                    out.append(_Stmt(n, cur))
                    cur = []
                out.append(_Stmt(n, [tok]))
            else:
                cur.append(tok)
        if cur:
            out.append(_Stmt(n, cur))
    return out


def _is_num(tok: str) -> bool:
    return bool(_NUM_RE.match(tok)) or tok.lower() in _NONFINITE


def _suggest(word: str, choices: Iterable[str]) -> str | None:
    choices = list(choices)
    lower = {c.lower(): c for c in choices}
    hit = difflib.get_close_matches(word.lower(), list(lower), n=1, cutoff=0.6)
    return lower[hit[0]] if hit else None


def _did_you_mean(word: str, choices: Iterable[str]) -> str:
    s = _suggest(word, choices)
    return f" (did you mean '{s}'?)" if s else ""


def _one_per_line(st: _Stmt) -> str:
    """A hint for lines that hold several statements (the format is one statement per line)."""
    if any(t.lower() in _ALL_KEYWORDS for t in st.args):
        return "; write one statement per line"
    return ""


def _plural(n: int, word: str) -> str:
    return f"{n} {word}" if n == 1 else f"{n} {word}s"


def _fmt_list(names: Iterable[str]) -> str:
    names = list(names)
    return ", ".join(names) if names else "none"


# ----------------------------------------------------------------------------- raw records

@dataclass
class _RawObject:
    name: str
    line: int
    fields: dict[str, Any] = field(default_factory=dict)
    lines: dict[str, int] = field(default_factory=dict)  # keyword -> line where given
    contacts: list[Vec3] = field(default_factory=list)


@dataclass
class _RawCompound:
    name: str
    line: int
    members: list[tuple[str, int]] = field(default_factory=list)
    fields: dict[str, Any] = field(default_factory=dict)
    lines: dict[str, int] = field(default_factory=dict)


@dataclass
class _RawJoint:
    name: str
    line: int
    bodies: list[tuple[str, Vec3, int]] = field(default_factory=list)
    fields: dict[str, Any] = field(default_factory=dict)
    lines: dict[str, int] = field(default_factory=dict)


# ----------------------------------------------------------------------------- parser

class _Parser:
    """Reads statements into raw records (syntax), then `_build` checks and assembles them."""

    def __init__(self, text: str, path: str):
        self.text, self.path = text, path
        self.stmts = _tokenize(text.removeprefix("\ufeff"))  # a byte-order mark is not a keyword
        self.n_lines = max(len(text.splitlines()), 1)
        self.i = 0
        self.desc = Description(path=path, text=text)
        self.settings: dict[str, int] = {}  # top-level keyword -> line (duplicates are errors)
        self.color_lines: dict[str, int] = {}
        self.objects: dict[str, _RawObject] = {}
        self.compounds: dict[str, _RawCompound] = {}
        self.joints: dict[str, _RawJoint] = {}
        self.track_line = 0

    # -- errors and arguments

    def err(self, line: int, message: str) -> DescriptionError:
        return DescriptionError(self.path, line, message)

    def number(self, tok: str, line: int, what: str, usage: str) -> float:
        if tok.lower() in _NONFINITE:
            raise self.err(line, f"{what}: '{tok}' is not a finite number (usage: {usage})")
        if not _NUM_RE.match(tok):
            raise self.err(line, f"{what} expects a number, got '{tok}' (usage: {usage})")
        v = float(tok)
        if not math.isfinite(v):
            raise self.err(line, f"{what}: '{tok}' is too large to be a finite number (usage: {usage})")
        return v

    def integer(self, tok: str, line: int, what: str, usage: str) -> int:
        if not _INT_RE.match(tok):
            raise self.err(line, f"{what} expects an integer, got '{tok}' (usage: {usage})")
        return int(tok)

    def numbers(self, st: _Stmt, kw: str, usage: str, lo: int, hi: int | None = None) -> tuple[float, ...]:
        """The arguments of ``st`` as ``lo``..``hi`` numbers, else an error naming ``kw`` and its usage."""
        hi = lo if hi is None else hi
        args = st.args
        want = _plural(lo, "number") if lo == hi else f"{lo} to {hi} numbers"
        for tok in args[:hi]:
            if not _is_num(tok):
                hint = _one_per_line(st)
                raise self.err(st.line, f"{kw} expects {want}, got '{tok}' (usage: {usage}){hint}")
        if not lo <= len(args) <= hi:
            got = f"{len(args)}: '{' '.join(args)}'" if args else "none"
            raise self.err(st.line, f"{kw} expects {want}, got {got} (usage: {usage})")
        return tuple(self.number(t, st.line, kw, usage) for t in args)

    def no_args(self, st: _Stmt, kw: str) -> None:
        if st.args:
            raise self.err(st.line, f"{kw} takes no arguments, got '{' '.join(st.args)}'")

    def onoff(self, st: _Stmt, kw: str, optional: bool = False) -> bool:
        if optional and not st.args:
            return True
        if len(st.args) != 1 or st.args[0].upper() not in ("ON", "OFF"):
            got = " ".join(st.args) or "nothing"
            raise self.err(st.line, f"{kw} expects ON or OFF, got '{got}' (usage: {TOP_KEYWORDS[kw]})")
        return st.args[0].upper() == "ON"

    def name_arg(self, st: _Stmt, kw: str, what: str) -> str:
        if len(st.args) != 1:
            got = " ".join(st.args) or "nothing"
            raise self.err(st.line, f"{kw} expects one {what}, got '{got}'{_one_per_line(st)}")
        return st.args[0]

    def check_name(self, name: str, line: int, what: str) -> None:
        if name.lower() in _ALL_KEYWORDS:
            raise self.err(line, f"{what} name '{name}' is a keyword; choose another name")
        if _is_num(name):
            raise self.err(line, f"{what} name '{name}' is a number; names must start with a letter")

    # -- blocks

    def next_stmt(self) -> _Stmt | None:
        if self.i >= len(self.stmts):
            return None
        st = self.stmts[self.i]
        self.i += 1
        return st

    def block(self, header: _Stmt, what: str) -> tuple[list[_Stmt], int]:
        """The statements between ``{`` (just after ``header``) and its ``}``, and the ``}`` line."""
        st = self.next_stmt()
        if st is None or st.toks != ["{"]:
            raise self.err(header.line, f"{what} expects a block: put '{{' at the end of this line or "
                                        "alone on the next line, and close it with '}'")
        opened = st.line
        body: list[_Stmt] = []
        while True:
            st = self.next_stmt()
            if st is None:
                raise self.err(self.n_lines, f"unterminated block '{{' opened at line {opened} ({what}): "
                                             "add a closing '}'")
            if st.toks == ["}"]:
                return body, st.line
            if st.toks == ["{"]:
                raise self.err(st.line, f"unexpected '{{' inside {what} (opened at line {opened}); blocks do "
                                        "not nest: is a '}' missing above?")
            if st.head.lower() in _BLOCK_KEYWORDS:
                raise self.err(st.line, f"'{st.head}' inside {what} (block opened at line {opened}): "
                                        "is a '}' missing above this line?")
            body.append(st)

    def unknown(self, st: _Stmt, where: str, allowed: Sequence[str], extra: str = "") -> DescriptionError:
        homes = [f"{home} blocks" if home != "top" else "the top level"
                 for home, table in (("top", TOP_KEYWORDS), ("Object", OBJECT_KEYWORDS),
                                     ("Compound", COMPOUND_KEYWORDS), ("Joint", JOINT_KEYWORDS))
                 if _canonical(st.head, table)]
        if homes:
            return self.err(st.line, f"'{st.head}' does not belong in {where}: it is allowed in "
                                     f"{' and '.join(homes)} (is a '{{' or '}}' misplaced?); allowed here: "
                                     f"{', '.join(allowed)}{extra}")
        return self.err(st.line, f"unknown keyword '{st.head}' in {where}{_did_you_mean(st.head, allowed)}; "
                                 f"allowed here: {', '.join(allowed)}{extra}")

    # -- top level

    def parse(self) -> Description:
        while (st := self.next_stmt()) is not None:
            if st.toks == ["{"]:
                raise self.err(st.line, "'{' without a header: a block follows 'Object NAME', "
                                        "'Compound NAME', 'Joint NAME' or 'Terrain matrix ...'")
            if st.toks == ["}"]:
                raise self.err(st.line, "'}' without a matching '{'")
            kw = _canonical(st.head, TOP_KEYWORDS)
            if kw is None:
                raise self.unknown(st, "the top level", list(TOP_KEYWORDS))
            if kw in ("Object", "Compound", "Joint"):
                getattr(self, f"parse_{kw.lower()}")(st)
            else:
                if kw not in ("ColorDef", "Log"):
                    if kw in self.settings:
                        raise self.err(st.line, f"{kw} given twice (first at line {self.settings[kw]}); "
                                                "keep one")
                    self.settings[kw] = st.line
                self.setting(kw, st)
        return self.build()

    def setting(self, kw: str, st: _Stmt) -> None:
        d, usage = self.desc, TOP_KEYWORDS[kw]
        if kw == "ColorDef":
            if len(st.args) != 4:
                raise self.err(st.line, f"ColorDef expects a name and 3 numbers, got '{' '.join(st.args)}' "
                                        f"(usage: {usage})")
            name = st.args[0]
            self.check_name(name, st.line, "colour")
            if name in self.color_lines:
                first = self.color_lines[name]
                raise self.err(st.line, f"colour '{name}' defined twice (first at line {first})")
            rgb = tuple(self.number(t, st.line, "ColorDef", usage) for t in st.args[1:])
            if not all(0.0 <= c <= 1.0 for c in rgb):
                raise self.err(st.line, f"ColorDef components are fractions in [0, 1], got {st.args[1:]}")
            self.color_lines[name] = st.line
            d.colors[name] = (rgb[0], rgb[1], rgb[2])
        elif kw == "TimeMax":
            (t,) = self.numbers(st, kw, usage, 1)
            if t <= 0:
                raise self.err(st.line, f"TimeMax must be positive (simulated seconds), got {t:g}")
            d.time_max = t
        elif kw == "Simulate":
            d.simulate = self.onoff(st, kw)
        elif kw == "Display":
            d.display = self.onoff(st, kw)
        elif kw == "TextOnly":
            d.text_only = self.onoff(st, kw, optional=True)
        elif kw == "LogRate":
            (r,) = self.numbers(st, kw, usage, 1)
            if r <= 0:
                raise self.err(st.line, f"LogRate must be positive (samples per simulated second), got {r:g}")
            d.log_rate = r
        elif kw == "Friction":
            mu = self.numbers(st, kw, usage, 1, 2)
            if min(mu) < 0:
                raise self.err(st.line, f"Friction coefficients must be >= 0, got {' '.join(st.args)}")
            d.friction = mu[0]
            d.friction_dynamic = mu[1] if len(mu) > 1 else None
        elif kw == "Gravity":
            (g,) = self.numbers(st, kw, usage, 1)
            if g < 0:
                raise self.err(st.line, f"Gravity is the magnitude of g (pointing down, -z), must be >= 0, "
                                        f"got {g:g}")
            d.gravity = g
        elif kw == "TimeStep":
            (dt,) = self.numbers(st, kw, usage, 1)
            if dt <= 0:
                raise self.err(st.line, f"TimeStep must be positive (seconds), got {dt:g}")
            d.time_step = dt
        elif kw == "Ground":
            a, b = self.numbers(st, kw, usage, 2)
            if a <= 0 or b < 0:
                raise self.err(st.line, f"Ground needs A > 0 (stiffness, kg/s^2) and B >= 0 (damping, kg/s), "
                                        f"got {a:g} {b:g}")
            d.ground = (a, b)
        elif kw == "JointSpring":
            a, b = self.numbers(st, kw, usage, 2)
            if a <= 0 or b < 0:
                raise self.err(st.line, f"JointSpring needs ALPHA > 0 (N/m) and BETA >= 0 (N s/m), "
                                        f"got {a:g} {b:g}")
            d.joint_spring = (a, b)
        elif kw == "Servo":
            d.servo = self.servo(st)
        elif kw == "Terrain":
            d.terrain = self.terrain(st)
        elif kw == "Track":
            d.track = self.name_arg(st, kw, "body name")
            self.track_line = st.line
        elif kw == "Harmonics":
            if len(st.args) != 1:
                raise self.err(st.line, f"Harmonics expects 1 integer, got '{' '.join(st.args)}' "
                                        f"(usage: {usage})")
            k = self.integer(st.args[0], st.line, kw, usage)
            if k < 1:
                raise self.err(st.line, f"Harmonics must be >= 1 (the K of the CPG Fourier series), got {k}")
            d.harmonics = k
        elif kw == "Frequency":
            (f,) = self.numbers(st, kw, usage, 1)
            if f <= 0:
                raise self.err(st.line, f"Frequency must be positive (the CPG base frequency f0, Hz), "
                                        f"got {f:g}")
            d.frequency = f
        elif kw == "Log":
            if len(st.args) != 2:
                raise self.err(st.line, f"Log expects a body and a file name, got '{' '.join(st.args)}' "
                                        f"(usage: {usage})")
            for other in d.logs:
                if other.file == st.args[1]:
                    raise self.err(st.line, f"log file '{st.args[1]}' is already used at line {other.line}; "
                                            "give each Log its own file")
            d.logs.append(LogDef(body=st.args[0], file=st.args[1], line=st.line))
        else:  # pragma: no cover - every keyword is handled above
            raise AssertionError(kw)

    def servo(self, st: _Stmt) -> ServoDef:
        kp, ki, kd, tau = self.numbers(st, "Servo", TOP_KEYWORDS["Servo"], 4)
        if min(kp, ki, kd) < 0 or tau <= 0:
            raise self.err(st.line, f"Servo needs KP, KI, KD >= 0 and TAUMAX > 0, got {' '.join(st.args)}")
        return ServoDef(kp=kp, ki=ki, kd=kd, tau_max=tau)

    def terrain(self, st: _Stmt) -> TerrainDef:
        usage = TOP_KEYWORDS["Terrain"]
        if not st.args:
            raise self.err(st.line, f"Terrain expects a kind (usage: {usage})")
        kind = st.args[0].lower()
        if kind not in _TERRAINS:
            raise self.err(st.line, f"unknown terrain kind '{st.args[0]}'{_did_you_mean(kind, _TERRAINS)}; "
                                    f"usage: {usage}")
        rest = _Stmt(st.line, st.toks[1:])  # head = kind, args = its parameters
        what = f"Terrain {kind}"
        if kind == "flat":
            self.no_args(rest, what)
            return TerrainDef("flat", line=st.line)
        if kind == "ramp":
            axis = "Y"
            if rest.args and rest.args[-1].upper() in ("X", "Y"):
                axis = rest.args[-1].upper()
                rest = _Stmt(st.line, rest.toks[:-1])
            (slope,) = self.numbers(rest, what, "Terrain ramp SLOPE_RAD [X|Y]", 1)
            if abs(slope) >= math.pi / 2:
                raise self.err(st.line, f"ramp slope is an angle in radians, |SLOPE| < pi/2, got {slope:g}")
            return TerrainDef("ramp", (slope,), axis=axis, line=st.line)
        if kind == "bump":
            p = self.numbers(rest, what, "Terrain bump HEIGHT Y [WIDTH]", 2, 3)
            if len(p) > 2 and p[2] <= 0:
                raise self.err(st.line, f"bump WIDTH must be positive (metres along y), got {p[2]:g}")
            return TerrainDef("bump", p, line=st.line)
        if kind == "rough":
            u = "Terrain rough RANGE [CELL [SEED]]"
            p = self.numbers(rest, what, u, 1, 3)
            if p[0] < 0:
                raise self.err(st.line, f"rough RANGE must be >= 0 (metres), got {p[0]:g}")
            if len(p) > 1 and p[1] <= 0:
                raise self.err(st.line, f"rough CELL must be positive (metres), got {p[1]:g}")
            if len(p) > 2:
                seed = self.integer(rest.args[2], st.line, "rough SEED", u)
                if seed < 0:
                    raise self.err(st.line, f"rough SEED must be a non-negative integer, got {seed}")
            return TerrainDef("rough", p, line=st.line)
        # matrix
        u = "Terrain matrix NX NY X0 X1 Y0 Y1 { NY rows of NX heights }"
        p = self.numbers(rest, what, u, 6)
        nx = self.integer(rest.args[0], st.line, "matrix NX", u)
        ny = self.integer(rest.args[1], st.line, "matrix NY", u)
        if nx < 2 or ny < 2:
            raise self.err(st.line, f"matrix needs NX >= 2 and NY >= 2 grid points, got {nx} x {ny}")
        if p[3] <= p[2] or p[5] <= p[4]:
            raise self.err(st.line, f"matrix extent needs X0 < X1 and Y0 < Y1, got x {p[2]:g}..{p[3]:g}, "
                                    f"y {p[4]:g}..{p[5]:g}")
        body, close = self.block(st, "Terrain matrix")
        rows: list[tuple[float, ...]] = []
        for row in body:
            if len(row.toks) != nx:
                raise self.err(row.line, f"matrix row {len(rows) + 1} has {len(row.toks)} heights, expected "
                                         f"NX = {nx}")
            rows.append(tuple(self.number(t, row.line, "matrix height", u) for t in row.toks))
        if len(rows) != ny:
            got = _plural(len(rows), "row")
            raise self.err(close, f"matrix has {got} of heights, expected NY = {ny} rows of {nx} "
                                  f"(row j is y = Y0 + j (Y1 - Y0) / (NY - 1))")
        return TerrainDef("matrix", p, heights=tuple(rows), line=st.line)

    # -- blocks

    def header_name(self, st: _Stmt, kw: str) -> str:
        if len(st.args) != 1:
            got = " ".join(st.args) or "nothing"
            raise self.err(st.line, f"{kw} expects one name before its block, got '{got}' "
                                    f"(usage: {kw} NAME {{)")
        name = st.args[0]
        self.check_name(name, st.line, kw)
        return name

    def check_body_name(self, name: str, line: int) -> None:
        for kind, table in (("Object", self.objects), ("Compound", self.compounds)):
            if name in table:
                raise self.err(line, f"duplicate name '{name}': already defined as {kind} at line "
                                     f"{table[name].line}; objects and compounds need unique names")

    def once(self, rec: _RawObject | _RawCompound | _RawJoint, kw: str, st: _Stmt, what: str) -> None:
        if kw in rec.lines:
            raise self.err(st.line, f"{kw} given twice in {what} (first at line {rec.lines[kw]}); keep one")
        rec.lines[kw] = st.line

    def parse_object(self, header: _Stmt) -> None:
        name = self.header_name(header, "Object")
        self.check_body_name(name, header.line)
        what = f"Object '{name}'"
        rec = _RawObject(name, header.line)
        self.objects[name] = rec
        body, _ = self.block(header, what)
        for st in body:
            kw = _canonical(st.head, OBJECT_KEYWORDS)
            if kw is None:
                raise self.unknown(st, what, list(OBJECT_KEYWORDS))
            usage = OBJECT_KEYWORDS[kw]
            if kw != "Contact":
                self.once(rec, kw, st, what)
            if kw == "Type":
                t = self.name_arg(st, kw, "shape (Cube, Cylinder or Sphere)")
                if t.lower() not in _TYPES:
                    raise self.err(st.line, f"unknown Type '{t}'{_did_you_mean(t, _TYPES.values())}; "
                                            "use Cube, Cylinder or Sphere")
                rec.fields["type"] = _TYPES[t.lower()]
            elif kw == "Color":
                rec.fields["color"] = self.name_arg(st, kw, "colour name (defined by ColorDef)")
            elif kw == "Mass":
                (m,) = self.numbers(st, kw, usage, 1)
                if m <= 0:
                    raise self.err(st.line, f"Mass of {what} must be positive (kg), got {m:g}")
                rec.fields["mass"] = m
            elif kw == "Dimensions":
                dims = self.numbers(st, kw, usage, 1, 3)
                if min(dims) <= 0:
                    raise self.err(st.line, f"Dimensions of {what} must be positive (metres), got "
                                            f"{' '.join(st.args)}")
                rec.fields["dimensions"] = dims
            elif kw in ("Position", "Orientation"):
                rec.fields[kw.lower()] = self.numbers(st, kw, usage, 3)
            elif kw == "Contact":
                rec.lines.setdefault("Contact", st.line)
                x, y, z = self.numbers(st, kw, usage, 3)
                rec.contacts.append((x, y, z))
            elif kw == "NoContact":
                self.no_args(st, kw)
            elif kw == "RimPoints":
                if len(st.args) != 1:
                    raise self.err(st.line, f"RimPoints expects 1 integer, got '{' '.join(st.args)}'")
                n = self.integer(st.args[0], st.line, kw, usage)
                if n < 3:
                    raise self.err(st.line, f"RimPoints must be >= 3 (contact points on each rim), "
                                            f"got {n}")
                rec.fields["rim_points"] = n
            elif kw == "Fixed":
                self.no_args(st, kw)
                rec.fields["fixed"] = True

    def parse_compound(self, header: _Stmt) -> None:
        name = self.header_name(header, "Compound")
        self.check_body_name(name, header.line)
        what = f"Compound '{name}'"
        rec = _RawCompound(name, header.line)
        self.compounds[name] = rec
        body, _ = self.block(header, what)
        for st in body:
            kw = _canonical(st.head, COMPOUND_KEYWORDS)
            if kw is None:
                if any(_is_num(t) for t in st.toks) or st.head.lower() in _ALL_KEYWORDS:
                    raise self.unknown(st, what, list(COMPOUND_KEYWORDS), "; other lines name member objects")
                rec.members.extend((t, st.line) for t in st.toks)
                continue
            self.once(rec, kw, st, what)
            if kw == "Fixed":
                self.no_args(st, kw)
                rec.fields["fixed"] = True
            else:
                rec.fields[kw.lower()] = self.numbers(st, kw, COMPOUND_KEYWORDS[kw], 3)

    def parse_joint(self, header: _Stmt) -> None:
        name = self.header_name(header, "Joint")
        if name in self.joints:
            first = self.joints[name].line
            raise self.err(header.line, f"duplicate joint name '{name}' (first at line {first})")
        what = f"Joint '{name}'"
        rec = _RawJoint(name, header.line)
        self.joints[name] = rec
        body, _ = self.block(header, what)
        for st in body:
            kw = _canonical(st.head, JOINT_KEYWORDS)
            if kw is None:
                if (len(st.toks) == 4 and all(_is_num(t) for t in st.args) and not _is_num(st.head)
                        and st.head.lower() not in _ALL_KEYWORDS):
                    if len(rec.bodies) == 2:
                        kw_hint = _suggest(st.head, JOINT_KEYWORDS)
                        hint = f" (or did you mean the keyword '{kw_hint}'?)" if kw_hint else ""
                        raise self.err(st.line, f"{what} names a third body '{st.head}'{hint}; a joint "
                                                "connects exactly two bodies (first line: BODY_A X Y Z, "
                                                "second: BODY_B X Y Z)")
                    pivot = self.numbers(st, st.head, "BODY X Y Z (the pivot in the body's frame)", 3)
                    rec.bodies.append((st.head, (pivot[0], pivot[1], pivot[2]), st.line))
                    continue
                raise self.unknown(st, what, list(JOINT_KEYWORDS), "; a body line is 'BODY X Y Z'")
            usage = JOINT_KEYWORDS[kw]
            if kw.startswith(("Control", "Passive")):
                self.no_args(st, kw)
                if "kind" in rec.lines:
                    raise self.err(st.line, f"{what} already has its kind at line {rec.lines['kind']}; "
                                            "give one of ControlX|Y|Z or PassiveX|Y|Z")
                rec.lines["kind"] = st.line
                rec.fields["controlled"] = kw.startswith("Control")
                rec.fields["axis"] = kw[-1]
                continue
            self.once(rec, kw, st, what)
            if kw == "Orientation":
                rec.fields["orientation"] = self.numbers(st, kw, usage, 3)
            elif kw == "Limits":
                lo, hi = self.numbers(st, kw, usage, 2)
                if lo >= hi:
                    raise self.err(st.line, f"Limits of {what} need LO < HI (radians), got {lo:g} {hi:g}")
                rec.fields["limits"] = (lo, hi)
            elif kw == "Servo":
                rec.fields["servo"] = self.servo(st)

    # -- checks and assembly

    def build(self) -> Description:
        """Check the raw records against each other and assemble the Description (all or nothing)."""
        errors: list[tuple[int, str]] = []

        def bad(line: int, message: str) -> None:
            errors.append((line, message))

        d = self.desc
        holder: dict[str, str] = {}  # object -> compound that holds it
        for c in self.compounds.values():
            if not c.members:
                bad(c.line, f"Compound '{c.name}' lists no objects; add one object name per line inside "
                            "its block")
            seen: dict[str, int] = {}
            for m, line in c.members:
                where = f"Compound '{c.name}' lists '{m}'"
                if m in self.compounds:
                    bad(line, f"{where}, which is a compound; compounds hold objects only")
                elif m not in self.objects:
                    hint = _did_you_mean(m, self.objects) or _did_you_mean(m, COMPOUND_KEYWORDS)
                    bad(line, f"{where}, which is not a defined Object{hint} "
                              f"(objects: {_fmt_list(self.objects)})")
                elif m in seen:
                    bad(line, f"{where} twice (first at line {seen[m]})")
                elif m in holder:
                    bad(line, f"Object '{m}' is already in Compound '{holder[m]}'; an object can belong to "
                              "one compound only (define a copy with another name)")
                else:
                    holder[m] = c.name
                    seen[m] = line

        objects: dict[str, ObjectDef] = {}
        for o in self.objects.values():
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
                bad(o.lines["Dimensions"], f"{what} is a {typ}, so Dimensions needs {_plural(n, 'number')} "
                                           f"({meaning}), got {len(dims)}")
                continue
            color = o.fields.get("color")
            if color is not None and color not in d.colors:
                bad(o.lines["Color"], f"colour '{color}' of {what} is not defined by a ColorDef"
                                      f"{_did_you_mean(color, d.colors)} (defined: {_fmt_list(d.colors)}); "
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

        compounds = {
            c.name: CompoundDef(
                name=c.name, objects=tuple(m for m, _ in c.members), line=c.line,
                position=_vec(c.fields.get("position")), orientation=_vec(c.fields.get("orientation")),
                fixed=bool(c.fields.get("fixed", False)),
            )
            for c in self.compounds.values()
        }
        bodies = [o for o in self.objects if o not in holder] + list(self.compounds)

        def check_body(name: str, line: int, what: str, keywords: Iterable[str] = ()) -> bool:
            if name in self.compounds or (name in self.objects and name not in holder):
                return True
            if name in holder:
                bad(line, f"{what} names '{name}', an object inside Compound '{holder[name]}'; name the "
                          f"compound '{holder[name]}' instead (pivots are in its frame)")
            else:
                hint = _did_you_mean(name, bodies)
                if not hint and (kw := _suggest(name, keywords)):
                    hint = f" (or did you mean the keyword '{kw}'?)"
                bad(line, f"{what} names body '{name}' which is not defined{hint} "
                          f"(objects/compounds: {_fmt_list(bodies)})")
            return False

        joints: list[JointDef] = []
        n_ctrl = 0
        for j in self.joints.values():
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

        # the joints must form a forest: one parent per body, no loops
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

        if d.track is not None:
            check_body(d.track, self.track_line, "Track")
        for lg in d.logs:
            check_body(lg.body, lg.line, "Log")

        if errors:
            errors.sort(key=lambda e: e[0])
            line, msg = errors[0]
            more = len(errors) - 1
            raise self.err(line, msg + (f" (and {_plural(more, 'more problem')})" if more else ""))
        d.objects, d.compounds, d.joints = objects, compounds, joints
        return d


def _canonical(word: str, table: dict[str, str]) -> str | None:
    low = word.lower()
    for k in table:
        if k.lower() == low:
            return k
    return None


def _vec(v: object) -> Vec3:
    if v is None:
        return (0.0, 0.0, 0.0)
    x, y, z = v
    return (float(x), float(y), float(z))


# ----------------------------------------------------------------------------- public API

def parse_wl(text: str, path: str = "<string>") -> Description:
    """Parse `.wl` text into a checked :class:`Description` (thesis Ch. 3.5.1).

    Raises :class:`DescriptionError` (``path:line: message``) at the first problem, in file
    order; nothing is returned half-built.
    """
    return _Parser(text, path).parse()


def load_wl(path: str | os.PathLike[str]) -> Description:
    """Read and parse a `.wl` file; the Description keeps ``path`` and the full ``text``."""
    p = os.fspath(path)
    try:
        with open(p, encoding="utf-8") as f:
            text = f.read()
    except UnicodeDecodeError as e:
        raise DescriptionError(p, 1, f"not a UTF-8 text file ({e.reason}); a .wl file is plain text") \
            from None
    return parse_wl(text, p)


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
    out.append(f"Ground {_v(desc.ground)}")
    if desc.joint_spring is not None:
        out.append(f"JointSpring {_v(desc.joint_spring)}")
    s = desc.servo
    out.append(f"Servo {_v((s.kp, s.ki, s.kd, s.tau_max))}")
    t = desc.terrain
    if t.kind == "matrix":
        nx, ny = int(t.params[0]), int(t.params[1])
        out.append(f"Terrain matrix {nx} {ny} {_v(t.params[2:])} {{")
        out += [f"    {_v(row)}" for row in (t.heights or ())]
        out.append("}")
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


def load_model(path: str | os.PathLike[str], *, dt: float | None = None, terrain: str | None = None) -> Model:
    """Parse a `.wl` file and build its simulator Model."""
    return build_model(load_wl(path), dt=dt, terrain=terrain)
