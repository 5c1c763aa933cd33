"""What a steering gait does with a constant command: its mean turning rate, speed and fall over one episode.

Each `.ctl` (a closed-loop controller that reads the command) walks 10 s from rest on exact joints with a
constant commanded turning rate of -0.4, -0.3, ..., +0.4 rad/s (a `steering.Schedule` whose two halves are
equal), all in one batch; printed per command: the mean turning rate (the heading of the tracked body unwrapped
at the log samples, its change over the episode), the speed along +y and whether it fell (body past 90 degrees).
The tables of docs/results/steering.md and steering-recipes.md.

    .venv/bin/python benchmarks/steering_response.py CTL [CTL ...] [--time 10]
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

COMMANDS = np.round(np.linspace(-0.4, 0.4, 9), 2).astype(np.float32)
MODEL = "models/quadruped.wl"


def batch(model, paths: list[str], time: float):
    """Every controller of ``paths`` once per command of :data:`COMMANDS`, robots first: controller ``i`` under
    command ``j`` is robot ``i * len(COMMANDS) + j``."""
    from cpgjax.episode import policy as pol
    from cpgjax.episode import steering
    from cpgjax.io.ctl import read_ctl

    cs = [pol.from_control(read_ctl(p, n_dof=model.n_ctrl, harmonics=model.episode.harmonics), model) for p in paths]
    cmd = np.tile(COMMANDS, len(cs))
    return pol.stack([c for c in cs for _ in COMMANDS], model).replace(
        steer=steering.Schedule(cmd, cmd, time / 2, float(np.abs(COMMANDS).max())))


def turning_rates(q: np.ndarray, time: float) -> np.ndarray:
    """Mean turning rate [rad/s] per robot over an episode of ``time`` s, from the tracked body's quaternions
    ``q`` [4, samples, robots] (w first): the heading of its y axis in the ground plane, unwrapped."""
    from cpgjax.sim.rotation import quat_to_mat_np

    f = quat_to_mat_np(q)[:, 1]
    heading = np.unwrap(np.arctan2(-f[0], f[1]), axis=0)
    return (heading[-1] - heading[0]) / time


def table(paths: list[str], turn, speed, fallen) -> list[str]:
    """One row per controller: per command its turning rate and speed, and "(fell)" where it fell."""
    n = len(COMMANDS)
    lines = ["| controller | " + " | ".join(f"{c:+.1f}" for c in COMMANDS) + " |", "|---|" + "---:|" * n]
    for i, p in enumerate(paths):
        k = range(i * n, (i + 1) * n)
        lines.append(f"| {p} | " + " | ".join(f"{turn[j]:+.2f}, {speed[j]:.2f}" + (" (fell)" if fallen[j] else "")
                                               for j in k) + " |")
    return lines


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("ctl", nargs="+", help="closed-loop controllers that read the command (.ctl)")
    ap.add_argument("--time", type=float, default=10.0, help="episode [s] (default 10)")
    a = ap.parse_args(argv)
    if a.time <= 0:
        ap.error("--time must be positive")
    from cpgjax.episode.batch import simulate
    from cpgjax.io.wl import load_model

    m = load_model(MODEL, pipeline="exact")
    r = simulate(m, batch(m, a.ctl, a.time), time=a.time, record=True)
    q = np.moveaxis(np.asarray(r["traj"]["q"][:, :, m.track], float), 1, 0)      # [4, samples, robots]
    print("\n".join(table(a.ctl, turning_rates(q, a.time), r["speed"], r["fallen"])))
    return 0


if __name__ == "__main__":
    sys.exit(main())
