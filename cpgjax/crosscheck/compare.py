"""`cpgjax crosscheck`: the same controllers in the penalty simulator, MuJoCo C and MJX (MJX: open-loop ones).

Per controller: forward distance, mean speed and fitness (eq. 4.6) in each engine; the
Spearman rank correlation of fitness between engines; and, for one chosen controller,
the joint angles and the CM path overlaid (thesis Fig. 6.3 and 6.4 style, with MuJoCo in
the place of the real robot).
"""

from __future__ import annotations

import json
import os

import numpy as np

from cpgjax.crosscheck.engines import joint_angles, mjx_run, mujoco_run
from cpgjax.crosscheck.mjcf import MJ_TIMESTEP
from cpgjax.crosscheck.ranks import spearman, spearman_interval
from cpgjax.episode.cpg import GENE_BOX

ENGINES = ("penalty", "mujoco", "mjx")


def controllers(model, *, ctl_files=(), run_files=(), n_random: int = 0, n_perturbed: int = 0,
                base_ctl: str | None = None, seed: int = 0):
    """(controllers, labels) from .ctl files, the best of GA runs, random and perturbed ones: coefficients
    [N, n_ctrl, 2K+1], or, when some are closed-loop, a :class:`~cpgjax.episode.policy.ClosedLoop` of N (the
    open-loop ones in it with a policy of zeros, which does what their CPG does; one family at a time)."""
    import jax

    from cpgjax.episode.policy import family_from_meta, from_control, from_genomes, stack
    from cpgjax.io.ctl import read_ctl

    out, labels = [], []
    for f in ctl_files:
        out.append(from_control(read_ctl(f, n_dof=model.n_ctrl, harmonics=model.episode.harmonics), model))
        labels.append(os.path.basename(f))
    for f in run_files:
        from cpgjax.io.results import read_run

        run = read_run(f)
        family = family_from_meta(run.meta)
        fit = run.valid_fitness()  # [gens, N]
        genomes = np.asarray(run.genomes).reshape(-1, run.genomes.shape[-1])
        order = np.argsort(-fit.reshape(-1))
        seen, kept = 0, []
        for k in order:
            g = genomes[k]
            if any(np.array_equal(g, h) for h in kept):
                continue
            kept.append(g)
            one = from_genomes(family, model, g[None].astype(np.float32))
            out.append(jax.tree.map(lambda a: np.asarray(a)[0], one))
            labels.append(f"{os.path.basename(f)}#{k}")
            seen += 1
            if seen >= 8:
                break
    rng = np.random.default_rng(seed)
    for i in range(n_random):
        out.append(rng.uniform(-GENE_BOX, GENE_BOX, (model.n_ctrl, model.n_coeff)))
        labels.append(f"random{i}")
    if n_perturbed and base_ctl:
        base = read_ctl(base_ctl, n_dof=model.n_ctrl, harmonics=model.episode.harmonics).coeffs
        for i in range(n_perturbed):
            out.append(np.clip(base + rng.normal(0.0, 0.1, base.shape), -GENE_BOX, GENE_BOX))
            labels.append(f"{os.path.basename(base_ctl)}+N(0,0.1)#{i}")
    return stack(out, model), labels


