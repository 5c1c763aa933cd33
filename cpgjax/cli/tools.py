"""The ``bench``, ``study-dt`` and ``study-friction`` subcommands of ``cpgjax``: speed, and the simulator's studies."""

from __future__ import annotations

import argparse
import os
from typing import Any

from cpgjax.cli import options as o
from cpgjax.errors import CpgjaxError


def register(subparsers: Any) -> None:
    from cpgjax.experiments.bench import AGAINST_BATCHES, DEFAULT_BATCHES

    model = o.default_model()
    batches = o.list_of(o.count, "expected batch sizes >= 1, e.g. 1,20,256")
    b = subparsers.add_parser("bench")
    o.model_argument(b, optional=True)
    b.add_argument("--batches", type=batches, default=None,
                   help=f"comma-separated batch sizes (default {','.join(map(str, DEFAULT_BATCHES))}; --against: "
                        f"{','.join(map(str, AGAINST_BATCHES))}, the thesis's population beside large batches)")
    b.add_argument("--time", type=o.seconds, default=None, metavar="SECONDS",
                   help="simulated seconds per episode (default: 2 s; with --table-a1 each example's time in the "
                        "thesis; the model file's TimeMax is not used)")
    b.add_argument("--chunk", type=o.count, default=256, help="robots per vectorised chunk (default 256)")
    b.add_argument("--tricks", action="store_true", help="also measure what each speed trick buys")
    b.add_argument("--against", choices=["mjx"],
                   help="also time the same robot in MJX (and MuJoCo C), side by side (default: ours only)")
    b.add_argument("--sweep", action="store_true",
                   help="evaluations/s of one GA run vs the thesis sweep (cpgjax sweep --preset full) in one program")
    b.add_argument("--generations", type=o.count, default=5, help="--sweep: generations per run (default 5)")
    b.add_argument("--seeds", type=o.count, default=5, help="--sweep: seeds per cell (default 5: 80 runs)")
    b.add_argument("--ray", nargs="?", const="", default=None, metavar="ADDRESS",
                   help="--sweep: the sweep in process vs on Ray (local instance, or the cluster at ADDRESS)")
    b.add_argument("--workers", type=o.count, default=2, help="--sweep --ray: Ray workers (default 2)")
    b.add_argument("--table-a1", action="store_true",
                   help="the thesis's Table A.1: slowdown of one robot of each example (car, worm, hexapod, quadruped) "
                        "beside the 1999 figures, and per robot in a batch")
    b.add_argument("--a1-batch", type=o.count, default=256, help="--table-a1: the batch size (default 256)")
    b.add_argument("--a1-examples", type=o.list_of(str, "expected example names, e.g. worm,quadruped"),
                   default=None, help="--table-a1: only these examples (default car,worm,hexapod,quadruped)")
    b.add_argument("--json", action="store_true", help="--table-a1: print one JSON object instead of the table")
    o.pipeline_option(b, "the model file's Pipeline, else springs; our simulator's rows only, MuJoCo's do not "
                         "depend on it")
    b.set_defaults(func=cmd_bench)

    d = subparsers.add_parser("study-dt")
    o.model_argument(d, optional=True)
    d.add_argument("--ctl", default=os.path.join(os.path.dirname(model), "quadruped-trot.ctl"),
                   help="the walking controller (.ctl) run at every step size (default: the hand-written trot)")
    d.add_argument("--dts", type=o.list_of(o.step, "expected time steps in (0, 0.05] s"),
                   default=[1e-4, 2e-4, 3e-4, 5e-4, 7e-4, 1e-3, 1.5e-3],
                   help="comma-separated time steps (default 1e-4,2e-4,3e-4,5e-4,7e-4,1e-3,1.5e-3)")
    o.time_option(d, 10.0)
    d.add_argument("--out", help="write the table as markdown here too")
    o.pipeline_option(d, o.CTL_PIPELINE)
    d.set_defaults(func=cmd_study_dt)

    f = subparsers.add_parser("study-friction")
    o.model_argument(f, optional=True)
    f.add_argument("--ctl", default=os.path.join(os.path.dirname(model), "quadruped-trot.ctl"),
                   help="the controller (.ctl) replayed with its genes jittered (default: the hand-written trot)")
    f.add_argument("--springs", type=_springs, default=[(1e3, 300.0), (1e4, 1e3), (1e5, 300.0), (1e5, 1e3)],
                   help="the friction bristles compared, each spring stiffness K and damping B as K:B, "
                        "comma-separated (default 1e3:300,1e4:1e3,1e5:300,1e5:1e3; "
                        "the simulator's default is 1e3:300)")
    f.add_argument("--runs", nargs="*", default=[], metavar="RUN.h5|SWEEP_DIR",
                   help="evolved runs: their bests are replayed here and in MuJoCo C")
    f.add_argument("--replays", type=o.count, default=64, help="jittered replays of --ctl (default 64)")
    f.add_argument("--jitter", type=float, default=1e-6, help="sd of the gene offsets (default 1e-6)")
    f.add_argument("--random", type=int, default=8, help="random controllers in the Spearman set (default 8)")
    f.add_argument("--perturbed", type=int, default=16,
                   help="--ctl with N(0, 0.1) added, in the Spearman set (default 16)")
    o.time_option(f, 10.0)
    f.add_argument("--out", help="write the table as markdown here too")
    f.add_argument("--json", action="store_true", help="print one JSON object (the rows) instead of the table")
    o.pipeline_option(f, f"{o.CTL_PIPELINE}; our simulator's side only")
    f.set_defaults(func=cmd_study_friction)


