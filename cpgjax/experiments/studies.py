"""The time-step stability study behind the simulator's default step (docs/simulator.md).

For each step dt it runs, on the quadruped: standing with zero targets (5 s), the
hand-written trot (10 s), and 64 random controllers from the GA's search box (10 s),
and reports the largest pivot-spring stretch, the deepest contact, how steady the
standing height is, how far the trot walks, and how many episodes diverged.  The
default is the largest dt at which pivots stay within 1 mm, no contact blows up (no
divergence, penetration within a few mm), and the robot stands and walks as at the
smallest dt.
"""

from __future__ import annotations

import time

import numpy as np


def timestep_study(model_path: str, ctl_path: str, dts, *, time_s: float = 10.0, n_random: int = 64,
                   seed: int = 0, out: str | None = None):
    from cpgjax.episode.batch import simulate
    from cpgjax.io.ctl import read_ctl
    from cpgjax.io.wl import load_model

    base = load_model(model_path)
    trot = np.asarray(read_ctl(ctl_path, n_dof=base.n_ctrl, harmonics=base.harmonics).coeffs)
    rng = np.random.default_rng(seed)
    rand = rng.uniform(-0.8, 0.8, (n_random, base.n_ctrl, base.n_coeff))
    zero = np.zeros_like(trot)
    rows = []
    for dt in dts:
        m = base.replace(dt=dt)
        t0 = time.perf_counter()
        stand = simulate(m, zero, time=5.0, record=True)
        z = stand["traj"]["x"][:, 2, m.track]
        tt = stand["traj"]["t"]
        walk = simulate(m, trot, time=time_s)
        rnd = simulate(m, rand, time=time_s)
        ok = ~rnd["diverged"]
        rows.append({
            "dt": dt,
            "stand_height": float(z[-1]),
            "stand_swing_mm": 1000 * float(np.ptp(z[tt >= 1.0])) if np.any(tt >= 1.0) else float("nan"),
            "stand_pivot_mm": 1000 * float(stand["pivot_err"]),
            "stand_depth_mm": 1000 * float(stand["depth"]),
            "trot_distance": float(walk["distance"]),
            "trot_pivot_mm": 1000 * float(walk["pivot_err"]),
            "trot_fallen": bool(walk["fallen"]),
            "trot_diverged": bool(walk["diverged"] or stand["diverged"]),
            "random_diverged": int(rnd["diverged"].sum()),
            "random_pivot_p95_mm": 1000 * float(np.percentile(rnd["pivot_err"][ok], 95)) if ok.any() else np.nan,
            "random_depth_max_mm": 1000 * float(rnd["depth"][ok].max()) if ok.any() else np.nan,
            "wall_s": time.perf_counter() - t0,
        })
        print(_fmt_row(rows[-1]), flush=True)
    text = table(rows, n_random, time_s)
    print()
    print(text)
    if out:
        with open(out, "w") as f:
            f.write(text + "\n")
    return rows


HEAD = ("| dt [s] | stand z [m] | stand swing [mm] | stand pivot [mm] | stand depth [mm] | trot dist [m] "
        "| trot pivot [mm] | trot fell | diverged (stand/trot) | random diverged | random pivot p95 [mm] "
        "| random depth max [mm] |")


def _fmt_row(r):
    return (f"| {r['dt']:.1e} | {r['stand_height']:.4f} | {r['stand_swing_mm']:.2f} | {r['stand_pivot_mm']:.3f} "
            f"| {r['stand_depth_mm']:.2f} | {r['trot_distance']:+.3f} | {r['trot_pivot_mm']:.3f} "
            f"| {'yes' if r['trot_fallen'] else 'no'} | {'yes' if r['trot_diverged'] else 'no'} "
            f"| {r['random_diverged']} | {r['random_pivot_p95_mm']:.3f} | {r['random_depth_max_mm']:.2f} |")


def table(rows, n_random, time_s):
    lines = [HEAD, "|" + "---|" * 12]
    lines += [_fmt_row(r) for r in rows]
    lines.append(f"\nstand: zero targets, 5 s (swing: peak-to-peak CM height after 1 s); trot: "
                 f"models/quadruped-trot.ctl, {time_s:g} s; random: {n_random} controllers uniform in "
                 f"[-0.8, 0.8]^G, {time_s:g} s.")
    return "\n".join(lines)
