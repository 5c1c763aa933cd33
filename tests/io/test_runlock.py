"""One writer per run file (cpgjax/io/runlock.py): the lock, a second writer refused, a kill -9 not blocking,
and with two real ``cpgjax`` processes: ``--overwrite`` while another writes, readers while it writes."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest

from cpgjax.errors import ResultsError
from cpgjax.io import runlock
from cpgjax.io.results import read_attrs, read_run

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
ENV = {**os.environ, "PYTHONPATH": ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""), "CPGJAX_DEVICES": "1"}


def test_held_then_released_and_a_second_writer_refused(tmp_path):
    run = tmp_path / "r.h5"
    assert runlock.holder(run) is None
    with runlock.hold(run):
        info = runlock.holder(run)
        assert info["pid"] == os.getpid() and info["host"]
        with pytest.raises(ResultsError) as e:           # another open file description: refused like a process
            runlock.acquire(run)
        msg = str(e.value)
        assert "\n" not in msg and str(run) in msg and f"pid {os.getpid()}" in msg and "another --out" in msg
    assert runlock.holder(run) is None and not os.path.exists(runlock.lock_path(run))


def test_a_lock_left_by_kill_9_does_not_block(tmp_path):
    run = tmp_path / "r.h5"
    code = ("import sys, time; from cpgjax.io import runlock; runlock.acquire(sys.argv[1]); print('held', flush=True);"
            " time.sleep(600)")
    p = subprocess.Popen([sys.executable, "-c", code, str(run)], stdout=subprocess.PIPE, text=True, env=ENV)
    try:
        assert p.stdout.readline().strip() == "held"
        assert runlock.holder(run)["pid"] == p.pid
        with pytest.raises(ResultsError, match=f"pid {p.pid}"):
            runlock.acquire(run)
        p.send_signal(signal.SIGKILL)
        p.wait(timeout=30)
    finally:
        if p.poll() is None:
            p.kill()
    assert os.path.exists(runlock.lock_path(run))            # left behind, with the dead writer's pid in it ...
    assert runlock.holder(run) is None                        # ... but nobody holds it
    with runlock.hold(run):
        assert runlock.holder(run)["pid"] == os.getpid()


def _cpgjax(*argv: str) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "cpgjax.cli", *argv], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=ENV, cwd=ROOT)


def _completed(path) -> int:
    try:
        return int(read_attrs(path)["completed"])
    except Exception:  # noqa: BLE001 - not there yet
        return -1


def test_two_real_processes_one_file(tmp_path, capsys):
    """A writes (another process); B (``--overwrite``, another seed; this process) is refused with one line naming
    the file and A, exit 2, and the file stays A's; readers read A's complete generations and say that it is still
    going; A killed -9, the next writer goes ahead."""
    from cpgjax.cli import main

    out = tmp_path / "same.h5"
    # experiments/test_evolve.py's run settings (other seeds): its compiled program, loaded from the cache
    ga = ("analytic:diverging:10", "--pocket", "4", "--crossover", "--gamma", "0.1", "--chunk", "4")
    a = _cpgjax("evolve", *ga, "--generations", "100000", "--seed", "0", "--quiet", "--out", str(out))
    try:
        deadline = time.monotonic() + 180
        while _completed(out) < 3 and a.poll() is None and time.monotonic() < deadline:
            time.sleep(0.1)
        assert a.poll() is None and _completed(out) >= 3, "the first writer did not get going"
        created = read_attrs(out)["created"]

        capsys.readouterr()
        assert main(["evolve", *ga, "--generations", "20", "--seed", "5", "--quiet", "--out", str(out),
                     "--overwrite"]) == 2
        lines = capsys.readouterr().err.strip().splitlines()
        assert len(lines) == 1 and str(out) in lines[0] and f"pid {a.pid}" in lines[0], lines
        attrs = read_attrs(out)
        assert attrs["seed"] == 0 and attrs["created"] == created       # nothing changed: still A's run

        run = read_run(out)                                   # a reader needs no lock, sees complete rows
        assert run.writer is not None and run.writer["pid"] == a.pid
        assert run.genomes.shape[0] == run.fitness.shape[0] == run.completed >= 3
        assert main(["best", str(out)]) == 0
        got = capsys.readouterr()
        assert "still being written" in got.err and f"pid {a.pid}" in got.err and "best fitness" in got.out

        a.send_signal(signal.SIGKILL)
        a.wait(timeout=30)
    finally:
        if a.poll() is None:
            a.kill()
    assert read_run(out).writer is None
    assert main(["evolve", *ga, "--generations", "5", "--seed", "5", "--quiet", "--out", str(out),
                 "--overwrite"]) == 0                                      # the lock left by kill -9 did not block
    assert read_attrs(out)["seed"] == 5 and read_run(out).completed == 5
    assert not os.path.exists(runlock.lock_path(out))


def test_a_read_torn_by_hdf5_while_a_writer_holds_the_file_is_tried_again(tmp_path, monkeypatch):
    """HDF5 itself may fail on a file caught mid-write (``RuntimeError: ... addr overflow``, seen under load);
    with a writer at work the read is tried again, without one the error is the file's."""
    from cpgjax.io import results

    path = str(tmp_path / "r.h5")
    real, calls = results._read_run, []

    def torn_once(p):
        calls.append(p)
        if len(calls) == 1:
            raise RuntimeError("Object specific failed (addr overflow, addr = 150336, size = 2616, eoa = 142536)")
        return real(p)

    from cpgjax.experiments.evolve import run_ga
    from cpgjax.optim.factory import make_problem
    from cpgjax.optim.ga import GAConfig

    # the first writer's settings above, two generations (its compiled program)
    run_ga(make_problem("analytic:diverging:10"),
           GAConfig(generations=2, pocket=4, crossover=True, gamma=0.1, seed=5, chunk=4), path)
    real_holder = runlock.holder
    monkeypatch.setattr(results, "_read_run", torn_once)
    monkeypatch.setattr(results.time, "sleep", lambda s: None)
    writing = {"pid": os.getpid() + 1, "host": "elsewhere"}          # another process holds the lock
    monkeypatch.setattr(runlock, "holder", lambda p: writing)
    run = read_run(path)
    assert run.completed == 2 and len(calls) == 2 and run.writer is not None
    calls.clear()
    monkeypatch.setattr(runlock, "holder", lambda p: None)
    with pytest.raises(RuntimeError):                      # nobody writes it: nothing to wait for
        read_run(path)
    calls.clear()
    monkeypatch.setattr(runlock, "holder", real_holder)
    with runlock.hold(path), pytest.raises(RuntimeError):  # this process holds it (a resume): not being written
        read_run(path)
    assert len(calls) == 1
    # the attributes alone too (`read_attrs`): HDF5 found the file shorter than its superblock says, mid-write
    real_attrs, calls[:] = results._read_attrs, []

    def truncated_once(p):
        calls.append(p)
        if len(calls) == 1:
            raise ResultsError(f"{p}: {results.NOT_A_RUN} (HDF5: truncated file: eof = 977624, "
                               "sblock->base_addr = 0, stored_eof = 978424)")
        return real_attrs(p)

    monkeypatch.setattr(results, "_read_attrs", truncated_once)
    monkeypatch.setattr(runlock, "holder", lambda p: writing)
    assert read_attrs(path)["completed"] == 2 and len(calls) == 2
    calls.clear()
    monkeypatch.setattr(runlock, "holder", lambda p: None)
    with pytest.raises(ResultsError, match="truncated"):   # nobody writes it: the file's error
        read_attrs(path)
