"""Stability figures (thesis Figs. 6.13-6.21) and the population study's fall probabilities.

* :func:`condition_panels` — one controller, one measure (vestibular S(theta), eq. 6.2, or projection
  stability), one kind of perturbation: a panel per condition, the perturbed run solid, the flat run
  dashed (the thesis's layout; rough fields: the first field solid, the others thin);
* :func:`flat_panel` — one controller on flat ground (Fig. 6.19, the hexapod);
* :func:`fall_probability` — the population study: fall probability vs bump height and vs roughness
  range, one line per GA setting, mean over seeds with a ± 1 sd band.
"""

from __future__ import annotations

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

MEASURES = {"vestibular": ("S", "vestibular stability S(θ)"), "projection": ("proj", "projection stability")}


def _figure(n: int, size_per=(3.2, 2.6)):
    cols = min(n, 4)
    rows = -(-n // cols)
    fig = Figure(figsize=(size_per[0] * cols, size_per[1] * rows + 0.5), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(rows, cols, squeeze=False, sharey=True).ravel()
    for ax in axes[n:]:
        ax.set_visible(False)
    return fig, axes[:n]


def condition_panels(result, i: int, measure: str, kind: str) -> Figure | None:
    """Controller ``i`` of a :class:`~cpgjax.experiments.stability.StabilityResult`, ``kind`` bump or rough."""
    key, ylabel = MEASURES[measure]
    series = getattr(result, key)[i]
    groups = [(lab, ks) for lab, ks in result.groups() if result.conditions[ks[0]].kind == kind]
    if not groups:
        return None
    flat = series[0]
    fig, axes = _figure(len(groups))
    for ax, (lab, ks) in zip(axes, groups, strict=True):
        ax.plot(result.t, flat, "k--", lw=1, label="flat")
        for j, k in enumerate(ks):
            ax.plot(result.t, series[k], color="C3", lw=1.4 if j == 0 else 0.5, alpha=1.0 if j == 0 else 0.5,
                    label=lab if j == 0 else None)
        fell = result.fell[i, ks].mean()
        ax.set_title(f"{lab}: fell {100 * fell:.0f} %" + (f" of {len(ks)}" if len(ks) > 1 else ""), fontsize=9)
        ax.set_xlabel("time [s]")
        if measure == "projection":
            ax.axhline(0, color="0.6", lw=0.5)
    axes[0].set_ylabel(ylabel)
    axes[0].legend(fontsize=7, loc="lower left")
    what = {"bump": "a bump across the path halfway", "rough": "random roughness", "stair": "a flight of 3 stairs "
            "halfway", "bar": "a bar across the path halfway"}[kind]
    fig.suptitle(f"{result.names[i]}: {ylabel} with {what} (solid) and on flat ground (dashed)", fontsize=10)
    return fig


def flat_panel(result, i: int, measure: str = "projection") -> Figure:
    """Controller ``i`` on flat ground (Fig. 6.19): the measure vs time, with its undefined samples counted."""
    key, ylabel = MEASURES[measure]
    y = getattr(result, key)[i, 0]
    fig, (ax,) = _figure(1, (7.0, 3.5))
    ax.plot(result.t, y, "C0", lw=1.2)
    if measure == "projection":
        ax.axhline(0, color="0.6", lw=0.5)
    und = int(np.sum(~np.isfinite(y)))
    ax.set_title(f"{result.names[i]} on flat ground: {ylabel}; undefined at {und} of {len(y)} samples"
                 + (f", min {np.nanmin(y):.3f}" if np.isfinite(y).any() else ""), fontsize=9)
    ax.set_xlabel("time [s]")
    ax.set_ylabel(ylabel)
    return fig


def fall_probability(study, what: str = "fall") -> Figure:
    """The population study vs perturbation size (flat ground at 0), per GA setting (mean ± sd over seeds):
    the fall probability (``what="fall"``) or the mean time to fall in s (``"time_to_fall"``)."""
    data = study.fall if what == "fall" else study.fall_time
    top = 1.0 if what == "fall" else float(max(np.max(a) for a in data)) if data else 1.0
    kinds = [k for k in ("bump", "rough", "stair", "bar") if any(g.startswith(k) for g in study.groups)] or ["bump"]
    fig, axes = _figure(max(2, len(kinds)), (5.0, 3.8))
    flat = [j for j, g in enumerate(study.groups) if g == "flat"]
    for kind, ax in zip(kinds + [""] * (len(axes) - len(kinds)), axes, strict=True):
        cols = [j for j, g in enumerate(study.groups) if kind and g.startswith(kind)]
        if not cols:
            ax.set_visible(False)
            continue
        x = [0.0] * len(flat) + [float(study.groups[j].split()[1]) for j in cols]
        cols = flat + cols
        for n, (lab, f) in enumerate(zip(study.labels, data, strict=True)):
            m = f[:, cols].mean(0)
            sd = f[:, cols].std(0, ddof=1) if f.shape[0] > 1 else np.zeros_like(m)
            ax.plot(x, m, "o-", color=f"C{n % 10}", lw=1.2, ms=3, label=lab)
            ax.fill_between(x, np.clip(m - sd, 0, top), np.clip(m + sd, 0, top), color=f"C{n % 10}", alpha=0.12)
        ax.set_xlabel({"bump": "bump height", "rough": "roughness range", "stair": "stair rise",
                       "bar": "bar height"}[kind] + " [cm] (0: flat)")
        ax.set_ylim(-0.02 * top, 1.02 * top)
    axes[0].set_ylabel("fall probability" if what == "fall" else "mean time to fall [s]")
    (axes[0] if axes[0].get_visible() else axes[1]).legend(fontsize=7)
    name = "Fall probability" if what == "fall" else "Mean time to fall"
    fig.suptitle(f"{name} of each GA setting's controllers ({study.controllers} per run; "
                 "mean ± sd over seeds)", fontsize=10)
    return fig
