"""The ``export``, ``crosscheck`` and ``transfer`` subcommands: MJCF, the same controllers in MuJoCo, evolved gaits
replayed in MuJoCo."""

from __future__ import annotations

import argparse
import contextlib
import os
import sys
from typing import Any

from cpgjax.cli import options as o
from cpgjax.crosscheck.ground import GROUND_FORMS, ground_form
from cpgjax.crosscheck.impedance import CONTACT_LAWS, contact_law
from cpgjax.crosscheck.limits import LIMITS, joint_limit
from cpgjax.crosscheck.mjcf import CONES, cone_note, contact_stiffness, friction_cone
from cpgjax.episode.cpg import GENE_BOX


def register(subparsers: Any) -> None:
    e = subparsers.add_parser("export")
    o.model_argument(e)
    e.add_argument("--out", help="the MJCF file written (.xml; default: beside the model, with .xml)")
    o.terrain_option(e)
    e.add_argument("--ground", choices=GROUND_FORMS, default="hfield",
                   help="the form of a non-flat ground in MuJoCo: hfield (default), mesh (a convex mesh per triangle "
                        "of the heightfield) or boxes (a tilted box per cell); docs/crosscheck.md")
    e.add_argument("--cone", choices=CONES, default="pyramidal",
                   help="MuJoCo's friction cone: pyramidal (default, MuJoCo's own) or elliptic (circular as ours, "
                        "needed above friction 3, where the pyramidal lets the ground give way; docs/crosscheck.md)")
    e.add_argument("--limit", choices=LIMITS, default="penalty",
                   help="the joint limits: penalty (default: act as ours, their damping capped for the file's 2 ms "
                        "step) or mujoco (MuJoCo's default limit); docs/crosscheck.md, joint limits")
    e.set_defaults(func=cmd_export)

    c = subparsers.add_parser("crosscheck")
    o.model_argument(c)
    c.add_argument("--ctl", nargs="*", help="controller files (.ctl) to compare, besides the random and perturbed ones")
    c.add_argument("--controllers", nargs="*", metavar="RUN.h5",
                   help="run files of evolve or search: each run's 8 best distinct controllers are compared")
    c.add_argument("--random", type=o.count0, default=16,
                   help=f"how many random controllers, every gene uniform in [-{GENE_BOX:g}, {GENE_BOX:g}], to compare "
                        "(default 16)")
    c.add_argument("--perturbed", type=o.count0, default=16,
                   help="the hand-written trot with N(0, 0.1) added to every gene (default 16)")
    c.add_argument("--perturb-ctl", help="the controller (.ctl) that --perturbed adds noise to "
                                          "(default models/quadruped-trot.ctl)")
    c.add_argument("--n", type=o.count, help="compare at most this many controllers in all (default: every one)")
    o.time_option(c, of=o.CTL_OR_FILE)
    o.terrain_option(c, of=o.CTL_OR_FILE)
    c.add_argument("--show", type=o.count0, default=0, help="which controller to plot (index, default 0)")
    c.add_argument("--no-mjx", action="store_true", help="skip MJX (slow to compile)")
    c.add_argument("--no-ceiling", action="store_true",
                   help="skip MuJoCo C and the penalty simulator at half their steps (the rank correlation each "
                        "engine has with itself: the ceiling)")
    o.seed_option(c)
    _variant_options(c)
    o.pipeline_option(c, f"{o.CTL_PIPELINE}; our simulator's side only, MuJoCo's model does not depend on it")
    c.add_argument("--mujoco-dt", type=o.step, default=None, metavar="SECONDS",
                   help="MuJoCo C's integration step (default: the export's, 2 ms; on rough ground use 0.00025, "
                        "where fast gaits' verdicts settle: docs/crosscheck.md); the ceiling runs it at half that")
    mujoco_ground_option(c)
    c.add_argument("--mujoco-stiffness", type=o.positive, default=None, metavar="SCALE",
                   help="MuJoCo's contact stiffness and damping (its solref) scaled by this (default: as exported, "
                        "1; docs/results/friction-cone.md); MuJoCo's side only")
    c.add_argument("--out", default="runs/crosscheck",
                   help="directory for the table and plots (default runs/crosscheck)")
    c.set_defaults(func=cmd_crosscheck)

    t = subparsers.add_parser(
        "transfer",
        description="Replay the best controller of each run (RUN.h5 files, or every run of sweep folders) in our "
                    "simulator and in MuJoCo C, once and under jittered replays, on the terrain it was evolved on "
                    "(or --terrain's, in both engines); tabulate fitness and speed here vs there, their ratio, the "
                    "falls and whether the gait carries over: it walks here (no fall, at least 0.1 m/s) and in "
                    "MuJoCo at >= 70 % of its fitness here with at most 2 falls in the jittered replays, per "
                    "evaluation mode (thesis / robust).  With --pick "
                    "validated, each run's champion is first chosen by validation: its best candidates re-scored "
                    "over fresh perturbed episodes, the same for each (docs/evolution.md).")
    t.add_argument("runs", nargs="+", metavar="RUN.h5|SWEEP_DIR",
                   help="run files, or sweep folders (every run in them); with --restate, transfer tables")
    t.add_argument("--replays", type=o.count, default=32, help="jittered replays per run (default 32)")
    t.add_argument("--jitter", type=o.nonneg, default=1e-3, help="sd of the gene jitter, rad (default 1e-3)")
    o.seed_option(t, what="random seed of the jitter and the validation")
    t.add_argument("--pick", choices=("best", "validated"), default="best",
                   help="which controller of each run: the best score it recorded (default), or the champion of a "
                        "validation (--candidates, --episodes)")
    o.validation_options(t)
    t.add_argument("--terrain", type=o.terrain,
                   help="replay every run on this terrain, here and in MuJoCo (the same field exported), instead of "
                        "the one it was evolved on (default); e.g. rough:0.02 or rough:0.02:0.1:SEED")
    t.add_argument("--mujoco-dt", type=o.step, default=None, metavar="SECONDS",
                   help="MuJoCo's integration step (default: the export's, 2 ms; at 2 ms MuJoCo's verdict on a "
                        "marginal gait depends on the step, and on rough ground a fast gait that walks at 0.25 ms "
                        "falls at 2 ms: use 0.00025 there; docs/results/closed-loop.md)")
    mujoco_ground_option(t)
    t.add_argument("--restate", action="store_true",
                   help="the arguments are transfer tables (transfer.md, as --out writes them): judge each run again "
                        "by today's rule from the figures in the table, without replaying anything")
    t.add_argument("--by", choices=("evaluation", "cell"), default="evaluation",
                   help="summary rows per evaluation mode (default), or per setting of a sweep (its cell folders: "
                        "which GA settings and baselines evolve gaits that carry over)")
    _variant_options(t)
    o.pipeline_option(t, "each run's, as it recorded; our side's replays only (MuJoCo's model does not depend on "
                         "it, and --pick validated validates on the run's own)")
    t.add_argument("--out", default=None, metavar="DIR", help="write transfer.md, transfer.json and transfer.png here")
    t.add_argument("--json", action="store_true", help="print one JSON object with the summary instead of the table")
    t.set_defaults(func=cmd_transfer)


