"""The ``evolve``, ``search``, ``best`` and ``plot`` subcommands of ``cpgjax`` (see ``docs/evolution.md``).

``cpgjax.cli`` calls :func:`register` with its ``add_subparsers()`` object.  Each
subcommand's function takes the parsed arguments and returns an exit code.

MODEL is a `.wl` file (:func:`cpgjax.optim.factory.make_problem`) or, as a test/demo feature that
needs no simulator, ``analytic:sphere:G`` / ``analytic:diverging:G``
(:func:`cpgjax.optim.analytic.analytic_problem`).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from typing import Any

GA_OPTIONS = ("population", "generations", "mu_max", "gamma", "pocket", "crossover", "mutation", "sigma",
              "init_spread", "selection", "seed", "chunk")
SEARCH_OPTIONS = ("method", "samples", "batch", "M", "width_end", "seed", "chunk")
PROBLEM_OPTIONS = ("time", "terrain", "delta", "replicas")


def register(subparsers: Any) -> None:
    """Add ``evolve``, ``search``, ``best`` and ``plot`` to an argparse subparsers object."""
    from cpgjax.optim.baselines import METHODS, SearchConfig
    from cpgjax.optim.ga import MUTATIONS, SELECTIONS, GAConfig

    d, s = GAConfig(), SearchConfig()

    def common(p: argparse.ArgumentParser, kind: str) -> None:
        p.add_argument("model", metavar="MODEL.wl",
                       help="robot model (.wl); or analytic:sphere:G / analytic:diverging:G (test/demo)")
        p.add_argument("--time", type=float, default=None, help="episode length in s (default: the model's)")
        p.add_argument("--terrain", default=None, help="terrain specification (default: the model's)")
        p.add_argument("--delta", type=float, default=None, help="delta of the fitness, eq. 4.5 (default 8)")
        p.add_argument("--replicas", type=int, default=None,
                       help="score each controller as the mean of R episodes with genes jittered by 1e-3 "
                            "(default 1, the thesis; see docs/evolution.md, 'A noisy fitness')")
        p.add_argument("--seed", type=int, default=None, help=f"random seed (default {d.seed})")
        p.add_argument("--chunk", type=int, default=None,
                       help="generations per jitted chunk; a kill loses at most the chunk in flight (default 1)")
        p.add_argument("--out", default=None, help=f"results file (default runs/MODEL-{kind}-sSEED.h5)")
        g = p.add_mutually_exclusive_group()
        g.add_argument("--resume", action="store_true", help="continue the run in --out")
        g.add_argument("--overwrite", action="store_true", help="replace an existing --out")
        p.add_argument("--quiet", action="store_true", help="no progress bar")

    p = subparsers.add_parser("evolve", help="evolve CPG controllers with the genetic algorithm (Ch. 4.3)",
                              description="Evolve CPG controllers with the GA of Ch. 4.3 / 6.2; results in HDF5.")
    common(p, "ga")
    p.add_argument("--population", type=int, default=None, help=f"N (default {d.population})")
    p.add_argument("--generations", type=int, default=None, help=f"generations (default {d.generations})")
    p.add_argument("--mu-max", type=float, default=None, help=f"mu_max of eq. 6.1 (default {d.mu_max})")
    p.add_argument("--gamma", type=float, default=None, help=f"gamma of eq. 6.1 (default {d.gamma})")
    p.add_argument("--pocket", type=int, default=None, help="pocket size P, 0 = off (default 0; thesis 4)")
    p.add_argument("--crossover", action=argparse.BooleanOptionalAction, default=None,
                   help="cross-over instead of duplication (default off)")
    p.add_argument("--mutation", choices=MUTATIONS, default=None, help="gauss step or uniform redraw")
    p.add_argument("--sigma", type=float, default=None, help=f"Gaussian mutation step (default {d.sigma})")
    p.add_argument("--init-spread", type=float, default=None,
                   help=f"initial genes: base + U(-s, s) (default {d.init_spread})")
    p.add_argument("--selection", choices=SELECTIONS, default=None,
                   help="weights max(f,0) (clip, thesis) or f-min(f) (shift) (default clip)")
    p.set_defaults(func=cmd_evolve)

    p = subparsers.add_parser("search", help="baseline search: random (Fig. 6.10) or adaptive Monte Carlo "
                              "(Fig. 6.11)")
    common(p, "search")
    p.add_argument("--method", choices=METHODS, default=None, help="random or amc (default random)")
    p.add_argument("--M", dest="M", type=int, default=None, help=f"amc: independent variables (default {s.M})")
    p.add_argument("--samples", type=int, default=None, help=f"evaluation budget (default {s.samples})")
    p.add_argument("--batch", type=int, default=None, help=f"evaluations per iteration (default {s.batch})")
    p.add_argument("--width-end", type=float, default=None,
                   help=f"amc: final half-width of the sampling box (default {s.width_end})")
    p.set_defaults(func=cmd_search)

    p = subparsers.add_parser("best", help="print the best controller of a run (and write it as a .ctl)")
    p.add_argument("run", metavar="RUN.h5")
    p.add_argument("--ctl", default=None, metavar="OUT.ctl", help="write the controller as a thesis .ctl file")
    p.add_argument("--round", action="store_true",
                   help="round to the thesis's 6 decimals (default: exact float32 digits, so that "
                        "`cpgjax simulate` replays the very controller the GA scored)")
    p.set_defaults(func=cmd_best)

    p = subparsers.add_parser("plot", help="fitness per generation of one or more runs (Fig. 6.5 style)")
    p.add_argument("runs", nargs="+", metavar="RUN.h5")
    p.add_argument("--out", default=None, metavar="FIG.png", help="figure file (default: first RUN with .png)")
    p.add_argument("--x", choices=("auto", "generation", "evaluations"), default="auto")
    p.add_argument("--no-cloud", action="store_true", help="lines only, no cloud of points")
    p.add_argument("--title", default=None)
    p.set_defaults(func=cmd_plot)


def _fail(cmd: str, err: Exception) -> int:
    print(f"cpgjax {cmd}: error: {err}", file=sys.stderr)
    return 1


def _stored(path: str | None, resume: bool) -> tuple[dict[str, Any], dict[str, Any]]:
    """(stored config, stored CLI problem args) when resuming an existing file, else empty."""
    if not (resume and path and os.path.exists(path)):
        return {}, {}
    from cpgjax.io.results import read_attrs

    a = read_attrs(path)
    meta = json.loads(a.get("meta", "{}"))
    return json.loads(a["config"]), json.loads(meta.get("cli_problem_args", "{}") or "{}")


def _settings(args: argparse.Namespace, names: tuple[str, ...], stored: dict[str, Any]) -> dict[str, Any]:
    """Options given on the command line, else the stored run's (on --resume), else the defaults."""
    out = {}
    for n in names:
        v = getattr(args, n, None)
        if v is None and n in stored:
            v = stored[n]
        if v is not None:
            out[n] = v
    return out


