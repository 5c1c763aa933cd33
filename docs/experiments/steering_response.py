"""What a steering gait does with a constant command: its mean turning rate, speed and fall over one episode.

Each `.ctl` (a closed-loop controller that reads the command) walks 10 s from rest on exact joints with a
constant commanded turning rate of -0.4, -0.3, ..., +0.4 rad/s (a `steering.Schedule` whose two halves are
equal), all in one batch; printed per command: the mean turning rate (the heading of the tracked body unwrapped
at the log samples, its change over the episode), the speed along +y and whether it fell (body past 90 degrees).

    .venv/bin/python docs/experiments/steering_response.py CTL [CTL ...] [--time 10]
"""

from __future__ import annotations

import argparse

import numpy as np

from cpgjax.episode import policy as pol
from cpgjax.episode import steering
from cpgjax.episode.batch import simulate
from cpgjax.io.ctl import read_ctl
from cpgjax.io.wl import load_model
from cpgjax.sim.rotation import quat_to_mat_np

COMMANDS = np.round(np.linspace(-0.4, 0.4, 9), 2).astype(np.float32)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("ctl", nargs="+")
    ap.add_argument("--time", type=float, default=10.0)
    a = ap.parse_args()
    m = load_model("models/quadruped.wl", pipeline="exact")
    cs = [pol.from_control(read_ctl(p, n_dof=m.n_ctrl, harmonics=m.harmonics), m) for p in a.ctl]
    n = len(COMMANDS)
    cmd = np.tile(COMMANDS, len(cs))
    batch = pol.stack([c for c in cs for _ in range(n)], m).replace(
        steer=steering.Schedule(cmd, cmd, a.time / 2, float(np.abs(COMMANDS).max())))
    r = simulate(m, batch, time=a.time, record=True)
    q = np.moveaxis(np.asarray(r["traj"]["q"][:, :, m.track], float), 1, 0)      # [4, S, B]
    f = quat_to_mat_np(q)[:, 1]
    turn = (lambda p: (p[-1] - p[0]) / a.time)(np.unwrap(np.arctan2(-f[0], f[1]), axis=0))
    print("| controller | " + " | ".join(f"{c:+.1f}" for c in COMMANDS) + " |")
    print("|---|" + "---:|" * n)
    for i, p in enumerate(a.ctl):
        cells = [f"{turn[i * n + j]:+.2f}, {r['speed'][i * n + j]:.2f}" + (" (fell)" if r["fallen"][i * n + j] else "")
                 for j in range(n)]
        print(f"| {p} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
