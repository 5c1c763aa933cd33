"""The ``repertoire``, ``adapt`` and ``follow`` subcommands of ``cpgjax`` (docs/repertoire.md).

``repertoire``: MAP-Elites into a run file (:mod:`cpgjax.experiments.repertoire`), ``repertoire-plot``: its
figure (:mod:`cpgjax.plots.repertoire`); ``adapt``: Intelligent
Trial and Error on a damaged robot (:mod:`cpgjax.experiments.adapt`); ``follow``: walk a path by choosing,
every gait cycle, a gait of the repertoire (:mod:`cpgjax.experiments.follow`), or with one closed-loop gait that
reads a turning command set from its own pose (``--ctl``, :mod:`cpgjax.experiments.steer`).  Every default comes from
:class:`~cpgjax.optim.mapelites.MEConfig` and the other configuration dataclasses.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
from typing import Any

from cpgjax.cli import options as o

ME_OPTIONS = ("method", "descriptor", "cells", "bounds", "evaluations", "batch", "init_batches", "sigma",
              "sigma_iso", "sigma_line", "qd_offset", "keep_fallen", "seed", "chunk")
DEFAULT_TIME = 4.0      # s: two cycles of the 0.5 Hz CPG (the thesis's episodes are 10 s; Cully's 5 s)


def cells(text: str) -> tuple[int, ...]:
    """``5`` (every dimension) or ``32x32`` / ``5,5,5,5`` (one per dimension), each in [1, 10000]."""
    parts = text.replace("x", ",").split(",")
    try:
        out = tuple(int(p) for p in parts)
    except ValueError:
        out = ()
    if not out or any(not 1 <= c <= 10_000 for c in out):
        raise argparse.ArgumentTypeError(f"expected bins per dimension: N, or NxN... (each 1..10000), got {text!r}")
    return out


def bounds(text: str) -> tuple[tuple[float, float], ...]:
    """``LO:HI`` (every dimension) or ``LO:HI,LO:HI`` (one per dimension), finite with LO < HI."""
    out = []
    for part in text.split(","):
        lo, sep, hi = part.partition(":")
        try:
            b = (float(lo), float(hi)) if sep else None
        except ValueError:
            b = None
        if b is None or not all(map(lambda v: abs(v) < float("inf"), b)) or not b[0] < b[1]:
            raise argparse.ArgumentTypeError(f"expected LO:HI[,LO:HI...] with LO < HI, got {part!r} in {text!r}")
        out.append(b)
    return tuple(out)


def register(subparsers: Any) -> None:
    from cpgjax.episode.descriptors import DESCRIPTORS
    from cpgjax.optim.ite import SPACES
    from cpgjax.optim.mapelites import METHODS, MEConfig

    d = MEConfig()
    p = subparsers.add_parser(
        "repertoire",
        description="Build a repertoire of gaits by MAP-Elites (quality-diversity; docs/glossary.md): the best "
                    "controller found for each cell of a grid of behaviour descriptors (each leg's duty factor, or "
                    "forward speed x turning rate), computed online in the episode; every evaluation is written to "
                    "an HDF5 run file, from which the archive is rebuilt exactly (--resume continues bit for bit).")
    o.model_argument(p)
    p.add_argument("--descriptor", choices=DESCRIPTORS, default=None,
                   help=f"duty: each leg's duty factor (Cully et al. 2015); speed-turn: forward speed (m/s) x "
                        f"turning rate (rad/s) (default {d.descriptor})")
    p.add_argument("--cells", type=cells, default=None, metavar="N|NxN...",
                   help=f"bins per descriptor dimension (default {d.cells[0]} each)")
    p.add_argument("--bounds", type=bounds, default=None, metavar="LO:HI[,LO:HI...]",
                   help="descriptor range per dimension (default: duty 0:1; speed -0.1:0.3 m/s; turn -0.5:0.5 "
                        "rad/s); values outside go to the edge cells")
    p.add_argument("--method", choices=METHODS, default=None,
                   help=f"map-elites: Gaussian mutation (Mouret & Clune 2015); iso-line: iso+line variation "
                        f"(Vassiliades & Mouret 2018) (default {d.method})")
    p.add_argument("--evaluations", type=o.count, default=None, help=f"evaluation budget: controllers scored in all "
                                                                     f"(default {d.evaluations})")
    p.add_argument("--batch", type=o.count, default=None, help=f"children per generation (default {d.batch})")
    p.add_argument("--init-batches", type=o.count0, default=None,
                   help=f"generations of random genomes first (default {d.init_batches})")
    p.add_argument("--sigma", type=o.nonneg, default=None,
                   help=f"map-elites: mutation std in box widths (default {d.sigma:g})")
    p.add_argument("--sigma-iso", type=o.nonneg, default=None,
                   help=f"iso-line: isotropic std in box widths (default {d.sigma_iso:g})")
    p.add_argument("--sigma-line", type=o.nonneg, default=None,
                   help=f"iso-line: std along the line between two elites (default {d.sigma_line:g})")
    p.add_argument("--qd-offset", type=o.finite, default=None,
                   help=f"the QD-score sums every elite's fitness minus this, a bound below any fitness, so that a "
                        f"fuller repertoire scores more (default {d.qd_offset:g})")
    p.add_argument("--keep-fallen", action="store_true", default=None,
                   help="insert robots that fell too (body past 60 degrees; default: never, a fall is not a gait)")
    o.time_option(p, of=f"{DEFAULT_TIME:g} s, not the model file's")
    o.terrain_option(p)
    o.pipeline_option(p, "the model file's Pipeline, else springs; on --resume the run's")
    p.add_argument("--damage", default=None, metavar="SPEC",
                   help="build the repertoire on a damaged robot (leg=AR, locked=KneeAR, weak=HipPL:0.3; "
                        "docs/repertoire.md)")
    o.seed_option(p, None, shown=d.seed)
    p.add_argument("--chunk", type=o.count, default=None,
                   help=f"generations compiled and run as one piece between writes to the run file; a kill loses at "
                        f"most the piece in flight, and results do not depend on it (default {d.chunk})")
    p.add_argument("--out", default=None, metavar="REP.h5",
                   help="the repertoire's run file, every evaluation in it (default runs/MODEL-repertoire-sSEED.h5)")
    o.run_file_options(p, "repertoire")
    o.quiet_option(p)
    p.set_defaults(func=cmd_repertoire)

    from cpgjax.optim.ite import ITEConfig

    a = ITEConfig()

    p = subparsers.add_parser(
        "adapt",
        description="Bayesian optimisation over a repertoire's elites (a Gaussian process over the descriptor, "
                    "the archive's fitness as its prior mean; Cully et al. 2015) on a damaged robot, which it only "
                    "observes through each trial's fitness.")
    o.model_argument(p, help="robot description (.wl): the repertoire's")
    p.add_argument("--repertoire", required=True, nargs="+", metavar="REP.h5",
                   help="a cpgjax repertoire file; several (one per seed): the study of docs/results/repertoire.md")
    p.add_argument("--damage", required=True, action="append", metavar="SPEC",
                   help="leg=AR | locked=KneeAR | weak=HipPL:0.3, several joined by ',' (none: intact); "
                        "repeat the option for a study over damages")
    p.add_argument("--study", action="store_true",
                   help="measure instead: every elite scored on the damaged robot (the best reachable R), IT&E's "
                        "trials to reach --level x R (stopping rule off), and with --ga-generations the GA from "
                        "scratch's evaluations to the same level")
    p.add_argument("--level", type=o.fraction, default=0.7, help="study: the share of R to reach (default 0.7)")
    p.add_argument("--ga-generations", type=o.count0, default=0,
                   help="study: generations of the GA from scratch on the damaged robot (population 20; 0: none)")
    p.add_argument("--trials", type=o.count, default=None,
                   help=f"the most trials on the damaged robot before giving up (default {a.trials}; study: 50 with "
                        f"the stopping rule off, {a.trials} with it)")
    p.add_argument("--alpha", type=o.fraction, default=None,
                   help=f"stop when the best trial reaches alpha x min(the best prediction + STOP_Z standard "
                        f"deviations, the repertoire's best) (default {a.alpha:g})")
    p.add_argument("--stop-z", type=o.nonneg, default=None, metavar="STOP_Z",
                   help=f"the stopping rule's confidence, in the GP's standard deviations (default {a.stop_z:g}; "
                        "0: Cully et al.'s rule, alpha x the best prediction)")
    p.add_argument("--kappa", type=o.nonneg, default=None,
                   help=f"how much the next trial favours elites the model is unsure of over those it predicts "
                        f"good (the UCB exploration weight; default {a.kappa:g})")
    p.add_argument("--rho", type=o.positive, default=None,
                   help=f"Matern-5/2 length scale, in descriptor units (default {a.rho:g})")
    p.add_argument("--noise", type=o.positive, default=None,
                   help=f"the Gaussian process's observation noise variance: how much a trial's fitness may differ "
                        f"from the truth (default {a.noise:g})")
    p.add_argument("--offset", action=argparse.BooleanOptionalAction, default=None,
                   help="the GP's prior mean is the repertoire's fitness plus an unknown constant, learnt from the "
                        "trials (a damage that lowers every gait is one shift, not a penalty on the tried "
                        "elites' neighbours); --no-offset: Cully et al.'s prior mean, the repertoire's fitness "
                        f"(default {'--offset' if a.offset else '--no-offset'})")
    p.add_argument("--space", choices=SPACES, default="descriptor",
                   help="the GP's space: descriptor (Cully et al.: the repertoire's descriptor, scaled to the grid), "
                        "genome (the elites' CPG coefficients, each scaled by its sd over the elites) or both (the "
                        "two, standardised, weighing the same); genome and both fit the length scale and noise by "
                        "marginal likelihood to the repertoire's intact fitness unless --rho or --noise is given "
                        "(default descriptor)")
    p.add_argument("--out", default=None, metavar="TRIALS.json", help="write the trials as JSON")
    p.set_defaults(func=cmd_adapt)

    p = subparsers.add_parser(
        "follow",
        description="--ctl: the closed-loop gait alone walks each --path in one episode, the turning rate it reads "
                    "set every step from its own pose (the heading error to the next waypoint times --gain, "
                    "clipped to --limit; docs/closed-loop.md, Steering). --repertoire: every gait cycle the robot "
                    "simulates the --lookahead gaits of the repertoire (a speed-turn one) whose turning rate best "
                    "reduces the heading error to the next waypoint, from the state it is in, for one cycle, and "
                    "walks the one that leaves the least path to walk without its body tilting past --safe-tilt "
                    "(docs/repertoire.md, Steering).")
    o.model_argument(p, help="robot description (.wl): the repertoire's, or the controllers'")
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument("--repertoire", metavar="REP.h5",
                     help="a repertoire file built with --descriptor speed-turn: the gaits to choose from")
    src.add_argument("--ctl", action="append", metavar="CTL",
                     help="a closed-loop controller that reads the command (.ctl); repeat for several, each walks "
                          "every --path")
    p.add_argument("--path", required=True, action="append", metavar="SPEC",
                   help="square:SIDE | circle:RADIUS | figure8:RADIUS | line:LENGTH | points:X,Y;X,Y;... (m); "
                        "with --ctl repeat for several")
    p.add_argument("--cycles", type=o.count, default=None,
                   help="--repertoire: the most gait cycles walked (default: 40)")
    p.add_argument("--lookahead", type=o.int_in(0, 4096), default=None, metavar="K",
                   help="candidate gaits simulated ahead every cycle, in one batch (default: 64); 0: no "
                        "look-ahead, the gait whose turning rate is nearest the wanted one")
    p.add_argument("--safe-tilt", type=o.float_in(0.0, math.pi, lo_open=True, what="an angle in (0, pi] rad"),
                   default=None, metavar="RAD",
                   help="a candidate whose body tilts more during the cycle is not taken (default: 0.8 rad)")
    from cpgjax.experiments.steer import GAIN, LIMIT, TIME

    p.add_argument("--time", type=o.float_in(0.0, 3600.0, lo_open=True, what="seconds in (0, 3600]"), default=None,
                   metavar="SECONDS", help=f"--ctl: the longest walk (default {TIME:g} s)")
    p.add_argument("--gain", type=o.float_in(0.0, 100.0, lo_open=True, what="a gain in (0, 100] 1/s"), default=None,
                   help=f"--ctl: commanded turning rate per rad of heading error (default {GAIN:g} 1/s)")
    p.add_argument("--limit", type=o.float_in(0.0, 10.0, lo_open=True, what="a rate in (0, 10] rad/s"),
                   default=None, metavar="RAD/S",
                   help=f"--ctl: the command's range, that of the evolution's --perturb command=R (default: the "
                        f"--ctl header's '# command:', else {LIMIT:g} rad/s)")
    o.pipeline_option(p, f"{o.CTL_PIPELINE}; --ctl only")
    p.add_argument("--engine", choices=("ours", "mujoco", "both"), default=None,
                   help="--ctl: walk in our simulator (default), in MuJoCo C (the robot: the policy reads MuJoCo's "
                        "sensors, the command is set every control period (the model's step) from MuJoCo's own "
                        "pose by the same law), or in both, each walk's rows side by side")
    p.add_argument("--mujoco-dt", type=o.step, default=None, metavar="SECONDS",
                   help="--engine mujoco|both: MuJoCo C's integration step (default: the export's, 2 ms; on rough "
                        "ground use 0.00025, as for transfer: docs/crosscheck.md)")
    from cpgjax.cli.crosscheck import mujoco_ground_option

    mujoco_ground_option(p)
    p.add_argument("--video", default=None, metavar="OUT.mp4",
                   help="render the walk to this video file (.mp4 or .gif; --ctl: one controller, one path)")
    p.add_argument("--out", default=None, metavar="WALK.json", help="write the walk (positions, gaits) as JSON")
    p.add_argument("--plot", default=None, metavar="WALKS.png",
                   help="--ctl: draw every walk, a panel per controller and path, each engine's walk in it")
    p.set_defaults(func=cmd_follow)

    p = subparsers.add_parser("repertoire-plot")
    p.add_argument("repertoire", metavar="REP.h5", help="a repertoire file written by cpgjax repertoire")
    p.add_argument("--out", default=None, metavar="FIG.png", help="the figure file written (default: REP's name with "
                                                                  ".png)")
    p.set_defaults(func=cmd_plot)


def _stored(path: str | None, resume: bool) -> tuple[dict, dict]:
    if not (resume and path and os.path.exists(path)):
        return {}, {}
    from cpgjax.io.results import read_attrs

    a = read_attrs(path)
    meta = json.loads(a.get("meta") or "{}")
    return json.loads(a["config"]), json.loads(meta.get("cli_problem_args", "{}") or "{}")


def cmd_repertoire(args: argparse.Namespace) -> int:
    from cpgjax.cli.evolve import interrupted
    from cpgjax.experiments.runner import deferred_sigint

    with deferred_sigint():
        from cpgjax.experiments.repertoire import run_repertoire
        from cpgjax.optim.behaviour import behaviour_problem
        from cpgjax.optim.mapelites import MEConfig

        seed = args.seed if args.seed is not None else MEConfig().seed
        out = args.out or os.path.join(
            "runs", f"{os.path.splitext(os.path.basename(args.model))[0]}-repertoire-s{seed}.h5")
        o.check_output_file(out)
        stored, cli = _stored(out, args.resume)
        kw = {}
        for n in ME_OPTIONS:
            v = getattr(args, n, None)
            if v is None and n in stored:
                v = stored[n]
            if v is not None:
                kw[n] = tuple(tuple(b) for b in v) if n == "bounds" else tuple(v) if n == "cells" else v
        cfg = MEConfig(**kw)
        pick = lambda n, default=None: getattr(args, n) if getattr(args, n) is not None else cli.get(n, default)  # noqa: E731
        problem = behaviour_problem(args.model, descriptor=cfg.descriptor, time=pick("time", DEFAULT_TIME),
                                    terrain=pick("terrain"), pipeline=pick("pipeline"), damage=pick("damage"))
        try:
            s = run_repertoire(problem, cfg, out, resume=args.resume, overwrite=args.overwrite,
                               progress=not args.quiet, allow_other_machine=args.allow_other_machine)
        except KeyboardInterrupt:
            raise interrupted(args, out) from None
    print(f"wrote {out}: {s['completed']} generations x {cfg.batch} evaluations; {s.get('filled', 0)} of "
          f"{s['cells']} cells filled ({s.get('coverage', 0):.1%}), QD-score {s.get('qd_score', 0):.4g}, best fitness "
          f"{s.get('best', float('nan')):.4f}; {s['evals_per_second']:.1f} evaluations/s "
          f"(compile {s['compile_time']:.1f} s)")
    return 0


def cmd_adapt(args: argparse.Namespace) -> int:
    import dataclasses

    from cpgjax.experiments.adapt import ADAPT_DEFAULTS, adapt

    keys = ("alpha", "kappa", "rho", "noise", "stop_z", "offset") + (() if args.study else ("trials",))
    cfg = dataclasses.replace(ADAPT_DEFAULTS, **{k: getattr(args, k) for k in keys if getattr(args, k) is not None})
    if args.out:
        o.check_output_file(args.out)
    if args.study:
        return _study(args, cfg)
    if len(args.repertoire) > 1 or len(args.damage) > 1:
        raise ValueError("several --repertoire or --damage: add --study (one adaptation takes one of each)")
    r = adapt(args.model, args.repertoire[0], args.damage[0], cfg, space=args.space,
              fit=args.rho is None and args.noise is None)
    from cpgjax.optim.mapelites import describe

    names = r["descriptor_names"]
    for i, t in enumerate(r["trials"]):
        print(f"trial {i + 1:>2}: cell {t['cell']:>6} ({describe(names, t['descriptor'])})  predicted "
              f"{t['predicted']:+.4f}  observed {t['fitness']:+.4f}")
    print(f"{r['damage']}: best {r['best_fitness']:+.4f} (cell {r['best_cell']}: "
          f"{describe(names, r['best_descriptor'])}) after {len(r['trials'])} trials; "
          f"the repertoire's best on the intact robot {r['prior_best']:+.4f}; stopped: {r['stop']}; the GP over the "
          f"{r['space']} (rho {r['config']['rho']:g}, noise {r['config']['noise']:g})")
    if args.out:
        with open(args.out, "w") as f:
            json.dump(r, f, indent=1)
    return 0


def _study(args: argparse.Namespace, cfg) -> int:
    from cpgjax.experiments.adapt import study

    r = study(args.model, args.repertoire, args.damage, level=args.level, trials=args.trials or 50,
              ga_generations=args.ga_generations, progress=True, cfg=cfg, space=args.space,
              fit=args.rho is None and args.noise is None)
    fmt = lambda v: "-" if v is None else str(v)  # noqa: E731
    print(f"{'damage':<22} {'seed':>4} {'elites':>6} {'R':>8} {'IT&E trials':>11} {'GA evals':>8}   "
          "IT&E's own stop: trials, best/R")
    for row in r["rows"]:
        print(f"{row['damage']:<22} {row['seed']:>4} {row['elites']:>6} {row['R']:>8.4f} {fmt(row['ite_trials']):>11} "
              f"{fmt(row.get('ga_evaluations')):>8}   {row['ite_stop_trial']:>2}, "
              f"{row['ite_stop_share']:.2f}")
    count = lambda v: "not reached" if v is None else f"{v:g}"  # noqa: E731
    for m in r["medians"]:
        print(f"{m['damage']}: median IT&E trials {count(m['ite_trials'])}"
              + (f", median GA evaluations {count(m['ga_evaluations'])}" if "ga_evaluations" in m else "")
              + f"; IT&E's own stop: median {m['ite_stop_trial']:g} trials, median best/R {m['ite_stop_share']:.2f}")
    if args.out:
        with open(args.out, "w") as f:
            json.dump(r, f, indent=1)
    return 0


def cmd_plot(args: argparse.Namespace) -> int:
    from cpgjax.experiments.repertoire import read_repertoire
    from cpgjax.plots.repertoire import figure

    out = args.out or os.path.splitext(args.repertoire)[0] + ".png"
    o.check_output_file(out)
    rep = read_repertoire(args.repertoire)
    figure(rep, out)
    print(f"wrote {out}: {int(rep.filled.sum())} of {rep.grid.n_cells} cells after {int(rep.evaluations[-1])} "
          f"evaluations, QD-score {rep.qd_score[-1]:.4g}")
    return 0


def cmd_follow(args: argparse.Namespace) -> int:
    from cpgjax.experiments.follow import follow

    for f, flag in ((args.out, "--out"), (args.video, "--video"), (args.plot, "--plot")):
        o.check_output_file(f, flag)
    if args.plot and not args.ctl:
        raise ValueError("--plot: with --ctl only (a repertoire's walk: --video)")
    if args.ctl:
        return _follow_ctl(args)
    ctl_only = [f"--{n}" for n in ("time", "gain", "limit", "pipeline") if getattr(args, n) is not None]
    if ctl_only:
        raise ValueError(f"{', '.join(ctl_only)}: with --ctl only (a repertoire's gaits run for whole cycles, on its "
                         "pipeline)")
    from cpgjax.cli.crosscheck import MUJOCO_OPTIONS, mujoco_options_given

    mj_only = mujoco_options_given(args, ("engine", *MUJOCO_OPTIONS))
    if mj_only:
        raise ValueError(f"{', '.join(mj_only)}: with --ctl only (a repertoire's walk is its look-ahead's "
                         "simulation, in our simulator)")
    if len(args.path) > 1:
        raise ValueError("--path: a repertoire walks one path at a time")
    args.path = args.path[0]
    from cpgjax.experiments import follow as fw

    r = follow(args.model, args.repertoire, args.path, cycles=args.cycles, video=args.video,
               lookahead=fw.LOOKAHEAD if args.lookahead is None else args.lookahead,
               safe_tilt=fw.SAFE_TILT if args.safe_tilt is None else args.safe_tilt)
    state = "finished" if r["finished"] else f"did not finish ({r['fell']})" if r["fell"] else "did not finish"
    print(f"{args.path}: {state} in {r['time']:.1f} s "
          f"({r['cycles']} gait cycles), mean distance from the path {r['mean_error']:.3f} m, "
          f"waypoints {r['reached']} of {r['waypoints']}")
    if args.out:
        with open(args.out, "w") as f:
            json.dump(r, f, indent=1)
    return 0


def _follow_ctl(args: argparse.Namespace) -> int:
    from cpgjax.experiments import steer

    for n in ("cycles", "lookahead", "safe_tilt"):
        if getattr(args, n) is not None:
            raise ValueError(f"--{n.replace('_', '-')}: with --repertoire only")
    engine = args.engine or "ours"
    from cpgjax.cli.crosscheck import mujoco_options_given

    mj_only = mujoco_options_given(args)
    if mj_only and engine == "ours":
        raise ValueError(f"{mj_only[0]}: with --engine mujoco or both (MuJoCo C's)")
    if args.video and engine == "mujoco":
        raise ValueError("--video draws our simulator's walk: with --engine ours or both")
    from cpgjax.cli.controllers import header_settings

    rp = header_settings(args.ctl, args, takes=("pipeline", "command"))   # --time is the walk's, not an episode's
    if rp.note:
        print(f"header: {rp.note}", flush=True)
    if engine != "ours":
        from cpgjax.cli.crosscheck import rough_step_note
        from cpgjax.crosscheck.mjcf import cone_note
        from cpgjax.io.wl import load_model

        m = load_model(args.model)
        for note in (rough_step_note([m.terrain.spec], args.mujoco_dt),
                     cone_note(m.mu_static, args.mujoco_cone or "pyramidal")):
            if note:
                print(note, file=sys.stderr)
    from cpgjax.cli.crosscheck import mujoco_ground

    with mujoco_ground(args):
        r = steer.walks(args.model, args.ctl, args.path, time=args.time or steer.TIME, gain=args.gain or steer.GAIN,
                        limit=rp.command or steer.LIMIT, pipeline=rp.pipeline, video=args.video, engine=engine,
                        mujoco_dt=args.mujoco_dt)
    names = {"ours": " [ours]:     ", "mujoco": " [MuJoCo C]: "}     # the two engines' rows aligned
    for w in r:
        state = ("finished" if w["finished"] else f"fell at {w['fell']:.1f} s" if w["fell"] is not None
                 else "did not finish")
        label = names[w["engine"]] if "engine" in w else ": "
        print(f"{w['ctl']} {w['path']}{label}{state}" + (f" in {w['time']:.1f} s" if w["finished"] else "")
              + f", mean distance from the path {w['mean_error']:.3f} m (largest {w['max_error']:.3f} m), "
                f"waypoints {w['reached']} of {w['waypoints']}, largest tilt {w['tilt_max']:.2f} rad")
    for e in ("ours", "mujoco") if engine == "both" else (engine,):
        ws = [w for w in r if w.get("engine", "ours") == e]
        where = "" if engine == "ours" else " in our simulator" if e == "ours" else " in MuJoCo C"
        print(f"{sum(w['finished'] for w in ws)} of {len(ws)} walks finished without a fall{where}")
    if args.out:
        with open(args.out, "w") as f:
            json.dump(r, f, indent=1)
    if args.plot:
        from cpgjax.plots.steering import walks_figure

        walks_figure(r).savefig(args.plot, dpi=110)
        print(f"wrote {args.plot}")
    return 0
