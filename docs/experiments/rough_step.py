"""Why MuJoCo C at its 2 ms step lets fast gaits fall on rough ground where at 0.25 ms they walk
(docs/results/engine-agreement.md, *MuJoCo's step on rough ground*).

Each run's plain best, replayed once as it is in MuJoCo C (closed-loop controllers step by step, as
`cpgjax transfer` replays them) on each terrain at each step; printed per case: the speed and whether it fell,
and over the first 2 s (before any fall) the feet's penetration (median, 99th percentile, largest; a foot is a
1 cm sphere, `crosscheck.mjcf.CONTACT_RADIUS`), the contacts per step and the share of them whose normal is more
than 25 degrees from vertical (on a heightfield: a sphere pushed sideways by a prism's wall).

    .venv/bin/python docs/experiments/rough_step.py runs/cl-mirror-b/s453.h5 [--terrain T ...] [--steps 0.002,0.00025]
"""

from __future__ import annotations

import argparse

import numpy as np

import cpgjax  # noqa: F401  (first: the host devices)
from cpgjax.crosscheck.engines import mujoco_run
from cpgjax.crosscheck.mjcf import load
from cpgjax.crosscheck.transfer import _model, run_setting
from cpgjax.episode.policy import family_from_meta, from_genomes
from cpgjax.io.results import read_run

WINDOW = 2.0      # s: the contacts are counted before this time (before the gaits that fall do)
STEEP = 0.9063    # cos(25 deg): a contact normal further than this from vertical is "steep"


def replay(model, C, time, dt):
    """(metrics, contact statistics) of one MuJoCo C replay at step ``dt``: every `mujoco.mj_step` the replay makes
    is followed by a look at the contacts (the replay calls `mujoco.mj_step`; wrapped here for the replay's length)."""
    import mujoco

    depth, ncon, steep = [], [], []
    step = mujoco.mj_step

    def looked(m, d):
        step(m, d)
        if d.time <= WINDOW:
            ncon.append(d.ncon)
            for i in range(d.ncon):
                depth.append(-d.contact[i].dist)
                steep.append(abs(d.contact[i].frame[2]) < STEEP)

    mujoco.mj_step = looked
    try:
        r, _, _ = mujoco_run(model, C, time=time, mj=load(model, timestep=dt))
    finally:
        mujoco.mj_step = step
    return r, np.asarray(depth) * 1e3, float(np.mean(ncon)), float(np.mean(steep)) if steep else 0.0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+")
    ap.add_argument("--terrain", action="append", default=None, help="default: flat and rough:0.02:0.1:1")
    ap.add_argument("--steps", default="0.002,0.00025", help="MuJoCo's steps [s], comma-separated")
    a = ap.parse_args()
    print("| run | terrain | MuJoCo's step | speed [m/s] | fell | penetration median / 99 % / largest [mm] | "
          "contacts per step | contacts > 25° from vertical |\n|---|---|---:|---:|---|---|---:|---:|")
    for path in a.runs:
        run = read_run(path)
        _, _, _, genome = run.best()
        _, T, _ = run_setting(run)
        for terrain in a.terrain or ["flat", "rough:0.02:0.1:1"]:
            model = _model(str(run.meta["model_text"]), str(run.meta.get("model_path", path)), terrain, None, None,
                           run.pipeline)
            C = from_genomes(family_from_meta(run.meta), model, np.asarray(genome)[None])
            for dt in (float(s) for s in a.steps.split(",")):
                r, d, n, s = replay(model, C, float(T or model.time_max), dt)
                p = np.percentile(d, [50, 99]) if d.size else (0.0, 0.0)
                print(f"| {path} | {terrain} | {dt * 1e3:g} ms | {float(r['speed'][0]):.3f} | "
                      f"{'yes' if bool(r['fallen'][0]) else 'no'} | {p[0]:.2f} / {p[1]:.2f} / "
                      f"{(d.max() if d.size else 0.0):.2f} | {n:.2f} | {100 * s:.0f} % |", flush=True)


if __name__ == "__main__":
    main()
