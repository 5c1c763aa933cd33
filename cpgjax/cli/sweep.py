"""The ``sweep`` and ``report`` subcommands of ``cpgjax`` (see ``docs/sweeps.md``).

``cpgjax sweep MODEL.wl --gamma 0,0.01,0.1,1 --pocket 0,4 [--crossover off,on] [--population 20]
[--seeds 5] [--generations 150] [--baselines random,amc3,amc5,amc10] --out runs/NAME/`` runs every
combination and seed batched into one XLA program (:mod:`cpgjax.experiments.sweep`); ``--preset full|tiny``
runs the thesis experiment of Fig. 6.5-6.12 instead; ``--ray [ADDRESS]`` runs the sweep's shards as Ray
tasks (:mod:`cpgjax.experiments.sweep.cluster`).  ``cpgjax report runs/NAME/`` writes
``runs/NAME/report.md`` (final fitness per cell, mean ± sd over seeds, and the thesis's claims
of Ch. 6.2-6.3 checked) and prints it.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from typing import Any

from cpgjax.cli import options as o


def _onoff(x: str) -> bool:
    x = x.lower()
    if x in ("on", "true", "1", "yes"):
        return True
    if x in ("off", "false", "0", "no"):
        return False
    raise ValueError(x)


_floats = o.list_of(o.nonneg, "expected numbers >= 0, e.g. 0,0.01,0.1,1")
_pockets = o.list_of(o.count0, "expected whole numbers >= 0, e.g. 0,4")
_counts = o.list_of(o.count, "expected whole numbers >= 1, e.g. 10,20")
_bools = o.list_of(_onoff, "expected on/off, e.g. off,on")
_es_counts = o.list_of(o.int_in(2), "expected whole numbers >= 2, e.g. 20,40")
_positives = o.list_of(o.positive, "expected numbers > 0, e.g. 0.1,0.2")
DEFAULT_SEEDS = 5


def _seeds(s: str) -> list[int]:
    """``5`` = seeds 0..4; ``3,7,9`` = those seeds; ``10:15`` = 10..14."""
    try:
        if "," in s:
            out = [o.whole(x.strip(), lo=0, hi=o.MAX_SEED) for x in s.split(",") if x.strip()]
        elif ":" in s:
            a, b = s.split(":")
            out = list(range(o.whole(a, lo=0, hi=o.MAX_SEED), o.whole(b, lo=0, hi=o.MAX_SEED)))
        else:
            out = list(range(o.whole(s, lo=1)))
    except (ValueError, argparse.ArgumentTypeError):
        out = []
    if not out:
        raise argparse.ArgumentTypeError(f"seeds: expected a count (5), a list (3,7,9) or a range (10:15), "
                                         f"got {s!r}")
    return out


GRID = ("gamma", "pocket", "crossover", "population", "generations", "mu_max", "mutation", "sigma", "selection",
        "no_ga", "baselines", "samples", "es_population", "es_sigma", "es_lr")


def register(subparsers: Any) -> None:
    from cpgjax.episode.fitness import DEFAULT_DELTA
    from cpgjax.optim.es import ESConfig
    from cpgjax.optim.ga import MUTATIONS, SELECTIONS, GAConfig
    from cpgjax.sim.model import PIPELINES

    d, e = GAConfig(), ESConfig()
    p = subparsers.add_parser(
        "sweep",
        description="Run every combination of the listed settings for every seed, batched into one jitted "
                    "program (one simulator call per generation for all runs); one HDF5 per run under "
                    "OUT/<cell>/s<seed>.h5; resumable (complete runs are skipped, partial ones continued).")
    o.model_argument(p, help="robot description (.wl) or analytic:sphere:G (test/demo)")
    p.add_argument("--out", required=True, metavar="DIR",
                   help="the sweep's folder, one run file per setting and seed in it (e.g. runs/NAME/)")
    p.add_argument("--preset", choices=("full", "tiny"), default=None,
                   help="run the thesis's experiment of Figs. 6.5-6.12, every GA setting and baseline it compares: "
                        "full at the thesis's scale, tiny a toy version of it; the other grid options are then "
                        "ignored (default: the grid the options give)")
    p.add_argument("--gamma", type=_floats,
                   help=f"comma list of mutation-rate decays: mu = mu_max / (1 + gamma x generation), 0 fixed "
                        f"(default {d.gamma:g}; see evolve --gamma)")
    p.add_argument("--pocket", type=_pockets, help=f"comma list of pocket sizes P: only the best P are parents (0: "
                                                   f"all; default {d.pocket})")
    p.add_argument("--crossover", type=_bools,
                   help=f"comma list of on/off: children by cross-over of two parents, or duplicates of one "
                        f"(default {'on' if d.crossover else 'off'})")
    p.add_argument("--population", type=_counts, help=f"comma list of population sizes, controllers per generation "
                                                      f"(default {d.population})")
    p.add_argument("--generations", type=o.count, help=f"generations per GA run (default {d.generations}; the "
                                                       f"baselines get the same evaluations)")
    p.add_argument("--mu-max", type=o.fraction, help=f"mutation rate at the start, the chance a gene changes "
                                                     f"(default {d.mu_max})")
    p.add_argument("--mutation", choices=MUTATIONS,
                   help=f"how a mutated gene changes: gauss, a Gaussian step of sd --sigma; redraw, uniform in the "
                        f"search range (default {d.mutation})")
    p.add_argument("--sigma", type=o.nonneg, help=f"standard deviation of the Gaussian mutation step, rad (default "
                                                  f"{d.sigma})")
    p.add_argument("--selection", choices=SELECTIONS,
                   help=f"how fitness becomes the chance of being a parent: clip, in proportion to max(fitness, 0) "
                        f"(the thesis); shift, to fitness minus the generation's worst (default {d.selection})")
    p.add_argument("--no-ga", action="store_true", help="run the --baselines only, no GA run")
    p.add_argument("--baselines", help="comma list of random, amc3, amc5, amc10, ... and the evolution strategies "
                                       "cmaes, sep_cmaes, openes, pgpe, snes (default none)")
    p.add_argument("--es-population", type=_es_counts,
                   help="evolution strategies: comma list of samples per generation (default: --population's "
                        "first; even for openes and pgpe)")
    p.add_argument("--es-sigma", type=_positives, help=f"evolution strategies: comma list of initial step sizes "
                                                       f"(default {e.sigma:g})")
    p.add_argument("--es-lr", type=_positives, help=f"openes and pgpe: comma list of optax.adam learning rates "
                                                    f"(default {e.lr:g})")
    p.add_argument("--samples", type=o.count, help="evaluation budget of each baseline run (default population x "
                                                   "generations, the GA's)")
    p.add_argument("--seeds", type=_seeds,
                   help=f"the seeds every setting runs with: a count N (seeds 0..N-1; default {DEFAULT_SEEDS}), a "
                        "comma list 3,7,9 or a range 10:15")
    o.time_option(p)
    o.terrain_option(p)
    o.delta_option(p, of=f"{DEFAULT_DELTA:g}")
    o.evaluation_options(p)
    o.pipeline_option(p, "the model file's Pipeline, else springs; every run of a sweep folder has one")
    o.controller_option(p)
    p.add_argument("--chunk", type=o.count, default=d.chunk,
                   help=f"generations compiled and run as one piece between writes to the run file; a kill loses at "
                        f"most the piece in flight, and results do not depend on it (default {d.chunk})")
    p.add_argument("--group", choices=("all", "kind"), default="all",
                   help="all: every run in one compiled program (default); kind: one program per group of runs of the "
                        "same shape")
    p.add_argument("--ray", nargs="?", const="", default=None, metavar="ADDRESS",
                   help="run the sweep's shards as Ray tasks (pip install -e .[cluster]): without ADDRESS on a "
                        "local Ray instance, with one (e.g. 10.0.0.1:6379 or auto) on that cluster; OUT must be "
                        "a folder every node sees (docs/sweeps.md)")
    p.add_argument("--workers", type=o.count, default=None,
                   help="--ray: number of shards (tasks), each with CPUs/N cores (default: one per node, "
                        "sized by its CPUs)")
    o.run_file_options(p, resume=False)
    p.add_argument("--dry-run", action="store_true", help="list the runs and exit")
    o.quiet_option(p)
    p.set_defaults(func=cmd_sweep)

    p = subparsers.add_parser("report")
    p.add_argument("sweep", metavar="runs/NAME/", help="a sweep folder written by cpgjax sweep")
    p.add_argument("--out", default=None, help="the markdown report written (default runs/NAME/report.md)")
    p.add_argument("--fig-6-12", default=None, metavar="FIG.png",
                   help="also draw Fig. 6.12 of the sweep: every GA setting (A) and every search and evolution "
                        "strategy (B) on one fitness scale, x in evaluations")
    p.set_defaults(func=cmd_report)

    p = subparsers.add_parser(
        "notebook",
        description="Run every cell of a notebook with this interpreter as its kernel and save it with its "
                    "outputs under runs/notebooks/ (the notebook in notebooks/ is left as it is unless --out names "
                    "it).  notebooks/thesis_figures.ipynb runs the sweep if its results are missing, then draws Fig. "
                    "6.5-6.12 and the claims table; each notebook's first cell says what its scales run.")
    p.add_argument("notebook", metavar="NOTEBOOK.ipynb", help="the notebook to run, e.g. "
                                                              "notebooks/thesis_figures.ipynb")
    p.add_argument("--scale", choices=("tiny", "full"), default=None,
                   help="sets CPGJAX_SCALE for the notebook: tiny, seconds to a minute, every cell run on a toy "
                        "problem (what the tests run; its results mean nothing); full, the experiment as the "
                        "results pages report it (minutes to an hour; figures into docs/figures/). Default: the "
                        "notebook's own (tiny)")
    p.add_argument("--sweep-dir", default=None,
                   help="the folder of the sweep the notebook reads or runs (sets CPGJAX_SWEEP_DIR; default: the "
                        "notebook's choice)")
    p.add_argument("--fig-dir", default=None,
                   help="the folder the notebook's figures are written to (sets CPGJAX_FIG_DIR; default: the "
                        "notebook's choice)")
    p.add_argument("--pipeline", choices=PIPELINES, default=None,
                   help=f"sets CPGJAX_PIPELINE: {o.PIPELINE_HELP} (default: the notebook's, the models' own)")
    p.add_argument("--out", default=None, metavar="OUT.ipynb",
                   help="save the executed notebook here (default: runs/notebooks/NAME-SCALE.ipynb)")
    p.add_argument("--no-save", action="store_true", help="do not save the executed notebook")
    p.set_defaults(func=cmd_notebook)


def build_specs(args: argparse.Namespace) -> tuple[list, dict[str, Any]]:
    """The runs and the problem settings the arguments ask for."""
    from cpgjax.experiments import sweep

    problem_args: dict[str, Any] = {"model": args.model, "time": args.time, "terrain": args.terrain,
                                    "evaluation": args.evaluation, "perturb": args.perturb,
                                    "delta": args.delta, "pipeline": args.pipeline}
    if args.controller is not None:
        problem_args["controller"] = args.controller
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
    from cpgjax.optim.ga import GAConfig

    d = GAConfig()
    defaults = {"gamma": [d.gamma], "pocket": [d.pocket], "crossover": [d.crossover], "population": [d.population],
                "generations": d.generations, "mu_max": d.mu_max, "seeds": list(range(DEFAULT_SEEDS))}
    a = {k: (getattr(args, k) if getattr(args, k) is not None else defaults.get(k)) for k in (*GRID, "seeds")}
    extra = {k: a[k] for k in ("mutation", "sigma", "selection") if a[k] is not None}
    cells: list = []
    if not a["no_ga"]:
        cells += sweep.ga_grid(gamma=a["gamma"], pocket=a["pocket"], crossover=a["crossover"],
                               population=a["population"], generations=a["generations"], mu_max=a["mu_max"],
                               **extra)
    if a["baselines"]:
        samples = a["samples"] or a["population"][0] * a["generations"]
        cells += sweep.baseline_cells(a["baselines"].split(","), samples=samples, batch=a["population"][0],
                                      es_population=a["es_population"], es_sigma=a["es_sigma"], es_lr=a["es_lr"])
    if not cells:
        raise ValueError("nothing to run (--no-ga without --baselines)")
    return sweep.plan(args.out, cells, a["seeds"], chunk=args.chunk), problem_args


def cmd_sweep(args: argparse.Namespace) -> int:
    from cpgjax.experiments import sweep
    from cpgjax.experiments.runner import deferred_sigint

    with deferred_sigint():
        if args.workers is not None and args.ray is None:
            raise ValueError("--workers is for --ray")
        specs, pa = build_specs(args)
        if args.dry_run:
            for s in specs:
                print(f"{s.path}  {s.kind}  seed {s.seed}")
            print(f"{len(specs)} runs, {sweep.total_batch(specs)} evaluations per sweep generation")
            return 0
        if args.ray is not None:
            from cpgjax.experiments.sweep import cluster

            cluster.require_ray()                      # the named extra, before anything is written
        o.check_output_dir(args.out)
        try:
            if args.ray is not None:
                problem = sweep.sweep_problem(pa)      # bad settings are refused here, not in every task
                if not args.overwrite:
                    sweep.check_new_runs(problem, specs)
                sweep.write_manifest(args.out, specs, pa)
                summary = cluster.run_on_ray(pa, specs, address=args.ray or None, workers=args.workers,
                                             chunk=args.chunk, overwrite=args.overwrite,
                                             progress=not args.quiet, group=args.group,
                                             allow_other_machine=args.allow_other_machine)
            else:
                problem = sweep.sweep_problem(pa, batch=sweep.total_batch(specs))
                sweep.write_manifest(args.out, specs, pa)
                summary = sweep.run_sweep(problem, specs, chunk=args.chunk, overwrite=args.overwrite,
                                          progress=not args.quiet, group=args.group,
                                          allow_other_machine=args.allow_other_machine)
        except KeyboardInterrupt:
            from cpgjax.cli.evolve import resume_command

            raise KeyboardInterrupt(f"every generation computed is written under {args.out}; continue with: "
                                    f"{resume_command(args, args.out, resume=False)}") from None
    print(f"{args.out}: {summary['runs']} runs ({summary['skipped']} already complete), "
          f"{summary['evaluations']} evaluations in {summary['wall_time']:.1f} s "
          f"(compile {summary['compile_time']:.1f} s); steady state "
          f"{summary['evals_per_second']:.4g} evaluations/s, {summary['cores_busy']:.2f} cores busy")
    for w in summary.get("workers", []):
        print(f"  worker {w['shard']} ({w['host']}, pid {w['pid']}, {w['devices']} devices): {w['runs']} runs, "
              f"{w['evaluations']} evaluations, {w['evals_per_second']:.4g} evaluations/s")
    with open(os.path.join(args.out, "sweep-timing.jsonl"), "a") as f:
        f.write(json.dumps({**summary, "argv": sys.argv[1:]}) + "\n")
    return 0


def cmd_report(args: argparse.Namespace) -> int:
    from cpgjax.analysis.report import write_report

    out = args.out or os.path.join(args.sweep, "report.md")
    if not os.path.isdir(args.sweep):
        raise FileNotFoundError(2, "no such sweep folder", args.sweep)
    o.check_output_file(out)
    o.check_output_file(args.fig_6_12, "--fig-6-12")
    text = write_report(args.sweep, out)
    if "Still going:" in text:
        print(f"{args.sweep}: some runs are still being written: the report reads their complete generations",
              file=sys.stderr)
    print(text)
    print(f"wrote {out}")
    if args.fig_6_12:
        from cpgjax.io.sweepdir import find_runs
        from cpgjax.plots import fig_6_12

        files = [p for fs in find_runs(args.sweep).values() for p in fs]
        fig = fig_6_12(files, files, title=f"Fig. 6.12 — every method of {args.sweep}, one fitness scale")
        fig.savefig(args.fig_6_12, dpi=120)
        print(f"wrote {args.fig_6_12}")
    return 0


def default_notebook_out(notebook: str, scale: str | None) -> str:
    """Where an executed notebook is saved when ``--out`` is not given: ``runs/notebooks/NAME-SCALE.ipynb``, never
    over the notebook itself (the committed notebooks keep their outputs as they were made)."""
    stem = os.path.splitext(os.path.basename(notebook))[0]
    return os.path.join("runs", "notebooks", f"{stem}-{scale or 'default'}.ipynb")


def cmd_notebook(args: argparse.Namespace) -> int:
    from cpgjax.errors import CpgjaxError
    from cpgjax.experiments.notebook import execute

    env = {k: v for k, v in (("CPGJAX_SCALE", args.scale), ("CPGJAX_SWEEP_DIR", args.sweep_dir),
                             ("CPGJAX_FIG_DIR", args.fig_dir), ("CPGJAX_PIPELINE", args.pipeline)) if v}
    out = None if args.no_save else (args.out or default_notebook_out(args.notebook, args.scale))
    if not os.path.isfile(args.notebook):
        raise FileNotFoundError(2, "no such notebook", args.notebook)
    o.check_output_file(out)
    try:
        execute(args.notebook, env=env, cwd=os.getcwd(), out=out)
    except (KeyboardInterrupt, OSError, CpgjaxError):
        raise
    except Exception as e:  # a failing cell: nbclient names the cell; keep its error's name and value
        what = f"{getattr(e, 'ename', type(e).__name__)}: {getattr(e, 'evalue', '') or str(e).splitlines()[-1:]}"
        raise o.CommandFailed(f"{args.notebook}: a cell failed: {what}") from None
    print(f"executed {args.notebook}" + (f", saved to {out}" if out else ""))
    return 0