def _default_out(model: str, kind: str, seed: int) -> str:
    stem = os.path.splitext(os.path.basename(model))[0].replace(":", "-")
    return os.path.join("runs", f"{stem}-{kind}-s{seed}.h5")


def _report(summary: dict[str, Any]) -> None:
    line = f"{summary['path']}: {summary['completed']}/{summary['generations']} generations"
    if "best_fitness" in summary:
        line += (f", best fitness {summary['best_fitness']:.6g} (generation {summary['best_generation']}, "
                 f"individual {summary['best_index']})")
    line += f", {summary['evals_per_second']:.3g} evaluations/s"
    print(line)


def cmd_evolve(args: argparse.Namespace) -> int:
    from cpgjax.experiments.evolve import run_ga
    from cpgjax.io.results import ResultsError
    from cpgjax.optim.factory import make_problem
    from cpgjax.optim.ga import GAConfig

    try:
        out = args.out
        if out is None:
            out = _default_out(args.model, "ga", args.seed if args.seed is not None else GAConfig().seed)
        cfg_stored, prob_stored = _stored(out, args.resume)
        cfg = GAConfig(**_settings(args, GA_OPTIONS, cfg_stored))
        pa = {n: (getattr(args, n) if getattr(args, n) is not None else prob_stored.get(n))
              for n in PROBLEM_OPTIONS}
        problem = make_problem(args.model, **pa)
        summary = run_ga(problem, cfg, out, resume=args.resume, overwrite=args.overwrite,
                         progress=not args.quiet)
    except (ResultsError, ValueError, FileNotFoundError, OSError) as e:
        return _fail("evolve", e)
    _report(summary)
    return 0


