"""The `.ctl` control file: a controller's fitness and its CPG Fourier coefficients (thesis Ch. 3.5.1).

Format (the thesis example has 8 DOFs and K = 2, i.e. 8 lines of 5 numbers)::

    0.012402                                            <- fitness (one number)
    0.400000  0.255476  0.032754  -0.030112  0.013921   <- DOF 0: c0 a1 b1 a2 b2
    ...                                                 <- one line per controlled DOF

Each DOF line holds the 2K+1 coefficients of (thesis Ch. 2.2.1, SPEC §5)
``q(t) = c0 + sum_k (a_k sin(2 pi k f0 t) + b_k cos(2 pi k f0 t))``, in the order
``c0 a1 b1 a2 b2 ... aK bK``.  DOF lines follow the controlled joints of the `.wl` file
(``JointDef.control_index``).  Blank lines and ``#`` comments are ignored.  The genome of
the genetic algorithm is the coefficient matrix flattened row by row
(:func:`coeffs_to_genome`, :func:`genome_to_coeffs`).

A closed-loop controller (:mod:`cpgjax.episode.policy`) adds its policy after the DOF lines::

    Policy pmtg                                         <- the controller family
    Inputs angles 8 tilt 2 rates 2 contact 4 phase 2 command 1 bias 1    <- the observation's groups, sizes
    Outputs offsets 8 frequency 1 amplitude 1           <- the action's groups, sizes
    0.0  0.12  ...                                      <- one line of weights per output, one number per input

(:class:`PolicyTable`; the words are case-insensitive).  A file without a ``Policy`` line is the thesis's
open-loop CPG.

Before the fitness, ``# key: value`` comment lines are the controller's provenance, its :class:`Header`::

    # model: quadruped.wl                 <- the model file(s) it was made for, by name
    # pipeline: exact                     <- the pipeline(s) it runs on, the first by default (or: any)
    # controller: cpg                     <- the controller family
    # time: 5                             <- the episode length [s] it was scored over
    # terrain: flat                       <- the ground it was scored on
    # run: runs/quickstart.h5             <- the run it came from
    # picked: best of generation 14 (...) <- how it was picked

Every key is optional; other comment lines are prose, and a file without a header reads as before.

Errors raise :class:`cpgjax.errors.DescriptionError` (``path:line: message``).
"""

from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from cpgjax.io.ctl_header import HEADER_KEYS, Header, Replay, header_line, replay_settings, run_header
from cpgjax.io.textfile import read_text
from cpgjax.sim.description import DescriptionError

__all__ = ["Control", "Header", "HEADER_KEYS", "PolicyTable", "Replay", "parse_ctl", "read_ctl", "format_ctl",
           "write_ctl", "replay_settings", "run_header", "genome_to_coeffs", "coeffs_to_genome"]

_NUM_RE = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?\Z")


@dataclass
class PolicyTable:
    """A closed-loop controller's policy as its `.ctl` file writes it.

    name: the family (``pmtg``); inputs, outputs: ``(group, size)`` pairs in file order; weights:
    ``[sum of output sizes, sum of input sizes]`` float64; line: the line of the ``Policy`` statement (for errors
    found later, against a model).
    """

    name: str
    inputs: tuple[tuple[str, int], ...]
    outputs: tuple[tuple[str, int], ...]
    weights: np.ndarray
    line: int = 0


@dataclass
class Control:
    """A controller read from a `.ctl` file.

    fitness: the first line of the file (the episode fitness, eq. 4.6; 0 if never evaluated).
    coeffs: ``[n_dof, 2K+1]`` float64, row ``i`` = ``c0 a1 b1 ... aK bK`` of controlled DOF ``i``.
    path: where it was read from (``"<string>"`` for text).
    policy: the policy of a closed-loop controller (None: the thesis's open-loop CPG).
    header: its provenance (:class:`Header`; empty for a file without one).
    """

    fitness: float
    coeffs: np.ndarray
    path: str = "<string>"
    policy: PolicyTable | None = None
    header: Header = field(default_factory=Header)

    @property
    def n_dof(self) -> int:
        return int(self.coeffs.shape[0])

    @property
    def harmonics(self) -> int:
        return (int(self.coeffs.shape[1]) - 1) // 2

    @property
    def genome(self) -> np.ndarray:
        """The coefficients flattened row by row (the GA's genome)."""
        return coeffs_to_genome(self.coeffs)


