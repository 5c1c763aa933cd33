"""``cpgjax adapt``: a damaged robot finds a gait of its repertoire by trial (Intelligent Trial and Error).

:func:`adapt` runs :func:`cpgjax.optim.ite.ite` over a repertoire's elites on the damaged robot
(:mod:`cpgjax.episode.damage`): each trial is one episode of one elite on the damaged robot, of the
repertoire's length, terrain and pipeline; the search sees only the trial's fitness.

:func:`study` is the measurement of docs/results/repertoire.md, for damages x repertoires (one per seed):

- the **best reachable damaged performance** ``R``: every elite of the repertoire scored on the damaged
  robot (one batched simulation; a robot's result does not depend on its batch, so each equals the trial
  of that elite), the best of them;
- **IT&E**: the number of trials until the best trial reaches ``level x R`` (default 70 %), with the
  stopping rule off so that the count is not cut short, and where the stopping rule stops, within the
  adaptation's own budget of trials (``ite_stop_trial``, ``ite_stop_fitness`` and its share of ``R``,
  ``ite_stop_share``: what a robot running ``cpgjax adapt`` with the same settings gets);
- **the GA from scratch** (the thesis's GA, :mod:`cpgjax.optim.ga`, its seed the repertoire's) on the
  damaged robot: the number of evaluations until its best so far reaches the same level.

**The GP's space** (``space``): ``"descriptor"`` is Cully et al.'s, the elites' behaviour descriptors scaled to
the grid's bounds (:func:`normalised`), with ``cfg``'s length scale and noise.  ``"genome"``: the elites' genomes
(the CPG coefficients, each scaled by its standard deviation over the elites, :func:`genome_space`), with the
Matérn length scale and the observation noise fitted by maximum marginal likelihood to the repertoire's *intact*
fitness over that space (:func:`fit_kernel`; Rasmussen & Williams 2006, eq. 2.30, type-II maximum likelihood
over a grid), i.e. from what the robot knows before the damage.  ``"both"``: the genome and the descriptor
together, each dimension standardised over the elites and the two groups weighted equally (:func:`joint_space`),
fitted the same way.  Beyond Cully et al., whose GP lives in the descriptor space with a fixed ``rho``: the
damaged fitness of near neighbours correlates more in the genome space than in the duty descriptor's
(docs/repertoire.md); what each space brings, damage by damage: docs/results/repertoire.md (damage recovery at
full scale).

Per damage, :func:`study_medians` summarises the rows over the repertoires (the medians the command prints
and docs/repertoire.md's tables quote).  Each row also keeps ``scores``, every elite's damaged fitness (in
the order of ``Repertoire.cells``; None where the episode diverged), so that other IT&E settings can be
measured on the same case without simulating again (IT&E only reads them).
"""

from __future__ import annotations

import dataclasses
import math
import os
import time as _time

import jax
import numpy as np

from cpgjax.errors import ResultsError
from cpgjax.experiments.repertoire import Repertoire, read_repertoire
from cpgjax.io.wl import load_wl
from cpgjax.optim.behaviour import behaviour_problem
from cpgjax.optim.ite import SPACES, ITEConfig, ite

ADAPT_DEFAULTS = ITEConfig()


def damaged_problem(model: str, rep: Repertoire, damage: str | None):
    """The repertoire's problem (descriptor, episode, terrain, pipeline) on the robot with ``damage``."""
    import json

    text = load_wl(model).text
    if rep.meta.get("model_text") and text != rep.meta["model_text"]:
        raise ResultsError(f"{model}: not the model the repertoire {rep.path} was made with (its text differs)")
    cli = json.loads(rep.meta.get("cli_problem_args") or "{}")
    return behaviour_problem(model, descriptor=str(rep.meta["descriptor"]), time=float(rep.meta["time"]),
                             terrain=cli.get("terrain"), pipeline=str(rep.meta.get("pipeline") or "springs"),
                             damage=damage)


def normalised(rep: Repertoire, idx) -> np.ndarray:
    """The descriptors of the elites ``idx`` scaled to the grid's bounds ([0, 1] per dimension)."""
    lo, hi = rep.grid.lower.astype(np.float64), rep.grid.upper.astype(np.float64)
    return (rep.descriptors[idx].astype(np.float64) - lo) / (hi - lo)


FIT_RHOS = (1.0, 1.5, 2.0, 3.0, 4.0, 5.0, 6.0, 8.0, 11.0, 16.0)
FIT_NOISES = (1e-3, 0.01, 0.03, 0.1, 0.3)


def genome_space(genomes) -> np.ndarray:
    """The genomes [C, ...] flattened to [C, G], each gene centred and divided by its standard deviation over the
    C elites (a gene constant over them: centred only)."""
    g = np.asarray(genomes, np.float64).reshape(len(genomes), -1)
    sd = g.std(0)
    return (g - g.mean(0)) / np.where(sd > 0, sd, 1.0)


