"""The `cpgjax` command line: simulate, bench, study-dt, and the commands of the other modules."""

from __future__ import annotations

import argparse
import os
import sys

import numpy as np


def _load_controller(args, model):
    from cpgjax.io.ctl import read_ctl

    if not args.ctl:
        return np.zeros((model.n_ctrl, model.n_coeff)), "-"
    ctl = read_ctl(args.ctl, n_dof=model.n_ctrl, harmonics=model.harmonics)
    return np.asarray(ctl.coeffs), args.ctl


def cmd_simulate(args) -> int:
    from cpgjax.episode.batch import simulate
    from cpgjax.io.logs import pose_rows, write_log
    from cpgjax.io.wl import load_model

    model = load_model(args.model, dt=args.dt, terrain=args.terrain)
    if args.gravity is not None:
        model = model.replace(gravity=args.gravity)
    coeffs, ctl_name = _load_controller(args, model)
    T = model.time_max if args.time is None else args.time
    r = simulate(model, coeffs, time=T, delta=args.delta, record=bool(args.log))
    body = model.body_names[model.track]
    print(f"model     {args.model}  ({model.nb} bodies, {model.n_ctrl} controlled DOFs, dt {model.dt:g} s, "
          f"terrain {model.terrain.spec})")
    print(f"control   {ctl_name}")
    print(f"time      {T:g} s")
    print(f"distance  {float(r['distance']):+.4f} m   (body {body}, forward = +y)")
    print(f"speed     {float(r['speed']):+.4f} m/s")
    print(f"tilt      {np.degrees(float(r['tilt'])):.2f} deg (mean angle of the body normal from vertical)")
    print(f"fitness   {float(r['fitness']):+.6f}   (eq. 4.6, delta {args.delta:g})")
    print(f"fallen    {'yes' if r['fallen'] else 'no'}")
    print(f"diverged  {'yes' if r['diverged'] else 'no'}")
    print(f"pivots    max stretch {1000 * float(r['pivot_err']):.3f} mm")
    if args.log:
        desc = model.description
        logs = desc.logs if desc and desc.logs else []
        if not logs:
            from cpgjax.sim.description import LogDef

            logs = [LogDef(body, f"{body.lower()}.log", 0)]
        for lg in logs:
            i = model.body_index(lg.body)
            kind = "compound" if desc and lg.body in desc.compounds else "object"
            path = os.path.join(args.log, os.path.basename(lg.file))
            write_log(path, kind, lg.body, os.path.basename(args.model), os.path.basename(ctl_name),
                      pose_rows(r["traj"], i))
            print(f"log       {path}")
    return 1 if r["diverged"] else 0


def cmd_bench(args) -> int:
    from cpgjax.experiments.bench import run_bench

    batches = tuple(int(b) for b in args.batches.split(","))
    if args.sweep:
        from cpgjax.experiments.bench import bench_sweep

        bench_sweep(args.model, time_s=args.time, generations=args.generations, seeds=args.seeds)
        return 0
    if args.against:
        from cpgjax.experiments.bench import bench_against_mjx

        bench_against_mjx(args.model, batches=batches, time_s=args.time, chunk=args.chunk)
        return 0
    run_bench(args.model, batches=batches, time_s=args.time, chunk=args.chunk, tricks=args.tricks)
    return 0


def cmd_study_dt(args) -> int:
    from cpgjax.experiments.studies import timestep_study

    timestep_study(args.model, args.ctl, [float(x) for x in args.dts.split(",")], time_s=args.time,
                   out=args.out)
    return 0


def cmd_robustness(args) -> int:
    """Replay a controller with every gene moved by tiny random amounts: how chaotic is its score?"""
    from cpgjax.episode.batch import simulate
    from cpgjax.io.wl import load_model

    model = load_model(args.model, terrain=args.terrain)
    coeffs, name = _load_controller(args, model)
    rng = np.random.default_rng(args.seed)
    rows = []
    for eps in [float(e) for e in args.jitter.split(",")]:
        C = coeffs[None] + rng.normal(0.0, eps, (args.n,) + coeffs.shape)
        C[0] = coeffs
        r = simulate(model, C, time=args.time, delta=args.delta)
        f = r["fitness"]
        rows.append((eps, f[0], f.mean(), f.std(), f.min(), f.max(), int(r["fallen"].sum()), int(r["diverged"].sum())))
    print(f"controller {name}: {args.n} replays per jitter (replay 0 is the controller itself)")
    print(f"{'jitter':>8}{'itself':>10}{'mean':>10}{'sd':>9}{'min':>10}{'max':>10}{'fell':>6}{'diverged':>10}")
    for e, f0, m, sd, lo, hi, fell, div in rows:
        print(f"{e:>8.0e}{f0:>10.4f}{m:>10.4f}{sd:>9.4f}{lo:>10.4f}{hi:>10.4f}{fell:>6}{div:>10}")
    return 0


