"""Does how a gait walks here tell whether it falls in MuJoCo C? (docs/results/closed-loop.md)

Each run's plain best is replayed as ``cpgjax transfer`` replays it (its episode, once as it is and 32 times
jittered), in MuJoCo C for its falls of the 32, and here with the trajectories recorded.  Per run, over our 33
replays (the median over them of each replay's value, or the mean over every sample): the body's largest tilt,
roll and pitch, the 95th percentile of its tilt, its mean tilt, its lowest height and the sd of its height, the sd
of its roll and pitch, the speed, and the sd of the fitness over the jittered replays.  Printed: each statistic's
Spearman rank correlation with MuJoCo's falls over the runs (with 60 runs, |rho| above about 0.25 is unlikely by
chance at the 5 % level).

    .venv/bin/python docs/experiments/falls_predictors.py runs/carry/*.h5 runs/carry-fresh/*.h5   # about 2 min
"""

from __future__ import annotations

import os
import sys

import numpy as np

import cpgjax  # noqa: F401  (first: the host devices)
from cpgjax.crosscheck.engines import spearman
from cpgjax.crosscheck.transfer import _model, jittered, replay_runs, run_setting
from cpgjax.episode.batch import simulate
from cpgjax.episode.policy import family_from_meta, from_genomes
from cpgjax.io.results import read_run
from cpgjax.sim.rotation import quat_to_mat_np


def walk_statistics(path: str) -> dict:
    """The statistics of our 33 replays of ``path``'s plain best (see the module docstring)."""
    run = read_run(path)
    _, _, _, genome = run.best()
    _, time, terrain = run_setting(run)
    model = _model(str(run.meta["model_text"]), str(run.meta.get("model_path", path)), terrain, None, None,
                   run.pipeline)
    r = simulate(model, from_genomes(family_from_meta(run.meta), model, jittered(genome)),
                 time=float(time or model.time_max), record=True)
    R = quat_to_mat_np(np.moveaxis(np.asarray(r["traj"]["q"])[:, :, model.track], 1, 0))     # [3, 3, S, B]
    tilt = np.degrees(np.arccos(np.clip(R[2, 2], -1.0, 1.0)))
    roll, pitch = np.degrees(np.arctan2(R[2, 1], R[2, 2])), np.degrees(np.arctan2(-R[2, 0], R[2, 2]))
    z = np.asarray(r["traj"]["x"])[:, 2, model.track]
    med = lambda x: float(np.median(x))  # noqa: E731
    return {"largest tilt": med(tilt.max(0)), "tilt, 95th percentile": float(np.percentile(tilt, 95)),
            "mean tilt": float(tilt.mean()), "largest roll": med(np.abs(roll).max(0)),
            "largest pitch": med(np.abs(pitch).max(0)), "lowest height": med(z.min(0)),
            "height sd": float(z.std(0).mean()), "roll sd": float(roll.std(0).mean()),
            "pitch sd": float(pitch.std(0).mean()), "speed": med(r["speed"]),
            "fitness sd (jittered)": float(np.std(np.asarray(r["fitness"])[1:]))}


def main(paths: list[str]) -> None:
    falls = {os.path.realpath(r.run): r.mujoco_jit["falls"] for r in replay_runs(paths)}
    falls = {p: falls[os.path.realpath(p)] for p in paths}
    stats = {}
    for p in paths:
        stats[p] = walk_statistics(p)
        print(f"{os.path.basename(p)}: MuJoCo falls {falls[p]}, " +
              ", ".join(f"{k} {v:.4g}" for k, v in stats[p].items()), flush=True)
    y = [falls[p] for p in paths]
    print(f"\n| statistic of our replays | Spearman with MuJoCo's falls ({len(paths)} runs) |\n|---|---:|")
    for k in stats[paths[0]]:
        print(f"| {k} | {spearman([stats[p][k] for p in paths], y):+.2f} |")


if __name__ == "__main__":
    main(sys.argv[1:])