def _number(tok: str, path: str, line: int) -> float:
    if not _NUM_RE.match(tok):
        if tok.lower().lstrip("+-") in ("nan", "inf", "infinity"):
            raise DescriptionError(path, line, f"'{tok}' is not a finite number")
        raise DescriptionError(path, line, f"'{tok}' is not a number")
    v = float(tok)
    if not math.isfinite(v):
        raise DescriptionError(path, line, f"'{tok}' is not a finite number")
    return v


def _expected(n_dof: int | None, n_coef: int | None) -> str:
    dof = f"{n_dof} DOF line{'s' if n_dof != 1 else ''}" if n_dof is not None else "DOF lines"
    if n_coef is None:
        return dof
    return f"{dof} of {n_coef} coefficients (K={(n_coef - 1) // 2})"


def parse_ctl(text: str, path: str = "<string>", n_dof: int | None = None,
              harmonics: int | None = None) -> Control:
    """Parse `.ctl` text (thesis Ch. 3.5.1): the fitness, then one line of 2K+1 coefficients per DOF.

    ``n_dof`` / ``harmonics``, when given, are checked against the file (e.g. the `.wl`
    file's controlled joints and ``Harmonics``).
    """
    rows: list[tuple[int, list[float]]] = []
    policy_lines: list[tuple[int, list[str]]] = []
    header = Header()
    last_line = 1
    for n, raw in enumerate(text.removeprefix("\ufeff").splitlines(), start=1):
        toks = raw.split("#", 1)[0].split()
        if not toks:
            if not rows:
                header_line(header, raw, path, n)
            continue
        last_line = n
        if policy_lines or toks[0].lower() == "policy":
            policy_lines.append((n, toks))
            continue
        rows.append((n, [_number(t, path, n) for t in toks]))
    n_coef = None if harmonics is None else 2 * harmonics + 1
    if not rows:
        raise DescriptionError(path, 1, "empty control file: expected the fitness on the first line, then "
                                        f"{_expected(n_dof, n_coef)}")
    fit_line, fit = rows[0]
    if len(fit) != 1:
        raise DescriptionError(path, fit_line, f"the first line must be the fitness (one number), found "
                                               f"{len(fit)} numbers; add the fitness line (0 if unknown)")
    dofs = rows[1:]
    if not dofs:
        raise DescriptionError(path, last_line, f"expected {_expected(n_dof, n_coef)} after the fitness, "
                                                "found none")
    want = n_coef if n_coef is not None else len(dofs[0][1])
    if want % 2 == 0:
        raise DescriptionError(path, dofs[0][0], "a DOF line has 2K+1 numbers (c0, then a_k b_k for "
                                                 f"k=1..K); found {want}")
    for line, vals in dofs:
        if len(vals) != want:
            raise DescriptionError(path, line, f"expected {_expected(n_dof, want)}, found a line of "
                                               f"{len(vals)} numbers")
    if n_dof is not None and len(dofs) != n_dof:
        line = dofs[n_dof][0] if len(dofs) > n_dof else last_line
        raise DescriptionError(path, line, f"expected {_expected(n_dof, want)}, found {len(dofs)} DOF "
                                           f"line{'s' if len(dofs) != 1 else ''}")
    coeffs = np.array([vals for _, vals in dofs], dtype=np.float64)
    policy = _parse_policy(policy_lines, path) if policy_lines else None
    if header.controller is not None:
        family = header.controller.split(":", 1)[0].strip().lower()
        if family != (policy.name if policy else "cpg"):
            held = f"a 'Policy {policy.name}' controller" if policy else "an open-loop CPG (no Policy line)"
            raise DescriptionError(path, header.lines["controller"], f"its header says controller "
                                                                     f"{header.controller}, but the file holds {held}")
    return Control(fitness=float(fit[0]), coeffs=coeffs, path=path, policy=policy, header=header)


