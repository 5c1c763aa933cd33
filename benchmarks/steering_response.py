"""What a steering gait does with a constant command: its mean turning rate, speed and fall over one episode.

Each `.ctl` (a closed-loop controller that reads the command) walks 10 s from rest on exact joints with a constant
commanded turning rate of -0.4, -0.3, ..., +0.4 rad/s (a `steering.Schedule` whose two halves are equal), all in
one batch; printed per command: the mean turning rate (the heading of the tracked body unwrapped at the log
samples, its change over the episode), the speed along +y and whether it fell (body past 90 degrees).  The tables
of docs/results/steering.md, steering-recipes.md and steering-margin.md.  ``--engine mujoco`` (or ``both``) walks
the same controllers under the same constant commands in MuJoCo C (``crosscheck.engines.mujoco_closed_run``, at
``--mujoco-dt``, its controller held for the robot's 2 ms control period), measured alike from its root body's
quaternions: how much of a command each engine turns.  ``--inputs`` adds a second table: per controller, engine and
command (-0.4, 0, +0.4 rad/s), the episode's mean of each tilt and contact input the policy read (ours at the log
samples, MuJoCo C's every control period): what each engine's turn feels like to the policy.

    .venv/bin/python benchmarks/steering_response.py CTL [CTL ...] [--time 10] [--engine ours|mujoco|both] [--inputs]
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


SHOWN = (-0.4, 0.0, 0.4)        # the commands of the --inputs table
READ = ("tilt", "contact")      # the input groups it shows


def read_columns(m, paths: list[str]) -> list[tuple[str, int]]:
    """(name, index into the observation) of each input of :data:`READ` the controllers read (the first one's
    family: all of ``paths`` are to read the same): the tilt's roll and pitch, each leg's contact
    (``descriptors.legs``: AR, AL, PR, PL on the quadruped)."""
    from cpgjax.episode.descriptors import legs

    names = {"tilt": ("roll", "pitch"), "contact": tuple(f"contact {leg}" for leg in legs(m)[0])}
    fam = batch(m, paths[:1], 1.0).family
    cols, i = [], 0
    for g, n in fam.input_sizes(m):
        cols += [(names[g][k], i + k) for k in range(n)] if g in READ else []
        i += n
    return cols


def inputs_table(m, paths: list[str], rows: list[tuple[str, np.ndarray]]) -> list[str]:
    """Per controller, engine and command of :data:`SHOWN`: the mean of each input of :func:`read_columns`;
    ``rows``: (engine, mean observations [robots, inputs]) per engine."""
    cols = read_columns(m, paths)
    lines = ["| controller | engine | command | " + " | ".join(c for c, _ in cols) + " |",
             "|---|---|---:|" + "---:|" * len(cols)]
    n = len(COMMANDS)
    for i, p in enumerate(paths):
        for engine, mean in rows:
            for c in SHOWN:
                j = i * n + int(np.argmin(np.abs(COMMANDS - c)))
                cells = " | ".join(f"{mean[j, k]:+.3f}" for _, k in cols)
                lines.append(f"| {p} | {engine} | {c:+.1f} | {cells} |")
    return lines


def ours(m, paths: list[str], time: float, inputs: bool = False):
    """(turning rates, speeds, fallen, mean observations [robots, inputs] with ``inputs``, else None) of
    :func:`batch` in our simulator."""
    from cpgjax.episode.batch import simulate

    n = len(paths) * len(COMMANDS)
    r = simulate(m, batch(m, paths, time), time=time, record=True)
    q = np.moveaxis(np.asarray(r["traj"]["q"][:, :, m.track], float), 1, 0)      # [4, samples, robots]
    obs = np.asarray(r["traj"]["obs"], float)[1:].mean(0).T[:n] if inputs else None  # [robots, inputs], t > 0
    return turning_rates(q[..., :n], time), np.asarray(r["speed"]), np.asarray(r["fallen"]), obs


def mujoco(m, paths: list[str], time: float, timestep: float, inputs: bool = False):
    """The same in MuJoCo C: :func:`batch`'s controllers, each with its constant command (``ClosedLoop.command``)."""
    from cpgjax.crosscheck.engines import mujoco_closed_run, root_slice
    from cpgjax.crosscheck.mjcf import load

    c = batch(m, paths, time)
    c = c.replace(command=np.asarray(c.steer.first, np.float32), steer=None)
    mj = load(m, timestep=timestep)
    metrics, qpos, _, *obs = mujoco_closed_run(m, c, time=time, timestep=timestep, mj=mj, record=inputs)
    q = np.moveaxis(qpos[:, :, root_slice(m, mj)][:, :, 3:], 2, 0)                   # [4, samples, robots]
    return (turning_rates(np.moveaxis(q, 1, 2), time), np.asarray(metrics["speed"]), np.asarray(metrics["fallen"]),
            np.asarray(obs[0], float).mean(1) if inputs else None)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("ctl", nargs="+", help="closed-loop controllers that read the command (.ctl)")
    ap.add_argument("--time", type=float, default=10.0, help="episode [s] (default 10)")
    ap.add_argument("--engine", choices=("ours", "mujoco", "both"), default="ours",
                    help="our simulator, MuJoCo C, or both, a row each (default ours)")
    ap.add_argument("--mujoco-dt", type=float, default=0.002, help="MuJoCo C's step [s] (default 0.002)")
    ap.add_argument("--inputs", action="store_true",
                    help="also the mean tilt and contact inputs each engine's policy read, at -0.4, 0 and +0.4 rad/s")
    a = ap.parse_args(argv)
    if a.time <= 0 or a.mujoco_dt <= 0:
        ap.error("--time and --mujoco-dt must be positive")
    from cpgjax.io.wl import load_model

    m = load_model(MODEL, pipeline="exact")
    lines, read = [], []        # one table: ours alone as before; with MuJoCo C a column naming each row's engine
    if a.engine != "mujoco":
        *r, obs = ours(m, a.ctl, a.time, a.inputs)
        lines += table(a.ctl, *r, "ours" if a.engine == "both" else None)
        read.append(("ours", obs))
    if a.engine != "ours":
        name = f"MuJoCo C, {a.mujoco_dt * 1e3:g} ms"
        *r, obs = mujoco(m, a.ctl, a.time, a.mujoco_dt, a.inputs)
        lines += table(a.ctl, *r, name)[2 if lines else 0:]
        read.append((name, obs))
    if a.inputs:
        lines += [""] + inputs_table(m, a.ctl, read)
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
