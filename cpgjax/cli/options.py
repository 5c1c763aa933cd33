"""What every command group shares: the parser class, option types that name the bad value, output checks.

Option values are checked at parse time by the ``type=`` functions here (a bad one is one line,
``cpgjax COMMAND: error: argument --time: ...``, exit 2); outputs are checked with
:func:`check_output_file` / :func:`check_output_dir` *before* any work, so that a run never
computes for minutes and then fails to write.
"""

from __future__ import annotations

import argparse
import math
import os
from collections.abc import Callable
from typing import Any

from cpgjax.errors import CpgjaxError
from cpgjax.io.paths import first_existing

MAX_TIME = 3600.0        # s: the longest episode an option accepts (the thesis's are 10 s)
MAX_COUNT = 10_000_000   # a sane bound on populations, generations, samples, replays
MAX_SEED = 2**31 - 1


class CommandFailed(CpgjaxError):
    """The input was fine but the work failed (e.g. a notebook cell raised): one line, exit code 1."""

    exit_code = 1


class Parser(argparse.ArgumentParser):
    """An ArgumentParser whose usage errors are one line: ``cpgjax COMMAND: error: MESSAGE`` (exit 2)."""

    def error(self, message: str) -> Any:
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def _bad(text: str, what: str) -> argparse.ArgumentTypeError:
    return argparse.ArgumentTypeError(f"expected {what}, got {text!r}")


def number(text: str, what: str = "a number", lo: float = -math.inf, hi: float = math.inf,
           lo_open: bool = False) -> float:
    """A finite float in ``[lo, hi]`` (``(lo, hi]`` with ``lo_open``), else ArgumentTypeError naming ``what``."""
    try:
        v = float(text)
    except ValueError:
        raise _bad(text, what) from None
    if not math.isfinite(v) or v > hi or v < lo or (lo_open and v == lo):
        raise _bad(text, what)
    return v


def whole(text: str, what: str = "a whole number", lo: int = 0, hi: int = MAX_COUNT) -> int:
    """An int in ``[lo, hi]``, else ArgumentTypeError naming ``what``."""
    try:
        v = int(text)
    except ValueError:
        raise _bad(text, what) from None
    if not lo <= v <= hi:
        raise _bad(text, what)
    return v


def _named(fn: Callable, name: str) -> Callable:
    fn.__name__ = name
    return fn


def float_in(lo: float = -math.inf, hi: float = math.inf, *, lo_open: bool = False, what: str) -> Callable:
    return _named(lambda t: number(t, what, lo, hi, lo_open), what)


def int_in(lo: int = 0, hi: int = MAX_COUNT, *, what: str | None = None) -> Callable:
    w = what or (f"a whole number >= {lo}" if hi == MAX_COUNT else f"a whole number in [{lo}, {hi}]")
    return _named(lambda t: whole(t, w, lo, hi), w)


# the option types the commands use
seconds = float_in(0.0, MAX_TIME, lo_open=True, what=f"a time in seconds, > 0 and <= {MAX_TIME:g}")
step = float_in(0.0, 0.05, lo_open=True, what="a time step in seconds, > 0 and <= 0.05")
positive = float_in(0.0, lo_open=True, what="a finite number > 0")
nonneg = float_in(0.0, what="a finite number >= 0")
finite = float_in(what="a finite number")
fraction = float_in(0.0, 1.0, what="a number in [0, 1]")
count = int_in(1)                      # populations, generations, samples, batches, replays
count0 = int_in(0)                     # pocket sizes, extra controllers
seed = int_in(0, MAX_SEED)


def validation_options(p: argparse.ArgumentParser) -> None:
    """How a run's champion is validated (``--pick validated``, ``best --validate``; cpgjax.experiments.validate)."""
    p.add_argument("--candidates", type=count, default=64,
                   help="validation: the run's best distinct genomes re-scored (default 64)")
    p.add_argument("--episodes", type=count, default=16,
                   help="validation: perturbed episodes per candidate, the same for each (default 16)")
    p.add_argument("--validate-perturb", type=perturbations, default={}, metavar="KEY=VALUE,...",
                   help="validation: ranges that replace the run's own in the validation episodes, a stricter test "
                        "than the evolution's (e.g. fall_zero=on,touch=0.002,jitter=0.003; keys as --perturb's; "
                        "default: none, the run's own ranges)")


