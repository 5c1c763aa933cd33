"""The ``evolve``, ``search``, ``best`` and ``plot`` subcommands of ``cpgjax`` (see ``docs/evolution.md``).

MODEL is a `.wl` file (:func:`cpgjax.optim.factory.make_problem`) or, as a test/demo feature that
needs no simulator, ``analytic:sphere:G`` / ``analytic:diverging:G``
(:func:`cpgjax.optim.analytic.analytic_problem`).  Every default comes from :class:`GAConfig` /
:class:`SearchConfig`; options left out on ``--resume`` are taken from the stored run.
"""

from __future__ import annotations

import argparse
import json
import os
import shlex
import sys
from typing import Any

from cpgjax.cli import options as o
from cpgjax.episode.cpg import GENE_BOX

GA_OPTIONS = ("population", "generations", "mu_max", "gamma", "pocket", "crossover", "mutation", "sigma",
              "init_spread", "selection", "seed", "chunk")
SEARCH_OPTIONS = ("method", "samples", "batch", "M", "width_end", "seed", "chunk")
ES_OPTIONS = ("method", "samples", "population", "sigma", "lr", "seed", "chunk")
ES_METHODS = ("cmaes", "sep_cmaes", "openes", "pgpe", "snes")   # cpgjax.optim.es.METHODS (no import at start-up)
PROBLEM_OPTIONS = ("time", "terrain", "delta", "replicas", "evaluation", "perturb", "pipeline", "start", "controller",
                   "free")