def cmd_search(args: argparse.Namespace) -> int:
    from cpgjax.experiments.evolve import run_search
    from cpgjax.io.results import ResultsError
    from cpgjax.optim.baselines import SearchConfig
    from cpgjax.optim.factory import make_problem

    try:
        out = args.out
        if out is None:
            method = args.method or SearchConfig().method
            out = _default_out(args.model, method, args.seed if args.seed is not None else 0)
        cfg_stored, prob_stored = _stored(out, args.resume)
        cfg = SearchConfig(**_settings(args, SEARCH_OPTIONS, cfg_stored))
        pa = {n: (getattr(args, n) if getattr(args, n) is not None else prob_stored.get(n))
              for n in PROBLEM_OPTIONS}
        problem = make_problem(args.model, **pa)
        summary = run_search(problem, cfg, out, resume=args.resume, overwrite=args.overwrite,
                             progress=not args.quiet)
    except (ResultsError, ValueError, FileNotFoundError, OSError) as e:
        return _fail("search", e)
    _report(summary)
    return 0


def cmd_best(args: argparse.Namespace) -> int:
    import numpy as np

    from cpgjax.io.results import ResultsError, read_run

    try:
        run = read_run(args.run)
        gen, idx, fit, genome = run.best()
        n_dof, harmonics = int(run.meta.get("n_dof", 0) or 0), int(run.meta.get("harmonics", -1))
        ncoef = 2 * harmonics + 1
        print(f"{args.run}: best fitness {fit:.6f} at generation {gen}, individual {idx} "
              f"({run.kind}, {run.completed} generations)")
        if harmonics >= 0 and n_dof * ncoef == genome.size:
            coeffs = np.asarray(genome, np.float64).reshape(n_dof, ncoef)
            names = ["c0"] + [f"{ab}{k}" for k in range(1, harmonics + 1) for ab in ("a", "b")]
            print("dof  " + "  ".join(f"{n:>9}" for n in names))
            for j, row in enumerate(coeffs):
                print(f"{j:>3}  " + "  ".join(f"{v:9.6f}" for v in row))
        else:
            coeffs = None
            print("genome: " + " ".join(f"{v:.6f}" for v in genome))
        if args.ctl:
            if coeffs is None:
                raise ValueError("the run does not record n_dof and harmonics: cannot write a .ctl")
            from cpgjax.io.ctl import write_ctl

            d = os.path.dirname(args.ctl)
            if d:
                os.makedirs(d, exist_ok=True)
            write_ctl(args.ctl, coeffs, fit, exact=not args.round)
            print(f"wrote {args.ctl}")
    except (ResultsError, ValueError, FileNotFoundError, OSError, KeyError) as e:
        return _fail("best", e)
    return 0


def cmd_plot(args: argparse.Namespace) -> int:
    from cpgjax.io.results import ResultsError
    from cpgjax.plots import plot_runs

    out = args.out or os.path.splitext(args.runs[0])[0] + ".png"
    try:
        plot_runs(args.runs, out, x=args.x, cloud=not args.no_cloud, title=args.title)
    except (ResultsError, ValueError, FileNotFoundError, OSError) as e:
        return _fail("plot", e)
    print(f"wrote {out}")
    return 0
