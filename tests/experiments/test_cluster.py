"""A sweep on Ray (cpgjax.experiments.sweep.cluster, cpgjax sweep --ray): the same files as in one process,
a worker killed mid-sweep costs nothing but time, one task per run file, and the extra named when missing.

Every test that starts Ray is marked slow (`make test-slow`, run by CI; 45 s of the 5-minute fast suite on 2
cores, most of it starting Ray); the fast suite keeps the shards, the lock and the missing extra (below)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys

import pytest
from runcases import same_rows

from cpgjax import cli
from cpgjax.experiments import sweep
from cpgjax.experiments.sweep import cluster
from cpgjax.io import sweepdir
from cpgjax.io.results import read_run

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
WL = os.path.join(ROOT, "models", "quadruped.wl")
# the quadruped, short episodes, a GA cell with and without pocket, and random search: 3 runs
TINY = [WL, "--time", "0.3", "--population", "4", "--generations", "2", "--gamma", "0.1", "--pocket", "0,2",
        "--seeds", "1", "--baselines", "random", "--quiet"]


def same_sweeps(a, b):
    """Two sweep folders hold the same run files, row for row, bit for bit."""
    ra, rb = sweepdir.find_runs(a), sweepdir.find_runs(b)
    assert sorted(ra) == sorted(rb) and ra
    for cell, files in ra.items():
        assert [os.path.basename(p) for p in files] == [os.path.basename(p) for p in rb[cell]]
        for p in files:
            x, y = read_run(p), read_run(os.path.join(b, cell, os.path.basename(p)))
            assert x.completed == y.completed
            same_rows(x, y)


@pytest.fixture(scope="module")
def local_ray():
    """One local Ray instance (2 CPUs) for the module: starting Ray takes seconds."""
    import ray  # make test installs the [cluster] extra
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False, configure_logging=False,
             object_store_memory=100 * 2**20)
    yield ray
    ray.shutdown()


@pytest.mark.slow  # Ray: 45 s, most of it starting Ray; fast: the shards, the lock, the missing extra (below)
def test_two_workers_write_the_files_of_the_sweep_in_one_process(local_ray, tmp_path):
    here, there = str(tmp_path / "here"), str(tmp_path / "ray")
    assert cli.main(["sweep", *TINY, "--out", here]) == 0
    assert cli.main(["sweep", *TINY, "--out", there, "--ray", "--workers", "2"]) == 0
    same_sweeps(here, there)
    assert json.load(open(os.path.join(there, sweep.MANIFEST))) == json.load(open(os.path.join(here, sweep.MANIFEST)))
    timing = [json.loads(x) for x in open(os.path.join(there, "sweep-timing.jsonl"))]
    workers = timing[-1]["workers"]
    assert len(workers) == 2 and len({w["pid"] for w in workers}) == 2
    assert sum(w["runs"] for w in workers) == 3 and sum(w["evaluations"] for w in workers) == 3 * 4 * 2
    assert all(w["devices"] >= cluster.MIN_DEVICES for w in workers)
    # report and best work on its files unchanged
    assert cli.main(["report", there, "--out", str(tmp_path / "r.md")]) == 0
    run = sweepdir.find_runs(there)["ga_n4_mu0.2_g0.1_p2_xoff"][0]
    assert cli.main(["best", run, "--ctl", str(tmp_path / "b.ctl")]) == 0


@pytest.mark.slow  # Ray
def test_worker_killed_mid_sweep_is_retried_and_resumes_to_the_uninterrupted_files(local_ray, tmp_path):
    """SIGKILL the worker of shard 0 while it runs; Ray retries its task, which resumes its runs from their
    files; the sweep's files equal those of the same sweep never interrupted (in one process)."""
    pa = {"model": "analytic:sphere:10"}
    cells = sweep.ga_grid(gamma=(0.0, 1.0), pocket=(2,), population=(4,), generations=80)
    killed: dict[str, int] = {}

    def kill_shard0(info):
        n, total = info["done"].get(0, 0), info["shard_totals"][0]
        if not killed and 0 < n < total // 2 and 0 in info["pids"]:
            killed["pid"], killed["at"] = info["pids"][0], n
            os.kill(info["pids"][0], signal.SIGKILL)
        elif killed:
            killed["after"] = info["pids"].get(0)

    out = str(tmp_path / "killed")
    specs = sweep.plan(out, cells, [0, 1])
    s = cluster.run_on_ray(pa, specs, workers=2, progress=False, on_progress=kill_shard0, poll=0.05)
    assert killed, "shard 0 finished before its worker could be killed"
    assert killed.get("after") not in (None, killed["pid"]), "the task was not run again in a new worker"
    assert sweep.complete(specs)
    assert s["evaluations"] < len(specs) * 4 * 80          # the retry did not start its runs again
    ref = str(tmp_path / "ref")
    rspecs = sweep.plan(ref, cells, [0, 1])
    sweep.run_sweep(sweep.sweep_problem(pa), rspecs, progress=False)
    same_sweeps(ref, out)


