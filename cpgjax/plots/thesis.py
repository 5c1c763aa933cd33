"""The thesis's evolution figures (Fig. 6.5-6.12) from run files, each over several seeds.

Every function takes run files (any number of cells x seeds; runs are grouped into *cells* by
their stored configuration without the seed) and returns a matplotlib ``Figure`` (Agg canvas,
no global backend change).  Where the thesis showed one run, we show, per cell, the **mean
over seeds with a band (± 1 sd)** and, thin, the thesis-style **single best trial** (the seed
whose best fitness is highest), so that an effect can be told from noise.

* :func:`fig_6_5` — GA, fixed mutation rate: fitness vs generation (best trial's population as
  a cloud, best and mean of each generation);
* :func:`fig_6_6` — mu(GEN) of eq. 6.1 for several gamma (mu_max 10 %), optionally with the
  rates stored in run files;
* :func:`fig_6_7` / :func:`fig_6_8` / :func:`fig_6_9` — gamma sweep: replication only / with
  pocketing / with cross-over (best of each generation);
* :func:`fig_6_10` — random search: best so far and overall mean vs evaluations;
* :func:`fig_6_11` — adaptive Monte Carlo, one curve per M;
* :func:`fig_6_12` — all methods on one fitness scale, x in evaluations: (A) GA variants,
  (B) random search and adaptive MC.
"""

from __future__ import annotations

import os
from collections.abc import Sequence

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from cpgjax.analysis.cells import Cell, load_cells
from cpgjax.episode.cpg import GENE_BOX

Paths = Sequence[str | os.PathLike[str]]
__all__ = ["Cell", "load_cells"]  # re-exported for the notebooks