def joint_space(genomes, descriptors) -> np.ndarray:
    """[C, G + D]: the genome space (:func:`genome_space`) and the descriptors, each dimension standardised the
    same way and the descriptor's then multiplied by ``sqrt(G / D)``, so that the two groups weigh the same in
    the squared distance (expected over pairs of elites: 2 G each)."""
    g = genome_space(genomes)
    d = genome_space(descriptors)
    return np.concatenate([g, d * math.sqrt(g.shape[1] / d.shape[1])], axis=1)


def fit_kernel(x, y, *, rhos=FIT_RHOS, noises=FIT_NOISES, n: int = 500, seed: int = 0) -> tuple[float, float]:
    """The Matérn-5/2 length scale and noise (a share of the variance, as :class:`ITEConfig`'s) of the grid
    ``rhos`` x ``noises`` maximising the log marginal likelihood of ``y`` [C] over the points ``x`` [C, D]
    (Rasmussen & Williams 2006, eq. 2.30), ``y`` centred, the kernel's variance the variance of ``y``; on a
    random subset of ``n`` points (seeded) when there are more."""
    from scipy.linalg import cho_factor, cho_solve

    from cpgjax.optim.ite import matern52

    x, y = np.asarray(x, np.float64), np.asarray(y, np.float64)
    if len(y) > n:
        sub = np.random.default_rng(seed).choice(len(y), n, replace=False)
        x, y = x[sub], y[sub]
    y = y - y.mean()
    v = float(y.var()) if y.var() > 0 else 1.0
    best = (np.inf, float(rhos[0]), float(noises[0]))
    for rho in rhos:
        K = matern52(x, x, float(rho), v)
        for noise in noises:
            c = cho_factor(K + float(noise) * v * np.eye(len(y)), lower=True)
            nll = 0.5 * float(y @ cho_solve(c, y)) + float(np.log(np.diag(c[0])).sum())
            if nll < best[0]:
                best = (nll, float(rho), float(noise))
    return best[1], best[2]


def search_space(rep: Repertoire, idx, space: str, cfg: ITEConfig, *, fit: bool = True) -> tuple[np.ndarray, ITEConfig]:
    """The points of the GP for the elites ``idx`` and the settings it runs with (module docstring): the
    descriptor with ``cfg``, or the genome with ``rho`` and ``noise`` fitted to the intact fitness (``fit``;
    else ``cfg``'s)."""
    if space == "descriptor":
        return normalised(rep, idx), cfg
    if space in ("genome", "both"):
        x = genome_space(rep.genomes[idx]) if space == "genome" else joint_space(rep.genomes[idx], rep.descriptors[idx])
        if fit:
            rho, noise = fit_kernel(x, rep.fitness[idx])
            cfg = dataclasses.replace(cfg, rho=rho, noise=noise)
        return x, cfg
    raise ValueError(f"unknown space {space!r}: expected one of {', '.join(SPACES)}")


def adapt(model: str, repertoire: str, damage: str, cfg: ITEConfig = ADAPT_DEFAULTS, *, space: str = "descriptor",
          fit: bool = True) -> dict:
    """IT&E on the robot with ``damage``: one episode per trial, the GP over ``space`` (see the module
    docstring)."""
    rep = read_repertoire(repertoire)
    problem = damaged_problem(model, rep, damage)
    f = jax.jit(problem.evaluate)
    idx = rep.cells
    genomes = rep.genomes[idx]

    def trial(i: int) -> float:
        r = f(genomes[i][None])
        return float(r["fitness"][0]) if not bool(r["diverged"][0]) else float("nan")

    x, cfg = search_space(rep, idx, space, cfg, fit=fit)
    r = ite(x, rep.fitness[idx], trial, cfg)
    trials = [{"cell": int(idx[t["index"]]), "descriptor": [float(v) for v in rep.descriptors[idx[t["index"]]]],
               "predicted": t["predicted"], "fitness": t["fitness"]} for t in r["trials"]]
    return {"damage": problem.meta["damage"], "repertoire": rep.path, "trials": trials,
            "best_cell": int(idx[r["best_index"]]), "best_fitness": r["best_fitness"],
            "descriptor_names": list(rep.grid.names),
            "best_descriptor": [float(v) for v in rep.descriptors[idx[r["best_index"]]]],
            "prior_best": float(rep.fitness[idx].max()), "stop": r["stop"], "space": space,
            "config": dataclasses.asdict(cfg)}


def damaged_scores(problem, genomes: np.ndarray, batch: int = 512) -> np.ndarray:
    """Every genome's fitness on ``problem`` (NaN where diverged), in batches."""
    f = jax.jit(problem.evaluate)
    out = []
    for s in range(0, len(genomes), batch):
        r = jax.device_get(f(genomes[s:s + batch]))
        out.append(np.where(r["diverged"], np.nan, r["fitness"]))
    return np.concatenate(out)


def first_reaching(best_so_far: np.ndarray, level: float) -> int | None:
    """1-based index of the first entry >= level (None if none)."""
    hit = np.flatnonzero(np.asarray(best_so_far) >= level)
    return int(hit[0]) + 1 if hit.size else None


