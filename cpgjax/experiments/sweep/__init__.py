"""Sweeps: many GA / baseline runs (settings x seeds) batched into one XLA program (docs/sweeps.md).

:mod:`~cpgjax.experiments.sweep.plan` — cells, seeds, names and files, the thesis experiment;
:mod:`~cpgjax.experiments.sweep.driver` — the batched driver;
:mod:`~cpgjax.experiments.sweep.cluster` — its shards as Ray tasks (``--ray``, imported on demand).
Reading a sweep back is in :mod:`cpgjax.io.sweepdir`; its report in :mod:`cpgjax.analysis.report`.
"""

from cpgjax.experiments.sweep.driver import check_new_runs, eval_chunk, run_sweep, sweep_problem, write_manifest
from cpgjax.experiments.sweep.plan import (
    MANIFEST,
    SCALES,
    RunSpec,
    baseline_cells,
    complete,
    ga_cell_name,
    ga_grid,
    plan,
    search_cell_name,
    thesis_cells,
    total_batch,
)

__all__ = ["MANIFEST", "SCALES", "RunSpec", "baseline_cells", "check_new_runs", "complete", "eval_chunk",
           "ga_cell_name", "ga_grid", "plan", "run_sweep", "search_cell_name", "sweep_problem", "thesis_cells",
           "total_batch", "write_manifest"]
