"""The ``render`` subcommand: one episode drawn frame by frame to an MP4 or GIF (docs/render.md)."""

from __future__ import annotations

import argparse
import os
from typing import Any

from cpgjax.cli import options as o


def size(text: str) -> tuple[int, int]:
    """``WIDTHxHEIGHT`` in pixels, each in [16, 4096]."""
    w, sep, h = text.lower().partition("x")
    try:
        wh = (int(w), int(h)) if sep else None
    except ValueError:
        wh = None
    if wh is None or not all(16 <= v <= 4096 for v in wh):
        raise argparse.ArgumentTypeError(f"expected WIDTHxHEIGHT in pixels (16..4096 each), e.g. 640x480, got {text!r}")
    return wh


fps = o.float_in(1.0, 120.0, what="frames per second in [1, 120]")


def register(subparsers: Any) -> None:
    r = subparsers.add_parser(
        "render",
        description="Render one episode of our simulator (the exact recorded poses) with MuJoCo's renderer: the "
                    "terrain, the feet in contact (red dots) and a caption with time, distance and fitness. "
                    "MODEL is a .wl file (with --ctl) or a run file RUN.h5 (its best controller).")
    o.model_argument(r, metavar="MODEL.wl|RUN.h5", help="robot description (.wl), or a GA run file")
    r.add_argument("--ctl", help="controller (.ctl) for a .wl model; without it every servo holds angle 0")
    r.add_argument("--generation", type=int, metavar="G",
                   help="RUN.h5: the best of generation G (negative: from the end) instead of the whole run's best")
    r.add_argument("--cell", metavar="CELL",
                   help="a repertoire (cpgjax repertoire): the elite of this cell: best, an index, or a descriptor "
                        "(comma-separated values: the cell it falls in)")
    o.time_option(r, of="the run's, or the --ctl header's, else the model file's")
    o.terrain_option(r, of="the run's, or the --ctl header's, else the model file's")
    r.add_argument("--out", help="output .mp4 or .gif (default: MODEL's name with .mp4, in the current folder)")
    r.add_argument("--fps", type=fps, default=30.0, help="frames per second of the video and of the recording "
                                                          "(default 30)")
    r.add_argument("--size", type=size, default=(640, 480),
                   help="the size of a frame, WIDTHxHEIGHT in pixels (default 640x480; with --engine both the video "
                        "is twice as wide)")
    r.add_argument("--camera", choices=("track", "fixed", "side"), default="track",
                   help="track: follow the robot; fixed: one view holding the whole path; side: from the right, "
                        "forward to the right (default track)")
    r.add_argument("--engine", choices=("ours", "mujoco", "both"), default="ours",
                   help="ours: our simulator; mujoco: the same controller in MuJoCo C; both: side by side "
                        "(default ours)")
    o.pipeline_option(r, f"{o.CTL_PIPELINE}; for a run file, the run's, as it recorded")
    o.quiet_option(r)
    r.set_defaults(func=cmd_render)


def _is_run(path: str) -> bool:
    if os.path.splitext(path)[1].lower() in (".h5", ".hdf5"):
        return True
    try:
        with open(path, "rb") as f:
            return f.read(8) == b"\x89HDF\r\n\x1a\n"
    except OSError:
        return False


def cmd_render(args: argparse.Namespace) -> int:
    from cpgjax.render.movie import render_video
    from cpgjax.render.video import check_output

    out = args.out or os.path.splitext(os.path.basename(args.model))[0] + ".mp4"
    check_output(out)
    if _is_run(args.model):
        from cpgjax.render.poses import load_run

        if args.ctl:
            raise ValueError("--ctl is for a .wl model; a run file brings its own controller")
        model, coeffs, T, what = load_run(args.model, args.generation, terrain=args.terrain, pipeline=args.pipeline)
        if args.cell is not None:
            from cpgjax.experiments.repertoire import read_repertoire

            if args.generation is not None:
                raise ValueError("--cell and --generation: give one")
            rep = read_repertoire(args.model)
            c = rep.cell(args.cell)
            coeffs = rep.genomes[c].reshape(model.n_ctrl, model.n_coeff)
            desc = ", ".join(f"{n} {v:.3g}" for n, v in zip(rep.grid.names, rep.descriptors[c], strict=True))
            what = f"cell {c} (fitness {rep.fitness[c]:+.4f}; {desc})"
        T = args.time or T
        title = f"{os.path.basename(args.model)}: {what}"
    else:
        from cpgjax.cli.controllers import header_settings, load_controller
        from cpgjax.io.wl import load_model

        if args.generation is not None or args.cell is not None:
            raise ValueError("--generation and --cell are for a run file (RUN.h5)")
        rp = header_settings([args.ctl] if args.ctl else [], args)
        model = load_model(args.model, terrain=rp.terrain, pipeline=rp.pipeline)
        coeffs, name = load_controller(args.ctl, model)
        T = rp.time or model.episode.time_max
        if rp.note:
            print(f"header: {rp.note}", flush=True)
        title = f"{os.path.basename(args.model)} + {os.path.basename(name)}" if args.ctl else None
    s = render_video(model, coeffs, out, time=T, fps=args.fps, size=args.size, camera=args.camera,
                     engine=args.engine, title=title, progress=not args.quiet)
    kb = os.path.getsize(out) / 1024
    print(f"wrote {out}: {s['frames']} frames, {s['size'][0]}x{s['size'][1]}, {s['fps']:g} fps, "
          f"{s['seconds']:.2f} s simulated, {kb:.0f} KB (GL back-end {s['backend']})")
    for e in s["episodes"]:
        flag = " (diverged)" if e["diverged"] else (" (fell)" if e["fallen"] else "")
        print(f"  {e['engine']:<9} fitness {e['fitness']:+.4f}  distance {e['distance']:+.3f} m{flag}")
    return 0
