"""The ``simulate`` and ``robustness`` subcommands of ``cpgjax``: one episode, and a controller's spread."""

from __future__ import annotations

import argparse
import os
from typing import Any

import numpy as np

from cpgjax.cli import options as o


def register(subparsers: Any) -> None:

    s = subparsers.add_parser("simulate")
    o.model_argument(s)
    s.add_argument("--ctl", help="controller (.ctl); without it every servo holds angle 0")
    o.time_option(s, of=o.CTL_OR_FILE)
    o.terrain_option(s, of=o.CTL_OR_FILE)
    s.add_argument("--log", metavar="DIR",
                   help="write one thesis-format log per Log statement into DIR (default: no logs)")
    o.dt_option(s)
    o.pipeline_option(s, o.CTL_PIPELINE)
    s.add_argument("--gravity", type=o.finite, help="the acceleration of gravity pulling every body down, m/s^2 "
                                                    "(default: the model file's Gravity, else 9.81)")
    o.delta_option(s)
    s.add_argument("--engine", choices=("ours", "mujoco"), default="ours",
                   help="run the episode in our simulator (default) or in MuJoCo C (the robot: the model exported, "
                        "a closed-loop controller reading MuJoCo's sensors every control period, the model's step)")
    s.add_argument("--mujoco-dt", type=o.step, default=None, metavar="SECONDS",
                   help="--engine mujoco: MuJoCo C's integration step (default: the export's, 2 ms; on rough "
                        "ground use 0.00025, as for transfer: docs/crosscheck.md)")
    from cpgjax.cli.crosscheck import mujoco_ground_option

    mujoco_ground_option(s)
    s.set_defaults(func=cmd_simulate)

    r = subparsers.add_parser("robustness")
    o.model_argument(r)
    r.add_argument("--ctl", required=True, help="the controller file (.ctl) replayed")
    r.add_argument("--n", type=o.count, default=64, help="replays at each --jitter value (default 64)")
    r.add_argument("--jitter", type=o.list_of(o.nonneg, "expected numbers >= 0, e.g. 1e-6,1e-4"),
                   default=[1e-6, 1e-4, 1e-2], help="standard deviations of the gene offsets (default 1e-6,1e-4,1e-2)")
    o.time_option(r, of=o.CTL_OR_FILE)
    o.terrain_option(r, of=o.CTL_OR_FILE)
    o.delta_option(r)
    o.seed_option(r, what="random seed of the offsets")
    o.pipeline_option(r, o.CTL_PIPELINE)
    r.set_defaults(func=cmd_robustness)


def cmd_simulate(args: argparse.Namespace) -> int:
    from cpgjax.cli.controllers import header_settings, load_controller
    from cpgjax.cli.crosscheck import mujoco_options_given
    from cpgjax.episode.batch import simulate
    from cpgjax.io.logs import pose_rows, write_log
    from cpgjax.io.wl import load_model

    if args.engine == "mujoco":
        for flag, given in (("--log", args.log), ("--gravity", args.gravity)):
            if given is not None:
                raise ValueError(f"{flag}: with --engine ours only (MuJoCo C's model is the export's)")
    elif mujoco_options_given(args):
        raise ValueError(f"{', '.join(mujoco_options_given(args))}: with --engine mujoco (MuJoCo C's)")
    o.check_output_dir(args.log, "--log")
    rp = header_settings([args.ctl] if args.ctl else [], args)
    model = load_model(args.model, dt=args.dt, terrain=rp.terrain, pipeline=rp.pipeline)
    if args.gravity is not None:
        model = model.replace(gravity=args.gravity)
    coeffs, ctl_name = load_controller(args.ctl, model)
    T = model.episode.time_max if rp.time is None else rp.time
    if rp.note:
        print(f"header    {rp.note}")
    if args.engine == "mujoco":
        return _simulate_mujoco(args, model, coeffs, ctl_name, T)
    r = simulate(model, coeffs, time=T, delta=args.delta, record=bool(args.log))
    body = model.body_names[model.track]
    _print_episode(args, model, f"{model.pipeline} pipeline, dt {model.dt:g} s", ctl_name, T, r)
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