def validation(args: argparse.Namespace):
    """The :class:`~cpgjax.experiments.validate.Validation` of parsed ``validation_options`` (``--seed`` too)."""
    from cpgjax.experiments.validate import Validation

    return Validation(candidates=args.candidates, episodes=args.episodes, seed=args.seed,
                      perturb=tuple(sorted(args.validate_perturb.items())))


def list_of(conv: Callable, what: str) -> Callable:
    """A comma list (``0,0.01,0.1``) of ``conv`` values, naming the bad item."""

    def parse(text: str) -> list:
        out = []
        for x in text.split(","):
            if not x.strip():
                continue
            try:
                out.append(conv(x.strip()))
            except (ValueError, argparse.ArgumentTypeError):
                raise argparse.ArgumentTypeError(f"{what}: {x.strip()!r} in {text!r} is not valid") from None
        if not out:
            raise argparse.ArgumentTypeError(f"{what}: empty list")
        return out

    return _named(parse, what)


def terrain(text: str) -> str:
    """A terrain specification, checked now (``flat``, ``ramp:SLOPE[:X|Y]``, ``bump:…``, ``rough:…``)."""
    from cpgjax.sim.terrain import parse_terrain

    try:
        parse_terrain(text)
    except (ValueError, TypeError) as e:
        raise argparse.ArgumentTypeError(str(e)) from None
    return text


ON, OFF = ("1", "on", "true", "yes"), ("0", "off", "false", "no")


def _perturbation(key: str, kind: object, value: str) -> bool | int | float:
    """One ``--perturb`` value of the field ``key`` (annotated ``kind``), else ArgumentTypeError naming the rule."""
    v = value.strip().lower()
    if kind in (bool, "bool"):
        if v not in ON + OFF:
            raise argparse.ArgumentTypeError(f"{key}: expected on or off (1/0, true/false, yes/no), got {value!r}")
        return v in ON
    if key == "latency":
        if v not in ("0", "1"):
            raise argparse.ArgumentTypeError(f"latency: expected 0 or 1 (steps between observation and action), "
                                             f"got {value!r}")
        return int(v)
    if key == "worst":
        try:
            return whole(v, "a whole number >= 0", 0)
        except argparse.ArgumentTypeError:
            raise argparse.ArgumentTypeError(f"worst: expected a whole number >= 0 (0: the mean of all the episodes), "
                                             f"got {value!r}") from None
    integer = kind in (int, "int")
    what = "a whole number >= 1" if integer else "a finite number >= 0"
    try:
        return whole(v, what, 1) if integer else number(v, what, 0.0)
    except argparse.ArgumentTypeError:
        raise argparse.ArgumentTypeError(f"{key}: expected {what}, got {value!r}") from None


def perturbations(text: str) -> dict:
    """``KEY=VALUE,...`` ranges of the robust evaluation (cpgjax.episode.perturb.Perturbations), checked now;
    ``preset=NAME`` starts from a named set of them (``domain``: domain randomisation).  A key given twice is
    refused (which one would hold?)."""
    import dataclasses

    from cpgjax.episode.perturb import PRESETS, Perturbations

    fields = {f.name: f.type for f in dataclasses.fields(Perturbations)} | {"preset": "str"}
    out: dict = {}
    for item in (x.strip() for x in text.split(",") if x.strip()):
        key, sep, value = item.partition("=")
        key = key.strip().replace("-", "_")
        if not sep or key not in fields:
            raise argparse.ArgumentTypeError(f"expected KEY=VALUE with KEY in {', '.join(fields)}, got {item!r}")
        if key in out:
            raise argparse.ArgumentTypeError(f"{key} is given twice in {text!r}: give each key once")
        if key == "preset":
            if value.strip() not in PRESETS:
                raise argparse.ArgumentTypeError(f"preset: expected one of {', '.join(PRESETS)}, got {value!r}")
            out[key] = value.strip()
            continue
        out[key] = _perturbation(key, fields[key], value)  # fields[key]: the annotation, maybe a string
    try:
        Perturbations.from_settings(out)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from None
    return out


