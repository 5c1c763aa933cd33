"""Where the engines part on evolved gaits: each gait replayed once, as it is, here and in MuJoCo C, with the feet
watched (``cpgjax agreement``; docs/results/engine-agreement.md).

The gaits: from every run file, the best individual of ``per_run`` generations spread evenly over the run (the
last included), so that one run gives gaits of several speeds; a genome met twice is kept once.

Per gait and engine, from the same samples (every ``sample`` s, MuJoCo's states at its own step):

- ``fell``: the body turned over (its up axis pointed down; the verdict of ``cpgjax transfer``), and ``speed``;
- ``depth``: how deep the feet that touch are in the ground, median / 99th percentile / largest [mm] (ours: the
  contact vertex under the terrain; MuJoCo: the foot sphere's penetration, ``-dist`` of its contact);
- ``steep``: the share of touching samples whose contact normal is more than :data:`STEEP` from vertical (ours:
  the terrain's normal under the vertex; MuJoCo: its contact frame's);
- ``slip``: the touching feet's mean speed along the ground [mm/s] between two samples at which they touch;
- ``slip_deep``: the same over the samples at which a foot is deeper than :data:`DEEP` in both, several times as
  deep as a resting foot sinks, where the ground pushes hard unless the foot is on its way out (0 where none is);
- ``landings``: how often a foot lands, per leg and second (a foot that bounces lands more often than it steps);
- ``past``: how far a joint went past its limit, the largest over joints and samples [rad] (ours: a penalty
  torque pushes it back; MuJoCo: its soft limit constraint, :mod:`cpgjax.crosscheck.limits`);
- ``lost``: for a gait that falls, the leg whose last touch before the fall's onset (tilt past 60 degrees) came
  first: the first leg to lose the ground.

With ``replays`` > 0 each gait is also replayed that many times jittered (genes moved by N(0, 1e-3^2), the draws of
``cpgjax transfer``) in each engine, and ``falls`` counts its falls there, ``speed_median`` their median speed: one
replay's verdict and speed on a marginal gait are chaotic, so the verdict compared is then whether it falls in at
least half of them.

The summary: the share of gaits on whose fall the engines agree, and the Spearman correlation of their speeds (as
they are, and with replays also of the replays' median speeds).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field

import numpy as np

from cpgjax.crosscheck.engines import foot_geoms, joint_angles, mujoco_closed_run, root_slice
from cpgjax.crosscheck.mjcf import load
from cpgjax.crosscheck.ranks import spearman
from cpgjax.episode.descriptors import legs
from cpgjax.episode.rollout import FALL_TILT
from cpgjax.sim.rotation import quat_to_mat_np

STEEP = math.radians(25.0)   # a contact normal this far from vertical pushes sideways
SAMPLE = 0.002               # s: the feet are watched at this interval in both engines
DEEP = 0.002                 # m: slip_deep counts feet deeper than this (the quadruped at rest: 0.34 mm)


@dataclass
class Watch:
    """One gait's feet in one engine, sampled: positions [S, L, 3], touching [S, L], depth [S, L] (m), the contact
    normal's z [S, L], the body's up z [S], the joints' angles [S, nj]."""

    feet: np.ndarray
    touch: np.ndarray
    depth: np.ndarray
    nz: np.ndarray
    up: np.ndarray
    angle: np.ndarray | None = None


@dataclass
class Gait:
    label: str
    ours: dict = field(default_factory=dict)
    mujoco: dict = field(default_factory=dict)


def pick_gaits(run, per_run: int) -> list[tuple[int, np.ndarray]]:
    """(generation, genome) of the best valid individual of ``per_run`` generations spread over the run."""
    v = run.valid_fitness()
    G = v.shape[0]
    gens = sorted({int(round(x)) - 1 for x in np.linspace(G / per_run, G, per_run)})
    out, seen = [], []
    for g in gens:
        row = v[g]
        if not np.any(np.isfinite(row)):
            continue
        g_best = run.genomes[g, int(np.nanargmax(row))]
        if any(np.array_equal(g_best, h) for h in seen):
            continue
        seen.append(g_best)
        out.append((g, np.asarray(g_best, np.float32)))
    return out