def run_crosscheck(model, coeffs, labels, *, time: float, delta: float = 8.0, mjx: bool = True,
                   ceiling: bool = True, show: int = 0, out_dir: str | None = None, mujoco_dt: float | None = None):
    """Run every engine; returns (rows, summary) and writes table + plots into out_dir.

    ``mujoco_dt``: MuJoCo C's step (None: the export's, ``mjcf.MJ_TIMESTEP``; on rough ground 0.25 ms, where a
    fast gait's verdict there settles: docs/crosscheck.md).  MJX keeps the export's.

    With ``ceiling``, MuJoCo C also runs every controller at half its step: the rank correlation
    of MuJoCo with itself (``rho_mujoco_half``) is what discretisation alone costs on this set of
    controllers, the ceiling against which the other engines' agreement with MuJoCo is read.  The
    penalty simulator does the same at half its step (``rho_penalty_half``): an engine cannot agree
    with MuJoCo better than it agrees with itself.
    """
    from cpgjax.episode.batch import simulate
    from cpgjax.episode.policy import is_closed

    res = {}
    pen = simulate(model, coeffs, time=time, delta=delta, record=True)
    res["penalty"] = pen
    mj_dt = MJ_TIMESTEP if mujoco_dt is None else float(mujoco_dt)
    mj_met, mj_q, _ = mujoco_run(model, coeffs, time=time, delta=delta, timestep=mj_dt)
    res["mujoco"] = mj_met
    if mjx and is_closed(coeffs):
        raise ValueError("MJX replays open-loop controllers only: add --no-mjx for closed-loop ones")
    if mjx:
        mx_met, mx_q, _, _ = mjx_run(model, coeffs, time=time, delta=delta, fast=True, sample_every=25)
        res["mjx"] = mx_met
    engines = [e for e in ENGINES if e in res]
    rows = []
    for i, lab in enumerate(labels):
        row = {"controller": lab}
        for e in engines:
            for k in ("distance", "speed", "fitness"):
                row[f"{e}_{k}"] = float(np.asarray(res[e][k])[i])
            row[f"{e}_fallen"] = bool(np.asarray(res[e]["fallen"])[i])
        rows.append(row)
    summary = {"n": len(labels), "time": time, "penalty_dt": model.dt, "penalty_alpha": model.joint_spring[0],
               "penalty_beta": model.joint_spring[1], "penalty_pipeline": model.pipeline, "terrain": model.terrain.spec,
               "mujoco_dt": mj_dt}
    for e in engines:
        summary[f"falls_{e}"] = int(np.sum(np.asarray(res[e]["fallen"], bool)))
    for a, b in (("penalty", "mujoco"), ("penalty", "mjx"), ("mujoco", "mjx")):
        if a in res and b in res:
            summary[f"rho_{a}_{b}"] = spearman(res[a]["fitness"], res[b]["fitness"])
            summary[f"ci_{a}_{b}"] = spearman_interval(res[a]["fitness"], res[b]["fitness"])
            summary[f"rho_dist_{a}_{b}"] = spearman(res[a]["distance"], res[b]["distance"])
            summary[f"ratio_{a}_{b}"] = distance_ratio(res[a], res[b])
    if ceiling:
        half = mujoco_run(model, coeffs, time=time, delta=delta, timestep=mj_dt / 2)[0]
        summary["rho_mujoco_half"] = spearman(res["mujoco"]["fitness"], half["fitness"])
        summary["ci_mujoco_half"] = spearman_interval(res["mujoco"]["fitness"], half["fitness"])
        summary["rho_dist_mujoco_half"] = spearman(res["mujoco"]["distance"], half["distance"])
        half = simulate(model.replace(dt=model.dt / 2), coeffs, time=time, delta=delta)
        summary["rho_penalty_half"] = spearman(pen["fitness"], half["fitness"])
        summary["ci_penalty_half"] = spearman_interval(pen["fitness"], half["fitness"])
        summary["rho_dist_penalty_half"] = spearman(pen["distance"], half["distance"])
    if out_dir:
        os.makedirs(out_dir, exist_ok=True)
        with open(os.path.join(out_dir, "crosscheck.md"), "w") as f:
            f.write(table(rows, summary, engines) + "\n")
        with open(os.path.join(out_dir, "crosscheck.json"), "w") as f:
            json.dump({"summary": summary, "controllers": rows}, f, indent=1, default=float)
        _plots(model, pen, mj_q, show, labels[show], out_dir, mj_dt=mj_dt, time=time)
    return rows, summary


WALKS = 0.1  # m: a controller "walks" in an engine when it stays up and goes at least this far forward


def distance_ratio(a: dict, b: dict) -> dict:
    """How far engine b carries the controllers that walk in both, against engine a: the ratio
    ``distance_b / distance_a`` per controller that stays up and goes at least :data:`WALKS` m forward in both,
    its median and quartiles (``n`` such controllers; NaN when none)."""
    da, db = np.asarray(a["distance"], float), np.asarray(b["distance"], float)
    ok = ~np.asarray(a["fallen"], bool) & ~np.asarray(b["fallen"], bool) & (da >= WALKS) & (db >= WALKS)
    r = db[ok] / da[ok]
    if not len(r):
        return {"n": 0, "median": float("nan"), "q1": float("nan"), "q3": float("nan")}
    q1, med, q3 = np.quantile(r, [0.25, 0.5, 0.75])
    return {"n": int(len(r)), "median": float(med), "q1": float(q1), "q3": float(q3)}


