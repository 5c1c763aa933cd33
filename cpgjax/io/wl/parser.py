"""The `.wl` parser: statements to raw records, one block at a time (thesis Ch. 3.5.1).

The thesis shows only an excerpt of the format (Ch. 3.5.1: ``ColorDef``, ``TimeMax``,
``Simulate``, ``Display``, ``LogRate``, ``Friction``, ``Object``, ``Compound``, ``Joint``,
``Log``; Ch. 3.5.3: ``TextOnly``).  The rest (``Gravity``, ``Ground``, ``Terrain``, ``Servo``, ``Pipeline``, ...)
completes it so that one file describes a whole experiment; docs/wl-format.md is the reference.

:class:`_Parser` dispatches each top-level statement: a setting goes into the
Description at once (checked on its own: counts, ranges, duplicates), an ``Object``, ``Compound`` or ``Joint``
block is read into a raw record.  Then :func:`cpgjax.io.wl.checks.assemble` checks them together.  Parsing is
all-or-nothing: every problem raises :class:`~cpgjax.errors.DescriptionError`, whose text
is ``path:line: what is wrong and how to fix it``.

Public API: :func:`parse_wl`, :func:`load_wl`, :func:`load_model`.
"""

from __future__ import annotations

import os

from cpgjax.io.textfile import read_text
from cpgjax.io.wl.checks import RawCompound, RawDescription, RawJoint, RawObject, assemble
from cpgjax.io.wl.lexer import (
    ALL_KEYWORDS,
    COMPOUND_KEYWORDS,
    DIMENSION_MIN,
    HARMONICS_MAX,
    JOINT_KEYWORDS,
    LENGTH_MAX,
    LOG_RATE,
    MASS_RANGE,
    OBJECT_KEYWORDS,
    RIM_POINTS_MAX,
    TIME_MAX,
    TIME_STEP,
    TOP_KEYWORDS,
    StatementReader,
    Stmt,
    canonical,
    did_you_mean,
    is_num,
    plural,
    suggest,
)
from cpgjax.sim import course
from cpgjax.sim.description import Description, LogDef, ServoDef, TerrainDef
from cpgjax.sim.model import PIPELINES, Model, build_model
from cpgjax.sim.terrain import TERRAIN_KINDS, check_terrain

__all__ = ["parse_wl", "load_wl", "load_model"]

_TYPES = {"cube": "Cube", "cylinder": "Cylinder", "sphere": "Sphere"}
_NUMBERS = {"bump": ("Terrain bump HEIGHT Y [WIDTH]", 2, 3), "stairs": ("Terrain stairs RISE TREAD [N]", 2, 3),
            "bar": ("Terrain bar HEIGHT Y [DEPTH]", 2, 3), "gap": ("Terrain gap WIDTH Y", 2, 2)}


