"""Does any one randomised parameter make a gait fall *here* the way it falls in MuJoCo C? (docs/results/closed-loop.md)

Each run's plain best is replayed on flat ground, exact joints, 5 s, as it is and 32 times with its genes
jittered (`cpgjax transfer`'s jitter, `crosscheck.transfer.jittered`: the same copies its replays use), once
nominal and once under each single variation at the edge of (or beyond) the domain preset's range: friction
x0.7 / x1.3, the ground's stiffness A x0.5 / x2 and damping B x0.5 / x2 (eq. 3.7), torque limits x0.8, servo gains
x0.8 / x1.2, the bristle x1000, masses x1.1.  Printed per run and condition: falls of the 32 jittered copies (tilt
past 60 degrees) and the unjittered copy's speed (m/s).  Run:

    .venv/bin/python docs/experiments/falls_here.py RUN.h5 [RUN.h5 ...]
"""

import os
import sys

import jax
import jax.numpy as jnp
import numpy as np

import cpgjax  # noqa: F401  (first: the host devices)
from cpgjax.crosscheck.transfer import jittered
from cpgjax.episode.batch import evaluate
from cpgjax.episode.policy import family_from_meta, from_genomes
from cpgjax.io.results import read_run
from cpgjax.io.wl.parser import load_wl
from cpgjax.sim.model import build_model
from cpgjax.sim.variation import Variation

REPLAYS = 32
CONDITIONS = {"nominal": {}, "friction0.7": dict(friction=0.7), "friction1.3": dict(friction=1.3),
              "A0.5": dict(stiffness=0.5), "A2": dict(stiffness=2.0), "B0.5": dict(damping=0.5),
              "B2": dict(damping=2.0), "torque0.8": dict(torque=0.8), "gain0.8": dict(gain=0.8),
              "gain1.2": dict(gain=1.2), "bristle1e3": dict(bristle=1000.0), "mass1.1": dict(mass=1.1)}


def main(runs: list[str]) -> None:
    m = build_model(load_wl("models/quadruped.wl"), pipeline="exact")
    genomes = []
    for path in runs:
        run = read_run(path)
        genomes.append(jittered(run.best()[3], REPLAYS))
    coeffs = from_genomes(family_from_meta(run.meta), m, np.concatenate(genomes))
    n = len(genomes) * (REPLAYS + 1)

    def variation(**scale):
        v = Variation.nominal(m, n)
        fields = {}
        for k, x in scale.items():
            cur = getattr(v, k)
            if cur is None:
                cur = jnp.ones((m.n_ctrl, n)) if k == "torque" else jnp.ones((n,))
            fields[k] = cur * x
        return v._replace(**fields)

    f = jax.jit(lambda c, v: evaluate(m, c, var=v, time=5.0, fall_ends=True))
    res = {}
    for k, scale in CONDITIONS.items():
        r = f(coeffs, variation(**scale))
        res[k] = [np.asarray(r[q]).reshape(len(runs), REPLAYS + 1) for q in ("down", "speed")]
    print("| run | " + " | ".join(CONDITIONS) + " |")
    print("|---|" + "---:|" * len(CONDITIONS))
    for i, path in enumerate(runs):
        cells = [f"{int(res[k][0][i, 1:].sum())}, {res[k][1][i, 0]:.2f}" for k in CONDITIONS]
        print(f"| {os.path.basename(path)} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main(sys.argv[1:])