def controller(text: str) -> str:
    """A controller family (``cpg``, ``pmtg[:GROUP+GROUP...][:mirror]``; cpgjax.episode.policy), checked now."""
    from cpgjax.episode.policy import parse_controller

    try:
        parse_controller(text)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from None
    return text.strip()


def controller_option(p: argparse.ArgumentParser) -> None:
    """``--controller cpg|pmtg[:GROUP+...][:mirror]``: the controller family evolved (``None`` when left out: the
    CPG)."""
    from cpgjax.episode.policy import CONTROLLER_SYNTAX
    from cpgjax.episode.sensors import GROUPS

    p.add_argument("--controller", type=controller, default=None, metavar="FAMILY",
                   help=f"{CONTROLLER_SYNTAX}: the kind of controller evolved. cpg: the thesis's open-loop CPG, a "
                        "Fourier series per joint (the default). pmtg (policies modulating trajectory generators): "
                        "the CPG modulated every step by a linear feedback policy reading the robot's sensors, "
                        "which shifts each joint's target and speeds up, slows down or scales the CPG; GROUP+GROUP "
                        f"names what it reads, of {', '.join(GROUPS)} (joint angles, body roll and pitch, their "
                        "rates, foot contacts, the CPG's phase, a turning command, the command times the phase, the "
                        "command's size, a constant; default all but steer and turn). :mirror: a mirror-symmetric "
                        "genome, the right legs evolved and the left ones derived from them (docs/closed-loop.md, "
                        "docs/glossary.md)")


TERRAIN_HELP = ("flat | ramp:SLOPE[:X|Y] | bump:HEIGHT[@Y][:WIDTH] | rough:RANGE[:CELL[:SEED]] | stairs:RISE:TREAD[:N] "
                "| bar:HEIGHT@Y[:DEPTH] | gap:WIDTH@Y | course:ITEM,ITEM,... (docs/wl-format.md §3.1)")

# --- the options many commands share, each declared here once ----------------------------------------
# (a command passes what its default is, when that differs: a run's recorded setting, or a fixed number)

MODEL_FILE = "the model file's"
RUN_OR_FILE = "the run's, or the model file's"


def model_argument(p: argparse.ArgumentParser, *, metavar: str = "MODEL.wl", help: str | None = None,
                   optional: bool = False) -> None:
    """The robot model, the first positional argument of every command that takes one (``MODEL.wl``);
    ``optional``: it may be left out, and is then ``models/quadruped.wl`` (:func:`default_model`)."""
    text = help or "robot description (.wl)"
    if optional:
        p.add_argument("model", nargs="?", default=default_model(), metavar=metavar,
                       help=f"{text} (default: models/quadruped.wl)")
    else:
        p.add_argument("model", metavar=metavar, help=text)


def time_option(p: argparse.ArgumentParser, default: float | None = None, of: str = MODEL_FILE) -> None:
    """``--time SECONDS``: the simulated length of an episode; ``None``: ``of``'s TimeMax."""
    what = f"{default:g} s" if default is not None else f"{of} TimeMax"
    p.add_argument("--time", type=seconds, default=default, metavar="SECONDS",
                   help=f"simulated seconds per episode (default: {what})")


def terrain_option(p: argparse.ArgumentParser, of: str = MODEL_FILE) -> None:
    """``--terrain SPEC`` (:data:`TERRAIN_HELP`), checked at parse time; ``None``: ``of``'s Terrain."""
    p.add_argument("--terrain", type=terrain, default=None, metavar="SPEC",
                   help=f"the ground: {TERRAIN_HELP} (default: {of} Terrain, else flat)")


