"""Is there a gait of 0.42 m/s in MuJoCo C on 2 cm rough ground among a run's candidates? (docs/results/closed-loop.md)

The run's ``K`` best distinct genomes by recorded score (`cpgjax.experiments.validate.candidates`), each replayed
on one rough field (``--terrain``, default ``rough:0.02:0.1:5``: a field none of the results pages' tables used)
once as it is and ``--replays`` times jittered (sd 1e-3, seed 1), its episode's length, in MuJoCo C and here.
Printed per candidate: the median speed and the falls in each engine; then the fastest in MuJoCo C without a fall.
An upper bound of what choosing among the run's gaits could give, chosen on the field it is measured on.

    .venv/bin/python docs/experiments/fastest_candidates.py runs/fastest/pmtg-s101.h5 [--k 64] [--replays 4]
"""

from __future__ import annotations

import argparse

import numpy as np

import cpgjax  # noqa: F401  (first: the host devices)
from cpgjax.crosscheck.engines import mujoco_run
from cpgjax.crosscheck.mjcf import load
from cpgjax.crosscheck.transfer import _model, jittered, run_setting
from cpgjax.episode.batch import simulate
from cpgjax.episode.policy import family_from_meta, from_genomes
from cpgjax.experiments.validate import candidates
from cpgjax.io.results import read_run


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run")
    ap.add_argument("--k", type=int, default=64)
    ap.add_argument("--replays", type=int, default=4)
    ap.add_argument("--terrain", default="rough:0.02:0.1:5")
    a = ap.parse_args()
    run = read_run(a.run)
    _, T, _ = run_setting(run)
    model = _model(str(run.meta["model_text"]), str(run.meta.get("model_path", a.run)), a.terrain, None, None,
                   run.pipeline)
    T = float(T or model.time_max)
    mj = load(model)
    family = family_from_meta(run.meta)
    where, genomes, recorded = candidates(run, a.k)
    print(f"| candidate | generation | recorded score | MuJoCo C: median speed [m/s], falls of {a.replays + 1} | "
          "here: median speed, falls |\n|---:|---:|---:|---|---|")
    rows = []
    for i, g in enumerate(genomes):
        C = from_genomes(family, model, jittered(g, a.replays, 1e-3, 1))
        theirs, _, _ = mujoco_run(model, C, time=T, mj=mj)
        ours = simulate(model, C, time=T)
        rows.append((float(np.median(theirs["speed"])), int(np.sum(theirs["fallen"])), i))
        print(f"| {i} | {where[i][0]} | {recorded[i]:.3f} | {rows[-1][0]:.3f}, {rows[-1][1]} | "
              f"{np.median(ours['speed']):.3f}, {int(np.sum(ours['fallen']))} |", flush=True)
    up = [r for r in rows if r[1] == 0]
    best = max(up) if up else None
    print(f"\n{len(up)} of {len(rows)} candidates never fell in MuJoCo C on {a.terrain}; the fastest of them: "
          + (f"candidate {best[2]}, {best[0]:.3f} m/s" if best else "none"))


if __name__ == "__main__":
    main()
