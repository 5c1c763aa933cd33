"""Runs grouped into *cells*: every seed of one setting, as arrays ready for statistics and figures."""

from __future__ import annotations

import json
import os
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from cpgjax.io.results import nanreduce, read_run
from cpgjax.optim.es import GRADIENT
from cpgjax.optim.es import NAMES as ES_NAMES

Paths = Sequence[str | os.PathLike[str]]



@dataclass
class Cell:
    """The runs of one setting (all seeds): fitness ``[S, G, N]`` with NaN where invalid."""

    kind: str
    config: dict
    seeds: list[int]
    paths: list[str]
    fitness: np.ndarray          # [S, G, N] valid fitness (NaN: diverged)
    mutation_rate: np.ndarray    # [S, G]
    diversity: np.ndarray        # [S, G] genetic diversity: sd of each gene over the population, mean over genes

    @property
    def population(self) -> int:
        return int(self.fitness.shape[2])

    def best_per_generation(self) -> np.ndarray:
        """``[S, G]`` best valid fitness of each generation (NaN when none is valid)."""
        return nanreduce(np.nanmax, self.fitness)

    def mean_per_generation(self) -> np.ndarray:
        return nanreduce(np.nanmean, self.fitness)

    def best_so_far(self) -> np.ndarray:
        """``[S, G]`` best valid fitness up to and including each generation."""
        b = np.where(np.isfinite(self.best_per_generation()), self.best_per_generation(), -np.inf)
        out = np.maximum.accumulate(b, axis=1)
        return np.where(np.isfinite(out), out, np.nan)

    def best_trial(self) -> int:
        """Index (into ``seeds``) of the run with the highest best fitness (the thesis-style single trial)."""
        return int(np.nanargmax(np.nanmax(self.best_per_generation(), axis=1)))

    def evaluations(self) -> np.ndarray:
        """Evaluations done at the end of each generation (x of Fig. 6.10-6.12)."""
        return (np.arange(self.fitness.shape[1]) + 1) * self.population

    def label(self) -> str:
        c = self.config
        if self.kind == "ga":
            s = f"γ={c.get('gamma'):g}"
            if c.get("pocket"):
                s += f", pocket {c.get('pocket')}"
            if c.get("crossover"):
                s += ", cross-over"
            return s
        if self.kind == "amc":
            return f"adaptive MC, M={c.get('M')}"
        if self.kind in ES_NAMES:
            s = f"{ES_NAMES[self.kind]}, N={c.get('population')}, σ0={c.get('sigma'):g}"
            return s + (f", lr={c.get('lr'):g}" if self.kind in GRADIENT else "")
        return "random search"


def load_cells(paths: Paths) -> list[Cell]:
    """Group run files into cells (same kind and configuration but the seed), truncated to the shortest run."""
    groups: dict[str, list] = {}
    for p in paths:
        run = read_run(p)
        cfg = {k: v for k, v in run.config.items() if k not in ("seed", "chunk")}
        key = json.dumps([run.kind, cfg], sort_keys=True)
        groups.setdefault(key, []).append(run)
    cells = []
    for runs in groups.values():
        runs.sort(key=lambda r: int(r.config.get("seed", 0)))
        g = min(r.completed for r in runs)
        if g == 0:
            continue
        cfg = {k: v for k, v in runs[0].config.items() if k not in ("seed", "chunk")}
        cells.append(Cell(kind=runs[0].kind, config=cfg, seeds=[int(r.config.get("seed", 0)) for r in runs],
                          paths=[r.path for r in runs],
                          fitness=np.stack([r.valid_fitness()[:g] for r in runs]),
                          mutation_rate=np.stack([r.mutation_rate[:g] for r in runs]),
                          diversity=np.stack([r.genomes[:g].std(axis=1).mean(axis=-1) for r in runs])))
    cells.sort(key=_order)
    return cells


def _order(c: Cell):
    k = {"ga": 0, "random": 1, "amc": 2, **{m: 3 + i for i, m in enumerate(ES_NAMES)}}.get(c.kind, 9)
    cfg = c.config
    return (k, int(bool(cfg.get("crossover"))), cfg.get("pocket", 0), cfg.get("gamma", 0), cfg.get("M", 0),
            cfg.get("population", 0))
