"""Figures of the thesis (Ch. 6) from run files; matplotlib's Agg canvas, no global backend change."""

from cpgjax.plots.evolution import plot_runs, run_label
from cpgjax.plots.thesis import (
    fig_6_5,
    fig_6_6,
    fig_6_7,
    fig_6_8,
    fig_6_9,
    fig_6_10,
    fig_6_11,
    fig_6_12,
    load_cells,
)

__all__ = ["plot_runs", "run_label", "fig_6_5", "fig_6_6", "fig_6_7", "fig_6_8", "fig_6_9", "fig_6_10", "fig_6_11",
           "fig_6_12", "load_cells"]
