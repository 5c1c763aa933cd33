"""Stability under perturbation (thesis Ch. 6.4, Figs. 6.13-6.21) and its population study (``cpgjax stability``).

:func:`perturbation_experiment`: controllers walk on flat ground, over a bump of each height across their
path halfway through the episode, and on rough ground of each range (several fields each); every
controller x condition x field runs in one batch on one heightfield (:mod:`cpgjax.episode.courses`).
The episode scan records, at every log sample, the vestibular stability S(theta) (eq. 6.2) and the
projection stability (:mod:`cpgjax.episode.support`).  A first, flat-ground episode of each controller
says how far it walks, so that its bump lies halfway along its own path.

A robot has *fallen* when its body tilted past :data:`~cpgjax.episode.rollout.FALL_TILT` (60 degrees) at
some sample (S(theta) below S(60 deg)), or when its episode diverged.

:func:`population_study`: the same experiment on the final population (or the best of each generation)
of run files, grouped per GA setting (:func:`cpgjax.analysis.cells.load_cells`): fall probability per
condition for each run, then mean and spread over the seeds of a setting.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import asdict, dataclass, field

import jax
import jax.numpy as jnp
import numpy as np

from cpgjax.episode.batch import LANES, evaluate, simulate
from cpgjax.episode.courses import LEDGE_KINDS, Condition, conditions, course, placement
from cpgjax.episode.fitness import DEFAULT_DELTA, stability
from cpgjax.episode.policy import batch_size, family_from_meta, from_genomes, is_closed, table_fields
from cpgjax.episode.probes import Stability
from cpgjax.episode.rollout import FALL_TILT, schedule
from cpgjax.sim.ledges import RISE_MAX
from cpgjax.sim.variation import Variation


@dataclass(frozen=True)
class StabilityConfig:
    """The perturbation experiments' settings; the defaults are the thesis's (Ch. 6.4)."""

    bumps: tuple[float, ...] = (0.01, 0.02, 0.03)          # m: bump heights (Fig. 6.13)
    roughs: tuple[float, ...] = (0.01, 0.02, 0.03, 0.04)   # m: roughness ranges (Fig. 6.14)
    seeds: int = 4                 # rough fields per range (the thesis: one)
    bump_width: float = 0.3        # m: along the path
    stairs: tuple[float, ...] = ()  # m: rises of a flight of stairs halfway (episode.courses.STAIR_STEPS steps)
    bars: tuple[float, ...] = ()    # m: heights of a bar halfway (sim.ledges.BAR_DEPTH deep)
    time: float | None = None      # s: the episode (None: the model's TimeMax)
    delta: float = DEFAULT_DELTA   # eq. 6.2
    block: int = 1024              # robots per call (one compiled program; a progress step per call)

    def __post_init__(self) -> None:
        if any(not (math.isfinite(h) and h >= 0) for h in (*self.bumps, *self.roughs)):
            raise ValueError("bump heights and roughness ranges must be finite numbers >= 0 (metres)")
        if any(not (math.isfinite(h) and 0 < h <= RISE_MAX) for h in (*self.stairs, *self.bars)):
            raise ValueError(f"stair rises and bar heights must be numbers > 0 and <= {RISE_MAX:g} m")
        if self.seeds < 1:
            raise ValueError(f"seeds must be >= 1, got {self.seeds}")
        if not self.bump_width > 0:
            raise ValueError(f"bump width must be > 0 m, got {self.bump_width:g}")


@dataclass
class StabilityResult:
    """Every controller x condition: series [C, K, S] and scores [C, K] (K conditions, S log samples)."""

    names: list[str]
    conditions: list[Condition]
    t: np.ndarray                  # [S] s
    S: np.ndarray                  # [C, K, S] vestibular stability (eq. 6.2)
    proj: np.ndarray               # [C, K, S] projection stability (NaN: fewer than three vertices down)
    fell: np.ndarray               # [C, K] bool
    distance: np.ndarray           # [C, K] m
    S_mean: np.ndarray             # [C, K]
    proj_mean: np.ndarray          # [C, K] over the defined samples
    proj_undefined: np.ndarray     # [C, K] fraction of samples with fewer than three vertices down
    flat_distance: np.ndarray      # [C] the first, flat-ground episode (places the bumps)
    config: dict = field(default_factory=dict)

    def groups(self) -> list[tuple[str, list[int]]]:
        """Conditions grouped over their rough fields: [(label, condition indices)]."""
        out: dict[str, list[int]] = {}
        for k, c in enumerate(self.conditions):
            label = c.label.split(" #")[0]
            out.setdefault(label, []).append(k)
        return list(out.items())

    def fall_time(self) -> np.ndarray:
        """Time to fall [C, K] in s: the first log sample with S(theta) below the fall threshold (or not a
        number: diverged), the episode's length for a robot that stays up."""
        below = ~(self.S >= fall_threshold(self.config.get("delta", DEFAULT_DELTA)))
        end = float(self.t[-1]) if len(self.t) else 0.0
        return np.where(below.any(-1), self.t[np.argmax(below, -1)] if len(self.t) else 0.0, end)

    def summary(self) -> dict:
        """Per controller and condition (rough fields pooled): fall rate, mean S, projection stability."""
        rows = {}
        tf = self.fall_time()
        for i, name in enumerate(self.names):
            rows[name] = {}
            for label, ks in self.groups():
                pm = self.proj_mean[i, ks]
                rows[name][label] = {
                    "fall_rate": float(np.mean(self.fell[i, ks])),
                    "time_to_fall": float(np.mean(tf[i, ks])),
                    "mean_S": float(np.mean(self.S_mean[i, ks])),
                    "proj_mean": float(np.nanmean(pm)) if np.isfinite(pm).any() else None,
                    "proj_undefined": float(np.mean(self.proj_undefined[i, ks])),
                    "distance": float(np.mean(self.distance[i, ks])),
                    "episodes": len(ks)}
        return rows


