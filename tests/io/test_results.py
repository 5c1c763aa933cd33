"""The HDF5 run layout: attributes, growable datasets, truncation to `completed`, resume point."""

from __future__ import annotations

import json

import h5py
import numpy as np
import pytest

from cpgjax.io.results import ResultsError, Row, RunWriter, create_run, read_attrs, read_resume_point, read_run
from cpgjax.optim.analytic import sphere_problem

N, G = 4, 5


def make(path, **kw):
    problem = sphere_problem(G)
    problem.meta["model_text"] = "# a tiny model\nbody 1\n"
    create_run(path, kind="ga", config={"seed": 11, "population": N, "mu_max": 0.2, "crossover": True},
               problem=problem, population=N, generations=3, metrics={"distance": ((N,), np.float32)},
               state={"population": ((N, G), np.float32)}, **kw)
    return problem


def row(i: int) -> Row:
    f = np.arange(N, dtype=np.float32) + i
    f[0] = np.nan
    return Row(genomes=np.full((N, G), i, np.float32), fitness=f, diverged=np.isnan(f),
               mutation_rate=0.2, wall_time=0.5 * (i + 1), metrics={"distance": f * 2},
               state={"population": np.full((N, G), i + 1, np.float32)})


def test_roundtrip_and_attributes(tmp_path):
    p = tmp_path / "sub" / "run.h5"
    make(p)
    with RunWriter(p) as w:
        assert w.completed == 0
        w.append(row(0))
        w.append(row(1))
    a = read_attrs(p)
    assert a["format"] == "cpgjax-run" and a["kind"] == "ga" and a["seed"] == 11 and a["completed"] == 2
    assert a["model_text"] == "# a tiny model\nbody 1\n" and a["n_genes"] == G and a["population"] == N
    assert json.loads(a["config"])["crossover"] is True and a["cfg_mu_max"] == 0.2
    v = json.loads(a["versions"])
    assert {"jax", "jaxlib", "numpy", "h5py", "python", "cpgjax"} <= set(v)
    run = read_run(p)
    assert run.genomes.shape == (2, N, G) and run.fitness.shape == (2, N)
    assert np.isnan(run.fitness[0, 0]) and run.n_diverged.tolist() == [1, 1]
    np.testing.assert_allclose(run.wall_time, [0.5, 1.0])
    np.testing.assert_allclose(run.metrics["distance"][1], row(1).fitness * 2)
    assert run.best()[:3] == (1, 3, 4.0)
    np.testing.assert_allclose(run.best_per_generation(), [3.0, 4.0])
    np.testing.assert_allclose(run.mean_per_generation(), [2.0, 3.0])
    n, state, wall = read_resume_point(p)
    assert n == 2 and wall == 1.0 and np.all(state["population"] == 2)


def test_refuses_to_clobber(tmp_path):
    p = tmp_path / "run.h5"
    make(p)
    with pytest.raises(ResultsError, match="--resume .* --overwrite"):
        make(p)
    make(p, overwrite=True)
    assert read_run(p).completed == 0


def test_rows_past_completed_are_ignored_and_dropped(tmp_path):
    """A write interrupted before `completed` was set leaves extra rows: readers and writers drop them."""
    p = tmp_path / "run.h5"
    make(p)
    with RunWriter(p) as w:
        w.append(row(0))
    with h5py.File(p, "a") as f:  # half of a second row, as a kill mid-write could leave
        for name in ("genomes", "fitness"):
            f[name].resize(2, axis=0)
        f["genomes"][1] = 99
    assert read_run(p).genomes.shape[0] == 1
    assert read_resume_point(p)[0] == 1
    with RunWriter(p) as w:
        w.append(row(1))
    run = read_run(p)
    assert run.completed == 2 and np.all(run.genomes[1] == 1)


def test_a_count_ahead_of_a_dataset_is_cut_to_the_rows_every_dataset_holds(tmp_path):
    """A kill while HDF5 wrote its metadata cache can leave `completed` on disk ahead of one dataset's extent (a
    sweep killed in CI left completed 5 with 4 rows of state): readers, the resume point and the writer all take
    the generations every dataset holds, and the run goes on from there."""
    p = tmp_path / "run.h5"
    make(p)
    with RunWriter(p) as w:
        for i in range(3):
            w.append(row(i))
    with h5py.File(p, "a") as f:
        f["state/population"].resize(2, axis=0)
    assert read_run(p).completed == 2
    n, state, wall = read_resume_point(p)
    assert n == 2 and wall == 1.0 and np.all(state["population"] == 2)
    with RunWriter(p) as w:
        assert w.completed == 2
        w.append(row(2))
    run = read_run(p)
    assert run.completed == 3 and read_attrs(p)["completed"] == 3
    assert run.genomes.shape[0] == run.state["population"].shape[0] == 3 and np.all(run.state["population"][2] == 3)


def test_not_a_run_file(tmp_path):
    p = tmp_path / "x.h5"
    with h5py.File(p, "w") as f:
        f["a"] = 1
    with pytest.raises(ResultsError):
        read_run(p)
