"""The drivers: what a GA run file holds, resume (stopped or SIGKILLed) = an uninterrupted run, the CLI."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest
from runcases import other_machine, same_rows

from cpgjax.cli import main
from cpgjax.experiments.evolve import run_ga
from cpgjax.io.ctl import read_ctl
from cpgjax.io.results import ResultsError, read_run
from cpgjax.optim.analytic import analytic_problem
from cpgjax.optim.ga import GAConfig

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SPEC = "analytic:diverging:10"
CFG = GAConfig(generations=15, pocket=4, crossover=True, gamma=0.1, seed=5, chunk=4)


def test_run_file_contents(tmp_path):
    problem = analytic_problem(SPEC)
    s = run_ga(problem, CFG, tmp_path / "run.h5")
    run = read_run(tmp_path / "run.h5")
    assert run.completed == 15 == s["completed"] and run.kind == "ga"
    assert run.genomes.shape == (15, 20, 10) and run.fitness.dtype == np.float32
    np.testing.assert_allclose(run.mutation_rate, 0.2 / (1 + 0.1 * np.arange(15)), rtol=1e-6)
    bad = ~np.isfinite(run.fitness)
    assert bad.any() and np.array_equal(run.diverged, bad) and np.array_equal(run.n_diverged, bad.sum(axis=1))
    assert np.all(np.diff(run.wall_time) >= 0) and run.wall_time[0] > 0
    np.testing.assert_array_equal(run.state["population"][:-1], run.genomes[1:])
    assert set(run.metrics) == {"distance"}
    assert run.config["pocket"] == 4 and run.meta["n_dof"] == 2 and run.attrs["seed"] == 5
    gen, idx, fit, genome = run.best()
    assert fit == pytest.approx(s["best_fitness"]) and np.array_equal(genome, s["best_genome"])


def test_stop_and_resume_equals_uninterrupted(tmp_path):
    problem = analytic_problem(SPEC)
    full = tmp_path / "full.h5"
    run_ga(problem, CFG, full)
    part = tmp_path / "part.h5"
    s = run_ga(problem, CFG, part, stop_after=6)  # 6 = one chunk of 4 and half of the next
    assert s["completed"] == 6 and read_run(part).completed == 6
    s = run_ga(problem, CFG, part, resume=True)
    assert s["completed"] == 15
    same_rows(read_run(full), read_run(part))
    # extending a finished run (more generations) = a longer run from the start
    longer = tmp_path / "longer.h5"
    run_ga(problem, GAConfig(**{**CFG.to_dict(), "generations": 20}), longer)
    run_ga(problem, GAConfig(**{**CFG.to_dict(), "generations": 20}), part, resume=True)
    same_rows(read_run(longer), read_run(part))
    assert read_run(part).attrs["generations"] == 20


def test_refusals(tmp_path):
    problem = analytic_problem(SPEC)
    p = tmp_path / "r.h5"
    run_ga(problem, CFG, p, stop_after=1)
    with pytest.raises(ResultsError, match="--resume"):
        run_ga(problem, CFG, p)
    with pytest.raises(ResultsError, match="pocket"):
        run_ga(problem, GAConfig(**{**CFG.to_dict(), "pocket": 2}), p, resume=True)
    with pytest.raises(ResultsError, match=r"the n_dof 3 differs from the run's 2 \(start anew with --overwrite\)"):
        run_ga(analytic_problem("analytic:diverging:15"), CFG, p, resume=True)
    run_ga(problem, CFG, p, overwrite=True, stop_after=2)
    assert read_run(p).completed == 2


KILL_SCRIPT = """
import sys
from cpgjax.experiments.evolve import run_ga
from cpgjax.optim.ga import GAConfig
from cpgjax.optim.analytic import analytic_problem

cfg = GAConfig(generations=100000, pocket=4, crossover=True, gamma=0.1, seed=9, chunk=4)
run_ga(analytic_problem("{spec}"), cfg, sys.argv[1], resume=True,
       callback=lambda done, info: print(done, flush=True))
