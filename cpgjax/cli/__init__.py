"""The ``cpgjax`` command line: :func:`build_parser` and :func:`main`.

One module per command group, each with ``register(subparsers)``, and each command's line in :data:`COMMANDS`:
:mod:`~cpgjax.cli.simulate` (simulate, robustness), :mod:`~cpgjax.cli.tools` (bench, study-dt,
study-friction), :mod:`~cpgjax.cli.crosscheck` (export, crosscheck, transfer), :mod:`~cpgjax.cli.agreement`
(agreement), :mod:`~cpgjax.cli.render` (render), :mod:`~cpgjax.cli.evolve` (evolve, search, best, plot),
:mod:`~cpgjax.cli.sweep` (sweep, report, notebook), :mod:`~cpgjax.cli.stability` (stability),
:mod:`~cpgjax.cli.validation` (servo), :mod:`~cpgjax.cli.repertoire` (repertoire, adapt, follow).  Command
functions return an exit code for a result (0; ``simulate`` 1 when the episode diverged) and *raise* on bad input.

:func:`main` is the one place that maps errors to exit codes: bad input (cpgjax's own errors,
``ValueError``, a file that is missing, a folder, unreadable or unwritable) is one line
``cpgjax COMMAND: error: MESSAGE`` on stderr and exit code 2, without a traceback; a bad option
is the same line from argparse (exit 2); work that fails on good input (a notebook cell) is the same
line with exit code 1 (:class:`~cpgjax.cli.options.CommandFailed`); Ctrl-C is exit code 130 with
a line saying what was kept.
"""

from __future__ import annotations

import argparse
import re
import sys

from cpgjax.cli.options import Parser

DESCRIPTION = """\
Evolve gaits for walking robots in a penalty-method rigid-body simulator written in JAX,
after G. Grasso's thesis (NJIT, 2000), and check them in MuJoCo.

- simulate, render: run or draw one episode of a robot model (.wl) and a controller (.ctl);
- evolve, search, sweep: evolve controllers with the thesis's genetic algorithm, or with
  random search, adaptive Monte Carlo or evolution strategies, one run or a grid of them:
  the thesis's open-loop CPGs (a Fourier series per joint), or closed-loop ones (pmtg: the
  CPG modulated by a feedback policy reading the robot's sensors); scored by one episode
  or robustly, over many perturbed ones (domain randomisation);
- best, plot, report, notebook, stability, robustness: read, plot and test the results;
- crosscheck, transfer, agreement, export, servo: compare the simulator with MuJoCo C and
  MJX, replay evolved gaits there (do they carry over?), and see where the engines part;
- repertoire, repertoire-plot, adapt, follow: a repertoire of gaits by MAP-Elites, a
  damaged robot finding by trial one of its gaits that still walks (intelligent trial
  and error, IT&E), walking along a path by steering;
- bench, study-dt, study-friction: speed and the simulator's numerical choices."""

#: every command: its module (``register`` adds it) and its one-line help, in ``cpgjax --help``'s order.  Only the
#: command being run is built in full (its module imported, and with it JAX): ``cpgjax --help`` lists the others
#: from here.
COMMANDS = {
    "simulate": ("simulate", "run one episode of a model (and a .ctl controller)"),
    "robustness": ("simulate", "replay a controller with its genes jittered: mean and spread of fitness"),
    "bench": ("tools", "robot-steps/s and simulated robot-s per wall s at several batch sizes"),
    "study-dt": ("tools", "the time-step stability study (docs/simulator.md)"),
    "study-friction": ("tools", "the friction bristle: steadiness of the score vs agreement with MuJoCo C "
                                "(docs/simulator.md)"),
    "export": ("crosscheck", "write the model as MJCF for MuJoCo / MJX"),
    "crosscheck": ("crosscheck", "the same controllers in the penalty simulator, MuJoCo C and MJX"),
    "transfer": ("crosscheck", "do evolved gaits carry over? each run's best replayed in MuJoCo C (thesis Fig. "
                               "6.3-6.4)"),
    "agreement": ("agreement", "where the engines part on evolved gaits: each gait here and in MuJoCo C, its feet "
                               "watched"),
    "render": ("render", "draw an episode frame by frame to a video (.mp4 or .gif)"),
    "evolve": ("evolve", "evolve controllers with the thesis's genetic algorithm"),
    "search": ("evolve", "baseline search: random (Fig. 6.10), adaptive Monte Carlo (Fig. 6.11), or an evolution "
                         "strategy of evosax (CMA-ES, OpenAI-ES, ...)"),
    "best": ("evolve", "print the best controller of a run (and write it as a .ctl)"),
    "plot": ("evolve", "fitness per generation of one or more runs (Fig. 6.5 style)"),
    "sweep": ("sweep", "many GA / baseline runs (settings x seeds) batched into one XLA program"),
    "report": ("sweep", "summary table of a sweep and the thesis's claims (Ch. 6.2-6.3)"),
    "notebook": ("sweep", "execute a notebook end to end (e.g. the thesis figures at a chosen scale)"),
    "stability": ("stability", "stability under bumps and roughness of controllers or of evolved populations (thesis "
                               "Figs. 6.13-6.21)"),
    "servo": ("validation", "servo frequency response: tracking error vs frequency, sigmoid fit, cut-off (Figs. "
                            "6.1-6.2)"),
    "repertoire": ("repertoire", "a repertoire of gaits by MAP-Elites (quality-diversity; docs/repertoire.md)"),
    "adapt": ("repertoire", "Intelligent Trial and Error: a damaged robot finds a gait of the repertoire by trial"),
    "follow": ("repertoire", "walk a path: with a gait that reads a turning command (--ctl), or a repertoire's gaits"),
    "repertoire-plot": ("repertoire", "a repertoire's heatmap, coverage and QD-score per evaluation"),
}
EXIT_BAD_INPUT = 2
EXIT_INTERRUPTED = 130