def diagnose(w: Watch, leg_names, sample: float, limits=None) -> dict:
    """The per-engine figures of the module docstring from one :class:`Watch`; ``limits``: the joints' (lo, hi)
    (None: ``past`` is 0)."""
    t = w.touch
    d = w.depth[t] * 1e3
    steep = float(np.mean(w.nz[t] < math.cos(STEEP))) if t.any() else 0.0
    both = t[1:] & t[:-1]
    step = np.linalg.norm(np.diff(w.feet[..., :2], axis=0), axis=-1) / sample
    slip = float(step[both].mean() * 1e3) if both.any() else 0.0
    deep = both & (w.depth[1:] > DEEP) & (w.depth[:-1] > DEEP)
    slip_deep = float(step[deep].mean() * 1e3) if deep.any() else 0.0
    landings = float(np.sum(np.diff(t.astype(np.int8), axis=0) == 1) / t.shape[1] / (sample * len(t)))
    onset = np.nonzero(w.up < math.cos(FALL_TILT))[0]
    lost = "—"
    if len(onset) and (w.up < 0).any():
        k = int(onset[0])
        last = [int(np.nonzero(t[:k, j])[0][-1]) if t[:k, j].any() else -1 for j in range(t.shape[1])]
        lost = leg_names[int(np.argmin(last))]
    past = 0.0
    if limits is not None and w.angle is not None:
        lo, hi = (np.asarray(x, float) for x in limits)
        past = float(np.maximum(w.angle - hi, lo - w.angle).max(initial=0.0))
    return {"past": past, "depth": tuple(float(x) for x in (np.percentile(d, [50, 99]).tolist() + [d.max()])) if d.size
            else (0.0, 0.0, 0.0), "steep": steep, "slip": slip, "slip_deep": slip_deep, "landings": landings,
            "lost": lost}


def watch_ours(model, controller, time: float, sample: float = SAMPLE) -> tuple[dict, list[Watch]]:
    """Our simulator's metrics and one :class:`Watch` per controller (robots first), recorded every ``sample`` s."""
    import jax
    import jax.numpy as jnp

    from cpgjax.episode.probes import Record
    from cpgjax.episode.rollout import rollout
    from cpgjax.sim.terrain import height_and_normal

    c = jax.tree.map(lambda a: jnp.moveaxis(jnp.asarray(a), 0, -1), controller)
    out = jax.jit(lambda cc: rollout(model, cc, time=time, probes=(Record(),), log_rate=1.0 / sample))(c)
    out = jax.tree.map(np.asarray, out)
    x, q = out["traj"]["x"], out["traj"]["q"]                       # [S, 3, nb, B], [S, 4, nb, B]
    feet = legs(model)[1]                                           # [L, nc]
    pts = np.asarray(model.ct_pt)
    body = np.asarray(model.pt_body)[pts]
    local = np.asarray(model.pt_local)[:, pts]                      # [3, nc]
    R = quat_to_mat_np(np.moveaxis(q[:, :, body], 1, 0))            # [3, 3, S, nc, B]
    p = x[:, :, body] + np.moveaxis(np.einsum("ijsnb,jn->isnb", R, local), 0, 1)   # [S, 3, nc, B]
    zg, n = height_and_normal(model.terrain, jnp.asarray(p[:, 0]), jnp.asarray(p[:, 1]))
    zg, nz = np.asarray(zg), np.asarray(n[2]) + np.zeros(p[:, 0].shape)
    depth = zg - p[:, 2]
    Rt = quat_to_mat_np(np.moveaxis(q[:, :, model.track], 1, 0))    # [3, 3, S, B]
    k = [np.nonzero(feet[j])[0][0] for j in range(feet.shape[0])]       # the first vertex of each foot
    watches = []
    for b in range(p.shape[-1]):
        watches.append(Watch(feet=np.moveaxis(p[:, :, k, b], 1, 2), touch=depth[:, k, b] > 0,
                             depth=np.maximum(depth[:, k, b], 0.0), nz=nz[:, k, b], up=Rt[2, 2, :, b],
                             angle=out["traj"]["angle"][:, :, b]))
    return {"speed": out["speed"], "fallen": out["fallen"]}, watches


