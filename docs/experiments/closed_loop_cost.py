"""The cost of a closed-loop controller and of domain randomisation, side by side (docs/results/closed-loop.md).

One generation's batch of the robust evaluation (20 controllers x 4 episodes, the quadruped on exact joints,
2 s episodes), timed in one process: every setting compiled, then run in turns five times, the best of each kept.  Run:

    .venv/bin/python docs/experiments/closed_loop_cost.py
"""

import os
import time

import jax
import jax.numpy as jnp
import numpy as np

import cpgjax  # noqa: F401  (first: one host device per core, cpgjax/_xla.py)
from cpgjax.optim.factory import make_problem

SETTINGS = [
    ("cpg, robust (defaults)", None, None),
    ("pmtg, robust (defaults)", "pmtg", None),
    ("cpg, preset=domain", None, {"preset": "domain"}),
    ("pmtg, preset=domain", "pmtg", {"preset": "domain"}),
    ("pmtg, preset=domain,latency=1,noise=0.02", "pmtg", {"preset": "domain", "latency": 1, "noise": 0.02}),
]

compiled = []
for label, ctl, pert in SETTINGS:                 # compile every setting first
    p = make_problem("models/quadruped.wl", pipeline="exact", evaluation="robust", perturb=pert, controller=ctl,
                     time=2.0)
    f = jax.jit(p.evaluate)
    g = jnp.asarray(np.random.default_rng(0).uniform(-0.1, 0.1, (20, p.n_genes)) + p.base_genome, jnp.float32)
    keys = jax.random.split(jax.random.key(0), 20)
    jax.block_until_ready(f(g, keys))
    compiled.append((label, f, g, keys))
best = {label: float("inf") for label, *_ in compiled}
for _ in range(5):                                # then time them in turns: a change of load hits every setting
    for label, f, g, keys in compiled:
        t0 = time.perf_counter()
        jax.block_until_ready(f(g, keys))
        best[label] = min(best[label], time.perf_counter() - t0)
rows = [(label, None, best[label]) for label, *_ in compiled]
base = rows[0][2]
print("\n| setting | run [s] | x the open-loop CPG's |\n|---|---:|---:|")
for label, _, run in rows:
    print(f"| {label} | {run:.3f} | {run / base:.2f} |")
print(f"\nload average {os.getloadavg()[0]:.1f} {os.getloadavg()[1]:.1f} {os.getloadavg()[2]:.1f}")