def mujoco_ground_option(p: argparse.ArgumentParser) -> None:
    """``--mujoco-ground`` and ``--mujoco-contact``: MuJoCo C's ground (:func:`mujoco_ground`)."""
    p.add_argument("--mujoco-ground", choices=GROUND_FORMS, default=None,
                   help="the form of a non-flat ground in MuJoCo C: hfield (default), mesh or boxes, the same surface "
                        "(MJX keeps the heightfield; docs/crosscheck.md, the ground's form in MuJoCo)")
    mujoco_contact_option(p)


def mujoco_contact_option(p: argparse.ArgumentParser) -> None:
    p.add_argument("--mujoco-contact", choices=CONTACT_LAWS, default=None,
                   help="MuJoCo C's contact stiffness and damping: resting (default: per unit mass, for the mass a "
                        "resting foot carries) or per-contact (each step divided by each touching foot's own "
                        "effective mass: eq. 3.7's force per metre, as here; docs/crosscheck.md)")
    p.add_argument("--mujoco-cone", choices=CONES, default=None,
                   help="MuJoCo C's friction cone: pyramidal (default, MuJoCo's own) or elliptic (the circular cone "
                        "|f_t| <= mu f_r that ours is; the pyramidal one makes MuJoCo's ground softer as mu grows: "
                        "docs/crosscheck.md)")
    p.add_argument("--mujoco-limit", choices=LIMITS, default=None,
                   help="MuJoCo C's joint limits: penalty (default: soft constraints that act as our penalty torque "
                        "beyond the stop) or mujoco (MuJoCo's default limit, far softer: knees buckle past it; "
                        "docs/crosscheck.md, joint limits)")