def watch_mujoco(model, controller, time: float, timestep: float, sample: float = SAMPLE):
    """MuJoCo C's metrics and one :class:`Watch` per closed-loop controller, sampled every ``sample`` s."""
    mj = load(model, timestep=timestep)
    leg_of = foot_geoms(model, mj)
    L = int(leg_of.max()) + 1
    geoms = [int(np.nonzero(leg_of == j)[0][0]) for j in range(L)]
    every = max(1, int(round(sample / mj.opt.timestep)))
    root = root_slice(model, mj)
    hinge = joint_angles(model, mj, np.arange(mj.nq))          # the joints' qpos addresses, in the `.wl` order
    rows: list[list] = []

    def watch(step, datas):
        if step % every:
            return
        row = []
        for d in datas:
            touch, depth, nz = np.zeros(L, bool), np.zeros(L), np.ones(L)
            for i in range(d.ncon):
                con = d.contact[i]
                if con.dist > 0:
                    continue
                for g in (con.geom1, con.geom2):
                    j = leg_of[g]
                    if j >= 0 and -con.dist >= depth[j]:
                        touch[j], depth[j], nz[j] = True, -con.dist, abs(con.frame[2])
            R = quat_to_mat_np(d.qpos[root][3:])
            row.append((d.geom_xpos[geoms].copy(), touch, depth, nz, R[2, 2], d.qpos[hinge].copy()))
        rows.append(row)

    metrics, _, _ = mujoco_closed_run(model, controller, time=time, timestep=timestep, mj=mj, watch=watch)
    watches = []
    for b in range(len(rows[0])):
        col = [r[b] for r in rows]
        watches.append(Watch(feet=np.stack([c[0] for c in col]), touch=np.stack([c[1] for c in col]),
                             depth=np.stack([c[2] for c in col]), nz=np.stack([c[3] for c in col]),
                             up=np.asarray([c[4] for c in col]), angle=np.stack([c[5] for c in col])))
    return metrics, watches


def as_closed(model, family, controller):
    """``controller`` as a :class:`~cpgjax.episode.policy.ClosedLoop` for :func:`mujoco_closed_run`: an open-loop
    CPG gets a policy of zeros, which does what the CPG does."""
    from cpgjax.episode.policy import ClosedLoop, parse_controller

    if family is not None:
        return controller
    fam = parse_controller("pmtg:bias")
    C = np.asarray(controller, np.float32)
    return ClosedLoop(fam, C, np.zeros((len(C), fam.n_out(model), fam.n_in(model)), np.float32),
                      np.zeros(len(C), np.float32))


def compare_runs(paths, *, terrain: str, mujoco_dt: float, per_run: int = 6, pipeline: str | None = None,
                 time: float | None = None, ours: dict | None = None, replays: int = 0,
                 progress=None) -> list[Gait]:
    """Every run's gaits (:func:`pick_gaits`) replayed here and in MuJoCo C on ``terrain``, with the feet watched.
    ``ours``: fields of our side's Model replaced (``{"friction_k": 1e5}``); MuJoCo's export does not read them."""
    from cpgjax.crosscheck.transfer import cached_model, run_setting
    from cpgjax.episode.policy import family_from_meta, from_genomes
    from cpgjax.io.results import read_run
    from cpgjax.io.sweepdir import run_files

    out: list[Gait] = []
    changes = dict(ours or {})
    for path in run_files(paths):
        run = read_run(path)
        _, T, _ = run_setting(run)
        text = str(run.meta.get("model_text", ""))
        if not text:
            raise ValueError(f"{path}: the run holds no model (an analytic problem?): nothing to replay")
        model = cached_model(text, str(run.meta.get("model_path", path)), terrain, None, None, pipeline or run.pipeline)
        T = float(time or T or model.episode.time_max)
        picked = pick_gaits(run, per_run)
        family = family_from_meta(run.meta)
        C = from_genomes(family, model, np.stack([g for _, g in picked]))
        names, limits = legs(model)[0], (model.j_lo, model.j_hi)
        here, w_ours = watch_ours(model.replace(**changes) if changes else model, C, T)
        mj, w_mj = watch_mujoco(model, as_closed(model, family, C), T, mujoco_dt)
        for i, (gen, _) in enumerate(picked):
            g = Gait(f"{os.path.basename(path)}@{gen + 1}")
            g.ours = {"fell": bool(here["fallen"][i]), "speed": float(here["speed"][i])} | diagnose(
                w_ours[i], names, SAMPLE, limits)
            g.mujoco = {"fell": bool(mj["fallen"][i]), "speed": float(mj["speed"][i])} | diagnose(
                w_mj[i], names, SAMPLE, limits)
            if replays:
                g.ours["replays"] = g.mujoco["replays"] = replays
                (g.ours["falls"], g.ours["speed_median"]), (g.mujoco["falls"], g.mujoco["speed_median"]) = \
                    _jittered_falls(model, family, picked[i][1], T, mujoco_dt, replays,
                                    ours=model.replace(**changes) if changes else None)
            out.append(g)
            if progress is not None:
                progress(g)
    return out


