"""Tokens and statements of the `.wl` format (thesis Ch. 3.5.1; grammar in docs/wl-format.md §1).

The format is line oriented: one statement per line, ``#`` starts a comment, ``{`` and ``}``
are statements of their own (so ``Object A {`` is two statements).  Keywords are
case-insensitive; names are case-sensitive.

This module holds what every part of the parser shares:

- the keyword tables (the canonical spelling is the key, the value its usage line);
- :func:`tokenize` (text -> :class:`Stmt` list) and the number syntax;
- :class:`StatementReader`: a cursor over the statements that reads arguments (numbers,
  integers, ON/OFF, names) and ``{ ... }`` blocks, raising
  :class:`~cpgjax.errors.DescriptionError` (``path:line: message``) with the usage;
- suggestions for misspelt words (``did you mean ...``).
"""

from __future__ import annotations

import difflib
import math
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

from cpgjax.errors import DescriptionError

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
    "ExactTimeStep": "ExactTimeStep SECONDS",
    "Pipeline": "Pipeline springs|exact",
    "Ground": "Ground A B",
    "JointSpring": "JointSpring ALPHA BETA",
    "FrictionSpring": "FrictionSpring K B",
    "Servo": "Servo KP KI KD TAUMAX",
    "Terrain": ("Terrain flat | ramp SLOPE [X|Y] | bump HEIGHT Y [WIDTH] | rough RANGE [CELL [SEED]] | "
                "stairs RISE TREAD [N] | bar HEIGHT Y [DEPTH] | gap WIDTH Y | matrix NX NY X0 X1 Y0 Y1 { rows }"),
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

BLOCK_KEYWORDS = ("object", "compound", "joint")
ALL_KEYWORDS = {k.lower() for k in (*TOP_KEYWORDS, *OBJECT_KEYWORDS, *COMPOUND_KEYWORDS, *JOINT_KEYWORDS)}

#: Ranges that keep a model physical (docs/wl-format.md): lengths (positions, pivots, contact
#: vertices, dimensions) in metres, masses in kg, and counts that size arrays.
LENGTH_MAX = 1.0e3
DIMENSION_MIN = 1.0e-4
MASS_RANGE = (1.0e-6, 1.0e6)
RIM_POINTS_MAX = 1000
HARMONICS_MAX = 100
#: Ranges of the run's timing: beyond them an episode's step count overflows the simulator's integers.
TIME_MAX = 3600.0  # s
TIME_STEP = (1.0e-5, 1.0e-2)  # s
LOG_RATE = (1.0e-2, 1.0e5)  # samples per simulated second

_NUM_RE = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?\Z")
_INT_RE = re.compile(r"[+-]?\d+\Z")
_NONFINITE = {"nan", "+nan", "-nan", "inf", "+inf", "-inf", "infinity", "+infinity", "-infinity"}
_TOKEN_RE = re.compile(r"[{}]|[^\s{}]+")


# ----------------------------------------------------------------------------- tokens

@dataclass
class Stmt:
    """One statement: the tokens of one line (``{`` and ``}`` are statements of their own)."""

    line: int
    toks: list[str]

    @property
    def head(self) -> str:
        return self.toks[0]

    @property
    def args(self) -> list[str]:
        return self.toks[1:]


def tokenize(text: str) -> list[Stmt]:
    """The statements of ``text``, comments dropped, each with its 1-based line number."""
    out: list[Stmt] = []
    for n, raw in enumerate(text.splitlines(), start=1):
        code = raw.split("#", 1)[0]
        cur: list[str] = []
        for tok in _TOKEN_RE.findall(code):
            if tok in "{}":
                if cur:
                    out.append(Stmt(n, cur))
                    cur = []
                out.append(Stmt(n, [tok]))
            else:
                cur.append(tok)
        if cur:
            out.append(Stmt(n, cur))
    return out


def is_num(tok: str) -> bool:
    """Whether ``tok`` is written as a number (finite or not: ``nan`` is a number, a bad one)."""
    return bool(_NUM_RE.match(tok)) or tok.lower() in _NONFINITE


def canonical(word: str, table: dict[str, str]) -> str | None:
    """The canonical spelling of keyword ``word`` in ``table`` (case-insensitive), else None."""
    low = word.lower()
    for k in table:
        if k.lower() == low:
            return k
    return None


# ----------------------------------------------------------------------------- wording

def suggest(word: str, choices: Iterable[str]) -> str | None:
    """The choice closest to ``word`` (case-insensitive), if one is close enough."""
    choices = list(choices)
    lower = {c.lower(): c for c in choices}
    hit = difflib.get_close_matches(word.lower(), list(lower), n=1, cutoff=0.6)
    return lower[hit[0]] if hit else None


def did_you_mean(word: str, choices: Iterable[str]) -> str:
    s = suggest(word, choices)
    return f" (did you mean '{s}'?)" if s else ""


def one_per_line(st: Stmt) -> str:
    """A hint for lines that hold several statements (the format is one statement per line)."""
    if any(t.lower() in ALL_KEYWORDS for t in st.args):
        return "; write one statement per line"
    return ""


def plural(n: int, word: str) -> str:
    return f"{n} {word}" if n == 1 else f"{n} {word}s"


