"""What climbs what, in both engines: each run's gait on a flight of stairs up and down again, at several rises.

For each run file and rise R, the gait (the run's best, or ``--pick validated``) walks ``course:flat:0.5,
stairs:R:TREAD:N,stairs:-R:TREAD:N,flat:2`` (``cpgjax.sim.course``) once as it is and in ``--replays`` jittered
replays, here and in MuJoCo C (``cpgjax.crosscheck.transfer.replay_runs``).  A replay fails when it falls or stays
up short of the finish (the last riser plus the hind legs' reach, ``sim.ledges.finish_line``); the gait *climbs* in
an engine when at most ``--allow`` of its jittered replays fail.  Printed: a table per run and rise, the share of
runs that climb per rise in each engine, and with ``--out`` a figure of that share against the rise and
``climb.json``.

    .venv/bin/python benchmarks/climb.py runs/stairs/s*.h5 --rises 0.01,0.02,0.03,0.04 [--pick validated] \\
        [--replays 32] [--mujoco-dt 0.00025] [--out DIR]
"""

from __future__ import annotations

import argparse
import json
import os
import sys

TREAD, STEPS = 0.3, 5


def course_of(rise: float, tread: float = TREAD, steps: int = STEPS) -> str:
    """Up ``steps`` stairs of ``rise`` and down again, flat before and after."""
    return f"course:flat:0.5,stairs:{rise:g}:{tread:g}:{steps},stairs:{-rise:g}:{tread:g}:{steps},flat:2"


def climb(paths, rises, *, replays: int, mujoco_dt: float, pick=None, allow: int = 1, progress=None) -> list[dict]:
    """One row per run and rise: speed, falls and replays short of the finish in each engine, and whether it
    climbs there."""
    from cpgjax.crosscheck.transfer import replay_runs

    rows = []
    for rise in rises:
        for r in replay_runs(paths, replays=replays, terrain=course_of(rise), pick=pick, mujoco_dt=mujoco_dt,
                             progress=progress):
            row = {"run": r.label, "seed": r.seed, "rise": rise}
            for side, one, jit in (("ours", r.ours, r.ours_jit), ("mujoco", r.mujoco, r.mujoco_jit)):
                fails = jit["falls"] + jit.get("short", 0)
                row[side] = {"speed": one["speed"], "distance": one["distance"], "fallen": one["fallen"],
                             "falls": jit["falls"], "short": jit.get("short", 0), "climbs": fails <= allow}
            rows.append(row)
    return rows


def table(rows: list[dict], replays: int) -> str:
    lines = [f"| run | rise [cm] | here: speed [m/s], falls / short of {replays} | climbs here | "
             f"MuJoCo C: speed, falls / short | climbs in MuJoCo C |", "|---|---:|---|---|---|---|"]
    for r in rows:
        o, m = r["ours"], r["mujoco"]
        lines.append(f"| {r['run']} | {100 * r['rise']:g} | {o['speed']:.3f}, {o['falls']} / {o['short']} | "
                     f"{'yes' if o['climbs'] else 'no'} | {m['speed']:.3f}, {m['falls']} / {m['short']} | "
                     f"{'yes' if m['climbs'] else 'no'} |")
    return "\n".join(lines)


def shares(rows: list[dict]) -> dict:
    """{rise: (runs, climb here, climb in MuJoCo C, climb in both)}."""
    out: dict = {}
    for r in rows:
        n, a, b, c = out.get(r["rise"], (0, 0, 0, 0))
        here, there = r["ours"]["climbs"], r["mujoco"]["climbs"]
        out[r["rise"]] = (n + 1, a + here, b + there, c + (here and there))
    return out


def plot(rows: list[dict], path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    s = shares(rows)
    rises = sorted(s)
    fig, ax = plt.subplots(figsize=(5.0, 3.4), layout="constrained")
    for k, (label, style) in enumerate((("here", "o-"), ("MuJoCo C", "s--"), ("both", "k:"))):
        ax.plot([100 * r for r in rises], [s[r][k + 1] / s[r][0] for r in rises], style, label=label, lw=1.3, ms=4)
    ax.set_xlabel("stair rise [cm] (5 steps up, 5 down, 0.3 m treads)")
    ax.set_ylabel("share of runs whose gait climbs")
    ax.set_ylim(-0.03, 1.03)
    ax.legend(fontsize=8)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("runs", nargs="+", help="run files (RUN.h5)")
    p.add_argument("--rises", default="0.01,0.02,0.03,0.04", help="stair rises, m, comma separated")
    p.add_argument("--replays", type=int, default=32, help="jittered replays per engine (default 32)")
    p.add_argument("--allow", type=int, default=1, help="failed replays a gait that climbs may have (default 1)")
    p.add_argument("--mujoco-dt", type=float, default=0.00025, help="MuJoCo C's step (default 0.25 ms)")
    p.add_argument("--pick", choices=("best", "validated"), default="best", help="which gait of each run")
    p.add_argument("--out", help="folder for climb.json and climb.png")
    a = p.parse_args(argv)
    try:
        rises = [float(v) for v in a.rises.split(",")]
    except ValueError:
        print(f"climb.py: --rises expects metres, comma separated, got {a.rises!r}", file=sys.stderr)
        return 2
    pick = None
    if a.pick == "validated":     # validated once per run, whatever the rise (the run's own evaluation)
        from cpgjax.experiments.validate import Validation, validate

        champions: dict = {}

        def pick(run):
            if run.path not in champions:
                c = validate(run, Validation())
                champions[run.path] = (c.recorded, c.genome, c.to_dict())
            return champions[run.path]
    rows = climb(a.runs, rises, replays=a.replays, mujoco_dt=a.mujoco_dt, pick=pick, allow=a.allow)
    print(table(rows, a.replays))
    print()
    print("| rise [cm] | runs | climb here | climb in MuJoCo C | climb in both |")
    print("|---:|---:|---:|---:|---:|")
    for rise, (n, here, there, both) in sorted(shares(rows).items()):
        print(f"| {100 * rise:g} | {n} | {here} | {there} | {both} |")
    if a.out:
        os.makedirs(a.out, exist_ok=True)
        with open(os.path.join(a.out, "climb.json"), "w") as f:
            json.dump({"rows": rows, "replays": a.replays, "allow": a.allow, "mujoco_dt": a.mujoco_dt}, f, indent=1)
        plot(rows, os.path.join(a.out, "climb.png"))
        print(f"\nwrote {a.out}/climb.json, climb.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
