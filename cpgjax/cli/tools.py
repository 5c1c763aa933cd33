"""The ``bench`` and ``study-dt`` subcommands of ``cpgjax``: speed, and the time-step study."""

from __future__ import annotations

import argparse
import os
from typing import Any

from cpgjax.cli import options as o
from cpgjax.errors import CpgjaxError


def register(subparsers: Any) -> None:
    from cpgjax.experiments.bench import DEFAULT_BATCHES

    model = o.default_model()
    batches = o.list_of(o.count, "expected batch sizes >= 1, e.g. 1,20,256")
    b = subparsers.add_parser("bench", help="robot-steps/s and simulated robot-s per wall s at several batch sizes")
    b.add_argument("--model", default=model, help="robot description (default: the quadruped)")
    b.add_argument("--batches", type=batches, default=list(DEFAULT_BATCHES),
                   help=f"comma-separated batch sizes (default {','.join(map(str, DEFAULT_BATCHES))})")
    b.add_argument("--time", type=o.seconds, default=None,
                   help="simulated seconds per episode (default 2; --table-a1: each example's time in the thesis)")
    b.add_argument("--chunk", type=o.count, default=256, help="robots per vectorised chunk (default 256)")
    b.add_argument("--tricks", action="store_true", help="also measure what each speed trick buys")
    b.add_argument("--against", choices=["mjx"], help="the same robot in MJX (and MuJoCo C) side by side")
    b.add_argument("--sweep", action="store_true",
                   help="evaluations/s of one GA run vs the thesis sweep (cpgjax sweep --preset full) in one program")
    b.add_argument("--generations", type=o.count, default=5, help="--sweep: generations per run (default 5)")
    b.add_argument("--seeds", type=o.count, default=5, help="--sweep: seeds per cell (default 5: 80 runs)")
    b.add_argument("--table-a1", action="store_true",
                   help="the thesis's Table A.1: slowdown of one robot of each example (car, worm, hexapod, quadruped) "
                        "beside the 1999 figures, and per robot in a batch")
    b.add_argument("--a1-batch", type=o.count, default=256, help="--table-a1: the batch size (default 256)")
    b.add_argument("--a1-examples", type=o.list_of(str, "expected example names, e.g. worm,quadruped"),
                   default=None, help="--table-a1: only these examples (default car,worm,hexapod,quadruped)")
    b.add_argument("--json", action="store_true", help="--table-a1: print one JSON object instead of the table")
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
    if args.table_a1:
        return _table_a1(args)
    if args.time is None:
        args.time = 2.0
    if args.json:
        raise CpgjaxError("--json is only for --table-a1 (the other tables are for reading)")
    if args.sweep:
        bench.bench_sweep(args.model, time_s=args.time, generations=args.generations, seeds=args.seeds)
    elif args.against:
        bench.bench_against_mjx(args.model, batches=batches, time_s=args.time, chunk=args.chunk)
    else:
        bench.run_bench(args.model, batches=batches, time_s=args.time, chunk=args.chunk, tricks=args.tricks)
    return 0


def _table_a1(args: argparse.Namespace) -> int:
    import json

    from cpgjax.experiments import bench
    from cpgjax.plots.validation import table_a1

    models_dir = os.path.dirname(os.path.abspath(args.model))
    rows = bench.table_a1(models_dir, batch=args.a1_batch, time_s=args.time, chunk=args.chunk,
                          examples=args.a1_examples, progress=not args.json)
    if args.json:
        print(json.dumps({"machine": bench.machine(), "rows": rows}))
    else:
        print(f"machine: {bench.machine()}")
        print(table_a1(rows))
    return 0


def cmd_study_dt(args: argparse.Namespace) -> int:
    from cpgjax.experiments.studies import timestep_study

    o.check_output_file(args.out)
    timestep_study(args.model, args.ctl, list(args.dts), time_s=args.time, out=args.out)
    return 0
