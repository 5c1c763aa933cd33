"""The ``servo`` subcommand of ``cpgjax``: the servo's frequency response and cut-off (thesis Figs. 6.1-6.2)."""

from __future__ import annotations

import argparse
import os
from typing import Any

from cpgjax.cli import options as o


def register(subparsers: Any) -> None:
    from cpgjax.experiments.servo import ServoConfig

    d = ServoConfig()
    freq = o.list_of(o.positive, "expected frequencies in Hz > 0, e.g. 0.5,1,2,4")
    amp = o.list_of(o.positive, "expected amplitudes in rad > 0, e.g. 0.1,0.2,0.4")
    p = subparsers.add_parser(
        "servo",
        description="One joint of the model on a rig (its first body welded to the world, the leg attached as in "
                    "the robot) follows sinusoids of every frequency x amplitude in one batch, in the penalty "
                    "simulator and in MuJoCo C; the relative mean absolute error vs frequency is fitted with the "
                    "thesis's sigmoid 1/(1+exp(-a(f-b))) and the cut-off is its steepest point b (thesis: 0.74 Hz).")
    o.model_argument(p, optional=True)
    p.add_argument("--joint", default=d.joint, help=f"the controlled joint to drive (default {d.joint})")
    p.add_argument("--freqs", type=freq, default=list(d.freqs),
                   help=f"drive frequencies, Hz (default {','.join(f'{f:g}' for f in d.freqs)})")
    p.add_argument("--amps", type=amp, default=list(d.amps),
                   help=f"drive amplitudes, rad (default {','.join(f'{a:g}' for a in d.amps)})")
    p.add_argument("--settle", type=o.nonneg, default=d.settle,
                   help=f"seconds before the error is averaged (default {d.settle:g})")
    p.add_argument("--periods", type=o.count, default=d.periods,
                   help=f"whole periods of the lowest frequency averaged (default {d.periods})")
    p.add_argument("--gravity", type=o.nonneg, default=None, help="override the file's gravity, m/s^2")
    p.add_argument("--tau-max", type=o.positive, default=None, help="override the servo's torque limit, N m")
    p.add_argument("--no-mujoco", action="store_true", help="skip the MuJoCo C run")
    o.pipeline_option(p, "the model file's Pipeline, else springs; the penalty simulator's side only")
    p.add_argument("--out", default=None, metavar="DIR",
                   help="write servo.json, servo.md, fig-6-1.png and fig-6-2.png here")
    p.add_argument("--json", action="store_true", help="print one JSON object with the summary instead of the table")
    p.set_defaults(func=cmd_servo)


def cmd_servo(args: argparse.Namespace) -> int:
    import json

    from cpgjax.experiments.servo import ServoConfig, run_servo, table

    o.check_output_dir(args.out)
    cfg = ServoConfig(joint=args.joint, freqs=tuple(args.freqs), amps=tuple(args.amps), settle=args.settle,
                      periods=args.periods, mujoco=not args.no_mujoco, gravity=args.gravity, tau_max=args.tau_max,
                      pipeline=args.pipeline)
    rec = 0.5 if 0.5 in cfg.freqs else min(cfg.freqs)
    out = run_servo(args.model, cfg, record_freq=rec if args.out else None, progress=not args.json)
    if args.out:
        from cpgjax.plots.validation import fig_6_1, fig_6_2

        os.makedirs(args.out, exist_ok=True)
        with open(os.path.join(args.out, "servo.json"), "w") as f:
            json.dump(out, f, indent=1, default=float)
        with open(os.path.join(args.out, "servo.md"), "w") as f:
            f.write(table(out) + "\n")
        fig_6_2(out).savefig(os.path.join(args.out, "fig-6-2.png"), dpi=90)
        fig_6_1(out).savefig(os.path.join(args.out, "fig-6-1.png"), dpi=90)
    if args.json:
        print(json.dumps(out["summary"]))
    else:
        print(table(out))
        if args.out:
            print(f"\nwrote {args.out}/servo.json, servo.md, fig-6-1.png, fig-6-2.png")
    return 0