def register(subparsers: Any) -> None:
    """Add ``evolve``, ``search``, ``best`` and ``plot`` to an argparse subparsers object."""
    from cpgjax.episode.fitness import DEFAULT_DELTA
    from cpgjax.optim import es
    from cpgjax.optim.baselines import METHODS, SearchConfig
    from cpgjax.optim.ga import MUTATIONS, SELECTIONS, GAConfig

    d, s, e = GAConfig(), SearchConfig(), es.ESConfig()

    def common(p: argparse.ArgumentParser, kind: str) -> None:
        o.model_argument(p, help="robot description (.wl); or analytic:sphere:G / analytic:diverging:G (test/demo)")
        o.time_option(p)
        o.terrain_option(p)
        o.delta_option(p, of=f"{DEFAULT_DELTA:g}")
        p.add_argument("--replicas", type=o.int_in(1, 1000), default=None,
                       help="score each controller as the mean of R episodes, each but the first with every gene "
                            "moved by a fixed offset of sd 1e-3 (default 1, the thesis; a lucky single episode then "
                            "counts for less: docs/evolution.md, 'A noisy fitness'); --evaluation robust goes further")
        o.evaluation_options(p)
        p.add_argument("--start", default=None, metavar="CTL",
                       help="start the search from this controller (.ctl) instead of the thesis's one 0.5 Hz "
                            "sinusoid per joint (the GA moves each of its genes by --init-spread); recorded in the "
                            "run file.  A closed-loop start may read fewer sensor groups than --controller: the "
                            "others get weights of 0")
        o.pipeline_option(p, "the model file's Pipeline, else springs; on --resume the run's")
        o.controller_option(p)
        p.add_argument("--free", default=None, metavar="GROUP+GROUP",
                       help="evolve only these genes, the others kept at the starting controller's values (the GA "
                            "and search's evolution strategies): cpg, the CPG's coefficients, or a group the "
                            "--controller's policy reads, its weights; e.g. --start models/quadruped-rough.ctl "
                            "--controller pmtg:tilt+contact+command+steer+turn+bias:mirror --free command+steer+turn "
                            "teaches a walker to turn and leaves its straight gait as it is (default: every gene "
                            "evolves)")
        o.seed_option(p, None, shown=d.seed)
        p.add_argument("--chunk", type=o.count, default=None,
                       help=f"generations compiled and run as one piece between writes to the run file; a kill loses "
                            f"at most the piece in flight, and results do not depend on it (default {d.chunk})")
        p.add_argument("--out", default=None, metavar="RUN.h5",
                       help=f"the run file written, one row per generation (default runs/MODEL-{kind}-sSEED.h5)")
        o.run_file_options(p)
        o.quiet_option(p)

    p = subparsers.add_parser("evolve",
                              description="Evolve controllers for a robot with the thesis's genetic algorithm "
                                          "(Ch. 4.3, 6.2): a population scored in simulation, the fitter ones "
                                          "duplicated (or crossed over) and mutated, generation after generation. "
                                          "The controllers are the thesis's open-loop CPGs, or with --controller "
                                          "pmtg closed-loop ones that read the robot's sensors. Every generation is "
                                          "written to an HDF5 run file (--out), which --resume continues. Terms: "
                                          "docs/glossary.md; the method: docs/evolution.md.")
    common(p, "ga")
    p.add_argument("--population", type=o.count, default=None,
                   help=f"controllers per generation (default {d.population}; the thesis used 10 to 20)")
    p.add_argument("--generations", type=o.count, default=None,
                   help=f"how many generations the GA runs (default {d.generations}: {d.population} x "
                        f"{d.generations} = {d.population * d.generations} evaluations, the thesis's budget)")
    p.add_argument("--mu-max", type=o.fraction, default=None,
                   help=f"mutation rate at the start: the chance that a gene of a child changes, in [0, 1] "
                        f"(default {d.mu_max}); --gamma makes it decay")
    p.add_argument("--gamma", type=o.nonneg, default=None,
                   help=f"how fast the mutation rate decays: mu = mu_max / (1 + gamma x generation); 0 keeps it "
                        f"fixed at --mu-max (default {d.gamma:g}; the mu schedule, docs/glossary.md)")
    p.add_argument("--pocket", type=o.count0, default=None,
                   help=f"keep only the best P controllers as parents of the next generation (0: all of them; "
                        f"default {d.pocket}; the thesis used 4 of 20)")
    p.add_argument("--crossover", action=argparse.BooleanOptionalAction, default=None,
                   help=f"make each child from two parents (the first genes of one, the rest of the other) instead "
                        f"of duplicating one (default {'on' if d.crossover else 'off'})")
    p.add_argument("--mutation", choices=MUTATIONS, default=None,
                   help=f"how a mutated gene changes: gauss, a Gaussian step of sd --sigma; redraw, a new value "
                        f"drawn uniformly in the search range [-{GENE_BOX:g}, {GENE_BOX:g}] (default {d.mutation})")
    p.add_argument("--sigma", type=o.nonneg, default=None,
                   help=f"standard deviation of a Gaussian mutation's step, rad (default {d.sigma}; genes span "
                        f"{2 * GENE_BOX:g})")
    p.add_argument("--init-spread", type=o.nonneg, default=None,
                   help=f"the first generation: every gene of the starting controller moved by a uniform amount in "
                        f"[-s, s] (default {d.init_spread})")
    p.add_argument("--selection", choices=SELECTIONS, default=None,
                   help=f"how fitness becomes the chance of being a parent when some fitness is negative: clip "
                        f"(the thesis), in proportion to max(fitness, 0), a controller that does not move forward is "
                        f"never a parent; shift, in proportion to fitness minus the generation's worst "
                        f"(default {d.selection})")
    p.set_defaults(func=cmd_evolve)

    p = subparsers.add_parser("search")
    common(p, "search")
    p.add_argument("--method", choices=METHODS + es.METHODS, default=None,
                   help=f"random or amc (the thesis's baselines), or an evolution strategy of evosax: "
                        f"{', '.join(es.METHODS)} (default {s.method})")
    p.add_argument("--M", dest="M", type=o.count, default=None,
                   help=f"amc: independent searchers, each sampling a shrinking box around its own best "
                        f"(default {s.M}; more explore, fewer refine)")
    p.add_argument("--samples", type=o.count, default=None,
                   help=f"evaluation budget: controllers scored in all (default {s.samples}, the GA's 20 x 150)")
    p.add_argument("--batch", type=o.count, default=None,
                   help=f"random, amc: controllers scored per iteration (default {s.batch})")
    p.add_argument("--width-end", type=o.positive, default=None,
                   help=f"amc: half-width of each searcher's sampling box at the last iteration; it shrinks "
                        f"geometrically from the whole search range (default {s.width_end})")
    p.add_argument("--population", type=o.int_in(2, 1_000_000), default=None,
                   help=f"evolution strategies: samples per generation (default {e.population}; even for "
                        f"{' and '.join(es.ANTITHETIC)})")
    p.add_argument("--sigma", type=o.positive, default=None,
                   help=f"evolution strategies: initial step size, the std of the search distribution "
                        f"(default {e.sigma:g}; genes span {2 * GENE_BOX:g})")
    p.add_argument("--lr", type=o.positive, default=None,
                   help=f"{' and '.join(es.GRADIENT)}: learning rate of optax.adam on the mean (default {e.lr:g})")
    p.set_defaults(func=cmd_search)

    p = subparsers.add_parser("best")
    p.add_argument("run", metavar="RUN.h5", help="a run file written by evolve or search")
    p.add_argument("--ctl", default=None, metavar="OUT.ctl", help="write the controller as a thesis .ctl file")
    p.add_argument("--round", action="store_true",
                   help="round to the thesis's 6 decimals (default: exact float32 digits, so that "
                        "`cpgjax simulate` replays the very controller the GA scored)")
    p.add_argument("--validate", action="store_true",
                   help="the run's champion by validation instead: its best distinct genomes re-scored over fresh "
                        "perturbed episodes, the same for each, the highest mean kept (docs/evolution.md)")
    o.validation_options(p)
    o.seed_option(p, what="validation: random seed of its episodes")
    o.pipeline_option(p, f"{o.RUN_PIPELINE}; --validate only")
    p.set_defaults(func=cmd_best)

    p = subparsers.add_parser("plot")
    p.add_argument("runs", nargs="+", metavar="RUN.h5", help="run files written by evolve, search or sweep")
    p.add_argument("--out", default=None, metavar="FIG.png", help="the figure file written (default: the first RUN's "
                                                                  "name with .png)")
    p.add_argument("--x", choices=("auto", "generation", "evaluations"), default="auto",
                   help="the x axis: generations, or evaluations (controllers scored so far); auto: evaluations "
                        "when the runs differ in evaluations per generation, else generations (default auto)")
    p.add_argument("--no-cloud", action="store_true", help="lines only, no cloud of points")
    p.add_argument("--title", default=None, help="the title above the figure (default: the model and the episode "
                                                 "length)")
    p.set_defaults(func=cmd_plot)


