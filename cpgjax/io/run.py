"""A run read back: its rows as numpy arrays and what is asked of them (the valid fitness, the best and the mean per
generation, the run's best individual).  Reading a file into one: :func:`cpgjax.io.results.read_run`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from cpgjax.errors import ResultsError


@dataclass
class Run:
    """A run file read back (rows truncated to ``completed``)."""

    path: str
    attrs: dict[str, Any]
    config: dict[str, Any]
    meta: dict[str, Any]
    genomes: np.ndarray        # [G, N, n_genes]
    fitness: np.ndarray        # [G, N], NaN kept
    diverged: np.ndarray       # [G, N]
    n_diverged: np.ndarray     # [G]
    mutation_rate: np.ndarray  # [G]
    wall_time: np.ndarray      # [G]
    metrics: dict[str, np.ndarray]
    state: dict[str, np.ndarray]
    writer: dict | None = None  # the process writing the file as it was read (cpgjax.io.runlock.holder), or None

    @property
    def kind(self) -> str:
        return str(self.attrs["kind"])

    @property
    def completed(self) -> int:
        return int(self.attrs["completed"])

    @property
    def pipeline(self) -> str:
        """The physics pipeline the run was scored on (``cpgjax.sim.model.PIPELINES``); runs made before it was
        recorded ran on the thesis's, "springs"."""
        return str(self.meta.get("pipeline") or "springs")

    def valid_fitness(self) -> np.ndarray:
        """Fitness with diverged / non-finite entries as NaN."""
        return np.where(self.diverged | ~np.isfinite(self.fitness), np.nan, self.fitness)

    def best_per_generation(self) -> np.ndarray:
        return nanreduce(np.nanmax, self.valid_fitness())

    def mean_per_generation(self) -> np.ndarray:
        return nanreduce(np.nanmean, self.valid_fitness())

    def best(self) -> tuple[int, int, float, np.ndarray]:
        """(generation, index, fitness, genome) of the best valid individual of the whole run."""
        if self.completed == 0 or self.fitness.shape[0] == 0:
            raise ResultsError(f"{self.path}: no generations in the file")
        v = self.valid_fitness()
        if v.size == 0 or not np.any(np.isfinite(v)):
            raise ResultsError(f"{self.path}: no valid (finite, not diverged) individual")
        gen, idx = np.unravel_index(int(np.nanargmax(v)), v.shape)
        return int(gen), int(idx), float(v[gen, idx]), self.genomes[gen, idx]


def nanreduce(fn, v: np.ndarray) -> np.ndarray:
    """``fn(v, axis=-1)`` (e.g. ``np.nanmax``) where a row has a finite entry, NaN where it has none (no warning)."""
    ok = np.any(np.isfinite(v), axis=-1)
    out = np.full(v.shape[:-1], np.nan)
    if np.any(ok):
        out[ok] = fn(v[ok], axis=-1)
    return out
