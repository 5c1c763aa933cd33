"""The provenance of a `.ctl` controller: its header's ``# key: value`` lines (docs/ctl-format.md), and what a
command replays it with (:func:`replay_settings`).  Read by :func:`cpgjax.io.ctl.parse_ctl`."""

from __future__ import annotations

import os
import re
from dataclasses import dataclass, field
from typing import Any

from cpgjax.errors import CpgjaxError, DescriptionError

_NUM_RE = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?\Z")

HEADER_KEYS = ("model", "pipeline", "controller", "time", "terrain", "command", "run", "picked")
_HEADER_RE = re.compile(r"#\s*([A-Za-z][A-Za-z_-]*)\s*:\s*(.*?)\s*\Z")
OPTION = {"command": "limit"}          # the command-line option that gives a header key's setting, where it differs
_PIPELINES = ("springs", "exact")      # cpgjax.sim.model.PIPELINES (not imported here: it loads JAX)


@dataclass
class Header:
    """A `.ctl` file's provenance: its ``# key: value`` lines before the fitness (docs/ctl-format.md).

    model: the model file(s) it was made for, compared by name (``quadruped.wl``; several: comma-separated);
    pipeline: the physics pipeline(s) it runs on, the first the one a replay takes (``exact``; ``springs, exact``;
    ``any``); controller: its family (``cpg``, ``pmtg:tilt+contact+bias:mirror``); time: the episode length [s]
    it was scored over; terrain: the ground it was scored on (a ``--terrain`` spec; ``matrix``: the model file's
    height matrix); command: the range of the turning rate it was commanded in evolution (``--perturb command=R``,
    rad/s; ``cpgjax follow``'s default ``--limit``); run: the run it came from; picked: how it was picked.  None: not
    said.  lines: the line of each key given (for errors found later, against a command line).
    """

    model: str | None = None
    pipeline: str | None = None
    controller: str | None = None
    time: float | None = None
    terrain: str | None = None
    command: float | None = None
    run: str | None = None
    picked: str | None = None
    lines: dict[str, int] = field(default_factory=dict, compare=False)

    @property
    def models(self) -> tuple[str, ...]:
        """The names (basenames) of the model files it was made for; empty: not said."""
        return tuple(os.path.basename(m.strip()) for m in (self.model or "").split(",") if m.strip())

    @property
    def pipelines(self) -> tuple[str, ...]:
        """The pipelines it runs on, the first by default; empty: any (or not said)."""
        names = tuple(p.strip().lower() for p in (self.pipeline or "").split(",") if p.strip())
        return () if names == ("any",) else names

    def setting(self, key: str) -> Any:
        """What a replay takes from it: ``pipeline`` (the first of its pipelines), ``time``, ``terrain``; None: not
        said (or any pipeline)."""
        return (self.pipelines or (None,))[0] if key == "pipeline" else getattr(self, key)

    def __bool__(self) -> bool:
        return any(getattr(self, k) is not None for k in HEADER_KEYS)

    def text(self) -> list[str]:
        """The ``# key: value`` lines, in :data:`HEADER_KEYS` order."""
        out = []
        for k in HEADER_KEYS:
            v = getattr(self, k)
            if v is not None:
                out.append(f"# {k}: {v:g}" if k in ("time", "command") else f"# {k}: {' '.join(str(v).split())}")
        return out


def header_line(h: Header, raw: str, path: str, line: int) -> None:
    """Add the comment line ``raw`` (line ``line`` of ``path``) to ``h`` if it is a ``# key: value`` line of a
    key of :data:`HEADER_KEYS`; other comments are prose, left alone."""
    m = _HEADER_RE.match(raw.strip())
    if not m or m[1].lower() not in HEADER_KEYS:
        return
    key, value = m[1].lower(), m[2]
    if not value:
        raise DescriptionError(path, line, f"the header's '{key}:' line has no value")
    if key in h.lines:
        raise DescriptionError(path, line, f"a second '{key}:' line in the header (the first is line {h.lines[key]})")
    if key == "pipeline":
        names = [p.strip().lower() for p in value.split(",")]
        if names != ["any"] and (not all(names) or any(n not in _PIPELINES for n in names)):
            raise DescriptionError(path, line, f"pipeline: expected {' or '.join(_PIPELINES)} (several: comma-"
                                               f"separated, the first by default) or any, got {value!r}")
        value = ", ".join(names)
    elif key == "model" and not all(m.strip() for m in value.split(",")):
        raise DescriptionError(path, line, f"model: expected model file names, comma-separated, got {value!r}")
    elif key == "time":
        t = value[:-1].strip() if value.endswith("s") else value
        if not _NUM_RE.match(t) or not 0 < float(t) <= 3600:
            raise DescriptionError(path, line, f"time: expected the episode length in seconds, > 0 and <= 3600, "
                                               f"got {value!r}")
        value = float(t)
    elif key == "command":
        r = value.removesuffix("rad/s").strip()
        if not _NUM_RE.match(r) or not 0 < float(r) <= 10:
            raise DescriptionError(path, line, f"command: expected the commanded turning rate's range in rad/s, > 0 "
                                               f"and <= 10, got {value!r}")
        value = float(r)
    elif key == "terrain" and value != "matrix":
        from cpgjax.sim.terrain import parse_terrain

        try:
            parse_terrain(value)
        except (ValueError, TypeError) as e:
            raise DescriptionError(path, line, f"terrain: {e}") from None
    setattr(h, key, value)
    h.lines[key] = line