def _stored(path: str | None, resume: bool) -> tuple[dict[str, Any], dict[str, Any]]:
    """(stored config, stored CLI problem args) when resuming an existing file, else empty."""
    if not (resume and path and os.path.exists(path)):
        return {}, {}
    from cpgjax.io.results import read_attrs

    a = read_attrs(path)
    meta = json.loads(a.get("meta") or "{}")
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


def resume_command(args: argparse.Namespace, out: str, *, resume: bool = True) -> str:
    """The command line that continues this one: the same arguments, ``--overwrite`` dropped, ``--resume`` added."""
    argv = [a for a in getattr(args, "argv", None) or [args.command] if a not in ("--overwrite", "--resume")]
    if "--out" not in argv and not any(a.startswith("--out=") for a in argv):
        argv += ["--out", out]
    return shlex.join(["cpgjax", *argv, *(["--resume"] if resume else [])])


def interrupted(args: argparse.Namespace, out: str) -> KeyboardInterrupt:
    """What a Ctrl-C kept (generations safe in ``out``) and the exact command that continues the run."""
    from cpgjax.io.results import read_attrs

    try:
        a = read_attrs(out)
        n = int(a["completed"])
        kept = (f"{out} holds {n} of {int(a['generations'])} generations, all complete" if n
                else f"{out} holds no generation yet")
    except Exception:  # noqa: BLE001 - no file yet, or unreadable: nothing was kept
        kept = f"nothing was written to {out} yet"
    return KeyboardInterrupt(f"{kept}; continue with: {resume_command(args, out)}")


