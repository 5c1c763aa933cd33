"""Shared test set-up: the helper modules beside this file (simcases, runcases) are importable from every folder,
and cpgjax is imported before any test module imports jax, so that every test runs on one host device per core
whichever file pytest collects first (had JAX run anything first, it could not make them: cpgjax/_xla.py).

Compiled programs are shared across tests: JAX's persistent compilation cache is pointed at a folder made for
this run and removed at its end (never reused by another run, so no stale program is ever loaded). Many tests
build the same model and jit the same episode or GA chunk again (a new closure each time, so JAX's in-memory
cache misses); from the second time on XLA's compile is a read from disk. The folder is passed on through the
environment (``JAX_COMPILATION_CACHE_DIR``, read by JAX at import), so subprocesses, notebook kernels and Ray
workers started by the tests share it too. A cached executable is the one XLA compiled for the same program:
results are bit for bit those of a fresh compile (the bit-for-bit tests run with it). ``CPGJAX_TEST_JAX_CACHE=0``
turns it off (to measure what it buys).

The tree mirrors the package (tests/sim/test_contact.py for cpgjax/sim/contact.py, ...).
"""

import os
import resource
import shutil
import sys
import tempfile
import time

_CACHE_DIR = None        # the folder, when this process made it (and removes it at the end)
if os.environ.get("CPGJAX_TEST_JAX_CACHE", "1") != "0":
    if os.environ.get("PYTEST_XDIST_WORKER") and os.path.isdir(os.environ.get("JAX_COMPILATION_CACHE_DIR", "")):
        pass                # a pytest-xdist worker: the controller's folder, inherited (the controller removes it)
    else:
        _CACHE_DIR = tempfile.mkdtemp(prefix="cpgjax-test-jax-cache-")
        os.environ["JAX_COMPILATION_CACHE_DIR"] = _CACHE_DIR
    os.environ["JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS"] = "0.1"   # skip the trivial programs: not worth a write
    os.environ["JAX_PERSISTENT_CACHE_MIN_ENTRY_SIZE_BYTES"] = "-1"     # no size floor
    # a size limit turns on JAX's file lock around each read and write of the cache: the test processes
    # (pytest-xdist's workers, subprocesses) share the folder, and one never reads an entry half written
    os.environ["JAX_COMPILATION_CACHE_MAX_SIZE"] = str(64 * 2**30)
else:
    os.environ["CPGJAX_COMPILE_CACHE"] = "0"      # nor the user's own cache (cpgjax/_xla.py)

import cpgjax  # noqa: E402,F401  (first: sets the host device count before a test module imports jax; cpgjax/_xla.py)

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

_T0 = time.monotonic()
_WORKERS_CPU: list[float] = []      # pytest-xdist: the CPU seconds each worker reported when it finished


def _cpu(*who) -> float:
    return sum(r.ru_utime + r.ru_stime for r in map(resource.getrusage, who))


def pytest_sessionfinish(session, exitstatus):
    if hasattr(session.config, "workeroutput"):      # an xdist worker: its CPU seconds go to the controller
        session.config.workeroutput["cpu"] = _cpu(resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN)


# The files that take longest (CPU seconds of the fast suite, measured 2026-11-26, heaviest first).  With
# `make test`'s pytest-xdist workers (``--dist loadfile``: a file's tests run in one worker, sharing its
# module-scoped fixtures) they start first, so that no long file is left alone at the end while the other
# worker idles.  Only the order changes: a stale list costs time, never a result.  Left off on purpose:
# analysis/test_report.py, which then runs late and loads the tiny sweep's program that experiments/test_sweep.py
# (first) compiled, rather than compiling it at the same time in the other worker.  experiments/test_robust.py and
# render/test_render.py come early for the same reason: they make the tiny robust and thesis runs, whose GA
# programs the validation, transfer and replay files then load.
HEAVY_FIRST = (
    "experiments/test_sweep.py", "experiments/test_robust.py", "render/test_render.py", "crosscheck/test_mjcf.py",
    "episode/test_rollout.py", "cli/test_repertoire.py", "optim/test_ga.py", "sim/test_variation.py",
    "episode/test_policy.py", "sim/exact/test_exact_step.py", "experiments/test_evolve.py", "optim/test_es.py",
    "test_models.py", "episode/test_descriptors.py", "optim/test_mapelites.py", "experiments/test_validate.py",
    "sim/test_contact.py", "cli/test_replay.py", "experiments/test_stability.py", "io/test_runlock.py",
    "crosscheck/test_compare.py", "episode/test_sensors.py", "cli/test_cli_bad_input.py", "optim/test_baselines.py",
    "crosscheck/test_ground.py", "crosscheck/test_ground_bench.py", "cli/test_ctl_provenance.py",
)


def pytest_collection_modifyitems(session, config, items):
    here = os.path.dirname(os.path.abspath(__file__))
    rank = {os.path.join(here, f): i for i, f in enumerate(HEAVY_FIRST)}
    items.sort(key=lambda item: rank.get(str(item.path), len(rank)))     # stable: the rest keep their order


class _WorkersCPU:
    """On the xdist controller: collects each worker's CPU seconds (a hook of xdist's, so registered only with it)."""

    @staticmethod
    def pytest_testnodedown(node, error):
        _WORKERS_CPU.append(getattr(node, "workeroutput", {}).get("cpu", 0.0))


def pytest_configure(config):
    if config.pluginmanager.hasplugin("xdist") and not hasattr(config, "workeroutput"):
        config.pluginmanager.register(_WorkersCPU(), "cpgjax-workers-cpu")


def pytest_terminal_summary(terminalreporter, exitstatus, config):
    cache = "on" if os.environ.get("CPGJAX_TEST_JAX_CACHE", "1") != "0" else "off (CPGJAX_TEST_JAX_CACHE=0)"
    load = " ".join(f"{x:.1f}" for x in os.getloadavg())
    # CPU seconds of this process and the subprocesses it waited for (with xdist: of the controller and what its
    # workers reported): less inflated than wall time by a busy machine
    if _WORKERS_CPU:
        cpu = _cpu(resource.RUSAGE_SELF) + sum(_WORKERS_CPU)
        procs = f", {len(_WORKERS_CPU)} workers"
    else:
        cpu, procs = _cpu(resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN), ""
    terminalreporter.write_line(f"suite: {time.monotonic() - _T0:.0f} s wall, {cpu:.0f} s CPU{procs}, collection "
                                f"included; the JAX compilation cache {cache}; load average at the end {load} "
                                "(1, 5, 15 min)")


import pytest  # noqa: E402


@pytest.fixture(scope="session")
def tiny_runs(tmp_path_factory):
    """The suite's shared tiny GA run files (tests/runcases.py: TinyRuns), made on first use in this process."""
    from runcases import TinyRuns

    return TinyRuns(tmp_path_factory.mktemp("tiny-runs"))


def pytest_unconfigure(config):
    if _CACHE_DIR:
        shutil.rmtree(_CACHE_DIR, ignore_errors=True)