def fall_threshold(delta: float = DEFAULT_DELTA) -> float:
    """S(theta) at the fall tilt: a sample below it is a fall."""
    return float(stability(jnp.float32(math.cos(FALL_TILT)), delta))


_JIT: dict = {}


def _runner(model, time, delta):
    key = (model, time, delta)       # the model's structure (sim.fingerprint)
    if key not in _JIT:
        _JIT[key] = jax.jit(lambda C, var: evaluate(model, C, var=var, time=time, delta=delta, probes=(Stability(),)))
    return _JIT[key]


def run_course(model, coeffs: np.ndarray, lane: np.ndarray, conds: list[Condition], flat_distance: np.ndarray,
               cfg: StabilityConfig, *, progress: bool = False) -> dict:
    """Run robots ``coeffs`` [N, n, 2K+1] on their lanes [N] of one course; returns batch-last numpy arrays."""
    from tqdm.auto import tqdm

    start_y = float(model.x0[1, model.track])
    bump_y = start_y
    reach = (float(model.x0[1].max()) - start_y, start_y - float(model.x0[1].min()))
    shift, lift, y_range = placement(conds, lane, flat_distance, start_y, bump_y, cfg.bump_width, reach)
    cm = model.replace(terrain=course(conds, y_range, bump_y, cfg.bump_width))
    N = batch_size(coeffs)
    block = max(LANES, min(cfg.block, -(-N // LANES) * LANES))
    total = -(-N // block) * block
    pad = lambda a: np.concatenate([a, np.repeat(a[..., -1:], total - N, -1)], -1) if total > N else a  # noqa: E731
    C = jax.tree.map(lambda a: pad(np.moveaxis(np.asarray(a), 0, -1)), coeffs)
    shift, lift = pad(shift), pad(lift)
    fn = _runner(cm, cfg.time, cfg.delta)
    parts = []
    for b in tqdm(range(0, total, block), desc="stability", unit="block", disable=not progress):
        var = Variation.nominal(cm, block)._replace(shift=jnp.asarray(shift[:, b:b + block]),
                                                    lift=jnp.asarray(lift[b:b + block]))
        out = fn(jax.tree.map(lambda a, b=b: jnp.asarray(np.moveaxis(a[..., b:b + block], -1, 0)), C), var)
        parts.append(jax.tree.map(np.asarray, out))
    return {k: np.concatenate([p[k] for p in parts], -1)[..., :N] for k in parts[0]}


def _run_grounds(model, coeffs, ci, lane, conds, flat_distance, cfg, progress) -> dict:
    """:func:`run_course` on the lanes of the heightfield conditions, then on each stair and bar (a ground of its
    own: their faces span every x), the results put back in the order of ``(ci, lane)``."""
    groups = [[k for k, c in enumerate(conds) if c.kind not in LEDGE_KINDS]]
    groups += [[k] for k, c in enumerate(conds) if c.kind in LEDGE_KINDS]
    out: dict = {}
    for g in groups:
        sel = np.nonzero(np.isin(lane, g))[0]
        if len(sel) == 0:
            continue
        remap = np.zeros(len(conds), int)
        remap[g] = np.arange(len(g))
        r = run_course(model, coeffs[ci[sel]], remap[lane[sel]], [conds[k] for k in g], flat_distance[ci[sel]], cfg,
                       progress=progress)
        for k, v in r.items():
            out.setdefault(k, np.zeros(v.shape[:-1] + (len(lane),), v.dtype))[..., sel] = v
    return out


def perturbation_experiment(model, coeffs: np.ndarray, names: list[str], cfg: StabilityConfig = StabilityConfig(),
                            *, progress: bool = False) -> StabilityResult:
    """Controllers [C, n, 2K+1] (or a :class:`~cpgjax.episode.policy.ClosedLoop` of C) on flat ground, bumps and
    rough fields, all in one batch (Figs. 6.13-6.21), and on stairs and bars (a batch each)."""
    coeffs = coeffs if is_closed(coeffs) else np.asarray(coeffs, np.float32)
    C = batch_size(coeffs)
    conds = conditions(cfg.bumps, cfg.roughs, cfg.seeds, stairs=cfg.stairs, bars=cfg.bars)
    K = len(conds)
    ci, lane = np.meshgrid(np.arange(C), np.arange(K), indexing="ij")
    ci, lane = ci.ravel(), lane.ravel()
    if K == 1:      # flat ground only (Fig. 6.19): the model's own ground, nothing to place
        r = jax.tree.map(np.asarray, _runner(model, cfg.time, cfg.delta)(jax.tree.map(jnp.asarray, coeffs), None))
        flat = r
    else:
        flat = simulate(model, coeffs, time=cfg.time, delta=cfg.delta)
        r = _run_grounds(model, coeffs, ci, lane, conds, np.asarray(flat["distance"], float), cfg, progress)
    inner, outer = schedule(model, cfg.time)
    t = (np.arange(outer) + 1) * inner * model.dt
    S = r["S"].T.reshape(C, K, -1)
    fell = (S.min(-1) < fall_threshold(cfg.delta)) | r["diverged"].reshape(C, K)
    return StabilityResult(
        names=list(names), conditions=conds, t=t, S=S, proj=r["proj"].T.reshape(C, K, -1), fell=fell,
        distance=r["distance"].reshape(C, K), S_mean=r["S_mean"].reshape(C, K),
        proj_mean=r["proj_mean"].reshape(C, K), proj_undefined=r["proj_undefined"].reshape(C, K) / outer,
        flat_distance=np.asarray(flat["distance"], float), config=asdict(cfg))


def save(result: StabilityResult, out_dir: str) -> str:
    """Write ``stability.npz`` (the series) into ``out_dir``; returns its path."""
    os.makedirs(out_dir, exist_ok=True)
    path = os.path.join(out_dir, "stability.npz")
    np.savez_compressed(path, names=np.asarray(result.names),
                        conditions=np.asarray([c.label for c in result.conditions]), t=result.t, S=result.S,
                        proj=result.proj, fell=result.fell, distance=result.distance,
                        S_mean=result.S_mean, proj_mean=result.proj_mean, proj_undefined=result.proj_undefined,
                        flat_distance=result.flat_distance, config=json.dumps(result.config))
    return path


def choose_stable_unstable(fitness: np.ndarray, S_mean_flat: np.ndarray, fell_any: np.ndarray) -> tuple[int, int]:
    """The thesis's pair from a population: (stable, unstable) indices.

    The thesis showed a "highly stable" and a "much lower vestibular stability" controller.  Among the
    walkers (fitness > 0), the stable one has the highest mean S(theta) on flat ground among those that
    never fell under any perturbation (if none: among all walkers); the unstable one has the lowest
    mean S(theta) on flat ground among the other walkers.
    """
    ok = np.isfinite(fitness) & (fitness > 0)
    idx = np.nonzero(ok)[0] if ok.any() else np.arange(len(fitness))
    robust = [i for i in idx if not fell_any[i]]
    stable = max(robust or list(idx), key=lambda i: S_mean_flat[i])
    rest = [i for i in idx if i != stable]
    unstable = min(rest or list(idx), key=lambda i: S_mean_flat[i])
    return int(stable), int(unstable)


# ---------------------------------------------------------------- the population study (beyond the thesis)

@dataclass
class PopulationStudy:
    """Fall probability per GA setting and condition: ``fall[cell]`` [seeds, K groups] (one row per run)."""

    labels: list[str]              # one per cell (GA setting)
    configs: list[dict]
    groups: list[str]              # condition groups: flat, bump 1 cm, ..., rough 1 cm, ...
    fall: list[np.ndarray]         # per cell [runs, groups]: fraction of the run's controllers (x fields) that fell
    S_mean: list[np.ndarray]       # per cell [runs, groups]
    controllers: int               # controllers scored per run
    config: dict = field(default_factory=dict)
    picks: dict = field(default_factory=dict)   # the thesis's pair (choose_stable_unstable): coeffs, policy, scores
    fall_time: list[np.ndarray] = field(default_factory=list)  # per cell [runs, groups]: mean time to fall, s

    def summary(self) -> dict:
        def band(a, j):
            return {"mean": float(a[:, j].mean()), "sd": float(a[:, j].std(ddof=1)) if a.shape[0] > 1 else 0.0}

        out = {}
        times = self.fall_time or [None] * len(self.labels)
        for lab, cfg, f, s, tf in zip(self.labels, self.configs, self.fall, self.S_mean, times, strict=True):
            out[lab] = {"gamma": cfg.get("gamma"), "pocket": cfg.get("pocket"), "crossover": cfg.get("crossover"),
                        "runs": int(f.shape[0]),
                        "fall": {g: band(f, j) for j, g in enumerate(self.groups)},
                        "fall_perturbed": float(f[:, 1:].mean()),
                        "mean_S": {g: float(s[:, j].mean()) for j, g in enumerate(self.groups)}}
            if tf is not None:
                out[lab]["time_to_fall"] = {g: band(tf, j) for j, g in enumerate(self.groups)}
                out[lab]["time_to_fall_perturbed"] = float(tf[:, 1:].mean())
        return out

    def ranking(self) -> tuple[list[str], str | None]:
        """GA settings from the most to the least robust, and the most robust one (None: a tie).

        Robust = the lowest fall probability over the perturbed grounds; between equal ones, the longest
        mean time to fall there (gaits that all fall within the episode are still told apart by when).
        """
        s = self.summary()
        key = {lab: (round(s[lab]["fall_perturbed"], 9), -round(s[lab].get("time_to_fall_perturbed", 0.0), 9))
               for lab in self.labels}
        order = sorted(self.labels, key=lambda lab: key[lab])
        best = order[0] if len(order) == 1 or key[order[0]] != key[order[1]] else None
        return order, best


def model_of(run, pipeline: str | None = None):
    """(model, episode length) a run was evolved on: its stored text, terrain and physics pipeline (``pipeline``:
    another one)."""
    from cpgjax.io.wl import parse_wl
    from cpgjax.sim.model import build_model

    text = str(run.meta.get("model_text", ""))
    if not text:
        raise ValueError(f"{run.path}: the run holds no model (an analytic problem?): nothing to perturb")
    cli = json.loads(run.meta.get("cli_problem_args", "{}") or "{}")
    model = build_model(parse_wl(text, str(run.meta.get("model_path", run.path))), terrain=cli.get("terrain"),
                        pipeline=pipeline or run.pipeline)
    return model, float(cli.get("time") or run.meta.get("time") or model.episode.time_max)




def controllers_of(run, which: str = "final", top: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(genomes, GA fitness) of a run to score: its final population (``final``) or the best of each generation
    (``best``).  ``top``: only the ``top`` fittest of them (None: all).
    """
    v = run.valid_fitness()
    g = run.completed
    if which == "final":
        G, f = run.genomes[g - 1], v[g - 1]
    elif which == "best":
        idx = np.nanargmax(np.where(np.isfinite(v[:g]), v[:g], -np.inf), axis=1)
        G, f = run.genomes[np.arange(g), idx], v[np.arange(g), idx]
    else:
        raise ValueError(f"which must be final or best, got {which!r}")
    if top is not None and top < len(f):
        order = np.argsort(np.where(np.isfinite(f), -f, np.inf), kind="stable")[:top]
        G, f = G[order], f[order]
    return G, f


def population_study(paths, cfg: StabilityConfig = StabilityConfig(), *, which: str = "final", top: int | None = None,
                     progress: bool = False, pipeline: str | None = None) -> PopulationStudy:
    """Score the controllers of every run (grouped per GA setting) under the perturbations, in one batch.

    ``pipeline``: the physics pipeline to score them on (None: the runs', as they recorded; they must agree)."""
    from cpgjax.analysis.cells import load_cells
    from cpgjax.io.results import read_run
    from cpgjax.io.sweepdir import run_files

    files = run_files(paths)
    cells = load_cells(files)
    if not cells:
        raise ValueError("no run with a completed generation among the given files")
    runs, per_cell = [], []
    model = time = None
    for c in cells:
        rs = [read_run(p) for p in c.paths]
        per_cell.append(len(rs))
        for r in rs:
            m, T = model_of(r, pipeline)
            if model is None:
                model, time = m, T
            elif m.description.text != model.description.text or T != time or m.pipeline != model.pipeline:
                raise ValueError(f"{r.path}: a different model, episode or physics pipeline from {runs[0].path}: "
                                 "study one model at a time")
            runs.append(r)
    picked = [controllers_of(r, which, top) for r in runs]
    n = min(len(g) for g, _ in picked)
    families = {family_from_meta(r.meta) for r in runs}
    if len(families) > 1:
        raise ValueError("runs of different controller families: study one family at a time")
    coeffs = from_genomes(families.pop(), model, np.concatenate([g[:n] for g, _ in picked]).astype(np.float32))
    fitness = np.concatenate([f[:n] for _, f in picked])
    cfg = StabilityConfig(**{**asdict(cfg), "time": cfg.time if cfg.time is not None else time})
    res = perturbation_experiment(model, coeffs, [f"r{i}c{j}" for i in range(len(runs)) for j in range(n)], cfg,
                                  progress=progress)
    groups = res.groups()
    fell = res.fell.reshape(len(runs), n, -1)
    S = res.S_mean.reshape(len(runs), n, -1)
    tf = res.fall_time().reshape(len(runs), n, -1)
    fall_g = np.stack([fell[:, :, ks].mean(axis=(1, 2)) for _, ks in groups], -1)      # [runs, groups]
    S_g = np.stack([S[:, :, ks].mean(axis=(1, 2)) for _, ks in groups], -1)
    tf_g = np.stack([tf[:, :, ks].mean(axis=(1, 2)) for _, ks in groups], -1)
    out_f, out_s, out_t, i = [], [], [], 0
    for k in per_cell:
        out_f.append(fall_g[i:i + k])
        out_s.append(S_g[i:i + k])
        out_t.append(tf_g[i:i + k])
        i += k
    stable, unstable = choose_stable_unstable(fitness, res.S_mean[:, 0], res.fell.any(axis=1))
    one = lambda i: jax.tree.map(lambda a: np.asarray(a)[i], coeffs)  # noqa: E731
    picks = {name: {"coeffs": one(i).coeffs if is_closed(coeffs) else one(i),
                    "policy": table_fields(one(i), model) if is_closed(coeffs) else None,
                    "ga_fitness": float(fitness[i]), "run": runs[i // n].path,
                    "S_flat": float(res.S_mean[i, 0]), "fell": {g: float(res.fell[i, ks].mean()) for g, ks in groups}}
             for name, i in (("stable", stable), ("unstable", unstable))}
    return PopulationStudy(labels=[c.label() for c in cells], configs=[c.config for c in cells],
                           groups=[g for g, _ in groups], fall=out_f, S_mean=out_s, fall_time=out_t, controllers=n,
                           config={**asdict(cfg), "which": which, "top": top, "runs": len(runs),
                                   "pipeline": model.pipeline}, picks=picks)