def delta_option(p: argparse.ArgumentParser, of: str | None = None) -> None:
    """``--delta``: the fitness's delta (eq. 4.5); ``of``: where its default comes from instead of the thesis's."""
    from cpgjax.episode.fitness import DEFAULT_DELTA

    p.add_argument("--delta", type=positive, default=None if of else DEFAULT_DELTA,
                   help=f"how much a tilted body's speed still counts: the fitness is the forward speed weighted "
                        f"by delta cos^2(t) / ((delta - 1) cos^2(t) + 1), t the body's tilt from upright; 1 weighs "
                        f"it by cos^2(t), larger values forgive a moderate tilt and punish only a body lying on its "
                        f"side (default: {of or f'{DEFAULT_DELTA:g}'})")


def seed_option(p: argparse.ArgumentParser, default: int | None = 0, what: str = "random seed",
                shown: int | None = None) -> None:
    """``--seed N``; ``default=None`` with ``shown``: left to the config, whose default is ``shown``."""
    p.add_argument("--seed", type=seed, default=default,
                   help=f"{what}: the same seed gives the same numbers (default {default if shown is None else shown})")


def evaluation_options(p: argparse.ArgumentParser) -> None:
    """``--evaluation thesis|robust`` and ``--perturb KEY=VALUE,...`` (cpgjax.episode.perturb; docs/evolution.md)."""
    p.add_argument("--evaluation", choices=("thesis", "robust"), default=None,
                   help="how a controller is scored. thesis: by one exact episode, its fitness averaged over time "
                        "(the default). robust: by the mean of several episodes, each with random perturbations "
                        "drawn anew every generation (start pose, rough ground, friction, masses, servo gains, gene "
                        "jitter, ...: --perturb), a fall ending the episode's score; a gait must then walk in many "
                        "worlds instead of being lucky in one (robust evaluation: docs/robust-evaluation.md, "
                        "docs/glossary.md)")
    p.add_argument("--perturb", type=perturbations, default=None, metavar="KEY=VALUE,...",
                   help=perturb_help())


def perturb_help() -> str:
    """``--perturb``'s help: every key of :class:`~cpgjax.episode.perturb.Perturbations` with its meaning and
    default, and what each preset sets."""
    from cpgjax.episode.perturb import MEANING, PRESET_MEANING, PRESETS, Perturbations

    d = Perturbations()
    show = lambda v: ("on" if v else "off") if isinstance(v, bool) else f"{v:g}"  # noqa: E731
    keys = "; ".join(f"{k}={show(getattr(d, k))}: {MEANING[k]}" for k in MEANING)
    presets = "; ".join(f"preset={n}: {PRESET_MEANING[n]}, it sets {', '.join(f'{k}={show(v)}' for k, v in p.items())}"
                        for n, p in PRESETS.items())
    return ("the ranges of --evaluation robust (given only with it), each key at most once, e.g. "
            f"replicas=8,bristle=3. The keys, with their defaults: {keys}. {presets}; a key given beside a preset "
            "overrides its value (docs/robust-evaluation.md, docs/glossary.md)")


def run_file_options(p: argparse.ArgumentParser, what: str = "run", *, resume: bool = True) -> None:
    """``--resume`` / ``--overwrite`` (one or the other) and ``--allow-other-machine`` of a command that writes a
    results file; ``resume=False``: resuming is what the command does anyway (a sweep), only ``--overwrite``."""
    if resume:
        g = p.add_mutually_exclusive_group()
        g.add_argument("--resume", action="store_true",
                       help=f"continue the {what} in --out where it stopped, with its recorded settings (options "
                            "left out are the run's; one that changes a score is refused)")
        g.add_argument("--overwrite", action="store_true",
                       help="replace an existing --out (without it, an existing file is refused)")
    else:
        p.add_argument("--overwrite", action="store_true",
                       help=f"start every {what} anew, replacing its file (without it, complete runs are kept and "
                            "partial ones continued)")
    p.add_argument("--allow-other-machine", action="store_true",
                   help=f"continue a {what} computed on another CPU or with other versions (refused otherwise: "
                        "the numbers would mix; the file records the switch, docs/reproducibility.md)")