_GROUP_RE = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")


def _groups(toks: list[str], path: str, line: int, what: str) -> tuple[tuple[str, int], ...]:
    """``NAME SIZE NAME SIZE ...`` of an ``Inputs`` / ``Outputs`` line."""
    body = toks[1:]
    if not body or len(body) % 2:
        raise DescriptionError(path, line, f"{what} lists its groups as NAME SIZE pairs (e.g. {what} tilt 2 bias 1); "
                                           f"found {len(body)} word{'s' if len(body) != 1 else ''}")
    out = []
    for name, size in zip(body[::2], body[1::2], strict=True):
        if not _GROUP_RE.match(name):
            raise DescriptionError(path, line, f"{what}: {name!r} is not a group name")
        if not size.isdigit() or int(size) < 1:
            raise DescriptionError(path, line, f"{what}: the size of {name} must be a whole number >= 1, got {size!r}")
        out.append((name.lower(), int(size)))
    if len({n for n, _ in out}) != len(out):
        raise DescriptionError(path, line, f"{what}: a group is named twice")
    return tuple(out)


def _parse_policy(lines: list[tuple[int, list[str]]], path: str) -> PolicyTable:
    """The ``Policy`` section: ``Policy NAME``, ``Inputs ...``, ``Outputs ...``, then one line of weights per output."""
    line, toks = lines[0]
    if len(toks) != 2 or not _GROUP_RE.match(toks[1]):
        raise DescriptionError(path, line, "expected 'Policy NAME' (the controller family, e.g. Policy pmtg)")
    name = toks[1].lower()
    heads: dict[str, tuple[tuple[str, int], ...]] = {}
    rest = lines[1:]
    for word in ("inputs", "outputs"):
        if not rest or rest[0][1][0].lower() != word:
            at = rest[0][0] if rest else line
            raise DescriptionError(path, at, f"expected the policy's '{word.capitalize()} NAME SIZE ...' line after "
                                             f"'{'Policy ' + name if word == 'inputs' else 'Inputs ...'}'")
        heads[word] = _groups(rest[0][1], path, rest[0][0], word.capitalize())
        rest = rest[1:]
    n_in = sum(n for _, n in heads["inputs"])
    n_out = sum(n for _, n in heads["outputs"])
    weights = []
    for at, toks in rest:
        if toks[0].lower() in ("policy", "inputs", "outputs"):
            raise DescriptionError(path, at, f"a second '{toks[0]}' line: a controller has one policy")
        vals = [_number(t, path, at) for t in toks]
        if len(vals) != n_in:
            raise DescriptionError(path, at, f"a line of policy weights has one number per input ({n_in}); found "
                                             f"{len(vals)}")
        weights.append(vals)
    if len(weights) != n_out:
        at = rest[n_out][0] if len(rest) > n_out else (rest[-1][0] if rest else line)
        raise DescriptionError(path, at, f"expected {n_out} lines of policy weights (one per output), found "
                                         f"{len(weights)}")
    return PolicyTable(name, heads["inputs"], heads["outputs"], np.array(weights, np.float64), line)


def read_ctl(path: str | os.PathLike[str], n_dof: int | None = None, harmonics: int | None = None) -> Control:
    """Read a `.ctl` file (see :func:`parse_ctl`).

    A file that cannot be read as text (missing, a directory, binary) is a DescriptionError
    too (:func:`cpgjax.io.textfile.read_text`).
    """
    p, text = read_text(path, ".ctl")
    return parse_ctl(text, p, n_dof=n_dof, harmonics=harmonics)


def _f6(v: float) -> str:
    return "%.6f" % (round(float(v), 6) + 0.0)  # + 0.0: no "-0.000000"


def _exact(v: float) -> str:
    """The shortest decimal that reads back as the same float32 (the simulator's precision)."""
    return np.format_float_positional(np.float32(v), unique=True, trim="0") if v != 0 else "0.0"