def test_shards_are_disjoint_and_balanced():
    specs = sweep.plan("/x", sweep.ga_grid(gamma=(0.0, 1.0), pocket=(0, 2), population=(20,), generations=150)
                       + sweep.baseline_cells(["random", "amc3"], samples=3000, batch=20), range(5))
    for n in (1, 2, 3, 7, 100):
        parts = cluster.shards(specs, n)
        assert len(parts) == min(n, len(specs))
        assert sorted(s.path for p in parts for s in p) == sorted(s.path for s in specs)
        loads = [sum(cluster.run_cost(s) for s in p) for p in parts]
        assert max(loads) - min(loads) <= max(cluster.run_cost(s) for s in specs)


def test_a_run_file_is_locked_by_one_task_at_a_time(tmp_path):
    specs = sweep.plan(str(tmp_path), sweep.ga_grid(population=(4,), generations=2), [0, 1])
    probe = ("import fcntl, sys\nf = open(sys.argv[1], 'a+')\n"
             "try:\n    fcntl.lockf(f, fcntl.LOCK_EX | fcntl.LOCK_NB)\nexcept OSError:\n    sys.exit(3)\n")
    with cluster.holding(specs):
        for sp in specs:
            assert subprocess.run([sys.executable, "-c", probe, cluster.lock_path(sp)]).returncode == 3
    assert subprocess.run([sys.executable, "-c", probe, cluster.lock_path(specs[0])]).returncode == 0
    assert not any(".locks" in c for c in sweepdir.find_runs(str(tmp_path)))


def test_ray_without_the_extra_is_named(tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "ray", None)         # import ray -> ImportError
    out = str(tmp_path / "s")
    assert cli.main(["sweep", "analytic:sphere:10", "--population", "4", "--generations", "2", "--seeds", "1",
                     "--out", out, "--ray", "--quiet"]) == 2
    assert "pip install -e .[cluster]" in capsys.readouterr().err
    assert not os.path.exists(out)
    assert cli.main(["sweep", "analytic:sphere:10", "--out", out, "--workers", "2", "--dry-run"]) == 2


@pytest.mark.slow  # Ray
def test_a_refused_run_in_a_task_is_named_as_in_one_process(local_ray, tmp_path, capsys):
    """A cpgjax error raised in a Ray task (here: a file made with other settings) reaches the user as itself."""
    import h5py

    out = str(tmp_path / "s")
    argv = ["sweep", "analytic:sphere:10", "--generations", "2", "--population", "4", "--seeds", "1", "--out", out,
            "--quiet"]
    assert cli.main(argv) == 0
    run = os.path.join(out, "ga_n4_mu0.2_g0_p0_xoff", "s0.h5")
    with h5py.File(run, "a") as f:
        cfg = json.loads(f.attrs["config"])
        cfg["init_spread"] = 0.3
        f.attrs["config"] = json.dumps(cfg)
    capsys.readouterr()
    assert cli.main([*argv, "--ray"]) == 2
    assert "cannot resume" in capsys.readouterr().err
