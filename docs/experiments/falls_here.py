"""Does any one randomised parameter make a gait fall *here* the way it falls in MuJoCo C? (docs/results/closed-loop.md)

Each run's plain best (`cpgjax best RUN --ctl`) is replayed on flat ground, exact joints, 5 s, 32 times with its
genes jittered (sd 1e-3, the jitter of `cpgjax transfer`'s replays; the first copy unjittered), once nominal and
once under each single variation at the edge of (or beyond) the domain preset's range: friction x0.7 / x1.3,
the ground's stiffness A x0.5 / x2 and damping B x0.5 / x2 (eq. 3.7), torque limits x0.8, servo gains x0.8 /
x1.2, the bristle x1000, masses x1.1.  Printed per run and condition: falls of the 32 (tilt past 60 degrees) and
the unjittered copy's speed (m/s).  Run:

    .venv/bin/python docs/experiments/falls_here.py RUN.h5 [RUN.h5 ...]
"""

import os
import subprocess
import sys
import tempfile

import numpy as np

import cpgjax  # noqa: F401  (first: the host devices)
import jax
import jax.numpy as jnp

from cpgjax.episode.batch import evaluate
from cpgjax.io.ctl import read_ctl
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
    tmp = tempfile.mkdtemp()
    best = []
    for r in runs:
        ctl = os.path.join(tmp, os.path.basename(r) + ".ctl")
        subprocess.run([os.path.join(os.path.dirname(sys.executable), "cpgjax"), "best", r, "--ctl", ctl],
                       check=True, stdout=subprocess.DEVNULL)
        best.append(np.asarray(read_ctl(ctl, m.n_ctrl, m.harmonics).coeffs, np.float32))
    jit = np.random.default_rng(1).normal(0, 1e-3, (REPLAYS,) + best[0].shape).astype(np.float32)
    jit[0] = 0
    coeffs = np.concatenate([c[None] + jit for c in best])
    n = len(coeffs)

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
        res[k] = (np.asarray(r["down"]).reshape(len(runs), REPLAYS), np.asarray(r["speed"]).reshape(len(runs), REPLAYS))
    print("| run | " + " | ".join(CONDITIONS) + " |")
    print("|---|" + "---:|" * len(CONDITIONS))
    for i, r in enumerate(runs):
        cells = [f"{int(res[k][0][i].sum())}, {res[k][1][i][0]:.2f}" for k in CONDITIONS]
        print(f"| {os.path.basename(r)} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main(sys.argv[1:])