def format_ctl(coeffs: Any, fitness: float = 0.0, exact: bool = False, policy: PolicyTable | None = None,
               header: Header | None = None) -> str:
    """The `.ctl` text: numbers separated by two spaces, one DOF per line (thesis example).

    The fitness is written ``%.6f``; the coefficients too by default (the thesis's 6 decimals).
    ``exact=True`` (what ``cpgjax best --ctl`` writes unless ``--round``) writes each
    coefficient with as many digits as it takes to read back the same float32: evolved gaits
    can be chaotic, and a controller rounded to 6 decimals may walk differently from the one
    the GA scored (docs/evolution.md).  ``header``: the provenance lines written first (:class:`Header`).
    """
    c = np.asarray(coeffs, dtype=np.float64)
    if c.ndim != 2 or c.shape[1] % 2 == 0:
        raise ValueError(f"coeffs must be [n_dof, 2K+1], got shape {c.shape}")
    if not (np.all(np.isfinite(c)) and math.isfinite(float(fitness))):
        raise ValueError("coefficients and fitness must be finite to be written to a .ctl file")
    fmt = _exact if exact else _f6
    lines = (header.text() if header else []) + [_f6(fitness)] + ["  ".join(fmt(v) for v in row) for row in c]
    if policy is not None:
        w = np.asarray(policy.weights, np.float64)
        n_in, n_out = sum(n for _, n in policy.inputs), sum(n for _, n in policy.outputs)
        if w.shape != (n_out, n_in) or not np.all(np.isfinite(w)):
            raise ValueError(f"policy weights must be finite, [{n_out}, {n_in}], got shape {w.shape}")
        cols = " ".join(f"{g}[{n}]" for g, n in policy.inputs)
        lines += [f"Policy {policy.name}", "Inputs " + " ".join(f"{g} {n}" for g, n in policy.inputs),
                  "Outputs " + " ".join(f"{g} {n}" for g, n in policy.outputs),
                  f"# one line per output ({', '.join(f'{g}[{n}]' for g, n in policy.outputs)}); columns: {cols}"]
        lines += ["  ".join(fmt(v) for v in row) for row in w]
    return "\n".join(lines) + "\n"


def write_ctl(path: str | os.PathLike[str], coeffs: Any, fitness: float = 0.0, exact: bool = False,
              policy: PolicyTable | None = None, header: Header | None = None) -> None:
    """Write a `.ctl` file (see :func:`format_ctl`); 6 decimals as in the thesis, or ``exact`` float32 digits."""
    text = format_ctl(coeffs, fitness, exact=exact, policy=policy, header=header)
    with open(os.fspath(path), "w", encoding="utf-8") as f:
        f.write(text)


def genome_to_coeffs(genome: Any, n_dof: int, harmonics: int) -> Any:
    """``[..., n_dof * (2K+1)]`` genome(s) -> ``[..., n_dof, 2K+1]`` coefficients (row-major).

    Works on numpy and JAX arrays alike (a JAX array stays a JAX array, also under ``jit``).
    """
    g = genome if hasattr(genome, "reshape") and hasattr(genome, "shape") else np.asarray(genome)
    n = 2 * harmonics + 1
    if g.shape[-1] != n_dof * n:
        raise ValueError(f"genome has {g.shape[-1]} genes, expected n_dof * (2K+1) = {n_dof} * {n} "
                         f"= {n_dof * n}")
    return g.reshape(*g.shape[:-1], n_dof, n)


def coeffs_to_genome(coeffs: Any) -> Any:
    """``[..., n_dof, 2K+1]`` coefficients -> ``[..., n_dof * (2K+1)]`` genome(s) (row-major)."""
    c = coeffs if hasattr(coeffs, "reshape") and hasattr(coeffs, "shape") else np.asarray(coeffs)
    if c.ndim < 2:
        raise ValueError(f"coeffs must be [..., n_dof, 2K+1], got shape {c.shape}")
    return c.reshape(*c.shape[:-2], c.shape[-2] * c.shape[-1])
