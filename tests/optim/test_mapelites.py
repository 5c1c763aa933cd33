"""MAP-Elites (cpgjax.optim.mapelites) on an analytic problem with a known optimum in every cell; insertion;
the archive rebuilt from the run file; resume bit for bit."""

from __future__ import annotations

import json

import h5py
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from cpgjax.experiments.repertoire import read_repertoire, run_repertoire
from cpgjax.optim import mapelites as me
from cpgjax.optim.problem import Problem

OPT = np.asarray([0.3, -0.2, 0.1], np.float32)


def qd_problem() -> Problem:
    """Genes 0 and 1 are the descriptor (the behaviour), genes 2..4 the quality: f = 1 - sum((g[2:] - OPT)^2).

    Every cell of the descriptor box holds genomes of fitness 1 (the optimum of each cell), none higher.
    """
    def evaluate(genomes):
        g = jnp.asarray(genomes, jnp.float32)
        f = 1.0 - jnp.sum(jnp.square(g[:, 2:] - OPT), axis=-1)
        return {"fitness": f, "diverged": jnp.zeros(g.shape[0], bool), "d0": g[:, 0], "d1": g[:, 1]}

    meta = {"model_path": "qd-test", "model_text": "", "descriptor_metrics": json.dumps(["d0", "d1"])}
    return Problem(name="qd-test", n_genes=5, base_genome=np.zeros(5, np.float32), evaluate=evaluate, meta=meta)


PROBLEM = qd_problem()


def cfg(**kw):
    base = dict(cells=(5,), bounds=((-0.8, 0.8),), evaluations=64 * 40, batch=64, chunk=10, sigma=0.05)
    return me.MEConfig(**{**base, **kw})


# the iso-line variation slow: a program of its own, the same insertion and grid (fast: MAP-Elites')
@pytest.mark.parametrize("method", [m if m == "map-elites" else pytest.param(m, marks=pytest.mark.slow)
                                    for m in me.METHODS])
def test_mapelites_fills_every_cell_and_converges_to_each_cells_optimum(tmp_path, method):
    """25 cells, each with optimum 1: after 2560 evaluations every cell is filled, every elite is within
    0.02 of its cell's optimum (the random first generations: ~0.85 at best) and lies in its own cell."""
    s = run_repertoire(PROBLEM, cfg(method=method), tmp_path / "rep.h5")
    rep = read_repertoire(tmp_path / "rep.h5")
    assert rep.filled.all() and s["filled"] == 25 and s["coverage"] == 1.0
    assert rep.fitness.min() > 0.98 and rep.fitness.max() <= 1.0
    cells = np.asarray(me.cell_index(rep.grid, rep.descriptors))
    np.testing.assert_array_equal(cells, np.arange(25))
    np.testing.assert_array_equal(rep.descriptors, rep.genomes[:, :2])
    assert np.all(np.diff(rep.qd_score) >= 0) and np.all(np.diff(rep.n_filled) >= 0)
    assert rep.qd_score[-1] == np.sum(rep.fitness.astype(np.float64) + 1.0)     # float64 on the host


def test_insertion_keeps_the_better_elite():
    insert = jax.jit(me.insert)                  # one compiled program per batch shape (eagerly: ~80 small ones)
    st = me.empty_archive(3, 2, 1, 4)
    g = jnp.asarray([[1.0, 1.0], [2.0, 2.0], [3.0, 3.0], [4.0, 4.0]])
    f = jnp.asarray([0.3, 0.5, 0.2, 9.0])
    d = jnp.asarray([[0.1], [0.2], [0.3], [0.4]])
    cells = jnp.asarray([1, 1, 2, 0], jnp.int32)
    valid = jnp.asarray([True, True, True, False])        # the fittest child is invalid (diverged): never inserted
    st = insert(st, g, f, d, cells, valid)
    np.testing.assert_array_equal(np.asarray(st.filled), [False, True, True])
    np.testing.assert_array_equal(np.asarray(st.fitness)[1:], np.float32([0.5, 0.2]))
    np.testing.assert_array_equal(np.asarray(st.genomes)[1:], [[2.0, 2.0], [3.0, 3.0]])
    np.testing.assert_array_equal(np.asarray(st.descriptors)[1:, 0], np.float32([0.2, 0.3]))
    # worse: kept; equal: kept (strictly better replaces); better: replaced (the first of two equal ones)
    one = lambda x, fit, c: insert(st, jnp.full((2, 2), x), jnp.asarray(fit, jnp.float32),  # noqa: E731
                                      jnp.full((2, 1), x), jnp.asarray(c, jnp.int32), jnp.ones(2, bool))
    assert float(one(7.0, [0.4, 0.1], [1, 2]).fitness[1]) == np.float32(0.5)
    assert float(one(7.0, [0.5, 0.2], [1, 2]).genomes[1, 0]) == 2.0
    st2 = insert(st, jnp.asarray([[5.0, 5.0], [6.0, 6.0]]), jnp.asarray([0.7, 0.7]), jnp.asarray([[0.5], [0.6]]),
                    jnp.asarray([1, 1], jnp.int32), jnp.ones(2, bool))
    assert float(st2.fitness[1]) == np.float32(0.7) and float(st2.genomes[1, 0]) == 5.0
    assert float(st2.fitness[2]) == np.float32(0.2)


