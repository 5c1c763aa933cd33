"""Shared test set-up: the helper modules beside this file (simcases, runcases) are importable from every folder,
and cpgjax is imported before any test module imports jax, so that every test runs on one host device per core
whichever file pytest collects first (with jax imported first, cpgjax keeps the single default device).

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

_CACHE_DIR = None
if os.environ.get("CPGJAX_TEST_JAX_CACHE", "1") != "0":
    _CACHE_DIR = tempfile.mkdtemp(prefix="cpgjax-test-jax-cache-")
    os.environ["JAX_COMPILATION_CACHE_DIR"] = _CACHE_DIR
    os.environ["JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS"] = "0.1"   # skip the trivial programs: not worth a write
    os.environ["JAX_PERSISTENT_CACHE_MIN_ENTRY_SIZE_BYTES"] = "-1"     # no size floor

import cpgjax  # noqa: E402,F401  (first: sets the host device count before a test module imports jax; cpgjax/_xla.py)

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

_T0 = time.monotonic()


def pytest_terminal_summary(terminalreporter, exitstatus, config):
    cache = "on" if _CACHE_DIR else "off (CPGJAX_TEST_JAX_CACHE=0)"
    load = " ".join(f"{x:.1f}" for x in os.getloadavg())
    # CPU seconds of this process and the subprocesses it waited for: less inflated than wall time by a busy machine
    cpu = sum(r.ru_utime + r.ru_stime for r in map(resource.getrusage, (resource.RUSAGE_SELF,
                                                                        resource.RUSAGE_CHILDREN)))
    terminalreporter.write_line(f"suite: {time.monotonic() - _T0:.0f} s wall, {cpu:.0f} s CPU, collection included; "
                                f"the JAX compilation cache {cache}; load average at the end {load} (1, 5, 15 min)")


def pytest_unconfigure(config):
    if _CACHE_DIR:
        shutil.rmtree(_CACHE_DIR, ignore_errors=True)