"""


def test_sigkill_mid_run_leaves_a_readable_file_that_resumes_to_the_same_result(tmp_path):
    script = tmp_path / "evolve_forever.py"
    script.write_text(textwrap.dedent(KILL_SCRIPT.format(spec=SPEC)))
    out = tmp_path / "killed.h5"
    env = {**os.environ, "PYTHONPATH": ROOT + os.pathsep + os.environ.get("PYTHONPATH", "")}
    proc = subprocess.Popen([sys.executable, str(script), str(out)], stdout=subprocess.PIPE, env=env, text=True)
    try:
        seen = 0
        deadline = time.monotonic() + 60
        while seen < 4 and time.monotonic() < deadline:
            line = proc.stdout.readline()
            if not line:
                break
            seen = int(line)
        time.sleep(0.004)  # land somewhere inside the next generations (compute or write)
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert seen >= 4, "the subprocess did not get going"
    assert proc.returncode == -signal.SIGKILL
    killed = read_run(out)  # opens: the file survived the kill
    assert killed.completed >= 4
    assert np.all(np.isfinite(killed.genomes))
    total = 40
    problem = analytic_problem(SPEC)
    # CFG's settings (another seed): the program test_run_file_contents compiled, which the subprocess loads
    cfg = GAConfig(generations=total, pocket=4, crossover=True, gamma=0.1, seed=9, chunk=4)
    run_ga(problem, cfg, out, resume=True)
    ref = tmp_path / "ref.h5"
    run_ga(problem, cfg, ref)
    n = min(total, read_run(out).completed)
    same_rows(read_run(ref), read_run(out), n=n)


def cli(*argv: str) -> int:
    return main(list(argv))


def test_cli_evolve_resume_best_search_plot(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    m = SPEC                                  # CFG's settings: test_run_file_contents's compiled program
    ga = ["--pocket", "4", "--crossover", "--gamma", "0.1", "--seed", "5", "--chunk", "4"]
    assert cli("evolve", m, "--generations", "6", *ga, "--out", "r.h5", "--quiet") == 0
    assert cli("evolve", m, "--generations", "6", "--out", "r.h5", "--quiet") == 2
    assert "--resume" in capsys.readouterr().err
    assert cli("evolve", m, "--generations", "9", "--out", "r.h5", "--resume", "--quiet") == 0
    run = read_run("r.h5")
    assert run.completed == 9 and run.config["pocket"] == 4 and run.config["chunk"] == 4
    assert cli("evolve", m, "--pocket", "3", "--out", "r.h5", "--resume", "--quiet") == 2
    assert "pocket" in capsys.readouterr().err

    assert cli("best", "r.h5", "--ctl", "best.ctl") == 0
    printed = capsys.readouterr().out
    gen, idx, fit, genome = run.best()
    assert f"best fitness {fit:.6f}" in printed
    ctl = read_ctl("best.ctl", n_dof=2, harmonics=2)
    np.testing.assert_allclose(np.asarray(ctl.coeffs).reshape(-1), genome, atol=1e-6)
    assert ctl.fitness == pytest.approx(fit, abs=1e-6)

    assert cli("search", m, "--method", "amc", "--M", "5", "--samples", "100", "--out", "s.h5", "--quiet") == 0
    assert read_run("s.h5").kind == "amc"
    assert cli("plot", "r.h5", "s.h5", "--out", "fig.png") == 0
    assert os.path.getsize("fig.png") > 10_000
    assert cli("evolve", m, "--generations", "3", *ga, "--out", "r.h5", "--overwrite", "--quiet") == 0
    assert read_run("r.h5").completed == 3
    assert cli("evolve", "analytic:nope:3", "--quiet") == 2


def _as_if_from(path, **other) -> None:
    """Make a run file look computed on another machine (its recorded machine changed)."""
    import json

    import h5py

    with h5py.File(path, "a") as f:
        m = json.loads(f.attrs["machines"])
        m[-1].update(other)
        f.attrs["machines"] = json.dumps(m)


def test_resume_on_another_machine_is_refused_unless_allowed(tmp_path):
    import json

    from cpgjax.io.results import machine, read_attrs

    problem = analytic_problem(SPEC)
    out = tmp_path / "run.h5"
    run_ga(problem, CFG, out, stop_after=4)
    m = json.loads(read_attrs(out)["machines"])
    assert m == [{"from_generation": 0, **machine()}] and {"cpu", "isa", "jax", "jaxlib", "cpgjax"} <= set(m[0])
    other = other_machine()
    _as_if_from(out, **other)
    with pytest.raises(ResultsError) as e:
        run_ga(problem, CFG, out, resume=True)
    msg = str(e.value)
    assert "\n" not in msg and str(out) in msg and "another machine" in msg
    here = machine()
    for k in here:                                   # every field differs, and the message names each
        assert f"{k} {other[k]} -> {here[k]}" in msg, k
    assert "--allow-other-machine" in msg and read_run(out).completed == 4      # nothing written
    run_ga(problem, CFG, out, resume=True, allow_other_machine=True)
    m = json.loads(read_attrs(out)["machines"])
    assert [x["from_generation"] for x in m] == [0, 4] and m[1] == {"from_generation": 4, **machine()}
    assert read_run(out).completed == CFG.generations
    # the same machine again: no question asked (the last machine is the one compared)
    run_ga(problem, CFG.__class__(**{**CFG.to_dict(), "generations": 18}), out, resume=True)
    assert len(json.loads(read_attrs(out)["machines"])) == 2