MUJOCO_OPTIONS = ("mujoco_dt", "mujoco_ground", "mujoco_contact", "mujoco_cone", "mujoco_limit")


def mujoco_options_given(args: argparse.Namespace, names: tuple[str, ...] = MUJOCO_OPTIONS) -> list[str]:
    """The flags of the MuJoCo C options ``names`` that ``args`` were given (``--mujoco-dt``, ...), for the error
    of a command that runs no MuJoCo C."""
    return [f"--{n.replace('_', '-')}" for n in names if getattr(args, n, None) is not None]


@contextlib.contextmanager
def mujoco_ground(args: argparse.Namespace):
    """Within this block MuJoCo C's ground has the form, the contact law, the friction cone and the contact stiffness
    ``args`` ask for, and its joints the limit (the options each command has)."""
    g = lambda name: getattr(args, name, None)      # noqa: E731
    with ground_form(g("mujoco_ground")), contact_law(g("mujoco_contact")), friction_cone(g("mujoco_cone")), \
            contact_stiffness(g("mujoco_stiffness")), joint_limit(g("mujoco_limit")):
        yield


def _variant_options(p: argparse.ArgumentParser) -> None:
    """Options that change our simulator's side only (MuJoCo's model does not depend on them)."""
    o.dt_option(p)
    p.add_argument("--joint-spring", type=o.positive, nargs=2, metavar=("ALPHA", "BETA"),
                   help="our pivot springs' stiffness [N/m] and damping [N s/m] (eq. 3.6; default: the model's "
                        "JointSpring, 3e5 300 for models/quadruped.wl); stiffer ones need a smaller --dt "
                        "(cpgjax study-dt)")


ROUGH_STEP_NOTE = ("note: on rough ground MuJoCo C at its default 2 ms step lets fast gaits fall that walk at every "
                   "step from 0.5 ms down; judge them with --mujoco-dt 0.00025 (docs/crosscheck.md)")


def rough_step_note(terrains, mujoco_dt) -> str | None:
    """:data:`ROUGH_STEP_NOTE` when MuJoCo runs at the export's step on any rough terrain of ``terrains`` (specs,
    None for flat), else None (docs/results/engine-agreement.md, *MuJoCo's step on rough ground*)."""
    if mujoco_dt is None and any(str(t or "").startswith("rough") for t in terrains):
        return ROUGH_STEP_NOTE
    return None


def runs_cone_note(files, cone: str | None) -> str | None:
    """:func:`~cpgjax.crosscheck.mjcf.cone_note` for the highest friction of the run files' models (from their
    attributes alone)."""
    import json

    from cpgjax.io.results import read_attrs
    from cpgjax.io.wl import parse_wl

    mus = []
    for p in files:
        meta = json.loads(read_attrs(p).get("meta") or "{}")
        if meta.get("model_text"):
            mus.append(float(parse_wl(str(meta["model_text"]), str(meta.get("model_path", p))).friction))
    return cone_note(max(mus), cone or "pyramidal") if mus else None


