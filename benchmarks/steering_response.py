"""What a steering gait does with a constant command: its mean turning rate, speed and fall over one episode.

Each `.ctl` (a closed-loop controller that reads the command) walks 10 s from rest on exact joints with a
constant commanded turning rate of -0.4, -0.3, ..., +0.4 rad/s (a `steering.Schedule` whose two halves are
equal), all in one batch; printed per command: the mean turning rate (the heading of the tracked body unwrapped
at the log samples, its change over the episode), the speed along +y and whether it fell (body past 90 degrees).
The tables of docs/results/steering.md and steering-recipes.md.  ``--engine mujoco`` (or ``both``) walks the same
controllers under the same constant commands in MuJoCo C (``crosscheck.engines.mujoco_closed_run``, at
``--mujoco-dt``, its controller held for the robot's 2 ms control period), measured alike from its root body's
quaternions: how much of a command each engine turns.

    .venv/bin/python benchmarks/steering_response.py CTL [CTL ...] [--time 10] [--engine ours|mujoco|both]
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


def table(paths: list[str], turn, speed, fallen, engine: str | None = None) -> list[str]:
    """One row per controller: per command its turning rate and speed, and "(fell)" where it fell; with ``engine``,
    a column that names it."""
    n = len(COMMANDS)
    head = "| controller | " + ("engine | " if engine else "")
    rule = "|---|" + ("---|" if engine else "") + "---:|" * n
    lines = [head + " | ".join(f"{c:+.1f}" for c in COMMANDS) + " |", rule]
    for i, p in enumerate(paths):
        k = range(i * n, (i + 1) * n)
        lines.append(f"| {p} | " + (f"{engine} | " if engine else "") +
                     " | ".join(f"{turn[j]:+.2f}, {speed[j]:.2f}" + (" (fell)" if fallen[j] else "") for j in k) + " |")
    return lines


def ours(m, paths: list[str], time: float):
    """(turning rates, speeds, fallen) [robots] of :func:`batch` in our simulator."""
    from cpgjax.episode.batch import simulate

    r = simulate(m, batch(m, paths, time), time=time, record=True)
    q = np.moveaxis(np.asarray(r["traj"]["q"][:, :, m.track], float), 1, 0)      # [4, samples, robots]
    return turning_rates(q, time), np.asarray(r["speed"]), np.asarray(r["fallen"])


def mujoco(m, paths: list[str], time: float, timestep: float):
    """The same in MuJoCo C: :func:`batch`'s controllers, each with its constant command (``ClosedLoop.command``)."""
    from cpgjax.crosscheck.engines import mujoco_closed_run, root_slice
    from cpgjax.crosscheck.mjcf import load

    c = batch(m, paths, time)
    c = c.replace(command=np.asarray(c.steer.first, np.float32), steer=None)
    mj = load(m, timestep=timestep)
    metrics, qpos, _ = mujoco_closed_run(m, c, time=time, timestep=timestep, mj=mj)
    q = np.moveaxis(qpos[:, :, root_slice(m, mj)][:, :, 3:], 2, 0)                   # [4, samples, robots]
    return turning_rates(np.moveaxis(q, 1, 2), time), np.asarray(metrics["speed"]), np.asarray(metrics["fallen"])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("ctl", nargs="+", help="closed-loop controllers that read the command (.ctl)")
    ap.add_argument("--time", type=float, default=10.0, help="episode [s] (default 10)")
    ap.add_argument("--engine", choices=("ours", "mujoco", "both"), default="ours",
                    help="our simulator, MuJoCo C, or both, a row each (default ours)")
    ap.add_argument("--mujoco-dt", type=float, default=0.002, help="MuJoCo C's step [s] (default 0.002)")
    a = ap.parse_args(argv)
    if a.time <= 0 or a.mujoco_dt <= 0:
        ap.error("--time and --mujoco-dt must be positive")
    from cpgjax.io.wl import load_model

    m = load_model(MODEL, pipeline="exact")
    lines = []                  # one table: ours alone as before; with MuJoCo C a column naming each row's engine
    if a.engine != "mujoco":
        lines += table(a.ctl, *ours(m, a.ctl, a.time), "ours" if a.engine == "both" else None)
    if a.engine != "ours":
        lines += table(a.ctl, *mujoco(m, a.ctl, a.time, a.mujoco_dt), f"MuJoCo C, {a.mujoco_dt * 1e3:g} ms")[
            2 if lines else 0:]
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