def _simulate_mujoco(args: argparse.Namespace, model, coeffs, ctl_name: str, T: float) -> int:
    """``simulate --engine mujoco``: the same episode in MuJoCo C, printed as ours is."""
    import sys

    from cpgjax.cli.crosscheck import mujoco_ground, rough_step_note
    from cpgjax.crosscheck.engines import mujoco_run
    from cpgjax.crosscheck.mjcf import cone_note, load
    from cpgjax.episode.policy import stack

    for note in (rough_step_note([model.terrain.spec], args.mujoco_dt),
                 cone_note(model.mu_static, args.mujoco_cone or "pyramidal")):
        if note:
            print(note, file=sys.stderr)
    with mujoco_ground(args):
        mj = load(model) if args.mujoco_dt is None else load(model, timestep=args.mujoco_dt)
        r, _, _ = mujoco_run(model, stack([coeffs], model), time=T, delta=args.delta, mj=mj)
    r = {k: v[0] for k, v in r.items()}                     # the one robot
    _print_episode(args, model, f"MuJoCo C, step {mj.opt.timestep:g} s, controller every {model.dt:g} s", ctl_name,
                   T, r)
    return 1 if r["diverged"] else 0


def _print_episode(args: argparse.Namespace, model, engine: str, ctl_name: str, T: float, r: dict) -> None:
    """The lines ``simulate`` prints for one episode ``r`` (one robot's metrics), in either engine."""
    print(f"model     {args.model}  ({model.nb} bodies, {model.n_ctrl} controlled DOFs, {engine}, "
          f"terrain {model.terrain.spec})")
    print(f"control   {ctl_name}")
    print(f"time      {T:g} s")
    print(f"distance  {float(r['distance']):+.4f} m   (body {model.body_names[model.track]}, forward = +y)")
    print(f"speed     {float(r['speed']):+.4f} m/s")
    print(f"tilt      {np.degrees(float(r['tilt'])):.2f} deg (mean angle of the body normal from vertical)")
    print(f"fitness   {float(r['fitness']):+.6f}   (eq. 4.6, delta {args.delta:g})")
    print(f"fallen    {'yes' if r['fallen'] else 'no'}")
    print(f"diverged  {'yes' if r['diverged'] else 'no'}")


def cmd_robustness(args: argparse.Namespace) -> int:
    """Replay a controller with every gene moved by tiny random amounts: how chaotic is its score?"""
    from cpgjax.cli.controllers import header_settings, load_controller
    from cpgjax.episode.batch import simulate
    from cpgjax.io.wl import load_model

    rp = header_settings([args.ctl], args)
    model = load_model(args.model, terrain=rp.terrain, pipeline=rp.pipeline)
    from cpgjax.episode.policy import from_genomes, is_closed, to_genome

    coeffs, name = load_controller(args.ctl, model)
    if rp.note:
        print(f"header: {rp.note}")
    family = coeffs.family if is_closed(coeffs) else None
    genome = to_genome(coeffs, model) if family else np.asarray(coeffs).reshape(-1)
    rng = np.random.default_rng(args.seed)
    rows = []
    for eps in args.jitter:
        C = genome[None] + rng.normal(0.0, eps, (args.n,) + genome.shape)
        C[0] = genome
        ctrl = from_genomes(family, model, C.astype(np.float32))
        if family:   # replay 0: the weights as read (a gene times its scale may differ from them in the last bit)
            ctrl.weights[0] = coeffs.weights
        r = simulate(model, ctrl, time=rp.time, delta=args.delta)
        f = r["fitness"]
        rows.append((eps, f[0], f.mean(), f.std(), f.min(), f.max(), int(r["fallen"].sum()),
                     int(r["diverged"].sum())))
    print(f"controller {name}: {args.n} replays per jitter (replay 0 is the controller itself), "
          f"{model.pipeline} pipeline")
    print(f"{'jitter':>8}{'itself':>10}{'mean':>10}{'sd':>9}{'min':>10}{'max':>10}{'fell':>6}{'diverged':>10}")
    for e, f0, m, sd, lo, hi, fell, div in rows:
        print(f"{e:>8.0e}{f0:>10.4f}{m:>10.4f}{sd:>9.4f}{lo:>10.4f}{hi:>10.4f}{fell:>6}{div:>10}")
    return 0