def table(rows, summary, engines) -> str:
    head = "| controller | " + " | ".join(f"{e} dist [m] | {e} fitness" for e in engines) + " |"
    lines = [head, "|---|" + "---:|---:|" * len(engines)]
    for r in rows:
        cells = []
        for e in engines:
            fell = " (fell)" if r[f"{e}_fallen"] else ""
            cells += [f"{r[f'{e}_distance']:+.3f}{fell}", f"{r[f'{e}_fitness']:+.4f}"]
        lines.append(f"| {r['controller']} | " + " | ".join(cells) + " |")
    lines.append("")
    if summary.get("penalty_pipeline") == "exact":
        lines.append(f"Our simulator: step {summary['penalty_dt'] * 1e3:g} ms, exact pipeline (exact joints: "
                     "generalized coordinates).")
    elif "penalty_dt" in summary:
        lines.append(f"Our simulator: step {summary['penalty_dt'] * 1e3:g} ms, pivot springs "
                     f"{summary['penalty_alpha']:g} N/m, {summary['penalty_beta']:g} N s/m (eq. 3.6), "
                     "springs pipeline.")
    if summary.get("mujoco_dt", MJ_TIMESTEP) != MJ_TIMESTEP:
        lines.append(f"MuJoCo C's step {summary['mujoco_dt'] * 1e3:g} ms (the export's {MJ_TIMESTEP * 1e3:g} ms).")
    if summary.get("terrain", "flat") != "flat":
        ledges = summary["terrain"].split(":")[0] in ("stairs", "bar", "gap")
        lines.append(f"Terrain {summary['terrain']}; " + ("MuJoCo's ground is boxes of the same profile "
                     "(crosscheck/ground.py: ledge_boxes)." if ledges else "MuJoCo's heightfield samples the same "
                     "surface (crosscheck/mjcf.py: hfield_grid)."))
    falls = ", ".join(f"{e} {summary[f'falls_{e}']}" for e in engines if f"falls_{e}" in summary)
    lines.append(f"{summary['n']} controllers, {summary['time']:g} s each; fell: {falls}.  Spearman rank correlation "
                 "(95 % bootstrap interval over the controllers):")
    for k, v in summary.items():
        if k.startswith("rho_") and not k.startswith("rho_dist"):
            a, b = k[4:].split("_")
            dist = summary["rho_dist_" + a + "_" + b]
            lo, hi = summary.get("ci_" + a + "_" + b, (float("nan"), float("nan")))
            val = f"{v:+.3f} [{lo:+.2f}, {hi:+.2f}]"
            if b == "half":
                step = summary.get("mujoco_dt", MJ_TIMESTEP) if a == "mujoco" else summary["penalty_dt"]
                lines.append(f"- fitness {a} vs {a} at half its step ({step / 2 * 1e3:g} ms): {val}  "
                             f"(distance: {dist:+.3f}); {a}'s ceiling: what discretisation alone costs")
            else:
                lines.append(f"- fitness {a} vs {b}: {val}  (distance: {dist:+.3f})")
    for k, v in summary.items():
        if k.startswith("ratio_"):
            a, b = k[6:].split("_")
            text = (f"{v['median']:.2f} (quartiles {v['q1']:.2f}-{v['q3']:.2f})" if v["n"] else "-")
            lines.append(f"- distance {b} / {a} over the {v['n']} controllers that walk in both (stay up, "
                         f">= {WALKS:g} m forward): median {text}")
    return "\n".join(lines)


