"""Fitness against generation, thesis Fig. 6.5-6.11 style, for one or several runs on one axis.

Per run: the population's fitness as a cloud of points (every valid individual of every
generation), and lines.  A GA run draws the best of each generation, the best so far and the mean
fitness of each generation (Fig. 6.5, 6.7-6.9); a search run (random, adaptive Monte Carlo) draws the best
estimate so far and the overall mean as a horizontal line (Fig. 6.10-6.11).  With runs of
different kinds, or ``x="evaluations"``, the x axis counts evaluations so that all methods
share one scale (Fig. 6.12).  Diverged individuals are left out.  The title names the model and the
episode length (from the runs' meta) unless one is given.
"""

from __future__ import annotations

import os
from collections.abc import Sequence

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from cpgjax.errors import ResultsError
from cpgjax.io.results import Run, read_run


def run_label(run: Run) -> str:
    """A short legend label: file name and the settings that tell runs apart."""
    name = os.path.splitext(os.path.basename(run.path))[0]
    c = run.config
    if run.kind == "ga":
        parts = [f"μmax={c.get('mu_max')}", f"γ={c.get('gamma')}"]
        if c.get("pocket"):
            parts.append(f"P={c.get('pocket')}")
        if c.get("crossover"):
            parts.append("cross-over")
    elif run.kind == "amc":
        parts = [f"AMC M={c.get('M')}"]
    else:
        parts = ["random search"]
    if run.meta.get("evaluation", "thesis") != "thesis":
        parts.append(f"{run.meta['evaluation']} evaluation")
    return f"{name} ({', '.join(parts)})"


def default_title(runs: Sequence[Run]) -> str:
    """The model(s) and the episode length(s) of the runs, from their meta (``quadruped.wl, 10 s episodes``)."""
    models = sorted({os.path.basename(str(r.meta.get("model_path") or r.attrs.get("problem", "?"))) for r in runs})
    times = sorted({float(r.meta["time"]) for r in runs if isinstance(r.meta.get("time"), (int, float))})
    text = ", ".join(models)
    if times:
        text += ", " + " / ".join(f"{t:g}" for t in times) + " s episodes"
    terrains = sorted({str(r.meta["terrain"]) for r in runs if r.meta.get("terrain")} - {"flat"})
    if terrains:
        text += ", terrain " + " / ".join(terrains)
    return text


def plot_runs(paths: Sequence[str | os.PathLike[str]], out: str | os.PathLike[str] | None = None, *,
              x: str = "auto", cloud: bool = True, title: str | None = None) -> Figure:
    """Plot runs on one axis; save to ``out`` if given; return the figure.

    ``x``: ``"generation"``, ``"evaluations"`` or ``"auto"`` (evaluations when the runs mix
    GA and search kinds or population sizes, generations otherwise).
    """
    runs = [read_run(p) for p in paths]
    if not runs:
        raise ValueError("no runs to plot")
    for run in runs:
        if run.completed == 0 or run.fitness.shape[0] == 0:
            raise ResultsError(f"{run.path}: no generations in the file")
    if x == "auto":
        mixed = len({r.kind == "ga" for r in runs}) > 1 or len({int(r.attrs["population"]) for r in runs}) > 1
        x = "evaluations" if mixed else "generation"
    if x not in ("generation", "evaluations"):
        raise ValueError(f"x must be generation, evaluations or auto, got {x!r}")
    fig = Figure(figsize=(8, 5), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    colors = [f"C{i % 10}" for i in range(len(runs))]
    for run, color in zip(runs, colors, strict=True):
        n_gen, n = run.fitness.shape if run.fitness.ndim == 2 else (0, 0)
        if n_gen == 0:
            continue
        xs = np.arange(n_gen) * (n if x == "evaluations" else 1) + (n if x == "evaluations" else 0)
        v = run.valid_fitness()
        label = run_label(run)
        if cloud:
            xx = np.repeat(xs, n).reshape(n_gen, n)
            ok = np.isfinite(v)
            ax.scatter(xx[ok], v[ok], s=4, color=color, alpha=0.25, linewidths=0,
                       label=f"{label}: each individual")
        gen_best = run.best_per_generation()
        so_far = np.fmax.accumulate(np.where(np.isnan(gen_best), -np.inf, gen_best))
        so_far = np.where(np.isfinite(so_far), so_far, np.nan)
        if run.kind == "ga":
            ax.plot(xs, gen_best, color=color, lw=1.5, label=f"{label}: best of the generation")
            ax.plot(xs, so_far, color=color, lw=1.0, ls=":", label=f"{label}: best so far")
            ax.plot(xs, run.mean_per_generation(), color=color, lw=1.0, ls="--", label=f"{label}: mean")
        else:
            ax.plot(xs, so_far, color=color, lw=1.5, label=f"{label}: best so far")
            if np.any(np.isfinite(v)):
                ax.axhline(float(np.nanmean(v)), color=color, lw=1.0, ls="--", label=f"{label}: mean")
    ax.set_xlabel("evaluations" if x == "evaluations" else "generation")
    ax.set_ylabel("fitness")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize="small", markerscale=3)
    ax.set_title(title if title is not None else default_title(runs))
    if out is not None:
        d = os.path.dirname(os.fspath(out))
        if d:
            os.makedirs(d, exist_ok=True)
        fig.savefig(os.fspath(out), dpi=120)
    return fig