def _figure(ncols: int = 1, size=(7.5, 4.5), sharey: bool = False):
    fig = Figure(figsize=size, layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(1, ncols, sharey=sharey, squeeze=False)[0]
    return fig, list(axes)


def _band(ax, x, ys: np.ndarray, color, label: str, lw: float = 1.8, ls: str = "-") -> None:
    """Mean over seeds (rows of ``ys``) with a ± 1 sd band."""
    m = np.nanmean(ys, axis=0)
    s = np.nanstd(ys, axis=0) if ys.shape[0] > 1 else np.zeros_like(m)
    ax.plot(x, m, color=color, lw=lw, ls=ls, label=f"{label} (mean of {ys.shape[0]} seeds ± sd)")
    ax.fill_between(x, m - s, m + s, color=color, alpha=0.18, linewidth=0)


def _cloud(ax, x, fit: np.ndarray, color, alpha: float = 0.25) -> None:
    ok = np.isfinite(fit)
    xx = np.repeat(np.asarray(x)[:, None], fit.shape[1], axis=1)
    ax.scatter(xx[ok], fit[ok], s=4, color=color, alpha=alpha, linewidths=0)


def _finish(ax, xlabel: str, title: str | None = None, legend: bool = True) -> None:
    ax.set_xlabel(xlabel)
    ax.set_ylabel("fitness (eq. 4.6)")
    ax.grid(alpha=0.3)
    if title:
        ax.set_title(title, fontsize=10)
    if legend:
        ax.legend(fontsize=7, loc="best")


def _ga_cells(paths: Paths, who: str) -> list[Cell]:
    cells = [c for c in load_cells(paths) if c.kind == "ga"]
    if not cells:
        raise ValueError(f"{who} needs GA runs; none among the {len(paths)} files given")
    return cells


def fig_6_5(paths: Paths, title: str | None = None) -> Figure:
    """Fig. 6.5: GA (fixed mutation rate, replication only): fitness vs generation.

    Left: the best trial (thesis style): its population as a cloud, the best and mean of each
    generation.  Right: best and mean of each generation, mean over seeds ± sd.
    """
    cells = _ga_cells(paths, "fig_6_5")
    fig, (a, b) = _figure(2, (11, 4.5), sharey=True)
    for i, c in enumerate(cells):
        col = f"C{i}"
        x = np.arange(c.fitness.shape[1])
        t = c.best_trial()
        _cloud(a, x, c.fitness[t], col)
        a.plot(x, c.best_per_generation()[t], color=col, lw=1.5, label=f"{c.label()}: best (seed {c.seeds[t]})")
        a.plot(x, c.mean_per_generation()[t], color=col, lw=1.0, ls="--", label=f"{c.label()}: mean")
        _band(b, x, c.best_per_generation(), col, f"{c.label()}: best")
        _band(b, x, c.mean_per_generation(), col, f"{c.label()}: mean", lw=1.0, ls="--")
    _finish(a, "generation", "best trial: population, best and mean per generation")
    _finish(b, "generation", "over seeds")
    fig.suptitle(title or f"Fig. 6.5 — GA, population {cells[0].population}, fixed μ = "
                 f"{cells[0].config.get('mu_max', 0) * 100:g} %, replication only", fontsize=11)
    return fig


def fig_6_6(gammas: Sequence[float] = (0.0, 0.01, 0.1, 1.0), mu_max: float = 0.1, generations: int = 150,
            paths: Paths | None = None, title: str | None = None) -> Figure:
    """Fig. 6.6: the mutation rate mu(GEN) = mu_max / (1 + gamma GEN) (eq. 6.1) for several gamma.

    With ``paths``, the rates stored in those GA runs (``/mutation_rate``) are drawn as points on
    top (scaled to ``mu_max``), which checks that the GA used eq. 6.1.
    """
    from cpgjax.optim.ga import expected_mutation_rates

    fig, (ax,) = _figure(1, (7, 4.5))
    gen = np.arange(generations)
    for i, g in enumerate(gammas):
        ax.plot(gen, 100 * expected_mutation_rates(mu_max, g, generations), color=f"C{i}", lw=1.8,
                label=f"γ = {g:g}")
    if paths:
        for c in (c for c in load_cells(paths) if c.kind == "ga"):
            g = float(c.config.get("gamma", 0))
            i = next((j for j, v in enumerate(gammas) if abs(v - g) < 1e-12), None)
            r = c.mutation_rate[0] * mu_max / float(c.config.get("mu_max", mu_max))
            ax.plot(np.arange(r.size), 100 * r, ".", ms=3, color=f"C{i}" if i is not None else "k", alpha=0.6)
    ax.set_xlabel("generation")
    ax.set_ylabel("mutation rate μ (%)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(title or f"Fig. 6.6 — μ = μmax / (1 + γ·GEN), μmax = {mu_max * 100:g} % (eq. 6.1)", fontsize=11)
    return fig


def _gamma_figure(paths: Paths, title: str) -> Figure:
    cells = _ga_cells(paths, "this figure")
    fig, (a, b) = _figure(2, (11, 4.5), sharey=True)
    for i, c in enumerate(cells):
        col = f"C{i}"
        x = np.arange(c.fitness.shape[1])
        _band(a, x, c.best_per_generation(), col, c.label())
        t = c.best_trial()
        _cloud(b, x, c.fitness[t], col, alpha=0.12)
        b.plot(x, c.best_per_generation()[t], color=col, lw=1.2, label=f"{c.label()} (seed {c.seeds[t]})")
    _finish(a, "generation", "best of each generation, mean over seeds ± sd")
    _finish(b, "generation", "best trial per setting: population cloud and best per generation")
    fig.suptitle(title, fontsize=11)
    return fig


def fig_6_7(paths: Paths, title: str | None = None) -> Figure:
    """Fig. 6.7: GA with gamma = 0, 0.01, 0.1, 1, replication only (pass those runs)."""
    return _gamma_figure(paths, title or "Fig. 6.7 — γ sweep, replication only (population 20, μmax 20 %)")


def fig_6_8(paths: Paths, title: str | None = None) -> Figure:
    """Fig. 6.8: the gamma sweep with pocketing (4 of 20)."""
    return _gamma_figure(paths, title or "Fig. 6.8 — γ sweep with pocketing")


def fig_6_9(paths: Paths, title: str | None = None) -> Figure:
    """Fig. 6.9: the gamma sweep with cross-over, mutation and pocketing."""
    return _gamma_figure(paths, title or "Fig. 6.9 — γ sweep with cross-over, mutation and pocketing")


def _search_figure(paths: Paths, kinds: tuple[str, ...], title: str) -> Figure:
    cells = [c for c in load_cells(paths) if c.kind in kinds]
    if not cells:
        raise ValueError(f"no {'/'.join(kinds)} runs given")
    fig, (a, b) = _figure(2, (11, 4.5), sharey=True)
    for i, c in enumerate(cells):
        col = f"C{i}"
        x = c.evaluations()
        _band(a, x, c.best_so_far(), col, f"{c.label()}: best so far")
        mean = float(np.nanmean(c.fitness))
        a.axhline(mean, color=col, lw=1.0, ls="--", label=f"{c.label()}: mean of all samples {mean:.3g}")
        t = c.best_trial()
        _cloud(b, x, c.fitness[t], col, alpha=0.12)
        b.plot(x, c.best_so_far()[t], color=col, lw=1.5, label=f"{c.label()}: best so far (seed {c.seeds[t]})")
        tm = float(np.nanmean(c.fitness[t]))
        b.axhline(tm, color=col, lw=1.0, ls="--", label=f"{c.label()}: its mean {tm:.3g}")
    _finish(a, "evaluations", "over seeds")
    _finish(b, "evaluations", "best trial: every sample, best so far, mean")
    fig.suptitle(title, fontsize=11)
    return fig


def fig_6_10(paths: Paths, title: str | None = None) -> Figure:
    """Fig. 6.10: random search in the hypercube of side 1.6: best so far and mean vs evaluations."""
    return _search_figure(paths, ("random",), title or f"Fig. 6.10 — random search in [−{GENE_BOX:g}, {GENE_BOX:g}]^G")


def fig_6_11(paths: Paths, title: str | None = None) -> Figure:
    """Fig. 6.11: adaptive Monte Carlo search, M = 3, 5, 10: best so far and mean vs evaluations."""
    return _search_figure(paths, ("amc",), title or "Fig. 6.11 — adaptive Monte Carlo search")


def fig_6_12(ga_paths: Paths, search_paths: Paths, title: str | None = None) -> Figure:
    """Fig. 6.12: all methods on one fitness scale, x in evaluations.

    (A) each GA variant: best of each generation of its best trial (thin) and the mean over
    seeds ± sd (band); (B) random search and adaptive MC: best so far, same.  Same y scale.
    """
    ga_cells = [c for c in load_cells(ga_paths) if c.kind == "ga"]
    s_cells = [c for c in load_cells(search_paths) if c.kind != "ga"]
    fig, (a, b) = _figure(2, (12, 4.8), sharey=True)
    for panel, cells, curve, what in ((a, ga_cells, "best_per_generation", "best of generation"),
                                      (b, s_cells, "best_so_far", "best so far")):
        for i, c in enumerate(cells):
            col = f"C{i}"
            ys = getattr(c, curve)()
            _band(panel, c.evaluations(), ys, col, c.label())
            t = c.best_trial()
            panel.plot(c.evaluations(), ys[t], color=col, lw=0.8, alpha=0.9)
        _finish(panel, "evaluations", f"({'A' if panel is a else 'B'}) {what}: mean ± sd; thin: best trial")
    fig.suptitle(title or "Fig. 6.12 — all methods, one fitness scale", fontsize=11)
    return fig


FIGURES = ("fig_6_5", "fig_6_6", "fig_6_7", "fig_6_8", "fig_6_9", "fig_6_10", "fig_6_11", "fig_6_12")