@dataclass(frozen=True)
class Replay:
    """What a command replays `.ctl` controllers with (:func:`replay_settings`); None: the command's own default
    (the model file's).  note: the line saying what the headers set (None: they set nothing)."""

    pipeline: str | None = None
    time: float | None = None
    terrain: str | None = None
    command: float | None = None
    note: str | None = None


def replay_settings(controls: list[Any], model_path: str, *, pipeline: str | None = None,
                    time: float | None = None, terrain: str | None = None, command: float | None = None,
                    takes: tuple[str, ...] = ("pipeline", "time", "terrain")) -> Replay:
    """The pipeline, episode length, terrain and (``follow``'s ``--limit``) command range to replay ``controls``
    (:class:`cpgjax.io.ctl.Control`) with on the model file ``model_path``: each option given (``pipeline``,
    ``time``, ``terrain``, ``command``), else the headers' (they must agree), else None.

    Refused (one line, naming the file and its header's line): a header that names other model files (compared by
    name: models are copied around), or pipelines that the ``pipeline`` given is not one of.  ``takes``: the
    settings the command takes from a header (``follow``'s length is a walk's, not an episode's, and it takes the
    command range; ``stability`` sets its own grounds): the others are neither used nor said.
    """
    controls = [c for c in controls if c.header]
    name = os.path.basename(os.fspath(model_path))
    for c in controls:
        h = c.header
        if h.models and name not in h.models:
            raise DescriptionError(c.path, h.lines["model"], f"made for {' or '.join(h.models)}, not {name} (its "
                                                             "header's '# model:' line; model files are compared by "
                                                             "name)")
        if pipeline is not None and h.pipelines and pipeline not in h.pipelines:
            raise DescriptionError(c.path, h.lines["pipeline"], f"its header says pipeline {h.pipeline}; --pipeline "
                                                                f"{pipeline} contradicts it (leave --pipeline out to "
                                                                "use the header's)")

    def said(key: str, given: Any) -> Any:
        """The headers' ``key`` (None: none sets it); refused when they disagree and ``given`` does not settle it."""
        vals = {c.path: c.header.setting(key) for c in controls if c.header.setting(key) is not None}
        if given is None and len(set(vals.values())) > 1:
            what = ", ".join(f"{k} {v:g} s" if key == "time" else f"{k} {v}" for k, v in vals.items())
            raise CpgjaxError(f"the controllers' headers disagree on the {key} ({what}): replay them separately"
                              + ("" if key == "pipeline" else f", or give --{OPTION.get(key, key)}"))
        return next(iter(vals.values())) if len(set(vals.values())) == 1 else None

    parts, out = [], {}
    hp = said("pipeline", pipeline) if "pipeline" in takes else None
    out["pipeline"] = pipeline or hp
    if pipeline is None and hp:
        parts.append(f"pipeline {hp}")
    its = "its" if len(controls) == 1 else "their"
    ht = said("time", time) if "time" in takes else None
    out["time"] = time if time is not None else ht
    if ht is not None:
        parts.append(f"{ht:g} s" if time is None or time == ht else f"--time {time:g} instead of {its} {ht:g} s")
    hg = said("terrain", terrain) if "terrain" in takes else None
    out["terrain"] = terrain if terrain is not None else (hg if hg != "matrix" else None)
    if hg is not None:
        parts.append(f"terrain {hg}" if terrain is None or terrain == hg else
                     f"--terrain {terrain} instead of {its} {hg}")
    hc = said("command", command) if "command" in takes else None
    out["command"] = command if command is not None else hc
    if hc is not None:
        parts.append(f"--limit {hc:g} rad/s ({its} command range)" if command is None or command == hc else
                     f"--limit {command:g} instead of {its} command range {hc:g} rad/s")
    runs = list(dict.fromkeys(c.header.run for c in controls if c.header.run))
    note = None
    if parts:
        note = (f"{', '.join(c.path for c in controls)}: {', '.join(parts)}"
                + (f"; from {runs[0]}" if len(runs) == 1 else ""))
    return Replay(**out, note=note)


def run_header(run: str, meta: dict, model: Any, controller: str, picked: str) -> Header:
    """The header of a controller taken from the run file ``run`` (as the user named it): ``meta``, the problem it
    recorded (:attr:`cpgjax.io.results.Run.meta`); ``model``, the model built from it (its terrain and TimeMax when
    the run did not set them); ``controller``, the family's spec; ``picked``, how the controller was picked."""
    import json

    if model is None:           # a problem without a robot (cpgjax.optim.analytic): no physics to say
        return Header(controller=controller, run=run, picked=picked)
    cli = json.loads(meta.get("cli_problem_args") or "{}")
    time = cli.get("time") or meta.get("time") or model.episode.time_max
    path = meta.get("model_path")
    pert = meta.get("perturbations") or {}
    command = (json.loads(pert) if isinstance(pert, str) else pert).get("command") or None
    return Header(model=os.path.basename(str(path)) if path else None, pipeline=str(meta.get("pipeline") or "springs"),
                  controller=controller, time=float(time), terrain=cli.get("terrain") or model.terrain.spec,
                  command=None if command is None else float(command), run=run, picked=picked)

