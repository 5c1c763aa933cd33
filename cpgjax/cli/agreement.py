"""The ``agreement`` subcommand: where the engines part on evolved gaits (:mod:`cpgjax.crosscheck.agreement`)."""

from __future__ import annotations

import argparse
import json
import os
import sys
from typing import Any

from cpgjax.cli import options as o


def register(subparsers: Any) -> None:
    a = subparsers.add_parser(
        "agreement",
        description="Replay gaits of evolved runs once each, as they are, in our simulator and in MuJoCo C on the "
                    "same terrain, and tabulate per gait and engine: whether it fell, its speed, how deep its feet "
                    "go into the ground, how often a contact pushes sideways (normal more than 25 degrees from "
                    "vertical), how fast the touching feet slip, and which leg lost the ground first before a fall. "
                    "The last line: on how many falls the engines agree, and the Spearman correlation of their "
                    "speeds.  From each run, the best gait of --per-run generations spread over it, so that one run "
                    "gives several speeds (docs/crosscheck.md).")
    a.add_argument("runs", nargs="+", metavar="RUN.h5|SWEEP_DIR",
                   help="run files, or sweep folders (every run in them)")
    a.add_argument("--terrain", type=o.terrain, default="rough:0.02:0.1:1",
                   help="the ground, here and in MuJoCo (the same field exported; default rough:0.02:0.1:1, 2 cm "
                        "of roughness, field 1)")
    a.add_argument("--mujoco-dt", type=o.step, default=0.00025, metavar="SECONDS",
                   help="MuJoCo C's integration step (default 0.00025, where its verdicts on rough ground settle; "
                        "docs/results/closed-loop.md)")
    a.add_argument("--per-run", type=o.count, default=6,
                   help="gaits per run: the best of this many generations spread evenly over it (default 6)")
    a.add_argument("--time", type=o.seconds, default=None, metavar="SECONDS",
                   help="simulated seconds per episode (default: each run's own episode length)")
    o.pipeline_option(a, "each run's, as it recorded; our side only (MuJoCo's model does not depend on it)")
    a.add_argument("--replays", type=o.count0, default=0,
                   help="jittered replays of each gait in each engine (default 0: only as it is); with some, a gait "
                        "falls when it falls in at least half of them")
    a.add_argument("--friction-spring", type=o.positive, nargs=2, metavar=("K", "B"),
                   help="our feet's friction bristle, spring [N/m] and damper [N s/m] (default: the model's "
                        "FrictionSpring, 1e3 300 for models/quadruped.wl); our side only")
    a.add_argument("--ground", type=o.positive, nargs=2, metavar=("A", "B"),
                   help="our ground's stiffness [N/m] and damping [N s/m] (eq. 3.7; default: the model's Ground, "
                        "1e5 1e3 for models/quadruped.wl); our side only")
    a.add_argument("--mujoco-stiffness", type=o.positive, default=None, metavar="SCALE",
                   help="MuJoCo's contact stiffness and damping (its solref) scaled by this (default: as exported, "
                        "1); e.g. 4 sinks MuJoCo's walking feet about as deep as ours (docs/results/walker.md); "
                        "MuJoCo's side only")
    from cpgjax.cli.crosscheck import mujoco_contact_option

    mujoco_contact_option(a)
    a.add_argument("--mujoco-control-dt", type=o.positive, default=None, metavar="SECONDS",
                   help="the closed-loop controller's period in MuJoCo C (default: the model's step, 0.002 for "
                        "models/quadruped.wl, as here; MuJoCo's step reads and acts every step); MuJoCo's side only")
    a.add_argument("--out", default=None, metavar="DIR",
                   help="write agreement.md, agreement.json and agreement.png (speed, slip, landings and how far "
                        "past a joint limit, here against MuJoCo C, one point per gait) here")
    a.add_argument("--json", action="store_true", help="print one JSON object with the summary instead of the table")
    a.set_defaults(func=cmd_agreement)


def cmd_agreement(args: argparse.Namespace) -> int:
    from tqdm.auto import tqdm

    from cpgjax.crosscheck import agreement
    from cpgjax.io.sweepdir import run_files

    for p in args.runs:
        if p.lower().endswith(".ctl"):
            raise ValueError(f"{p}: agreement replays gaits of run files (RUN.h5); for one controller: "
                             f"cpgjax crosscheck MODEL.wl --ctl {p}")
    if args.out:
        o.check_output_dir(args.out)
    files = run_files(args.runs)
    from cpgjax.cli.crosscheck import runs_cone_note

    note = runs_cone_note(files, args.mujoco_cone)
    if note:
        print(note, file=sys.stderr)
    ours = {}
    if args.friction_spring:
        ours |= {"friction_k": float(args.friction_spring[0]), "friction_b": float(args.friction_spring[1])}
    if args.ground:
        ours |= {"ground_A": float(args.ground[0]), "ground_B": float(args.ground[1])}
    ours = ours or None
    from cpgjax.crosscheck.engines import control_period
    from cpgjax.crosscheck.impedance import contact_law
    from cpgjax.crosscheck.limits import joint_limit
    from cpgjax.crosscheck.mjcf import contact_stiffness, friction_cone

    with tqdm(total=len(files) * args.per_run, desc="agreement", unit="gait", disable=args.json) as bar, \
            contact_stiffness(args.mujoco_stiffness), control_period(args.mujoco_control_dt), \
            contact_law(args.mujoco_contact), friction_cone(args.mujoco_cone), joint_limit(args.mujoco_limit):
        gaits = agreement.compare_runs(files, terrain=args.terrain, mujoco_dt=args.mujoco_dt, per_run=args.per_run,
                                       pipeline=args.pipeline, time=args.time, ours=ours, replays=args.replays,
                                       progress=lambda _: bar.update())
    summary = agreement.summary(gaits) | {"terrain": args.terrain, "mujoco_dt": args.mujoco_dt}
    if args.friction_spring:
        summary["friction_spring"] = list(args.friction_spring)
    if args.ground:
        summary["ground"] = list(args.ground)
    if args.mujoco_stiffness is not None:
        summary["mujoco_stiffness"] = args.mujoco_stiffness
    if args.mujoco_contact is not None:
        summary["mujoco_contact"] = args.mujoco_contact
    if args.mujoco_control_dt is not None:
        summary["mujoco_control_dt"] = args.mujoco_control_dt
    if args.mujoco_cone is not None:
        summary["mujoco_cone"] = args.mujoco_cone
    if args.mujoco_limit is not None:
        summary["mujoco_limit"] = args.mujoco_limit
    text = agreement.table(gaits)
    if args.out:
        os.makedirs(args.out, exist_ok=True)
        with open(os.path.join(args.out, "agreement.md"), "w") as f:
            f.write(text + "\n")
        with open(os.path.join(args.out, "agreement.json"), "w") as f:
            json.dump({"summary": summary, "gaits": [g.__dict__ for g in gaits]}, f, indent=1)
        agreement.plot(gaits, os.path.join(args.out, "agreement.png"))
    if args.json:
        print(json.dumps(summary))
    else:
        print(text)
        if args.out:
            print(f"\nwrote {args.out}/agreement.md, agreement.json, agreement.png")
    return 0
