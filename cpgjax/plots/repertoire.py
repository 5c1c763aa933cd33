"""Figures of a repertoire (beyond the thesis): the archive as a heatmap and its growth per evaluation.

:func:`heatmap` draws the elites' fitness over two descriptor dimensions: the grid itself for a 2-D
descriptor (speed x turning rate), else its projection on a pair of dimensions (each pixel: the best elite
over the other dimensions; the duty factors of the front legs, then of the hind legs).  :func:`growth`
draws the filled cells (coverage) and the QD-score against the evaluations.  :func:`figure` puts them side
by side.  They take a repertoire read back by :func:`cpgjax.experiments.repertoire.read_repertoire`
(any object with its fields: ``grid``, ``fitness``, ``filled``, ``evaluations``, ``n_filled``, ``qd_score``).
"""

from __future__ import annotations

import os

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from cpgjax.optim.mapelites import axis_label


def projection(rep, a: int, b: int) -> np.ndarray:
    """[bins_a, bins_b]: the best elite's fitness over the other dimensions (NaN: no elite)."""
    bins = tuple(rep.grid.bins)
    f = np.where(rep.filled, rep.fitness, -np.inf).reshape(bins)
    other = tuple(i for i in range(len(bins)) if i not in (a, b))
    m = f.max(axis=other) if other else f
    if a > b:
        m = m.T
    return np.where(np.isfinite(m), m, np.nan)


def heatmap(rep, ax, a: int = 0, b: int = 1, *, colorbar: bool = True):
    """Draw the projection of the archive on dimensions ``a`` (x) and ``b`` (y) on ``ax``."""
    g = rep.grid
    m = projection(rep, a, b)
    im = ax.imshow(m.T, origin="lower", aspect="auto", cmap="viridis",
                   extent=(g.lower[a], g.upper[a], g.lower[b], g.upper[b]))
    ax.set_xlabel(axis_label(g.names[a]))
    ax.set_ylabel(axis_label(g.names[b]))
    if colorbar:
        ax.figure.colorbar(im, ax=ax, label="fitness (best elite)")
    return im


def growth(rep, ax) -> None:
    """Filled cells and QD-score against the evaluations (two y axes)."""
    ev = np.asarray(rep.evaluations)
    ax2 = ax.twinx()
    q, = ax2.plot(ev, rep.qd_score, color="C1", linestyle="--", linewidth=1.5, label="QD-score (right)")
    ax2.set_ylabel("QD-score (sum of the elites' fitness)", color="C1")
    c, = ax.plot(ev, 100.0 * np.asarray(rep.n_filled) / rep.grid.n_cells, color="C0", linewidth=2.5,
                 label="coverage (left)")
    ax.set_xlabel("evaluations")
    ax.set_ylabel(f"coverage [% of {rep.grid.n_cells} cells]", color="C0")
    # the two curves often rise alike: coverage drawn solid and above (the twin axis is drawn over the first
    # one unless the first is raised), the QD-score dashed beneath, and a legend naming both
    ax.set_zorder(ax2.get_zorder() + 1)
    ax.patch.set_visible(False)
    ax.legend(handles=[c, q], loc="lower right")


def figure(rep, out: str | os.PathLike[str] | None = None, title: str | None = None) -> Figure:
    """The archive's heatmap(s) and its growth; saved to ``out`` if given."""
    D = len(rep.grid.names)
    pairs = [(0, 1)] if D == 2 else [(0, 1), (2, 3)] if D >= 4 else [(0, 1)] if D == 3 else []
    fig = Figure(figsize=(5.0 * (len(pairs) + 1), 4.2), layout="constrained")
    axes = fig.subplots(1, len(pairs) + 1, squeeze=False)[0]
    for ax, (a, b) in zip(axes, pairs, strict=False):
        heatmap(rep, ax, a, b)
    growth(rep, axes[-1])
    filled = int(np.sum(rep.filled))
    fig.suptitle(title or f"{os.path.basename(getattr(rep, 'path', ''))}: {filled} of {rep.grid.n_cells} cells, "
                          f"best {np.max(np.where(rep.filled, rep.fitness, -np.inf)):.3f}")
    if out is not None:
        FigureCanvasAgg(fig)
        fig.savefig(os.fspath(out), dpi=110)
    return fig