def median_count(counts) -> float | None:
    """The median of counts where ``None`` means "never reached" (an infinite count): ``None`` when at least half
    of them are, else the median with each ``None`` counted as infinite."""
    counts = list(counts)
    if not counts or 2 * sum(c is None for c in counts) >= len(counts):
        return None
    return float(np.median([np.inf if c is None else c for c in counts]))


def study_medians(rows: list[dict]) -> list[dict]:
    """Per damage, in the order of ``rows`` (:func:`study`'s), over its repertoires: ``ite_trials`` and, where
    the GA from scratch ran, ``ga_evaluations``, the median counts to the level (:func:`median_count`: ``None``,
    not reached in at least half of them); ``ite_stop_trial`` and ``ite_stop_share``, the medians of the trials
    after which IT&E's own stopping rule stopped and of its best trial then as a share of ``R`` (the rows')."""
    out = []
    for damage in dict.fromkeys(r["damage"] for r in rows):
        own = [r for r in rows if r["damage"] == damage]
        m = {"damage": damage, "repertoires": len(own), "ite_trials": median_count(r["ite_trials"] for r in own)}
        if any("ga_budget" in r for r in own):
            m["ga_evaluations"] = median_count(r.get("ga_evaluations") for r in own)
        m["ite_stop_trial"] = float(np.median([r["ite_stop_trial"] for r in own]))
        m["ite_stop_share"] = float(np.median([r["ite_stop_share"] for r in own]))
        out.append(m)
    return out


def study(model: str, repertoires: list[str], damages: list[str], *, level: float = 0.7,
          trials: int = 50, ga_generations: int = 0, ga_population: int = 20, progress: bool = False,
          cfg: ITEConfig = ADAPT_DEFAULTS, space: str = "descriptor", fit: bool = True) -> dict:
    """The table of docs/results/repertoire.md: per damage and repertoire, ``R``, IT&E's trials and the GA's
    evaluations to reach ``level x R`` (see the module docstring), and per damage their medians
    (``medians``: :func:`study_medians`).  IT&E runs with ``cfg`` (its GP and
    search) over ``space`` (:func:`search_space`): at most ``trials`` trials with the stopping rule off, at most
    ``cfg.trials`` with it on."""
    from tqdm.auto import tqdm

    from cpgjax.experiments.evolve import run_ga
    from cpgjax.optim.ga import GAConfig

    reps = [read_repertoire(p) for p in repertoires]
    spaces = [search_space(rep, rep.cells, space, cfg, fit=fit) for rep in reps]   # fitted once per repertoire
    rows = []
    bar = tqdm(total=len(damages) * len(reps), desc="adapt", unit="case", disable=not progress)
    problems: dict = {}
    for damage in damages:
        for rep, (x, rcfg) in zip(reps, spaces, strict=True):
            t0 = _time.perf_counter()
            key = (damage, rep.meta.get("descriptor"), rep.meta.get("time"), rep.meta.get("terrain"),
                   rep.meta.get("pipeline"))
            if key not in problems:
                problems[key] = damaged_problem(model, rep, damage)
            problem = problems[key]
            idx = rep.cells
            scores = damaged_scores(problem, rep.genomes[idx])
            R = float(np.nanmax(scores))
            r = ite(x, rep.fitness[idx], lambda i, s=scores: float(s[i]),
                    dataclasses.replace(rcfg, trials=min(trials, len(idx))), stop=False)
            ys = np.maximum.accumulate([t["fitness"] for t in r["trials"]])
            stopped = ite(x, rep.fitness[idx], lambda i, s=scores: float(s[i]),
                          dataclasses.replace(rcfg, trials=min(cfg.trials, len(idx))))
            row = {"damage": problem.meta["damage"], "repertoire": rep.path, "seed": int(rep.config.get("seed", 0)),
                   "elites": int(len(idx)), "R": R, "intact_best": float(rep.fitness[idx].max()),
                   "ite_trials": first_reaching(ys, level * R), "ite_best": float(ys[-1]),
                   "ite_trials_run": len(ys), "ite_stop_trial": len(stopped["trials"]),
                   "ite_stop_fitness": stopped["best_fitness"], "ite_stop_share": stopped["best_fitness"] / R,
                   "space": space, "rho": rcfg.rho,
                   "noise": rcfg.noise,
                   "scores": [None if not np.isfinite(v) else float(v) for v in scores]}
            if ga_generations:
                cfg_ga = GAConfig(population=ga_population, generations=ga_generations,
                                  seed=int(rep.config.get("seed", 0)))
                s = run_ga(problem, cfg_ga)
                fit = np.where(s["history"]["diverged"], -np.inf, s["history"]["fitness"]).reshape(-1)
                row.update(ga_evaluations=first_reaching(np.maximum.accumulate(fit), level * R),
                           ga_best=float(fit.max()), ga_budget=int(fit.size))
            row["seconds"] = _time.perf_counter() - t0
            rows.append(row)
            bar.update(1)
    bar.close()
    return {"model": os.fspath(model), "level": level, "rows": rows, "medians": study_medians(rows)}
