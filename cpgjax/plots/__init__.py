"""Figures of the thesis (Ch. 6) from run files; matplotlib's Agg canvas, no global backend change."""

from cpgjax.plots.evolution import plot_runs, run_label

__all__ = ["plot_runs", "run_label"]