def test_cell_index_row_major_clipped_and_nan_is_no_cell():
    grid = me.Grid(("a", "b"), np.float32([0, 0]), np.float32([1, 2]), (2, 4))
    d = np.float32([[0.1, 0.1], [0.6, 0.1], [0.1, 1.9], [0.99, 1.51], [-5, 9], [np.nan, 0.5]])
    np.testing.assert_array_equal(np.asarray(me.cell_index(grid, d)), [0, 4, 3, 7, 3, -1])
    c = me.cell_centres(grid)
    np.testing.assert_array_equal(np.asarray(me.cell_index(grid, c)), np.arange(8))


def test_the_archive_rebuilt_from_the_file_equals_the_runs_and_resume_is_bit_for_bit(tmp_path):
    c = cfg(evaluations=64 * 12)                  # chunks of 10: the compiled program of the other tests
    full = run_repertoire(PROBLEM, c, tmp_path / "a.h5")
    run_repertoire(PROBLEM, c, tmp_path / "b.h5", stop_after=5)          # stops inside a chunk
    part = read_repertoire(tmp_path / "b.h5")
    assert len(part.n_filled) == 5
    run_repertoire(PROBLEM, c, tmp_path / "b.h5", resume=True)
    rep = read_repertoire(tmp_path / "a.h5")
    for k in ("genomes", "fitness", "descriptors", "filled"):
        np.testing.assert_array_equal(getattr(rep, k), getattr(full["archive"], k))
    with h5py.File(tmp_path / "a.h5") as a, h5py.File(tmp_path / "b.h5") as b:
        names = []
        a.visititems(lambda n, o: names.append(n) if isinstance(o, h5py.Dataset) else None)
        for n in names:
            if n != "wall_time":
                np.testing.assert_array_equal(a[n][:], b[n][:], err_msg=n)
        assert int(b.attrs["completed"]) == 12


def test_resume_refuses_another_grid(tmp_path):
    from cpgjax.errors import ResultsError

    run_repertoire(PROBLEM, cfg(evaluations=128), tmp_path / "r.h5")
    with pytest.raises(ResultsError, match="cells"):
        run_repertoire(PROBLEM, cfg(evaluations=256, cells=(4,)), tmp_path / "r.h5", resume=True)


def test_a_child_that_fell_is_never_inserted(tmp_path):
    """The problem flags children with gene 0 > 0.64 as fallen (``meta["fall_metric"]``): no elite has it, and the
    25 cells are still filled (the top column keeps 0.48..0.64); with ``keep_fallen`` they are inserted (below)."""
    def evaluate(genomes):
        out = PROBLEM.evaluate(genomes)
        return {**out, "down": (jnp.asarray(genomes)[:, 0] > 0.64).astype(jnp.float32)}

    meta = {**PROBLEM.meta, "fall_metric": "down"}
    falls = Problem(name="qd-falls", n_genes=5, base_genome=PROBLEM.base_genome, evaluate=evaluate, meta=meta)
    run_repertoire(falls, cfg(evaluations=64 * 20), tmp_path / "f.h5")
    rep = read_repertoire(tmp_path / "f.h5")
    assert rep.filled.all() and rep.descriptors[:, 0].max() <= np.float32(0.64)
    assert np.all(rep.metrics["down"] == 0)


@pytest.mark.slow  # a program of its own; fast: the fallen never inserted, above
def test_with_keep_fallen_a_child_that_fell_is_inserted(tmp_path):
    def evaluate(genomes):
        out = PROBLEM.evaluate(genomes)
        return {**out, "down": (jnp.asarray(genomes)[:, 0] > 0.64).astype(jnp.float32)}

    meta = {**PROBLEM.meta, "fall_metric": "down"}
    falls = Problem(name="qd-falls", n_genes=5, base_genome=PROBLEM.base_genome, evaluate=evaluate, meta=meta)
    run_repertoire(falls, cfg(evaluations=64 * 20, keep_fallen=True), tmp_path / "k.h5")
    assert read_repertoire(tmp_path / "k.h5").descriptors[:, 0].max() > 0.64