def _run_command(args: argparse.Namespace, kind: str) -> int:
    from cpgjax.experiments.runner import deferred_sigint

    with deferred_sigint():
        out = args.out
        try:
            from cpgjax.experiments.evolve import run_ga, run_search
            from cpgjax.optim.baselines import SearchConfig
            from cpgjax.optim.es import ESConfig
            from cpgjax.optim.factory import make_problem
            from cpgjax.optim.ga import GAConfig

            config, names = (GAConfig, GA_OPTIONS) if kind == "ga" else (SearchConfig, SEARCH_OPTIONS)
            if out is None:
                label = kind if kind == "ga" else (args.method or SearchConfig().method)
                out = _default_out(args.model, label, args.seed if args.seed is not None else config().seed)
            o.check_output_file(out)
            cfg_stored, prob_stored = _stored(out, args.resume)
            if kind != "ga" and (args.method or cfg_stored.get("method")) in ES_METHODS:
                config, names = ESConfig, ES_OPTIONS
            elif kind != "ga":
                _refuse_es_options(args)
            cfg = config(**_settings(args, names, cfg_stored))
            pa = {n: (getattr(args, n) if getattr(args, n) is not None else prob_stored.get(n))
                  for n in PROBLEM_OPTIONS}
            problem = make_problem(args.model, **pa)
            run = run_ga if kind == "ga" else run_search
            summary = run(problem, cfg, out, resume=args.resume, overwrite=args.overwrite, progress=not args.quiet,
                          allow_other_machine=args.allow_other_machine)
        except KeyboardInterrupt:
            raise interrupted(args, out or "?") from None
    _report(summary)
    return 0


def _refuse_es_options(args: argparse.Namespace) -> None:
    for n in ("population", "sigma", "lr"):
        if getattr(args, n, None) is not None:
            raise ValueError(f"--{n} applies to the evolution strategies ({', '.join(ES_METHODS)}), "
                             f"not to --method {args.method or 'random'} "
                             "(use --batch for its evaluations per iteration)")


def _report(summary: dict[str, Any]) -> None:
    line = f"{summary['path']}: {summary['completed']}/{summary['generations']} generations"
    if "best_fitness" in summary:
        line += (f", best so far {summary['best_fitness']:.6g} (generation {summary['best_generation']}, "
                 f"individual {summary['best_index']})")
    line += f", {summary['evals_per_second']:.3g} evaluations/s"
    print(line)


def cmd_evolve(args: argparse.Namespace) -> int:
    return _run_command(args, "ga")


def cmd_search(args: argparse.Namespace) -> int:
    return _run_command(args, "search")