def _plots(model, pen, mj_q, i, label, out_dir, mj_dt, time):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from cpgjax.crosscheck.mjcf import load

    mj = load(model) if mj_dt is None else load(model, timestep=mj_dt)     # MuJoCo's samples are its steps
    tr = pen["traj"]
    t_pen = tr["t"]
    t_mj = np.arange(mj_q.shape[1]) * mj.opt.timestep
    ang_mj = joint_angles(model, mj, mj_q)[i]
    # Fig. 6.3 style: the front right leg's knee and hip
    names = list(model.joint_names)
    pick = [n for n in ("KneeAR", "HipAR") if n in names] or names[:2]
    fig, axes = plt.subplots(len(pick), 1, figsize=(7, 2.6 * len(pick)), sharex=True)
    axes = np.atleast_1d(axes)
    for ax, n in zip(axes, pick, strict=True):
        j = names.index(n)
        ax.plot(t_pen, tr["angle"][:, j, i], label="penalty simulator")
        ax.plot(t_mj, ang_mj[:, j], label="MuJoCo", alpha=0.8)
        c = list(model.ctrl_joint).index(j) if j in model.ctrl_joint else None
        if c is not None:
            ax.plot(t_pen, tr["target"][:, c, i], "k:", lw=1, label="CPG target")
        ax.set_ylabel(f"{n} [rad]")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    axes[-1].set_xlabel("time [s]")
    fig.suptitle(f"joint angles, {label} (cf. thesis Fig. 6.3)")
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, "joints.png"), dpi=90)
    plt.close(fig)
    # Fig. 6.4 style: forward position vs time, and the CM path in the plane
    from cpgjax.crosscheck.engines import metrics_from_qpos

    cm_mj = metrics_from_qpos(model, mj, mj_q[i:i + 1], mj.opt.timestep)["cm"][0]
    from cpgjax.io.logs import pose_rows

    single = {k: (v[..., i] if k != "t" else v) for k, v in tr.items()}
    rows = pose_rows(single, model.track)
    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 3.8))
    a.plot(rows[:, 0], rows[:, 2], label="penalty simulator")
    a.plot(t_mj, cm_mj[:, 1], label="MuJoCo")
    a.set_xlabel("time [s]")
    a.set_ylabel("Y of the CM [m]")
    a.legend(fontsize=8)
    a.grid(alpha=0.3)
    b.plot(rows[:, 1], rows[:, 2], label="penalty simulator")
    b.plot(cm_mj[:, 0], cm_mj[:, 1], label="MuJoCo")
    b.set_xlabel("X [m]")
    b.set_ylabel("Y [m]")
    b.grid(alpha=0.3)
    b.set_aspect("equal", adjustable="datalim")
    fig.suptitle(f"CM path, {label} (cf. thesis Fig. 6.4)")
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, "cm_path.png"), dpi=90)
    plt.close(fig)


def traces(model, coeffs, *, time: float, delta: float = 8.0) -> list[dict]:
    """Joint angles and CM paths of N controllers [N, n_ctrl, 2K+1] in the penalty simulator and MuJoCo C.

    One dict per controller (thesis Figs. 6.3-6.4, MuJoCo in the place of the robot): ``joint_names``;
    ``penalty`` and ``mujoco``: ``t`` [S], ``angle`` [S, nj], ``cm`` [S, 3] of the tracked body and the
    episode's ``distance``, ``speed``, ``fitness``; ``target``: the CPG target [S] of each controlled
    joint (at the penalty simulator's samples).  Both engines run all controllers in one batch.
    """
    from cpgjax.crosscheck.engines import metrics_from_qpos
    from cpgjax.crosscheck.mjcf import load
    from cpgjax.episode.batch import simulate

    coeffs = np.asarray(coeffs, float)
    pen = simulate(model, coeffs, time=time, delta=delta, record=True)
    mj = load(model)
    mj_met, mj_q, _ = mujoco_run(model, coeffs, time=time, delta=delta, mj=mj)
    tr = pen["traj"]
    names = list(model.joint_names)
    ang_mj = joint_angles(model, mj, mj_q)
    cm_mj = metrics_from_qpos(model, mj, mj_q, mj.opt.timestep, delta)["cm"]
    t_mj = np.arange(mj_q.shape[1]) * mj.opt.timestep
    out = []
    for i in range(len(coeffs)):
        m = {k: {e: float(np.asarray(r[k])[i]) for e, r in (("penalty", pen), ("mujoco", mj_met))}
             for k in ("distance", "speed", "fitness")}
        out.append({
            "joint_names": names,
            "penalty": {"t": np.asarray(tr["t"]), "angle": np.asarray(tr["angle"])[:, :, i],
                        "cm": np.asarray(tr["x"])[:, :, model.track, i],
                        **{k: m[k]["penalty"] for k in m}},
            "mujoco": {"t": t_mj, "angle": ang_mj[i], "cm": cm_mj[i], **{k: m[k]["mujoco"] for k in m}},
            "target": {names[j]: np.asarray(tr["target"])[:, c, i] for c, j in enumerate(model.ctrl_joint)},
        })
    return out