def _jittered_falls(model, family, genome, time, mujoco_dt, replays, ours=None):
    """(falls, median speed) of ``replays`` jittered copies of one gait here, and in MuJoCo C (``cpgjax transfer``'s
    draws); ``ours``: our side's model where it differs from ``model`` (:func:`compare_runs`'s ``ours``), MuJoCo C
    exporting ``model`` whatever it is."""
    from cpgjax.crosscheck.engines import mujoco_run
    from cpgjax.crosscheck.transfer import jittered
    from cpgjax.episode.batch import simulate
    from cpgjax.episode.policy import from_genomes

    C = from_genomes(family, model, jittered(genome, replays)[1:])
    here = simulate(model if ours is None else ours, C, time=time)
    there, _, _ = mujoco_run(model, C, time=time, mj=load(model, timestep=mujoco_dt))
    return ((int(np.asarray(here["fallen"]).sum()), float(np.median(np.asarray(here["speed"])))),
            (int(np.asarray(there["fallen"]).sum()), float(np.median(np.asarray(there["speed"])))))


def falls(e: dict) -> bool:
    """An engine's verdict on a gait: it falls in at least half of its jittered replays, when it had some; else in
    its one replay as it is."""
    if "falls" in e and e.get("replays"):
        return 2 * e["falls"] >= e["replays"]
    return e["fell"]


def summary(gaits: list[Gait]) -> dict:
    """Fall agreement (share), the Spearman correlation of the speeds, and the counts behind them."""
    fo = np.array([falls(g.ours) for g in gaits])
    fm = np.array([falls(g.mujoco) for g in gaits])
    both = np.array([g.ours["fell"] and g.mujoco["fell"] for g in gaits], bool)
    same_leg = sum(1 for g, b in zip(gaits, both, strict=True) if b and g.ours["lost"] == g.mujoco["lost"])
    return {"gaits": len(gaits), "falls_agree": float(np.mean(fo == fm)), "fell_ours": int(fo.sum()),
            "fell_mujoco": int(fm.sum()), "fell_only_mujoco": int((fm & ~fo).sum()),
            "fell_only_ours": int((fo & ~fm).sum()),
            "spearman": spearman([g.ours["speed"] for g in gaits], [g.mujoco["speed"] for g in gaits]),
            "same_leg_lost": same_leg, "fell_both": int(both.sum())} | ({
                "spearman_replays": spearman([g.ours["speed_median"] for g in gaits],
                                             [g.mujoco["speed_median"] for g in gaits])}
                if gaits and all("speed_median" in g.ours for g in gaits) else {})


def _cells(e: dict) -> list[str]:
    d = e["depth"]
    falls_ = [f"{e['falls']}", f"{e['speed_median']:.3f}"] if e.get("replays") and "speed_median" in e else (
        [f"{e['falls']}"] if e.get("replays") else [])
    return [f"{e['speed']:.3f}{' (fell)' if e['fell'] else ''}", *falls_, f"{d[0]:.1f} / {d[1]:.1f} / {d[2]:.1f}",
            f"{100 * e['steep']:.0f} %", f"{e['slip']:.0f}", f"{e.get('slip_deep', 0.0):.0f}",
            f"{e['landings']:.1f}", f"{e.get('past', 0.0):.2f}",
            e["lost"]]