def build_parser(argv: list[str] | None = None) -> Parser:
    """The ``cpgjax`` parser.  With ``argv``, only the command it names is built in full (the others: a name and
    a line of help, :data:`COMMANDS`), so that ``cpgjax --help`` imports no command and no JAX; without, every
    command."""
    import importlib

    p = Parser(prog="cpgjax", formatter_class=argparse.RawDescriptionHelpFormatter,
               description=DESCRIPTION, epilog="Each command's options: cpgjax COMMAND --help. Terms: "
                                               "docs/glossary.md.")
    from cpgjax import __version__

    p.add_argument("--version", action="version", version=f"cpgjax {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    if argv is None:
        wanted = {group for group, _ in COMMANDS.values()}
    else:       # the command: the first word that is not an option (the top level's options take no value)
        named = next((a for a in argv if not a.startswith("-")), None)
        wanted = {COMMANDS[named][0]} if named in COMMANDS else set()
    registered: set[str] = set()
    for name, (group, line) in COMMANDS.items():
        if group not in wanted:
            sub.add_parser(name, help=line)
        elif group not in registered:       # the module adds its commands, in the table's order
            importlib.import_module(f"cpgjax.cli.{group}").register(_Commands(sub))
            registered.add(group)
    # a command's --help opens with what it does: its one-line help where no longer description was written
    for action in sub._choices_actions:
        cmd = sub.choices[action.dest]
        if not cmd.description:
            cmd.description = action.help[:1].upper() + action.help[1:] + "." if action.help else None
    return p


class _Commands:
    """The subparsers as a command module's ``register`` sees them: each command added with its line of
    :data:`COMMANDS` as its help."""

    def __init__(self, sub):
        self._sub = sub

    def add_parser(self, name: str, **kw):
        if name not in COMMANDS:
            raise KeyError(f"command {name!r} is not in cpgjax.cli.COMMANDS")
        return self._sub.add_parser(name, help=COMMANDS[name][1], **kw)


def _message(e: BaseException) -> str:
    """One line for an error: the file it concerns and what went wrong."""
    from cpgjax.errors import CpgjaxError

    text = str(e) or type(e).__name__
    if isinstance(e, OSError) and not isinstance(e, CpgjaxError) and e.filename:
        what = {FileNotFoundError: "no such file or folder", IsADirectoryError: "is a folder, not a file",
                NotADirectoryError: "a part of the path is a file, not a folder",
                PermissionError: "permission denied"}.get(type(e), e.strerror or text)
        text = f"{e.filename}: {what}"
    return " ".join(line.strip() for line in text.splitlines() if line.strip())


def _options(parser: Parser, command: str) -> set[str]:
    """The option strings of ``cpgjax COMMAND``."""
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return {s for a in sub.choices[command]._actions for s in a.option_strings}


def main(argv: list[str] | None = None) -> int:
    """Run ``cpgjax ARGV``; returns the exit code (0 ok, 2 bad input, 130 interrupted)."""
    from cpgjax.errors import CpgjaxError

    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser(argv)
    try:
        args = parser.parse_args(argv)
    except SystemExit as e:        # --help, or a bad option (argparse printed one line)
        return e.code if isinstance(e.code, int) else (0 if e.code is None else EXIT_BAD_INPUT)
    except KeyboardInterrupt:
        print("cpgjax: interrupted while starting (nothing was written)", file=sys.stderr)
        return EXIT_INTERRUPTED
    cmd = f"cpgjax {args.command}"
    args.argv = argv     # for the hint after a Ctrl-C
    try:
        return int(args.func(args) or 0)
    except KeyboardInterrupt as e:
        print(f"{cmd}: interrupted" + (f": {e}" if str(e) else ""), file=sys.stderr)
        return EXIT_INTERRUPTED
    except (CpgjaxError, ValueError, OSError) as e:
        advice = getattr(e, "advice", None)    # e.g. "start anew with --overwrite": only where the command has it
        fits = advice and all(o in _options(parser, args.command) for o in re.findall(r"--[a-z][-a-z]*", advice))
        print(f"{cmd}: error: {_message(e)}" + (f"; {advice}" if fits else ""), file=sys.stderr)
        return getattr(e, "exit_code", EXIT_BAD_INPUT)


if __name__ == "__main__":
    sys.exit(main())
