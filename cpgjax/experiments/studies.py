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

from cpgjax.episode.cpg import GENE_BOX


def timestep_study(model_path: str, ctl_path: str, dts, *, time_s: float = 10.0, n_random: int = 64,
                   seed: int = 0, out: str | None = None, pipeline: str | None = None):
    from cpgjax.episode.batch import simulate
    from cpgjax.io.ctl import read_ctl
    from cpgjax.io.wl import load_model

    base = load_model(model_path, pipeline=pipeline)
    trot = np.asarray(read_ctl(ctl_path, n_dof=base.n_ctrl, harmonics=base.episode.harmonics).coeffs)
    rng = np.random.default_rng(seed)
    rand = rng.uniform(-GENE_BOX, GENE_BOX, (n_random, base.n_ctrl, base.n_coeff))
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
                 f"[-{GENE_BOX:g}, {GENE_BOX:g}]^G, {time_s:g} s.")
    return "\n".join(lines)


# ---------------------------------------------------------------------------------------------------------
# The friction bristle: steadiness of the score vs agreement with MuJoCo (docs/simulator.md)

def friction_study(model_path: str, ctl_path: str, springs, *, runs=(), replays: int = 64, jitter: float = 1e-6,
                   n_random: int = 8, n_perturbed: int = 16, time_s: float = 10.0, seed: int = 0, progress=None,
                   pipeline: str | None = None):
    """For each friction bristle ``(k, b)`` (``FrictionSpring`` in a `.wl`): how chaotic and how MuJoCo-like?

    - ``trot_sd``, ``trot_falls``: the controller ``ctl_path`` with every gene moved by N(0, jitter), ``replays``
      episodes here (the score's sensitivity; MuJoCo C's is in ``mujoco_trot_sd``);
    - ``ratio_median``, ``ratio_min``: MuJoCo C fitness / ours of the best of every run in ``runs`` (evolved
      gaits: do they carry over?);
    - ``rho``: Spearman rank correlation of fitness ours vs MuJoCo C over the crosscheck set (the controller,
      ``n_random`` random ones and ``n_perturbed`` with N(0, 0.1) added, as ``cpgjax crosscheck``).
    MuJoCo C runs once (its model does not depend on the bristle).  Returns one dict per spring.
    """
    from cpgjax.crosscheck.compare import controllers
    from cpgjax.crosscheck.engines import mujoco_run
    from cpgjax.crosscheck.mjcf import load
    from cpgjax.crosscheck.ranks import spearman
    from cpgjax.episode.batch import simulate
    from cpgjax.io.results import read_run
    from cpgjax.io.sweepdir import run_files
    from cpgjax.io.wl import load_model

    base = load_model(model_path, pipeline=pipeline)
    bests = []
    for p in run_files(runs):
        g = np.asarray(read_run(p).best()[3], np.float32)
        if g.size != base.n_ctrl * base.n_coeff:
            raise ValueError(f"{p}: its genomes have {g.size} genes, {model_path} needs {base.n_ctrl * base.n_coeff}")
        bests.append(g.reshape(base.n_ctrl, base.n_coeff))
    xc, _ = controllers(base, ctl_files=[ctl_path], n_random=n_random, n_perturbed=n_perturbed, base_ctl=ctl_path,
                        seed=seed)
    jit = xc[:1] + np.random.default_rng(seed).normal(0.0, jitter, (replays,) + xc.shape[1:])
    nb = len(bests)
    C = np.concatenate([np.asarray(bests, np.float32).reshape(nb, *xc.shape[1:]), xc, jit]).astype(np.float32)
    mj, _, _ = mujoco_run(base, C, time=time_s, mj=load(base))
    f_mj = np.asarray(mj["fitness"])
    rows = []
    for k, b in springs:
        m = base.replace(friction_k=float(k), friction_b=float(b))
        r = simulate(m, C, time=time_s)
        f = np.asarray(r["fitness"])
        ours_b, mj_b = f[:nb], f_mj[:nb]
        ratio = mj_b / np.where(ours_b != 0, ours_b, np.nan)
        jit_f = f[nb + len(xc):]
        rows.append({
            "k": float(k), "b": float(b),
            "trot_sd": float(np.std(jit_f)), "trot_mean": float(np.mean(jit_f)),
            "trot_falls": int(np.asarray(r["fallen"])[nb + len(xc):].sum()),
            "ratio_median": float(np.nanmedian(ratio)) if nb else float("nan"),
            "ratio_min": float(np.nanmin(ratio)) if nb else float("nan"),
            "ours_best_mean": float(ours_b.mean()) if nb else float("nan"),
            "rho": spearman(f[nb:nb + len(xc)], f_mj[nb:nb + len(xc)]),
            "mujoco_trot_sd": float(np.std(f_mj[nb + len(xc):])),
            "mujoco_best_mean": float(mj_b.mean()) if nb else float("nan"),
            "runs": nb, "replays": replays, "crosscheck": len(xc),
        })
        if progress is not None:
            progress(rows[-1])
    return rows


def friction_table(rows) -> str:
    """The friction study as a markdown table."""
    lines = ["| bristle k [N/m] | b [N s/m] | trot sd (jitter) | falls | evolved bests: MuJoCo/ours, median (min) "
             "| ours (MuJoCo) mean best | Spearman vs MuJoCo |",
             "|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        lines.append(f"| {r['k']:g} | {r['b']:g} | {r['trot_sd']:.4f} | {r['trot_falls']} of {r['replays']} "
                     f"| {r['ratio_median']:.2f} ({r['ratio_min']:.2f}) | {r['ours_best_mean']:.3f} "
                     f"({r['mujoco_best_mean']:.3f}) | {r['rho']:+.2f} |")
    if rows:
        r = rows[0]
        lines.append("")
        lines.append(f"MuJoCo C: trot sd {r['mujoco_trot_sd']:.4f} over the same {r['replays']} jittered replays; "
                     f"{r['runs']} run bests; Spearman over {r['crosscheck']} controllers.")
    return "\n".join(lines)