def cmd_export(args) -> int:
    from cpgjax.crosscheck.mjcf import load, to_mjcf
    from cpgjax.io.wl import load_model

    model = load_model(args.model, terrain=args.terrain)
    text = to_mjcf(model)
    out = args.out or os.path.splitext(args.model)[0] + ".xml"
    with open(out, "w") as f:
        f.write(text)
    mj = load(model)  # proves that MuJoCo loads it
    print(f"wrote {out}: {mj.nbody - 1} bodies, {mj.njnt} joints, {mj.nu} actuators, "
          f"total mass {mj.body_mass.sum():.3f} kg")
    return 0


def cmd_crosscheck(args) -> int:
    from cpgjax.crosscheck.compare import controllers, run_crosscheck, table
    from cpgjax.io.wl import load_model

    model = load_model(args.model, terrain=args.terrain)
    here = os.path.dirname(os.path.abspath(args.model))
    trot = os.path.join(here, "quadruped-trot.ctl")
    base = args.perturb_ctl or (trot if os.path.exists(trot) and model.n_ctrl == 8 else None)
    coeffs, labels = controllers(model, ctl_files=args.ctl or (), run_files=args.controllers or (),
                                 n_random=args.random, n_perturbed=args.perturbed if base else 0,
                                 base_ctl=base, seed=args.seed)
    if len(coeffs) == 0:
        raise ValueError("no controllers: give --ctl, --controllers RUN.h5, --random N or --perturbed N")
    if args.n:
        coeffs, labels = coeffs[: args.n], labels[: args.n]
    T = args.time or model.time_max
    rows, summary = run_crosscheck(model, coeffs, labels, time=T, mjx=not args.no_mjx, show=args.show,
                                   out_dir=args.out)
    engines = [e for e in ("penalty", "mujoco", "mjx") if f"{e}_fitness" in rows[0]]
    print(table(rows, summary, engines))
    if args.out:
        print(f"\nwrote {args.out}/crosscheck.md, joints.png, cm_path.png")
    return 0


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="cpgjax",
        description="Evolve open-loop CPG controllers for walking robots in a penalty-method JAX simulator "
                    "(after G. Grasso, 2000).",
    )
    sub = p.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True

    s = sub.add_parser("simulate", help="run one episode of a model (and a .ctl controller)")
    s.add_argument("model", help="robot description (.wl)")
    s.add_argument("--ctl", help="controller (.ctl); without it every servo holds angle 0")
    s.add_argument("--time", type=float, help="simulated seconds (default: the file's TimeMax)")
    s.add_argument("--terrain", help="flat | ramp:SLOPE[:X|Y] | bump:HEIGHT[@Y][:WIDTH] | rough:RANGE[:CELL[:SEED]]")
    s.add_argument("--log", metavar="DIR", help="write one thesis-format log per Log statement into DIR")
    s.add_argument("--dt", type=float, help="integration step (default: the file's TimeStep or 5e-4 s)")
    s.add_argument("--gravity", type=float, help="gravity [m/s^2] (default: the file's, 9.81)")
    s.add_argument("--delta", type=float, default=8.0, help="delta of the fitness, eq. 4.5 (default 8)")
    s.set_defaults(func=cmd_simulate)

    b = sub.add_parser("bench", help="robot-steps/s and simulated robot-s per wall s at several batch sizes")
    b.add_argument("--model", default=_default_model(), help="robot description (default: the quadruped)")
    b.add_argument("--batches", default="1,20,256,1024,4096", help="comma-separated batch sizes")
    b.add_argument("--time", type=float, default=2.0, help="simulated seconds per episode (default 2)")
    b.add_argument("--chunk", type=int, default=256, help="robots per vectorised chunk (default 256)")
    b.add_argument("--tricks", action="store_true", help="also measure what each speed trick buys")
    b.add_argument("--against", choices=["mjx"], help="the same robot in MJX (and MuJoCo C) side by side")
    b.add_argument("--sweep", action="store_true",
                   help="evaluations/s of one GA run vs the thesis sweep (cpgjax sweep --preset full) in one program")
    b.add_argument("--generations", type=int, default=5, help="--sweep: generations per run (default 5)")
    b.add_argument("--seeds", type=int, default=5, help="--sweep: seeds per cell (default 5: 80 runs)")
    b.set_defaults(func=cmd_bench)

    r = sub.add_parser("robustness", help="replay a controller with its genes jittered: mean and spread of fitness")
    r.add_argument("model", help="robot description (.wl)")
    r.add_argument("--ctl", required=True, help="controller (.ctl)")
    r.add_argument("--n", type=int, default=64, help="replays per jitter (default 64)")
    r.add_argument("--jitter", default="1e-6,1e-4,1e-2", help="standard deviations of the gene offsets")
    r.add_argument("--time", type=float, help="simulated seconds (default: the file's TimeMax)")
    r.add_argument("--terrain", help="terrain (default: the file's)")
    r.add_argument("--delta", type=float, default=8.0)
    r.add_argument("--seed", type=int, default=0)
    r.set_defaults(func=cmd_robustness)

    d = sub.add_parser("study-dt", help="the time-step stability study (docs/simulator.md)")
    d.add_argument("--model", default=_default_model())
    d.add_argument("--ctl", default=os.path.join(os.path.dirname(_default_model()), "quadruped-trot.ctl"))
    d.add_argument("--dts", default="1e-4,2e-4,3e-4,5e-4,7e-4,1e-3,1.5e-3")
    d.add_argument("--time", type=float, default=10.0)
    d.add_argument("--out", help="write the table as markdown here too")
    d.set_defaults(func=cmd_study_dt)

    e = sub.add_parser("export", help="write the model as MJCF for MuJoCo / MJX")
    e.add_argument("model", help="robot description (.wl)")
    e.add_argument("--out", help="output .xml (default: beside the model)")
    e.add_argument("--terrain", help="terrain (default: the file's)")
    e.set_defaults(func=cmd_export)

    c = sub.add_parser("crosscheck", help="the same controllers in the penalty simulator, MuJoCo C and MJX")
    c.add_argument("model", help="robot description (.wl)")
    c.add_argument("--ctl", nargs="*", help="controllers (.ctl)")
    c.add_argument("--controllers", nargs="*", metavar="RUN.h5", help="GA runs: their 8 best distinct genomes")
    c.add_argument("--random", type=int, default=16, help="random controllers in [-0.8, 0.8] (default 16)")
    c.add_argument("--perturbed", type=int, default=16,
                   help="the hand-written trot with N(0, 0.1) added to every gene (default 16)")
    c.add_argument("--perturb-ctl", help="controller to perturb (default models/quadruped-trot.ctl)")
    c.add_argument("--n", type=int, help="at most this many controllers")
    c.add_argument("--time", type=float, help="simulated seconds (default: the file's TimeMax)")
    c.add_argument("--terrain", help="terrain (default: the file's)")
    c.add_argument("--show", type=int, default=0, help="which controller to plot (index, default 0)")
    c.add_argument("--no-mjx", action="store_true", help="skip MJX (slow to compile)")
    c.add_argument("--seed", type=int, default=0)
    c.add_argument("--out", default="runs/crosscheck", help="directory for the table and plots")
    c.set_defaults(func=cmd_crosscheck)

    from cpgjax.cli import evolve as cli_evolve
    from cpgjax.cli import sweep as cli_sweep

    cli_evolve.register(sub)
    cli_sweep.register(sub)
    return p


def _default_model() -> str:
    here = os.path.dirname(os.path.abspath(__file__))
    for cand in (os.path.join(os.getcwd(), "models", "quadruped.wl"),
                 os.path.join(os.path.dirname(here), "models", "quadruped.wl")):
        if os.path.exists(cand):
            return cand
    return "models/quadruped.wl"


def main(argv=None) -> int:
    from cpgjax.sim.description import DescriptionError

    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except DescriptionError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    except FileNotFoundError as e:
        print(f"error: {e.filename}: no such file", file=sys.stderr)
        return 2
    except ValueError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
