"""The ``bench`` and ``study-dt`` subcommands of ``cpgjax``: speed, and the time-step study."""

from __future__ import annotations

import argparse
import os
from typing import Any

from cpgjax.cli import options as o


def register(subparsers: Any) -> None:
    from cpgjax.experiments.bench import DEFAULT_BATCHES

    model = o.default_model()
    batches = o.list_of(o.count, "expected batch sizes >= 1, e.g. 1,20,256")
    b = subparsers.add_parser("bench", help="robot-steps/s and simulated robot-s per wall s at several batch sizes")
    b.add_argument("--model", default=model, help="robot description (default: the quadruped)")
    b.add_argument("--batches", type=batches, default=list(DEFAULT_BATCHES),
                   help=f"comma-separated batch sizes (default {','.join(map(str, DEFAULT_BATCHES))})")
    b.add_argument("--time", type=o.seconds, default=2.0, help="simulated seconds per episode (default 2)")
    b.add_argument("--chunk", type=o.count, default=256, help="robots per vectorised chunk (default 256)")
    b.add_argument("--tricks", action="store_true", help="also measure what each speed trick buys")
    b.add_argument("--against", choices=["mjx"], help="the same robot in MJX (and MuJoCo C) side by side")
    b.add_argument("--sweep", action="store_true",
                   help="evaluations/s of one GA run vs the thesis sweep (cpgjax sweep --preset full) in one program")
    b.add_argument("--generations", type=o.count, default=5, help="--sweep: generations per run (default 5)")
    b.add_argument("--seeds", type=o.count, default=5, help="--sweep: seeds per cell (default 5: 80 runs)")
    b.add_argument("--ray", nargs="?", const="", default=None, metavar="ADDRESS",
                   help="--sweep: the sweep in process vs on Ray (local instance, or the cluster at ADDRESS)")
    b.add_argument("--workers", type=o.count, default=2, help="--sweep --ray: Ray workers (default 2)")
    b.set_defaults(func=cmd_bench)

    d = subparsers.add_parser("study-dt", help="the time-step stability study (docs/simulator.md)")
    d.add_argument("--model", default=model, help="robot description (default: the quadruped)")
    d.add_argument("--ctl", default=os.path.join(os.path.dirname(model), "quadruped-trot.ctl"),
                   help="the walking controller (default: the hand-written trot)")
    d.add_argument("--dts", type=o.list_of(o.step, "expected time steps in (0, 0.05] s"),
                   default=[1e-4, 2e-4, 3e-4, 5e-4, 7e-4, 1e-3, 1.5e-3],
                   help="comma-separated time steps (default 1e-4,2e-4,3e-4,5e-4,7e-4,1e-3,1.5e-3)")
    d.add_argument("--time", type=o.seconds, default=10.0, help="simulated seconds per episode (default 10)")
    d.add_argument("--out", help="write the table as markdown here too")
    d.set_defaults(func=cmd_study_dt)


def cmd_bench(args: argparse.Namespace) -> int:
    from cpgjax.experiments import bench

    batches = tuple(args.batches)
    if args.ray is not None and not args.sweep:
        raise ValueError("--ray is for --sweep (cpgjax bench --sweep --ray)")
    if args.sweep and args.ray is not None:
        bench.bench_sweep_ray(args.model, time_s=args.time, generations=args.generations, seeds=args.seeds,
                              workers=args.workers, address=args.ray or None)
    elif args.sweep:
        bench.bench_sweep(args.model, time_s=args.time, generations=args.generations, seeds=args.seeds)
    elif args.against:
        bench.bench_against_mjx(args.model, batches=batches, time_s=args.time, chunk=args.chunk)
    else:
        bench.run_bench(args.model, batches=batches, time_s=args.time, chunk=args.chunk, tricks=args.tricks)
    return 0


def cmd_study_dt(args: argparse.Namespace) -> int:
    from cpgjax.experiments.studies import timestep_study

    o.check_output_file(args.out)
    timestep_study(args.model, args.ctl, list(args.dts), time_s=args.time, out=args.out)
    return 0