def cmd_export(args: argparse.Namespace) -> int:
    from cpgjax.crosscheck.mjcf import load, to_mjcf
    from cpgjax.io.wl import load_model

    out = args.out or os.path.splitext(args.model)[0] + ".xml"
    o.check_output_file(out)
    model = load_model(args.model, terrain=args.terrain)
    note = cone_note(model.mu_static, args.cone, flag="--cone")
    if note:
        print(note, file=sys.stderr)
    with joint_limit(args.limit):
        text = to_mjcf(model, ground=args.ground, cone=args.cone)
        mj = load(model, ground=args.ground, cone=args.cone)  # proves that MuJoCo loads it (before anything is written)
    with open(out, "w") as f:
        f.write(text)
    print(f"wrote {out}: {mj.nbody - 1} bodies, {mj.njnt} joints, {mj.nu} actuators, "
          f"total mass {mj.body_mass.sum():.3f} kg")
    return 0


def cmd_crosscheck(args: argparse.Namespace) -> int:
    from cpgjax.crosscheck.compare import controllers, run_crosscheck, table
    from cpgjax.io.wl import load_model

    o.check_output_dir(args.out)
    from cpgjax.cli.controllers import header_settings
    from cpgjax.crosscheck.transfer import variant

    rp = header_settings([*(args.ctl or ()), *([args.perturb_ctl] if args.perturb_ctl else [])], args)
    if rp.note:
        print(f"header: {rp.note}")
    model = variant(load_model(args.model, terrain=rp.terrain, pipeline=rp.pipeline), args.dt, args.joint_spring)
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
    T = rp.time or model.episode.time_max
    note = rough_step_note([model.terrain.spec], args.mujoco_dt)
    if note:
        print(note, file=sys.stderr)
    note = cone_note(model.mu_static, args.mujoco_cone or "pyramidal")
    if note:
        print(note, file=sys.stderr)
    with mujoco_ground(args):
        rows, summary = run_crosscheck(model, coeffs, labels, time=T, mjx=not args.no_mjx, ceiling=not args.no_ceiling,
                                       show=args.show, out_dir=args.out, mujoco_dt=args.mujoco_dt)
    if args.mujoco_ground and not model.terrain.flat:
        print(f"MuJoCo C's ground: {args.mujoco_ground}")
    engines = [e for e in ("penalty", "mujoco", "mjx") if f"{e}_fitness" in rows[0]]
    print(table(rows, summary, engines))
    if args.out:
        print(f"\nwrote {args.out}/crosscheck.md, crosscheck.json, joints.png, cm_path.png")
    return 0


def _ctl_not_run(path: str) -> str:
    """Why ``transfer`` takes no `.ctl` file: it replays runs, on the settings they recorded; a header names its run."""
    from cpgjax.io.ctl import read_ctl

    run = read_ctl(path).header.run
    return (f"{path}: transfer replays run files (RUN.h5), on the settings each recorded; "
            + (f"its header names its run: cpgjax transfer {run}" if run else
               "a controller alone: cpgjax crosscheck MODEL.wl --ctl " + path))