def cmd_best(args: argparse.Namespace) -> int:
    import jax
    import numpy as np

    from cpgjax.episode.policy import family_from_meta, from_genomes, table_fields
    from cpgjax.io.ctl import PolicyTable
    from cpgjax.io.results import read_run, writing_note

    o.check_output_file(args.ctl, "--ctl")
    if args.pipeline is not None and not args.validate:
        raise ValueError("--pipeline is for --validate (the run's best is the score it recorded)")
    run = read_run(args.run)
    note = writing_note(run.path, run.attrs, run.writer) if run.writer is not None else None
    if note:
        print(note, file=sys.stderr)
    gen, idx, fit, genome = run.best()
    if args.validate:
        from cpgjax.experiments.validate import validate

        v = o.validation(args)
        if args.pipeline is not None and args.pipeline != run.pipeline:
            print(f"{args.run}: validating on the {args.pipeline} pipeline, not the run's {run.pipeline}")
        ch = validate(run, v, pipeline=args.pipeline)
        print(f"{args.run}: validated {len(ch.scores)} candidates over {v.episodes} perturbed episodes "
              f"(seed {v.seed}{v.stricter}):"
              f" the best recorded one ({fit:.6f}) scores {ch.scores[0]:.6f}; the champion scores {ch.score:.6f}")
        gen, idx, fit, genome = ch.generation, ch.index, ch.recorded, ch.genome
    n_dof, harmonics = int(run.meta.get("n_dof", 0) or 0), int(run.meta.get("harmonics", -1))
    ncoef = 2 * harmonics + 1
    family = family_from_meta(run.meta)
    policy, cpg_genes, model = None, genome, None
    if run.meta.get("model_text"):
        from cpgjax.io.wl import parse_wl
        from cpgjax.sim.model import build_model

        model = build_model(parse_wl(str(run.meta.get("model_text", "")), str(run.meta.get("model_path", args.run))),
                            terrain=json.loads(run.meta.get("cli_problem_args") or "{}").get("terrain"),
                            pipeline=run.pipeline)
    if family is not None:       # a closed-loop controller: the CPG's genes, then the policy's
        cl = from_genomes(family, model, np.asarray(genome, np.float32)[None])
        cl = jax.tree.map(lambda a: np.asarray(a)[0], cl)
        policy, cpg_genes = PolicyTable(**table_fields(cl, model)), np.asarray(cl.coeffs).reshape(-1)
    if args.ctl and not (harmonics >= 0 and n_dof * ncoef == cpg_genes.size):
        raise ValueError(f"{args.run}: the run does not record n_dof and harmonics: cannot write a .ctl")
    what = "champion" if args.validate else "best"
    print(f"{args.run}: {what} fitness {fit:.6f} at generation {gen}, individual {idx} "
          f"({run.kind}, {run.completed} generations, {run.pipeline} pipeline)")
    scored = _scored_by(run.meta)
    if scored[1]:
        print(f"replay: {fit:.6f} is the robust evaluation's score, the {scored[0]}; a replay (cpgjax simulate) is "
              "one unperturbed episode, so it scores otherwise")
    else:
        print(f"replay: the thesis evaluation scores {scored[0]}, as a replay (cpgjax simulate) does: it scores "
              f"{fit:.6f} again")
    if harmonics >= 0 and n_dof * ncoef == cpg_genes.size:
        coeffs = np.asarray(cpg_genes, np.float64).reshape(n_dof, ncoef)
        names = ["c0"] + [f"{ab}{k}" for k in range(1, harmonics + 1) for ab in ("a", "b")]
        print("dof  " + "  ".join(f"{n:>9}" for n in names))
        for j, row in enumerate(coeffs):
            print(f"{j:>3}  " + "  ".join(f"{v:9.6f}" for v in row))
    else:
        print("genome: " + " ".join(f"{v:.6f}" for v in genome))
    if policy is not None:
        w = np.abs(policy.weights)
        print(f"policy {family.spec}: {w.shape[0]} outputs x {w.shape[1]} inputs, {int((w > 0).sum())} weights not 0, "
              f"largest |w| {w.max():.4f}")
    if args.ctl:
        from cpgjax.io.ctl import write_ctl

        d = os.path.dirname(args.ctl)
        if d:
            os.makedirs(d, exist_ok=True)
        from cpgjax.io.ctl import run_header

        picked = (f"best of generation {gen} ({'robust' if scored[1] else 'thesis'} score {fit:.4g}, {scored[0]})"
                  if not args.validate else
                  f"champion of a validation: {ch.score:.4g} over {v.episodes} fresh perturbed "
                  f"episode{'s' if v.episodes != 1 else ''} (seed {v.seed}), the highest of the run's "
                  f"{len(ch.scores)} best; recorded {fit:.4g} at generation {gen} ({scored[0]})")
        header = run_header(args.run, run.meta, model, family.spec if family else "cpg", picked)
        if args.validate and args.pipeline not in (None, run.pipeline):
            header.pipeline += f", {args.pipeline}"
        write_ctl(args.ctl, coeffs, fit, exact=not args.round, policy=policy, header=header)
        print(f"wrote {args.ctl}")
    return 0


def _scored_by(meta: dict[str, Any]) -> tuple[str, bool]:
    """How a run scored each controller, in words (``mean of 4 perturbed episodes``), and whether robustly."""
    if meta.get("evaluation") == "robust":
        r = int(meta.get("replicas") or 1)
        return f"mean of {r} perturbed episode{'s' if r != 1 else ''}", True
    return "one unperturbed episode", False


def cmd_plot(args: argparse.Namespace) -> int:
    from cpgjax.io.results import writing_note
    from cpgjax.plots import plot_runs

    out = args.out or os.path.splitext(args.runs[0])[0] + ".png"
    o.check_output_file(out)
    for p in args.runs:                 # a run still being written: its complete generations are plotted
        note = writing_note(p) if os.path.isfile(p) else None
        if note:
            print(note, file=sys.stderr)
    plot_runs(args.runs, out, x=args.x, cloud=not args.no_cloud, title=args.title)
    print(f"wrote {out}")
    return 0
