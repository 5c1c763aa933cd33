"""The ``sweep`` and ``report`` subcommands of ``cpgjax`` (see ``docs/sweeps.md``).

``cpgjax sweep MODEL.wl --gamma 0,0.01,0.1,1 --pocket 0,4 [--crossover off,on] [--population 20]
[--seeds 5] [--generations 150] [--baselines random,amc3,amc5,amc10] --out runs/NAME/`` runs every
combination and seed batched into one XLA program (:mod:`cpgjax.experiments.sweep`); ``--preset full|tiny``
runs the thesis experiment of Fig. 6.5-6.12 instead.  ``cpgjax report runs/NAME/`` writes
``runs/NAME/report.md`` (final fitness per cell, mean ± sd over seeds, and the thesis's claims
of Ch. 6.2-6.3 checked) and prints it.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from typing import Any


def _list(conv, what: str):
    """An argparse type for a comma list (``0,0.01,0.1``), naming the option and the bad item on error."""

    def parse(text: str) -> list:
        out = []
        for x in text.split(","):
            if not x.strip():
                continue
            try:
                out.append(conv(x.strip()))
            except ValueError:
                raise argparse.ArgumentTypeError(f"{what}: {x.strip()!r} in {text!r} is not valid") from None
        if not out:
            raise argparse.ArgumentTypeError(f"{what}: empty list")
        return out

    return parse


def _onoff(x: str) -> bool:
    x = x.lower()
    if x in ("on", "true", "1", "yes"):
        return True
    if x in ("off", "false", "0", "no"):
        return False
    raise ValueError(x)


_floats = _list(float, "expected numbers, e.g. 0,0.01,0.1,1")
_ints = _list(int, "expected whole numbers, e.g. 0,4")
_bools = _list(_onoff, "expected on/off, e.g. off,on")


def _seeds(s: str) -> list[int]:
    """``5`` = seeds 0..4; ``3,7,9`` = those seeds; ``10:15`` = 10..14."""
    try:
        if "," in s:
            return [int(x) for x in s.split(",") if x.strip()]
        if ":" in s:
            a, b = s.split(":")
            return list(range(int(a), int(b)))
        return list(range(int(s)))
    except ValueError:
        raise argparse.ArgumentTypeError(f"seeds: expected a count (5), a list (3,7,9) or a range (10:15), "
                                         f"got {s!r}") from None


GRID = ("gamma", "pocket", "crossover", "population", "generations", "mu_max", "mutation", "sigma", "selection",
        "no_ga", "baselines", "samples")
DEFAULTS = {"gamma": [0.0], "pocket": [0], "crossover": [False], "population": [20], "generations": 150,
            "mu_max": 0.2, "seeds": list(range(5))}


def register(subparsers: Any) -> None:
    p = subparsers.add_parser(
        "sweep", help="many GA / baseline runs (settings x seeds) batched into one XLA program",
        description="Run every combination of the listed settings for every seed, batched into one jitted "
                    "program (one simulator call per generation for all runs); one HDF5 per run under "
                    "OUT/<cell>/s<seed>.h5; resumable (complete runs are skipped, partial ones continued).")
    p.add_argument("model", metavar="MODEL.wl", help="robot model (.wl) or analytic:sphere:G (test/demo)")
    p.add_argument("--out", required=True, help="sweep directory (runs/NAME/)")
    p.add_argument("--preset", choices=("full", "tiny"), default=None,
                   help="the thesis experiment of Fig. 6.5-6.12 (cpgjax.experiments.sweep.SCALES); "
                        "other grid options ignored")
    p.add_argument("--gamma", type=_floats, help="comma list of γ (eq. 6.1), default 0")
    p.add_argument("--pocket", type=_ints, help="comma list of pocket sizes P (0 = off), default 0")
    p.add_argument("--crossover", type=_bools, help="comma list of on/off, default off")
    p.add_argument("--population", type=_ints, help="comma list of population sizes, default 20")
    p.add_argument("--generations", type=int, help="generations per GA run, default 150")
    p.add_argument("--mu-max", type=float, help="mutation rate at generation 0 (eq. 6.1), default 0.2")
    p.add_argument("--mutation", choices=("gauss", "redraw"), help="how a mutated gene changes, default gauss")
    p.add_argument("--sigma", type=float, help="std of the Gaussian mutation step, default 0.1")
    p.add_argument("--selection", choices=("clip", "shift"), help="reading of 'probability ∝ fitness', default clip")
    p.add_argument("--no-ga", action="store_true", help="baselines only")
    p.add_argument("--baselines", help="comma list of random, amc3, amc5, amc10, ... (default none)")
    p.add_argument("--samples", type=int, help="baseline budget (default population x generations)")
    p.add_argument("--seeds", type=_seeds, help="5 (= seeds 0..4, the default), a comma list 3,7,9 or a range 10:15")
    p.add_argument("--time", type=float, default=None, help="episode length in s (default: the model's TimeMax)")
    p.add_argument("--terrain", default=None, help="flat | ramp:… | bump:… | rough:… (default: the model's)")
    p.add_argument("--delta", type=float, default=None, help="δ of the fitness, eq. 4.5 (default 8)")
    p.add_argument("--chunk", type=int, default=1, help="generations per jitted chunk (default 1)")
    p.add_argument("--group", choices=("all", "kind"), default="all",
                   help="all runs in one program (default) or one program per group of same-shaped runs")
    p.add_argument("--overwrite", action="store_true", help="start every run anew")
    p.add_argument("--dry-run", action="store_true", help="list the runs and exit")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_sweep)

    p = subparsers.add_parser("report", help="summary table of a sweep and the thesis's claims (Ch. 6.2-6.3)")
    p.add_argument("sweep", metavar="runs/NAME/")
    p.add_argument("--out", default=None, help="markdown file (default runs/NAME/report.md)")
    p.set_defaults(func=cmd_report)

    p = subparsers.add_parser(
        "notebook", help="execute a notebook end to end (e.g. the thesis figures at a chosen scale)",
        description="Run every cell of a notebook with this interpreter as its kernel and save it with its "
                    "outputs.  notebooks/thesis_figures.ipynb runs the sweep if its results are missing, then "
                    "draws Fig. 6.5-6.12 and the claims table.")
    p.add_argument("notebook", metavar="NOTEBOOK.ipynb")
    p.add_argument("--scale", choices=("tiny", "full"), default=None, help="sets CPGJAX_SCALE for the notebook")
    p.add_argument("--sweep-dir", default=None, help="sets CPGJAX_SWEEP_DIR (default: the notebook's choice)")
    p.add_argument("--fig-dir", default=None, help="sets CPGJAX_FIG_DIR (default: the notebook's choice)")
    p.add_argument("--out", default=None, help="save the executed notebook here (default: in place)")
    p.add_argument("--no-save", action="store_true", help="do not save the executed notebook")
    p.set_defaults(func=cmd_notebook)


def build_specs(args: argparse.Namespace) -> tuple[list, dict[str, Any]]:
    """The runs and the problem settings the arguments ask for."""
    from cpgjax.experiments import sweep

    problem_args: dict[str, Any] = {"model": args.model, "time": args.time, "terrain": args.terrain,
                                    "delta": args.delta}
    if args.preset:
        given = [f"--{k.replace('_', '-')}" for k in GRID if getattr(args, k) not in (None, False)]
        if given:
            raise ValueError(f"--preset {args.preset} is a whole experiment; drop {', '.join(given)} "
                             "(or leave out --preset to run your own grid)")
        s = sweep.SCALES[args.preset]
        if args.time is None:
            problem_args["time"] = s["time"]
        seeds = args.seeds if args.seeds is not None else list(range(s["seeds"]))
        return sweep.plan(args.out, sweep.thesis_cells(args.preset), seeds, chunk=args.chunk), problem_args
    a = {k: (getattr(args, k) if getattr(args, k) is not None else DEFAULTS.get(k)) for k in (*GRID, "seeds")}
    extra = {k: a[k] for k in ("mutation", "sigma", "selection") if a[k] is not None}
    cells: list = []
    if not a["no_ga"]:
        cells += sweep.ga_grid(gamma=a["gamma"], pocket=a["pocket"], crossover=a["crossover"],
                               population=a["population"], generations=a["generations"], mu_max=a["mu_max"],
                               **extra)
    if a["baselines"]:
        samples = a["samples"] or a["population"][0] * a["generations"]
        cells += sweep.baseline_cells(a["baselines"].split(","), samples=samples, batch=a["population"][0])
    if not cells:
        raise ValueError("nothing to run (--no-ga without --baselines)")
    return sweep.plan(args.out, cells, a["seeds"], chunk=args.chunk), problem_args


def cmd_sweep(args: argparse.Namespace) -> int:
    from cpgjax.experiments import sweep
    from cpgjax.io.results import ResultsError

    try:
        specs, pa = build_specs(args)
        if args.dry_run:
            for s in specs:
                print(f"{s.path}  {s.kind}  seed {s.seed}")
            print(f"{len(specs)} runs, {sweep.total_batch(specs)} evaluations per sweep generation")
            return 0
        problem = sweep.sweep_problem(pa, batch=sweep.total_batch(specs))
        sweep.write_manifest(args.out, specs, pa)
        summary = sweep.run_sweep(problem, specs, chunk=args.chunk, overwrite=args.overwrite,
                                  progress=not args.quiet, group=args.group)
    except (ResultsError, ValueError, FileNotFoundError, OSError) as e:
        print(f"cpgjax sweep: error: {e}", file=sys.stderr)
        return 1
    print(f"{args.out}: {summary['runs']} runs ({summary['skipped']} already complete), "
          f"{summary['evaluations']} evaluations in {summary['wall_time']:.1f} s "
          f"(compile {summary['compile_time']:.1f} s); steady state "
          f"{summary['evals_per_second']:.4g} evaluations/s, {summary['cores_busy']:.2f} cores busy")
    with open(os.path.join(args.out, "sweep-timing.jsonl"), "a") as f:
        f.write(json.dumps({**summary, "argv": sys.argv[1:]}) + "\n")
    return 0


def cmd_report(args: argparse.Namespace) -> int:
    from cpgjax.analysis.report import write_report
    from cpgjax.io.results import ResultsError

    try:
        out = args.out or os.path.join(args.sweep, "report.md")
        text = write_report(args.sweep, out)
    except (ResultsError, ValueError, FileNotFoundError, OSError) as e:
        print(f"cpgjax report: error: {e}", file=sys.stderr)
        return 1
    print(text)
    print(f"wrote {out}")
    return 0


def cmd_notebook(args: argparse.Namespace) -> int:
    from cpgjax.experiments.notebook import execute

    env = {k: v for k, v in (("CPGJAX_SCALE", args.scale), ("CPGJAX_SWEEP_DIR", args.sweep_dir),
                             ("CPGJAX_FIG_DIR", args.fig_dir)) if v}
    out = None if args.no_save else (args.out or args.notebook)
    root = os.getcwd()
    try:
        execute(args.notebook, env=env, cwd=root, out=out)
    except Exception as e:  # a failing cell: nbclient names the cell and the traceback
        print(f"cpgjax notebook: {args.notebook}: {type(e).__name__}: {e}", file=sys.stderr)
        return 1
    print(f"executed {args.notebook}" + (f", saved to {out}" if out else ""))
    return 0