class _Parser(StatementReader):
    """Reads statements into the settings and raw records (syntax); `assemble` checks the rest."""

    def __init__(self, text: str, path: str):
        super().__init__(text, path)
        self.raw = RawDescription(Description(path=path, text=text))
        self.desc = self.raw.desc
        self.settings: dict[str, int] = {}  # top-level keyword -> line (duplicates are errors)
        self.color_lines: dict[str, int] = {}

    # -- top level

    def parse(self) -> Description:
        while (st := self.next_stmt()) is not None:
            if st.toks == ["{"]:
                raise self.err(st.line, "'{' without a header: a block follows 'Object NAME', "
                                        "'Compound NAME', 'Joint NAME' or 'Terrain matrix ...'")
            if st.toks == ["}"]:
                raise self.err(st.line, "'}' without a matching '{'")
            kw = canonical(st.head, TOP_KEYWORDS)
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
        return assemble(self.raw)

    def setting(self, kw: str, st: Stmt) -> None:
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
            self.limited(st, "TimeMax", (t,), TIME_MAX, "s (the thesis's episodes last 8 to 30 s)", lo=0.0)
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
            self.limited(st, "LogRate", (r,), LOG_RATE[1], "samples per simulated second", lo=LOG_RATE[0])
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
        elif kw in ("TimeStep", "ExactTimeStep"):   # the springs' (and default) step; the exact pipeline's
            (dt,) = self.numbers(st, kw, usage, 1)
            if dt <= 0:
                raise self.err(st.line, f"{kw} must be positive (seconds), got {dt:g}")
            doc = ("docs/simulator.md: the default is 5e-4" if kw == "TimeStep"
                   else "docs/exact-joints.md: the default is 2e-3")
            self.limited(st, kw, (dt,), TIME_STEP[1], f"s ({doc})", lo=TIME_STEP[0])
            setattr(d, "time_step" if kw == "TimeStep" else "exact_time_step", dt)
        elif kw == "Pipeline":
            d.pipeline = self.pipeline(st)
            d.pipeline_line = st.line
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
        elif kw == "FrictionSpring":
            k, b = self.numbers(st, kw, usage, 2)
            if k <= 0 or b < 0:
                raise self.err(st.line, f"FrictionSpring needs K > 0 (bristle spring, N/m) and B >= 0 "
                                        f"(its damper, N s/m), got {k:g} {b:g}")
            d.friction_spring = (k, b)
        elif kw == "Servo":
            d.servo = self.servo(st)
        elif kw == "Terrain":
            d.terrain = self.terrain(st)
        elif kw == "Track":
            d.track = self.name_arg(st, kw, "body name")
            self.raw.track_line = st.line
        elif kw == "Harmonics":
            if len(st.args) != 1:
                raise self.err(st.line, f"Harmonics expects 1 integer, got '{' '.join(st.args)}' "
                                        f"(usage: {usage})")
            k = self.integer(st.args[0], st.line, kw, usage)
            if k < 1:
                raise self.err(st.line, f"Harmonics must be >= 1 (the K of the CPG Fourier series), got {k}")
            if k > HARMONICS_MAX:
                raise self.err(st.line, f"Harmonics must be at most {HARMONICS_MAX} (the thesis uses 2), got {k}")
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

    def pipeline(self, st: Stmt) -> str:
        """``Pipeline springs|exact`` (any case): which physics runs the model (:data:`PIPELINES`)."""
        usage = TOP_KEYWORDS["Pipeline"]
        name = self.name_arg(st, "Pipeline", "pipeline (springs or exact)")
        if name.lower() not in PIPELINES:
            raise self.err(st.line, f"unknown pipeline '{name}'{did_you_mean(name, PIPELINES)}; choose one of "
                                    f"{', '.join(PIPELINES)} (usage: {usage})")
        return name.lower()

    def servo(self, st: Stmt) -> ServoDef:
        kp, ki, kd, tau = self.numbers(st, "Servo", TOP_KEYWORDS["Servo"], 4)
        if min(kp, ki, kd) < 0 or tau <= 0:
            raise self.err(st.line, f"Servo needs KP, KI, KD >= 0 and TAUMAX > 0, got {' '.join(st.args)}")
        return ServoDef(kp=kp, ki=ki, kd=kd, tau_max=tau)

    def terrain(self, st: Stmt) -> TerrainDef:
        """``Terrain KIND ...``: the syntax is read here, the values are checked by
        :func:`cpgjax.sim.terrain.check_terrain` (the same check as ``--terrain``)."""
        usage = TOP_KEYWORDS["Terrain"]
        if not st.args:
            raise self.err(st.line, f"Terrain expects a kind (usage: {usage})")
        kind = st.args[0].lower()
        if kind not in TERRAIN_KINDS:
            raise self.err(st.line, f"unknown terrain kind '{st.args[0]}'{did_you_mean(kind, TERRAIN_KINDS)}; "
                                    f"usage: {usage}")
        rest = Stmt(st.line, st.toks[1:])  # head = kind, args = its parameters
        what = f"Terrain {kind}"
        axis, heights = "Y", None
        if kind == "flat":
            self.no_args(rest, what)
            p: tuple[float, ...] = ()
        elif kind == "ramp":
            if rest.args and rest.args[-1].upper() in ("X", "Y"):
                axis = rest.args[-1].upper()
                rest = Stmt(st.line, rest.toks[:-1])
            p = self.numbers(rest, what, "Terrain ramp SLOPE_RAD [X|Y]", 1)
        elif kind in _NUMBERS:     # bump, stairs, bar, gap: numbers only
            p = self.numbers(rest, what, *_NUMBERS[kind])
        elif kind == "course":     # its items as one text, as on the command line (sim/course.py)
            try:
                p = course.encode(course.parse_items("".join(rest.args)))
            except ValueError as e:
                raise self.err(st.line, str(e)) from None
        elif kind == "rough":
            u = "Terrain rough RANGE [CELL [SEED]]"
            p = self.numbers(rest, what, u, 1, 3)
            if len(p) > 2:
                self.integer(rest.args[2], st.line, "rough SEED", u)
        else:
            u = "Terrain matrix NX NY X0 X1 Y0 Y1 { NY rows of NX heights }"
            p = self.numbers(rest, what, u, 6)
            nx = self.integer(rest.args[0], st.line, "matrix NX", u)
            self.integer(rest.args[1], st.line, "matrix NY", u)
            self.checked_terrain(st.line, kind, p)  # NX, NY and the extent, before the rows
            body, close = self.block(st, "Terrain matrix")
            rows: list[tuple[float, ...]] = []
            for row in body:
                if len(row.toks) != nx:
                    raise self.err(row.line, f"matrix row {len(rows) + 1} has {len(row.toks)} heights, "
                                             f"expected NX = {nx}")
                rows.append(tuple(self.number(t, row.line, "matrix height", u) for t in row.toks))
            if len(rows) != int(p[1]):
                got = plural(len(rows), "row")
                raise self.err(close, f"matrix has {got} of heights, expected NY = {int(p[1])} rows of {nx} "
                                      f"(row j is y = Y0 + j (Y1 - Y0) / (NY - 1))")
            heights = tuple(rows)
        return self.checked_terrain(st.line, kind, p, axis, heights)

    def checked_terrain(self, line: int, kind: str, p: tuple[float, ...], axis: str = "Y",
                        heights: tuple[tuple[float, ...], ...] | None = None) -> TerrainDef:
        try:
            return check_terrain(kind, p, axis, heights, line=line)
        except ValueError as e:
            raise self.err(line, str(e)) from None

    # -- blocks

    def header_name(self, st: Stmt, kw: str) -> str:
        if len(st.args) != 1:
            got = " ".join(st.args) or "nothing"
            raise self.err(st.line, f"{kw} expects one name before its block, got '{got}' "
                                    f"(usage: {kw} NAME {{)")
        name = st.args[0]
        self.check_name(name, st.line, kw)
        return name

    def check_body_name(self, name: str, line: int) -> None:
        for kind, table in (("Object", self.raw.objects), ("Compound", self.raw.compounds)):
            if name in table:
                raise self.err(line, f"duplicate name '{name}': already defined as {kind} at line "
                                     f"{table[name].line}; objects and compounds need unique names")

    def once(self, rec: RawObject | RawCompound | RawJoint, kw: str, st: Stmt, what: str) -> None:
        if kw in rec.lines:
            raise self.err(st.line, f"{kw} given twice in {what} (first at line {rec.lines[kw]}); keep one")
        rec.lines[kw] = st.line

    def parse_object(self, header: Stmt) -> None:
        name = self.header_name(header, "Object")
        self.check_body_name(name, header.line)
        what = f"Object '{name}'"
        rec = RawObject(name, header.line)
        self.raw.objects[name] = rec
        body, _ = self.block(header, what)
        for st in body:
            kw = canonical(st.head, OBJECT_KEYWORDS)
            if kw is None:
                raise self.unknown(st, what, list(OBJECT_KEYWORDS))
            usage = OBJECT_KEYWORDS[kw]
            if kw != "Contact":
                self.once(rec, kw, st, what)
            if kw == "Type":
                t = self.name_arg(st, kw, "shape (Cube, Cylinder or Sphere)")
                if t.lower() not in _TYPES:
                    raise self.err(st.line, f"unknown Type '{t}'{did_you_mean(t, _TYPES.values())}; "
                                            "use Cube, Cylinder or Sphere")
                rec.fields["type"] = _TYPES[t.lower()]
            elif kw == "Color":
                rec.fields["color"] = self.name_arg(st, kw, "colour name (defined by ColorDef)")
            elif kw == "Mass":
                (m,) = self.numbers(st, kw, usage, 1)
                if m <= 0:
                    raise self.err(st.line, f"Mass of {what} must be positive (kg), got {m:g}")
                self.limited(st, f"Mass of {what}", (m,), MASS_RANGE[1], "kg", lo=MASS_RANGE[0])
                rec.fields["mass"] = m
            elif kw == "Dimensions":
                dims = self.numbers(st, kw, usage, 1, 3)
                if min(dims) <= 0:
                    raise self.err(st.line, f"Dimensions of {what} must be positive (metres), got "
                                            f"{' '.join(st.args)}")
                rec.fields["dimensions"] = self.limited(st, f"Dimensions of {what}", dims, LENGTH_MAX, "m",
                                                        lo=DIMENSION_MIN)
            elif kw == "Position":
                rec.fields["position"] = self.limited(st, f"Position of {what}", self.numbers(st, kw, usage, 3),
                                                      LENGTH_MAX, "m")
            elif kw == "Orientation":
                rec.fields["orientation"] = self.numbers(st, kw, usage, 3)
            elif kw == "Contact":
                rec.lines.setdefault("Contact", st.line)
                x, y, z = self.limited(st, f"Contact of {what}", self.numbers(st, kw, usage, 3), LENGTH_MAX, "m")
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
                if n > RIM_POINTS_MAX:
                    raise self.err(st.line, f"RimPoints must be at most {RIM_POINTS_MAX} (contact points on "
                                            f"each rim), got {n}")
                rec.fields["rim_points"] = n
            elif kw == "Fixed":
                self.no_args(st, kw)
                rec.fields["fixed"] = True

    def parse_compound(self, header: Stmt) -> None:
        name = self.header_name(header, "Compound")
        self.check_body_name(name, header.line)
        what = f"Compound '{name}'"
        rec = RawCompound(name, header.line)
        self.raw.compounds[name] = rec
        body, _ = self.block(header, what)
        for st in body:
            kw = canonical(st.head, COMPOUND_KEYWORDS)
            if kw is None:
                if any(is_num(t) for t in st.toks) or st.head.lower() in ALL_KEYWORDS:
                    raise self.unknown(st, what, list(COMPOUND_KEYWORDS), "; other lines name member objects")
                rec.members.extend((t, st.line) for t in st.toks)
                continue
            self.once(rec, kw, st, what)
            if kw == "Fixed":
                self.no_args(st, kw)
                rec.fields["fixed"] = True
            else:
                v = self.numbers(st, kw, COMPOUND_KEYWORDS[kw], 3)
                rec.fields[kw.lower()] = self.limited(st, f"Position of {what}", v, LENGTH_MAX, "m") \
                    if kw == "Position" else v

    def parse_joint(self, header: Stmt) -> None:
        name = self.header_name(header, "Joint")
        if name in self.raw.joints:
            first = self.raw.joints[name].line
            raise self.err(header.line, f"duplicate joint name '{name}' (first at line {first})")
        what = f"Joint '{name}'"
        rec = RawJoint(name, header.line)
        self.raw.joints[name] = rec
        body, _ = self.block(header, what)
        for st in body:
            kw = canonical(st.head, JOINT_KEYWORDS)
            if kw is None:
                if (len(st.toks) == 4 and all(is_num(t) for t in st.args) and not is_num(st.head)
                        and st.head.lower() not in ALL_KEYWORDS):
                    if len(rec.bodies) == 2:
                        kw_hint = suggest(st.head, JOINT_KEYWORDS)
                        hint = f" (or did you mean the keyword '{kw_hint}'?)" if kw_hint else ""
                        raise self.err(st.line, f"{what} names a third body '{st.head}'{hint}; a joint "
                                                "connects exactly two bodies (first line: BODY_A X Y Z, "
                                                "second: BODY_B X Y Z)")
                    pivot = self.numbers(st, st.head, "BODY X Y Z (the pivot in the body's frame)", 3)
                    self.limited(st, f"the pivot on '{st.head}' of {what}", pivot, LENGTH_MAX, "m")
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