def quiet_option(p: argparse.ArgumentParser) -> None:
    """``--quiet``: no progress bar."""
    p.add_argument("--quiet", action="store_true", help="print no progress bar (the final summary still)")


def dt_option(p: argparse.ArgumentParser) -> None:
    """``--dt SECONDS``: the integration step, else the model file's."""
    p.add_argument("--dt", type=step, metavar="SECONDS",
                   help="the simulator's integration time step (default: the file's TimeStep, else 5e-4 s; with "
                        "--pipeline exact its ExactTimeStep, else its TimeStep, else 2e-3 s)")

PIPELINE_HELP = ("the physics pipeline: springs (the thesis's: every body free, each joint a stiff pivot spring, "
                 "eq. 3.6) or exact (generalized coordinates: a floating base and one angle per revolute joint, "
                 "default step 2 ms)")


def pipeline_option(p: argparse.ArgumentParser, default: str = "the model file's Pipeline, else springs") -> None:
    """``--pipeline {springs,exact}`` (:data:`cpgjax.sim.model.PIPELINES`); ``None`` when left out: the caller's
    default (``default`` says which in the help: a model file's ``Pipeline`` keyword, or a run's recorded one)."""
    from cpgjax.sim.model import PIPELINES

    p.add_argument("--pipeline", choices=PIPELINES, default=None, help=f"{PIPELINE_HELP} (default: {default})")


RUN_PIPELINE = "the run's, as it recorded"
# a command that replays .ctl controllers takes its pipeline and episode length from their headers
# (cpgjax.io.ctl_header.replay_settings; docs/ctl-format.md)
CTL_OR_FILE = "the --ctl header's, else the model file's"
CTL_PIPELINE = f"{CTL_OR_FILE} Pipeline, else springs"


# --- outputs --------------------------------------------------------------------------------------


def _check_folder_chain(path: str, folder: str) -> None:
    """``folder`` (to hold ``path``) exists as a writable folder, or can be created in one."""
    anc = first_existing(folder or ".")
    if not os.path.isdir(anc):
        raise CpgjaxError(f"{path}: cannot write there: {anc} is a file, not a folder")
    if not os.access(anc, os.W_OK | os.X_OK):
        raise CpgjaxError(f"{path}: cannot write there: permission denied on the folder {anc}")


def check_output_file(path: str | os.PathLike[str] | None, option: str = "--out") -> None:
    """Raise :class:`CpgjaxError` (naming ``path``) if ``path`` cannot be written; creates nothing."""
    if path is None:
        return
    p = os.fspath(path)
    if os.path.isdir(p):
        raise CpgjaxError(f"{p}: is a folder; {option} needs a file name")
    if os.path.lexists(p) and not os.access(p, os.W_OK):
        raise CpgjaxError(f"{p}: cannot write: permission denied")
    _check_folder_chain(p, os.path.dirname(p))


def check_output_dir(path: str | os.PathLike[str] | None, option: str = "--out") -> None:
    """Raise :class:`CpgjaxError` (naming ``path``) if the folder ``path`` cannot be created or written into."""
    if path is None:
        return
    p = os.fspath(path)
    if os.path.lexists(p) and not os.path.isdir(p):
        raise CpgjaxError(f"{p}: is a file; {option} needs a folder")
    _check_folder_chain(p, p)


def default_model() -> str:
    """``models/quadruped.wl`` of the working directory or of the source tree."""
    here = os.path.dirname(os.path.abspath(__file__))
    root = os.path.dirname(os.path.dirname(here))
    for cand in (os.path.join(os.getcwd(), "models", "quadruped.wl"), os.path.join(root, "models", "quadruped.wl")):
        if os.path.exists(cand):
            return cand
    return "models/quadruped.wl"