def fmt_list(names: Iterable[str]) -> str:
    names = list(names)
    return ", ".join(names) if names else "none"


# ----------------------------------------------------------------------------- reader

class StatementReader:
    """A cursor over the statements of one text, with the argument readers every statement uses."""

    def __init__(self, text: str, path: str):
        self.path = path
        self.stmts = tokenize(text.removeprefix("\ufeff"))  # a byte-order mark is not a keyword
        self.n_lines = max(len(text.splitlines()), 1)
        self.i = 0

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

    def numbers(self, st: Stmt, kw: str, usage: str, lo: int, hi: int | None = None) -> tuple[float, ...]:
        """The arguments of ``st`` as ``lo``..``hi`` numbers, else an error naming ``kw`` and its usage."""
        hi = lo if hi is None else hi
        args = st.args
        want = plural(lo, "number") if lo == hi else f"{lo} to {hi} numbers"
        for tok in args[:hi]:
            if not is_num(tok):
                hint = one_per_line(st)
                raise self.err(st.line, f"{kw} expects {want}, got '{tok}' (usage: {usage}){hint}")
        if not lo <= len(args) <= hi:
            got = f"{len(args)}: '{' '.join(args)}'" if args else "none"
            raise self.err(st.line, f"{kw} expects {want}, got {got} (usage: {usage})")
        return tuple(self.number(t, st.line, kw, usage) for t in args)

    def limited(self, st: Stmt, what: str, values: tuple[float, ...], hi: float, unit: str,
                lo: float | None = None) -> tuple[float, ...]:
        """``values`` if each is in ``[lo, hi]`` (``lo`` None: ``|v| <= hi``), else an error naming the range.

        The ranges keep a description physical: far beyond them the model's inertias and
        effective masses overflow or become singular.
        """
        for v in values:
            if lo is None and abs(v) > hi:
                raise self.err(st.line, f"{what} must be within +-{hi:g} {unit}, got {v:g}")
            if lo is not None and not lo <= v <= hi:
                raise self.err(st.line, f"{what} must be between {lo:g} and {hi:g} {unit}, got {v:g}")
        return values

    def no_args(self, st: Stmt, kw: str) -> None:
        if st.args:
            raise self.err(st.line, f"{kw} takes no arguments, got '{' '.join(st.args)}'")

    def onoff(self, st: Stmt, kw: str, optional: bool = False) -> bool:
        if optional and not st.args:
            return True
        if len(st.args) != 1 or st.args[0].upper() not in ("ON", "OFF"):
            got = " ".join(st.args) or "nothing"
            raise self.err(st.line, f"{kw} expects ON or OFF, got '{got}' (usage: {TOP_KEYWORDS[kw]})")
        return st.args[0].upper() == "ON"

    def name_arg(self, st: Stmt, kw: str, what: str) -> str:
        if len(st.args) != 1:
            got = " ".join(st.args) or "nothing"
            raise self.err(st.line, f"{kw} expects one {what}, got '{got}'{one_per_line(st)}")
        return st.args[0]

    def check_name(self, name: str, line: int, what: str) -> None:
        if name.lower() in ALL_KEYWORDS:
            raise self.err(line, f"{what} name '{name}' is a keyword; choose another name")
        if is_num(name):
            raise self.err(line, f"{what} name '{name}' is a number; names must start with a letter")

    # -- statements and blocks

    def next_stmt(self) -> Stmt | None:
        if self.i >= len(self.stmts):
            return None
        st = self.stmts[self.i]
        self.i += 1
        return st

    def block(self, header: Stmt, what: str) -> tuple[list[Stmt], int]:
        """The statements between ``{`` (just after ``header``) and its ``}``, and the ``}`` line."""
        st = self.next_stmt()
        if st is None or st.toks != ["{"]:
            raise self.err(header.line, f"{what} expects a block: put '{{' at the end of this line or "
                                        "alone on the next line, and close it with '}'")
        opened = st.line
        body: list[Stmt] = []
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
            if st.head.lower() in BLOCK_KEYWORDS:
                raise self.err(st.line, f"'{st.head}' inside {what} (block opened at line {opened}): "
                                        "is a '}' missing above this line?")
            body.append(st)

    def unknown(self, st: Stmt, where: str, allowed: Sequence[str], extra: str = "") -> DescriptionError:
        """The error for a keyword not allowed here: where it would belong, or the closest allowed one."""
        homes = [f"{home} blocks" if home != "top" else "the top level"
                 for home, table in (("top", TOP_KEYWORDS), ("Object", OBJECT_KEYWORDS),
                                     ("Compound", COMPOUND_KEYWORDS), ("Joint", JOINT_KEYWORDS))
                 if canonical(st.head, table)]
        if homes:
            return self.err(st.line, f"'{st.head}' does not belong in {where}: it is allowed in "
                                     f"{' and '.join(homes)} (is a '{{' or '}}' misplaced?); allowed here: "
                                     f"{', '.join(allowed)}{extra}")
        return self.err(st.line, f"unknown keyword '{st.head}' in {where}{did_you_mean(st.head, allowed)}; "
                                 f"allowed here: {', '.join(allowed)}{extra}")