def cmd_transfer(args: argparse.Namespace) -> int:
    import json

    from tqdm.auto import tqdm

    from cpgjax.crosscheck import transfer

    if args.restate:
        for path in args.runs:
            with open(path) as f:
                rows = transfer.read_table(f.read())
            if not rows:
                raise ValueError(f"{path}: no per-run rows of a transfer table (| run | evaluation | fitness here | "
                                 "...) in it")
            print(transfer.restate_text(path, rows))
        return 0
    for p in args.runs:
        if p.lower().endswith(".ctl"):
            raise ValueError(_ctl_not_run(p))
    if args.out:
        o.check_output_dir(args.out)
    files = transfer.run_files(args.runs)
    from cpgjax.io.results import machines_line, writing_note

    for note in (writing_note(p) for p in files):
        if note:
            print(note, file=sys.stderr)
    from cpgjax.io.results import read_attrs

    # the terrain each run will be replayed on, from its attributes alone (the rows are read once, to replay)
    terrains = [args.terrain] if args.terrain else [
        transfer.evolved_terrain(json.loads(read_attrs(p).get("meta") or "{}")) for p in files]
    note = rough_step_note(terrains, args.mujoco_dt)
    if note:
        print(note, file=sys.stderr)
    note = runs_cone_note(files, args.mujoco_cone)
    if note:
        print(note, file=sys.stderr)
    pick, here = None, []
    if args.pick == "validated":
        from cpgjax.experiments.validate import validate

        v = o.validation(args)

        def pick(run):
            champion = validate(run, v)
            return champion.recorded, champion.genome, champion.to_dict()
        here.append(f"each run's validated champion ({v.candidates} candidates x {v.episodes} episodes, "
                    f"seed {v.seed}{v.stricter})")
    with tqdm(total=len(files), desc="transfer", unit="run", disable=args.json) as bar, mujoco_ground(args):
        replays = transfer.replay_runs(files, replays=args.replays, jitter=args.jitter, seed=args.seed,
                                       dt=args.dt, joint_spring=args.joint_spring, pipeline=args.pipeline,
                                       terrain=args.terrain, pick=pick, progress=lambda _: bar.update(),
                                       mujoco_dt=args.mujoco_dt)
    summary = transfer.summary(replays, args.by)
    summary["pick"] = args.pick
    if args.pipeline is not None:
        here.append(f"{args.pipeline} pipeline")
        summary["pipeline"] = args.pipeline
    if args.terrain is not None:
        here.append(f"terrain {args.terrain} (in MuJoCo too)")
        summary["terrain"] = args.terrain
    if args.dt is not None:
        here.append(f"step {args.dt * 1e3:g} ms")
        summary["dt"] = args.dt
    if args.mujoco_dt is not None:
        here.append(f"MuJoCo's step {args.mujoco_dt * 1e3:g} ms")
        summary["mujoco_dt"] = args.mujoco_dt
    if args.mujoco_ground is not None:
        here.append(f"MuJoCo's ground {args.mujoco_ground}")
        summary["mujoco_ground"] = args.mujoco_ground
    if args.mujoco_contact is not None:
        here.append(f"MuJoCo's contact {args.mujoco_contact}")
        summary["mujoco_contact"] = args.mujoco_contact
    if args.mujoco_cone is not None:
        here.append(f"MuJoCo's friction cone {args.mujoco_cone}")
        summary["mujoco_cone"] = args.mujoco_cone
    if args.mujoco_limit is not None:
        here.append(f"MuJoCo's joint limits {args.mujoco_limit}")
        summary["mujoco_limit"] = args.mujoco_limit
    if args.joint_spring is not None:
        here.append(f"pivot springs {args.joint_spring[0]:g} N/m, {args.joint_spring[1]:g} N s/m")
        summary["joint_spring"] = list(args.joint_spring)
    text = transfer.table(replays, args.replays, here=", ".join(here) or None, by=args.by)
    machines = machines_line(files)
    if machines:
        text += "\n\n" + machines
        summary["machines"] = machines
    if args.out:
        os.makedirs(args.out, exist_ok=True)
        with open(os.path.join(args.out, "transfer.md"), "w") as f:
            f.write(text + "\n")
        with open(os.path.join(args.out, "transfer.json"), "w") as f:
            json.dump({"summary": summary, "runs": [r.__dict__ for r in replays]}, f, indent=1, default=float)
        transfer.plot(replays, os.path.join(args.out, "transfer.png"))
    if args.json:
        print(json.dumps(summary))
    else:
        print(text)
        if args.out:
            print(f"\nwrote {args.out}/transfer.md, transfer.json, transfer.png")
        if len(replays) == 1:
            print("\n" + transfer.sentence(replays[0], args.replays))
    return 0