def _springs(text: str) -> list[tuple[float, float]]:
    out = []
    for part in text.split(","):
        try:
            k, b = (float(x) for x in part.split(":"))
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected K:B pairs like 1e3:300,1e5:1e3, got {part!r}") from None
        if not (k > 0 and b >= 0):
            raise argparse.ArgumentTypeError(f"a bristle needs K > 0 and B >= 0, got {part!r}")
        out.append((k, b))
    return out


def cmd_bench(args: argparse.Namespace) -> int:
    from cpgjax import _xla
    from cpgjax.experiments import bench

    _xla.cold_compiles()          # the compile columns are XLA's compile, not a read of the persistent cache

    from cpgjax.experiments.bench import AGAINST_BATCHES, DEFAULT_BATCHES

    batches = tuple(args.batches or (AGAINST_BATCHES if args.against else DEFAULT_BATCHES))
    if args.table_a1:
        return _table_a1(args)
    if args.time is None:
        args.time = 2.0
    if args.json:
        raise CpgjaxError("--json is only for --table-a1 (the other tables are for reading)")
    if args.ray is not None and not args.sweep:
        raise ValueError("--ray is for --sweep (cpgjax bench --sweep --ray)")
    if args.sweep and args.ray is not None:
        bench.bench_sweep_ray(args.model, time_s=args.time, generations=args.generations, seeds=args.seeds,
                              workers=args.workers, address=args.ray or None, pipeline=args.pipeline)
    elif args.sweep:
        bench.bench_sweep(args.model, time_s=args.time, generations=args.generations, seeds=args.seeds,
                          pipeline=args.pipeline)
    elif args.against:
        bench.bench_against_mjx(args.model, batches=batches, time_s=args.time, chunk=args.chunk,
                                pipeline=args.pipeline)
    else:
        bench.run_bench(args.model, batches=batches, time_s=args.time, chunk=args.chunk, tricks=args.tricks,
                        pipeline=args.pipeline)
    return 0


def _table_a1(args: argparse.Namespace) -> int:
    import json

    from cpgjax.experiments import bench
    from cpgjax.plots.validation import table_a1

    models_dir = os.path.dirname(os.path.abspath(args.model))
    rows = bench.table_a1(models_dir, batch=args.a1_batch, time_s=args.time, chunk=args.chunk,
                          examples=args.a1_examples, progress=not args.json, pipeline=args.pipeline)
    if args.json:
        print(json.dumps({"machine": bench.machine(), "rows": rows}))
    else:
        print(f"machine: {bench.machine()}; pipeline {', '.join(dict.fromkeys(r['pipeline'] for r in rows))}")
        print(table_a1(rows))
    return 0


def _pipeline(args: argparse.Namespace) -> str | None:
    """--pipeline, else the --ctl header's (a header made for another model, or contradicted, is refused); the
    study's --time is its own."""
    from cpgjax.cli.controllers import header_settings

    rp = header_settings([args.ctl], args, takes=("pipeline",))
    if rp.note and not getattr(args, "json", False):
        print(f"header: {rp.note}", flush=True)
    return rp.pipeline


def cmd_study_dt(args: argparse.Namespace) -> int:
    from cpgjax.experiments.studies import timestep_study

    o.check_output_file(args.out)
    timestep_study(args.model, args.ctl, list(args.dts), time_s=args.time, out=args.out, pipeline=_pipeline(args))
    return 0


def cmd_study_friction(args: argparse.Namespace) -> int:
    import json

    from cpgjax.experiments.studies import friction_study, friction_table

    o.check_output_file(args.out)
    show = None if args.json else (lambda r: print(f"  k {r['k']:g} b {r['b']:g}: trot sd {r['trot_sd']:.4f}, "
                                                   f"ratio {r['ratio_median']:.2f}, rho {r['rho']:+.2f}", flush=True))
    rows = friction_study(args.model, args.ctl, args.springs, runs=args.runs, replays=args.replays,
                          jitter=args.jitter, n_random=args.random, n_perturbed=args.perturbed, time_s=args.time,
                          progress=show, pipeline=_pipeline(args))
    text = friction_table(rows)
    if args.out:
        with open(args.out, "w") as fh:
            fh.write(text + "\n")
    clean = [{k: (None if isinstance(v, float) and v != v else v) for k, v in r.items()} for r in rows]
    print(json.dumps({"rows": clean}) if args.json else text)
    return 0