def table(gaits: list[Gait]) -> str:
    """The per-gait markdown table and the summary line under it."""
    n = gaits[0].ours.get("replays", 0) if gaits else 0
    med = bool(n) and all("speed_median" in g.ours for g in gaits)
    cols = ["speed [m/s]", *([f"falls of {n}"] if n else []), *([f"median speed of {n} [m/s]"] if med else []),
            "feet's depth, median / 99 % / max [mm]",
            "steep", "slip [mm/s]", f"slip deeper than {DEEP * 1e3:g} mm [mm/s]", "landings per leg [1/s]",
            "past a joint limit [rad]", "first leg lost"]
    head = ["gait"] + [f"{c} here" for c in cols] + [f"{c} in MuJoCo C" for c in cols]
    align = ["---"] + [("---" if c.startswith(("feet", "first")) else "---:") for c in cols] * 2
    rows = ["| " + " | ".join([g.label, *_cells(g.ours), *_cells(g.mujoco)]) + " |" for g in gaits]
    s = summary(gaits)
    verdict = f"falls in at least half of {n} jittered replays" if n else "falls in its replay as it is"
    agree = s["gaits"] - s["fell_only_mujoco"] - s["fell_only_ours"]
    line = (f"{s['gaits']} gaits; the verdict: a gait {verdict}.  The engines agree on {agree} of {s['gaits']} "
            f"({100 * s['falls_agree']:.0f} %; it falls here in {s['fell_ours']}, in MuJoCo C in {s['fell_mujoco']}, "
            f"only in MuJoCo C in {s['fell_only_mujoco']}, only here in {s['fell_only_ours']}); Spearman of the speeds "
            f"{s['spearman']:.2f}"
            + (f" (of the replays' median speeds {s['spearman_replays']:.2f})" if "spearman_replays" in s else "")
            + f"; of {s['fell_both']} that fall as they are in both, {s['same_leg_lost']} lose the "
            "same leg first")
    return "\n".join(["| " + " | ".join(head) + " |", "|" + "|".join(align) + "|", *rows, "", line])


def plot(gaits: list[Gait], out: str) -> None:
    """Four panels, one point per gait, here (x) against MuJoCo C (y): speed, the feet's slip, their landings per
    second, how far past a joint limit; hollow where the engines' fall verdicts differ."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(16, 4), layout="constrained")
    FigureCanvasAgg(fig)
    differ = [falls(g.ours) != falls(g.mujoco) for g in gaits]
    panels = (("speed", "speed [m/s]"), ("slip", "touching feet's slip [mm/s]"),
              ("landings", "landings per leg and second"), ("past", "farthest past a joint limit [rad]"))
    for k, (key, name) in enumerate(panels):
        ax = fig.add_subplot(1, len(panels), k + 1)
        x = np.array([g.ours.get(key, 0.0) for g in gaits])
        y = np.array([g.mujoco.get(key, 0.0) for g in gaits])
        hi = max(float(np.max(x, initial=0)), float(np.max(y, initial=0)), 1e-3) * 1.1
        lo = min(float(np.min(x, initial=0)), float(np.min(y, initial=0)), 0.0)
        ax.plot([lo, hi], [lo, hi], "k:", lw=1, label="same in both")
        d = np.array(differ, bool)
        ax.plot(x[~d], y[~d], "o", color="tab:blue", label="the engines agree on its fall verdict")
        if d.any():
            ax.plot(x[d], y[d], "o", mfc="none", color="tab:red", label="they differ")
        ax.set_xlabel(f"{name}, here")
        ax.set_ylabel(f"{name}, MuJoCo C")
        ax.grid(alpha=0.3)
        if k == 0:
            ax.legend(fontsize=7, loc="upper left")
    fig.suptitle("Evolved gaits here and in MuJoCo C, one point per gait")
    fig.savefig(out, dpi=100)