# ----------------------------------------------------------------------------- public API

def parse_wl(text: str, path: str = "<string>") -> Description:
    """Parse `.wl` text into a checked :class:`Description` (thesis Ch. 3.5.1).  Raises :class:`DescriptionError`
    (``path:line: message``) at the first problem, in file order; nothing is returned half-built."""
    return _Parser(text, path).parse()


def load_wl(path: str | os.PathLike[str]) -> Description:
    """Read and parse a `.wl` file; the Description keeps ``path`` and the full ``text``.  A file that cannot be
    read as text (missing, a directory, binary) is a DescriptionError too (:func:`cpgjax.io.textfile.read_text`)."""
    p, text = read_text(path, ".wl")
    return parse_wl(text, p)


def load_model(path: str | os.PathLike[str], *, dt: float | None = None, terrain: str | None = None,
               pipeline: str | None = None) -> Model:
    """Parse a `.wl` file and build its simulator Model (``build_model(load_wl(path), dt=, terrain=, pipeline=)``).

    ``terrain`` is command-line text (``bump:0.02@1.0``) that overrides the file's ``Terrain``;
    ``pipeline`` ("springs" | "exact") overrides the file's ``Pipeline``.
    """
    return build_model(load_wl(path), dt=dt, terrain=terrain, pipeline=pipeline)
