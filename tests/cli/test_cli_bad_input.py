"""Every bad input is one clear line and exit code 2, and changes no file (issue "Every bad input a clear error").

Table-driven: each row is a command line run in-process (``cpgjax.cli.main``) in a folder of
prepared files; it must exit 2 with ONE line on stderr (no traceback) naming the file or option,
and leave every file of the folder as it was.  Ctrl-C is tested on a real subprocess at the end.
"""

from __future__ import annotations

import hashlib
import os
import shlex
import signal
import subprocess
import sys
import time

import jax
import pytest
from runcases import one_line_error

from cpgjax.cli import main
from cpgjax.experiments.runner import open_run, run_keys
from cpgjax.io.results import read_attrs, read_run
from cpgjax.optim.algorithm import make_algorithm
from cpgjax.optim.factory import make_problem
from cpgjax.optim.ga import GAConfig

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
M = os.path.join(ROOT, "models", "quadruped.wl")
CTL = os.path.join(ROOT, "models", "quadruped-trot.ctl")


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    """Malformed inputs, a regular file standing where a folder should be, and a run of 0.3 s on flat ground."""
    d = tmp_path_factory.mktemp("bad")
    (d / "dir.wl").mkdir()
    (d / "dir.ctl").mkdir()
    (d / "adir").mkdir()
    (d / "empty.wl").write_text("")
    (d / "binary.ctl").write_bytes(bytes(range(256)) * 4)
    (d / "afile").write_text("a file, not a folder\n")
    (d / "notrun.h5").write_text("not HDF5\n")
    # a run file with no generation yet, made as `cpgjax evolve --time 0.3 --population 4` makes it
    problem = make_problem(M, time=0.3)
    algo = make_algorithm(problem, GAConfig(population=4, generations=3))
    params = jax.tree.map(jax.numpy.asarray, algo.params)
    open_run(problem, algo, str(d / "run0.h5"), params, run_keys(0)[0], resume=False, overwrite=False, metrics={})
    data = (d / "run0.h5").read_bytes()
    (d / "trunc.h5").write_bytes(data[: len(data) // 3])
    return d


def _hashes(d) -> dict[str, str]:
    out = {}
    for root, dirs, files in os.walk(d):
        for name in dirs + files:
            p = os.path.join(root, name)
            rel = os.path.relpath(p, d)
            out[rel] = "dir" if os.path.isdir(p) else hashlib.sha256(open(p, "rb").read()).hexdigest()
    return out


ROWS = [
    # malformed or missing input files
    ("wl-is-a-folder", ["simulate", "dir.wl"], ["dir.wl"]),
    ("ctl-is-a-folder", ["simulate", M, "--ctl", "dir.ctl", "--time", "0.1"], ["dir.ctl"]),
    ("empty-wl", ["simulate", "empty.wl"], ["empty.wl"]),
    ("binary-ctl", ["simulate", M, "--ctl", "binary.ctl", "--time", "0.1"], ["binary.ctl"]),
    ("missing-wl", ["simulate", "missing.wl"], ["missing.wl"]),
    ("missing-wl-evolve", ["evolve", "missing.wl", "--out", "o.h5", "--quiet"], ["missing.wl"]),
    ("missing-run", ["best", "missing.h5"], ["missing.h5"]),
    ("run-is-a-folder", ["plot", "adir", "--out", "p.png"], ["adir"]),
    # option values
    ("time-0", ["simulate", M, "--time", "0"], ["--time", "'0'"]),
    ("time-negative", ["simulate", M, "--time", "-1"], ["--time", "'-1'"]),
    ("time-nan", ["evolve", M, "--time", "nan", "--out", "o.h5"], ["--time", "'nan'"]),
    ("time-huge", ["evolve", M, "--time", "1e9", "--out", "o.h5"], ["--time", "'1e9'"]),
    ("time-text", ["simulate", M, "--time", "ten"], ["--time", "'ten'"]),
    ("generations-0", ["evolve", M, "--generations", "0", "--out", "o.h5"], ["--generations"]),
    ("population-0", ["evolve", M, "--population", "0", "--out", "o.h5"], ["--population"]),
    ("samples-0", ["search", M, "--samples", "0", "--out", "o.h5"], ["--samples"]),
    ("mu-max-2", ["evolve", M, "--mu-max", "2", "--out", "o.h5"], ["--mu-max"]),
    ("delta-inf", ["simulate", M, "--delta", "inf"], ["--delta"]),
    ("replicas-0", ["evolve", M, "--replicas", "0", "--out", "o.h5"], ["--replicas"]),
    ("dt-0", ["simulate", M, "--dt", "0"], ["--dt"]),
    ("sweep-population-0", ["sweep", M, "--population", "0", "--out", "sw"], ["--population"]),
    ("sweep-time-nan", ["sweep", M, "--time", "nan", "--out", "sw"], ["--time"]),
    ("free-unknown-group", ["evolve", M, "--free", "cpg+legs", "--out", "o.h5"],
     ["--free cpg+legs", "distinct ones of cpg", "legs"]),
    ("free-in-a-search", ["search", M, "--controller", "pmtg", "--free", "bias", "--out", "o.h5"],
     ["--free", "applies to the GA"]),
    ("pocket-above-population", ["evolve", M, "--population", "4", "--pocket", "5", "--out", "o.h5"], ["pocket"]),
    ("terrain-ramp-2", ["evolve", M, "--terrain", "ramp:2", "--out", "o.h5"], ["--terrain", "ramp:2"]),
    ("terrain-bump-width-0", ["simulate", M, "--terrain", "bump:0.1:0"], ["--terrain", "bump:0.1:0"]),
    ("terrain-rough-cell-0", ["evolve", M, "--terrain", "rough:0.01:0", "--out", "o.h5"],
     ["--terrain", "rough:0.01:0"]),
    ("terrain-stairs-negative-tread", ["simulate", M, "--terrain", "stairs:0.04:-0.3"],
     ["--terrain", "stairs TREAD must be between 0.05 and 3 m, got -0.3"]),
    ("terrain-stairs-taller-than-the-leg", ["evolve", M, "--terrain", "stairs:0.4:0.3", "--out", "o.h5"],
     ["--terrain", "stairs RISE", "0.32 m", "got 0.4"]),
    ("terrain-bar-without-y", ["simulate", M, "--terrain", "bar:0.03"], ["--terrain", "bar takes HEIGHT@Y"]),
    ("terrain-gap-too-wide", ["simulate", M, "--terrain", "gap:3@1"], ["--terrain", "gap WIDTH", "got 3"]),
    # outputs that cannot be written (checked before any work)
    ("evolve-out-under-file", ["evolve", M, "--time", "0.1", "--out", "afile/o.h5"], ["afile/o.h5", "afile"]),
    ("evolve-out-is-folder", ["evolve", M, "--time", "0.1", "--out", "adir"], ["adir"]),
    ("search-out-under-file", ["search", M, "--time", "0.1", "--out", "afile/s.h5"], ["afile/s.h5"]),
    ("sweep-out-under-file", ["sweep", "analytic:sphere:10", "--generations", "2", "--seeds", "1",
                              "--out", "afile/sw"], ["afile/sw"]),
    ("simulate-log-under-file", ["simulate", M, "--time", "0.1", "--log", "afile/logs"], ["afile/logs"]),
    ("best-ctl-under-file", ["best", "run0.h5", "--ctl", "afile/b.ctl"], ["afile/b.ctl"]),
    ("plot-out-under-file", ["plot", "run0.h5", "--out", "afile/p.png"], ["afile/p.png"]),
    ("export-out-under-file", ["export", M, "--out", "afile/m.xml"], ["afile/m.xml"]),
    # results files: not HDF5, truncated, empty, already there
    ("resume-not-hdf5", ["evolve", M, "--out", "notrun.h5", "--resume", "--quiet"],
     ["notrun.h5", "not a readable cpgjax run", "--overwrite"]),
    ("resume-truncated", ["evolve", M, "--out", "trunc.h5", "--resume", "--quiet"],
     ["trunc.h5", "not a readable cpgjax run", "--overwrite"]),
    ("best-not-hdf5", ["best", "notrun.h5"], ["notrun.h5", "not a readable cpgjax run"]),
    ("best-no-generations", ["best", "run0.h5"], ["run0.h5: no generations in the file"]),
    ("plot-no-generations", ["plot", "run0.h5", "--out", "p.png"], ["run0.h5: no generations in the file"]),
    ("out-exists", ["evolve", M, "--time", "0.3", "--out", "run0.h5", "--quiet"], ["run0.h5", "--resume"]),
    # resume with settings that change the fitness
    ("resume-other-time", ["evolve", M, "--out", "run0.h5", "--resume", "--time", "0.5", "--quiet"],
     ["run0.h5: cannot resume: --time 0.5 differs from the run's 0.3 s (drop the option, or start anew with "
      "--overwrite)"]),
    ("resume-other-terrain", ["evolve", M, "--out", "run0.h5", "--resume", "--terrain", "rough:0.02", "--quiet"],
     ["run0.h5: cannot resume:", "--terrain rough:0.02", "flat"]),
    ("resume-other-delta", ["evolve", M, "--out", "run0.h5", "--resume", "--delta", "4", "--quiet"],
     ["run0.h5: cannot resume:", "--delta 4"]),
    ("resume-other-replicas", ["evolve", M, "--out", "run0.h5", "--resume", "--replicas", "3", "--quiet"],
     ["run0.h5: cannot resume:", "--replicas 3"]),
    ("resume-other-population", ["evolve", M, "--out", "run0.h5", "--resume", "--population", "6", "--quiet"],
     ["run0.h5: cannot resume:", "--population 6"]),
]


@pytest.mark.parametrize("argv,expect", [pytest.param(a, e, id=i) for i, a, e in ROWS])
def test_bad_input_is_one_line_exit_2_and_changes_nothing(folder, monkeypatch, capsys, argv, expect):
    monkeypatch.chdir(folder)
    before = _hashes(folder)
    rc = main(argv)
    err = capsys.readouterr().err
    assert rc == 2, err
    one_line_error(err, argv[0], expect)
    assert _hashes(folder) == before


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only folders")
def test_read_only_folder(tmp_path, capsys):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        assert main(["evolve", "analytic:sphere:10", "--out", str(ro / "o.h5"), "--quiet"]) == 2
        assert "permission denied" in capsys.readouterr().err
        assert main(["simulate", M, "--time", "0.1", "--log", str(ro / "logs")]) == 2
        assert str(ro) in capsys.readouterr().err
        assert os.listdir(ro) == []
    finally:
        ro.chmod(0o755)


# --- Ctrl-C on a real process ----------------------------------------------------------------------


# a GA run of experiments/test_evolve.py (CFG, its CLI test): one compiled program for the runs that are interrupted
SHARED_GA = ("analytic:diverging:10", "--pocket", "4", "--crossover", "--gamma", "0.1", "--seed", "5", "--chunk", "4")


def _cpgjax(*argv: str) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": ROOT + os.pathsep + os.environ.get("PYTHONPATH", "")}
    # SIGINT as a terminal gives it: a suite started in the background (`make test &`) runs with SIGINT
    # ignored, which children inherit, and Python then installs no KeyboardInterrupt handler; so the child
    # installs it before it runs `python -m cpgjax.cli` (no preexec_fn: forking a threaded JAX process)
    boot = ("import runpy, signal; signal.signal(signal.SIGINT, signal.default_int_handler); "
            "runpy.run_module('cpgjax.cli', run_name='__main__', alter_sys=True)")
    return subprocess.Popen([sys.executable, "-c", boot, *argv], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env, cwd=ROOT)


def _interrupt_when(proc: subprocess.Popen, ready, timeout: float = 120) -> tuple[str, str]:
    try:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline and proc.poll() is None and not ready():
            time.sleep(0.01)
        assert proc.poll() is None, "the command ended before it could be interrupted"
        proc.send_signal(signal.SIGINT)
        return proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()


def _completed(path) -> int:
    try:
        return int(read_attrs(path)["completed"])
    except Exception:  # noqa: BLE001 - not there yet, or being written
        return -1


def _check_interrupted(proc, err: str, out_path) -> list[str]:
    assert proc.returncode == 130, err
    assert "Traceback" not in err, err
    last = err.strip().splitlines()[-1]
    assert last.startswith("cpgjax evolve: interrupted: ") and f"{out_path}" in last, err
    cmd = last.split("continue with: ", 1)[1]
    argv = shlex.split(cmd)
    assert argv[0] == "cpgjax" and "--resume" in argv and "--overwrite" not in argv
    return argv[1:]


@pytest.mark.slow  # a subprocess compiling; fast: Ctrl-C between generations, this file
def test_ctrl_c_during_compilation_exits_130_and_resume_completes(tmp_path, capsys):
    out = tmp_path / "c.h5"
    # an analytic problem of a shape no other test compiles (a cached program would load before the signal came,
    # and the resume below compiles it again): compiled in about a second, still 100 times the signal's latency
    proc = _cpgjax("evolve", "analytic:sphere:7", "--population", "3", "--generations", "2", "--out", str(out),
                   "--quiet", "--overwrite")
    _, err = _interrupt_when(proc, lambda: os.path.exists(out))   # the file is made just before compiling
    argv = _check_interrupted(proc, err, out)
    assert "holds no generation yet" in err or "holds 0 of 2" in err or "holds 1 of 2" in err
    assert main(argv) == 0
    assert read_run(out).completed == 2


def test_ctrl_c_between_generations_keeps_them_and_resume_completes(tmp_path, capsys):
    out = tmp_path / "g.h5"
    # experiments/test_evolve.py's run settings: its compiled program, which the subprocess loads from the cache
    proc = _cpgjax("evolve", *SHARED_GA, "--generations", "3000", "--out", str(out), "--quiet")
    _, err = _interrupt_when(proc, lambda: _completed(out) >= 1)
    argv = _check_interrupted(proc, err, out)
    done = read_run(out).completed
    assert 1 <= done < 3000 and f"holds {done} of 3000 generations" in err
    i = argv.index("--generations")
    argv[i + 1] = str(done + 5)                   # extend a little past the interruption, not all 3000
    assert main(argv) == 0
    assert read_run(out).completed == done + 5
