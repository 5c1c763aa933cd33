"""Sweeps (cpgjax.experiments.sweep, cpgjax sweep / report): batching must not change results; resume;
figures; report."""

from __future__ import annotations

import json
import os
import shutil

import h5py
import jax
import numpy as np
import pytest
from runcases import TINY_SWEEP, TINY_TIME, same_rows

from cpgjax import cli
from cpgjax.experiments import sweep
from cpgjax.io import sweepdir
from cpgjax.io.results import ResultsError, read_run
from cpgjax.plots import thesis

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
WL = os.path.join(ROOT, "models", "quadruped.wl")
# the quadruped, short episodes: the simulator's result for a robot does not depend on its batch
QUAD = ["--time", str(TINY_TIME), "--population", "6", "--generations", "3"]   # the suite's tiny episodes


@pytest.fixture(scope="module")
def quad_sweep(tmp_path_factory):
    """A 2 x 2 sweep (pocket 0/2 x cross-over off/on, gamma 0.1) x 2 seeds, plus random and amc3, one program
    (the slow tests: the quadruped's sweep)."""
    out = str(tmp_path_factory.mktemp("sweep") / "quad")
    rc = cli.main(["sweep", WL, *QUAD, "--gamma", "0.1", "--pocket", "0,2", "--crossover", "off,on",
                   "--seeds", "2", "--baselines", "random,amc3", "--out", out, "--quiet"])
    assert rc == 0
    return out


# the suite's tiny sweep (tests/runcases.py, analysis/test_report.py's too): 8 GA settings, random search, amc and
# CMA-ES on the analytic sphere, 6 generations, 2 seeds, one program; the drivers are the same for every problem
GENS = 6


@pytest.fixture(scope="module")
def tiny_sweep(tmp_path_factory):
    out = str(tmp_path_factory.mktemp("sweep") / "tiny")
    assert cli.main([*TINY_SWEEP, "--generations", str(GENS), "--out", out]) == 0
    return out


def test_layout_and_manifest(tiny_sweep):
    cells = sweepdir.find_runs(tiny_sweep)
    assert sorted(cells) == ["amc_M3", "cmaes_n6_s0.2", *[f"ga_n6_mu0.2_g{g}_p{p}_x{x}" for g in (0, 1) for p in (0, 2)
                                                         for x in ("off", "on")], "random"]
    assert all(len(v) == 2 for v in cells.values())
    man = json.load(open(os.path.join(tiny_sweep, sweep.MANIFEST)))
    assert len(man["runs"]) == 22 and man["problem"]["model"] == "analytic:sphere:10"
    run = read_run(cells["ga_n6_mu0.2_g1_p2_xon"][1])
    assert run.kind == "ga" and run.completed == GENS and run.config["crossover"] and run.config["seed"] == 1
    assert run.fitness.shape == (GENS, 6) and run.genomes.shape == (GENS, 6, 10)


def _same_as_evolve(sweep_dir, tmp_path, pocket, xo, seed, problem=(WL, *QUAD), gamma="0.1"):
    single = str(tmp_path / f"p{pocket}{xo}{seed}.h5")
    assert cli.main(["evolve", *problem, "--gamma", gamma, "--pocket", str(pocket), xo,
                     "--seed", str(seed), "--out", single, "--quiet"]) == 0
    cell = f"ga_n6_mu0.2_g{gamma}_p{pocket}_x{'on' if xo == '--crossover' else 'off'}"
    same_rows(read_run(os.path.join(sweep_dir, cell, f"s{seed}.h5")), read_run(single))


def test_a_sweep_run_equals_the_run_made_alone_with_cpgjax_evolve(tiny_sweep, tmp_path):
    """Batching (8 GA settings x 2 seeds and the baselines in one program) changes no number: the run with
    a pocket, cross-over and gamma 1, second seed (on the quadruped, every setting and seed: the slow test below)."""
    _same_as_evolve(tiny_sweep, tmp_path, 2, "--crossover", 1,
                    problem=("analytic:sphere:10", "--population", "6", "--generations", str(GENS)), gamma="1")


@pytest.mark.slow  # long; `make test-all` runs it
def test_sweep_equals_runs_made_one_by_one_with_cpgjax_evolve(quad_sweep, tmp_path):
    """Batching (4 GA settings x 2 seeds and the baselines in one program) changes no number."""
    for pocket in (0, 2):
        for xo in ("--no-crossover", "--crossover"):
            for seed in (0, 1):
                _same_as_evolve(quad_sweep, tmp_path, pocket, xo, seed)


def test_baselines_propose_as_cpgjax_search(tiny_sweep, tmp_path):
    """Random search and amc in a sweep draw the genomes `cpgjax search` draws and record the fitness it records
    (on the analytic problem: the driver is the same for every problem; on the quadruped: the slow test below)."""
    m = "analytic:sphere:10"
    for method, extra, cell in (("random", [], "random"), ("amc", ["--M", "3"], "amc_M3")):
        single = str(tmp_path / f"{cell}.h5")
        assert cli.main(["search", m, "--method", method, *extra, "--samples", str(6 * GENS), "--batch", "6",
                         "--seed", "1", "--out", single, "--quiet"]) == 0
        same_rows(read_run(os.path.join(tiny_sweep, cell, "s1.h5")), read_run(single))


@pytest.mark.slow  # two searches on the quadruped, each its own program; fast: the analytic one above
def test_baselines_propose_as_cpgjax_search_and_score_their_genomes(quad_sweep, tmp_path):
    """Random search and amc in a sweep draw the genomes `cpgjax search` draws; each stored fitness is
    exactly the simulator's for the stored genome (re-evaluated here in a batch of its own)."""
    import jax
    import jax.numpy as jnp

    problem = sweep.sweep_problem({"model": WL, "time": TINY_TIME})
    evaluate = jax.jit(problem.evaluate)
    for method, extra, cell in (("random", [], "random"), ("amc", ["--M", "3"], "amc_M3")):
        single = str(tmp_path / f"{cell}.h5")
        assert cli.main(["search", WL, "--time", str(TINY_TIME), "--method", method, *extra, "--samples", "18",
                         "--batch", "6", "--seed", "1", "--out", single, "--quiet"]) == 0
        a, b = read_run(os.path.join(quad_sweep, cell, "s1.h5")), read_run(single)
        np.testing.assert_array_equal(a.genomes[0], b.genomes[0])   # generation 0 does not depend on fitness
        for gen in range(a.completed):
            f = np.asarray(evaluate(jnp.asarray(a.genomes[gen]))["fitness"])
            np.testing.assert_array_equal(f, a.fitness[gen])


# run in a subprocess with ONE host device: a tiny sweep of random search and amc, each stored fitness re-evaluated
ONE_DEVICE = """
import sys
import cpgjax  # first: the host device count (cpgjax/_xla.py)
import jax
import jax.numpy as jnp
import numpy as np
from cpgjax.experiments import sweep
from cpgjax.io.results import read_run

wl, out = sys.argv[1:3]
assert len(jax.devices()) == 1, jax.devices()
specs = sweep.plan(out, sweep.baseline_cells(["random", "amc3"], samples=12, batch=6), [1])
sweep.run_sweep(sweep.sweep_problem({"model": wl, "time": 0.3}, batch=sweep.total_batch(specs)), specs,
                progress=False)
evaluate = jax.jit(sweep.sweep_problem({"model": wl, "time": 0.3}).evaluate)
for s in specs:
    run = read_run(s.path)
    assert run.completed == 2
    for gen in range(run.completed):
        f = np.asarray(evaluate(jnp.asarray(run.genomes[gen]))["fitness"])
        np.testing.assert_array_equal(f, run.fitness[gen], err_msg=f"{s.cell}, generation {gen}")
"""


@pytest.mark.slow  # a subprocess that imports jax and compiles its one-device programs; `make test-all` runs it
def test_baselines_score_their_genomes_on_one_host_device_too(tmp_path):
    """As above with ONE host device (``CPGJAX_DEVICES=1``: no `shard_map`, the simulation inline in the sweep's
    `lax.cond`): each stored fitness is still exactly the simulator's for the stored genome (it differed in its
    last bits when the model's constants reached the simulation as operands of the conditional; see
    `cpgjax.optim.algorithm.generation_step`)."""
    import subprocess
    import sys

    from cpgjax import _xla

    env = dict(_xla.child_environ(), CPGJAX_DEVICES="1")    # not this process's devices and pools
    r = subprocess.run([sys.executable, "-c", ONE_DEVICE, WL, str(tmp_path / "one")], cwd=ROOT, env=env,
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr[-4000:]


@pytest.mark.slow  # 10 s; fast: an evolve run killed -9 resumes (experiments/test_evolve.py)
def test_resume_after_interruption_equals_uninterrupted(quad_sweep, tmp_path):
    out = str(tmp_path / "resumed")
    args = ["sweep", WL, *QUAD, "--gamma", "0.1", "--pocket", "0,2", "--crossover", "off,on", "--seeds", "2",
            "--baselines", "random,amc3", "--out", out, "--quiet"]
    specs = sweep.plan(out, sweep.ga_grid(gamma=(0.1,), pocket=(0, 2), crossover=(False, True), population=(6,),
                                          generations=3)
                       + sweep.baseline_cells(["random", "amc3"], samples=18, batch=6), [0, 1])
    problem = sweep.sweep_problem({"model": WL, "time": TINY_TIME, "terrain": None, "delta": None})
    s = sweep.run_sweep(problem, specs, progress=False, stop_after=1)        # interrupted after 1 generation
    assert s["evaluations"] == sum(sp.cfg.population for sp in specs)
    assert not sweep.complete(specs)
    # one run further behind (a kill during its first write), one already complete (a previous sweep)
    with h5py.File(specs[0].path, "a") as f:
        f.attrs["completed"] = 0
    shutil.copy(os.path.join(quad_sweep, specs[3].cell, "s1.h5"), specs[3].path)
    assert cli.main(args) == 0
    assert sweep.complete(specs)
    for sp in specs:
        same_rows(read_run(sp.path), read_run(os.path.join(quad_sweep, sp.cell, os.path.basename(sp.path))))
    # a complete sweep is skipped as a whole
    s = sweep.run_sweep(problem, specs, progress=False)
    assert s["skipped"] == len(specs) and s["evaluations"] == 0


# the small sweeps on the analytic problem below: the tiny sweep's program (tests/runcases.py; the number of
# generations is part of a sweep's program)
SMALL = TINY_SWEEP


def test_mismatching_settings_are_refused(tiny_sweep, tmp_path):
    out = str(tmp_path / "s")
    shutil.copytree(tiny_sweep, out)        # the tiny sweep's files: made by this command (SMALL, GENS)
    run = os.path.join(out, "ga_n6_mu0.2_g0_p0_xoff", "s0.h5")
    with h5py.File(run, "a") as f:              # pretend it was made with another init spread
        cfg = json.loads(f.attrs["config"])
        cfg["init_spread"] = 0.3
        f.attrs["config"] = json.dumps(cfg)
    assert cli.main([*SMALL, "--generations", str(GENS), "--out", out]) == 2
    with pytest.raises(ResultsError):
        sweep.run_sweep(sweep.sweep_problem({"model": "analytic:sphere:10"}),
                        sweep.plan(out, sweep.ga_grid(population=(6,), generations=GENS), [0]), progress=False)


def test_generations_can_be_extended(tmp_path):
    """A GA sweep runs on to more generations (a baseline's budget is fixed: --samples, not extended)."""
    out = str(tmp_path / "s")
    base = ["sweep", "analytic:sphere:10", "--population", "4", "--seeds", "2", "--gamma", "0,1", "--quiet",
            "--out", out]
    assert cli.main([*base, "--generations", "2"]) == 0
    assert cli.main([*base, "--generations", "5"]) == 0
    for files in sweepdir.find_runs(out).values():
        for p in files:
            assert read_run(p).completed == 5


def test_cpgjax_best_plot_and_report_on_cells(tiny_sweep, tmp_path, capsys):
    run = os.path.join(tiny_sweep, "ga_n6_mu0.2_g1_p2_xoff", "s0.h5")
    assert cli.main(["best", run, "--ctl", str(tmp_path / "b.ctl")]) == 0
    assert cli.main(["plot", run, os.path.join(tiny_sweep, "random", "s0.h5"), "--out", str(tmp_path / "p.png")]) == 0
    assert os.path.getsize(tmp_path / "p.png") > 0
    assert cli.main(["report", tiny_sweep, "--out", str(tmp_path / "r.md")]) == 0
    text = open(tmp_path / "r.md").read()
    assert "| ga |" in text and "| random |" in text and "| amc |" in text   # the claims: analysis/test_report.py


def test_every_thesis_figure(tiny_sweep):
    ga_all = sweepdir.runs_matching(tiny_sweep, "ga")
    assert len(ga_all) == 16 and len(sweepdir.runs_matching(tiny_sweep, "ga", pocket=2, crossover=True)) == 4
    cells = thesis.load_cells(ga_all)
    assert len(cells) == 8 and all(c.fitness.shape == (2, GENS, 6) for c in cells)
    c = cells[0]
    np.testing.assert_array_equal(c.best_so_far()[:, -1], np.nanmax(c.fitness, axis=(1, 2)))
    figs = [thesis.fig_6_5(sweepdir.runs_matching(tiny_sweep, "ga", pocket=0, crossover=False)),
            thesis.fig_6_6(paths=ga_all, generations=GENS),
            thesis.fig_6_7(sweepdir.runs_matching(tiny_sweep, "ga", pocket=0)),
            thesis.fig_6_8(sweepdir.runs_matching(tiny_sweep, "ga", pocket=2, crossover=False)),
            thesis.fig_6_9(sweepdir.runs_matching(tiny_sweep, "ga", pocket=2, crossover=True)),
            thesis.fig_6_10(sweepdir.runs_matching(tiny_sweep, "random")),
            thesis.fig_6_11(sweepdir.runs_matching(tiny_sweep, "amc")),
            thesis.fig_6_12(ga_all, sweepdir.runs_matching(tiny_sweep, "random")
                            + sweepdir.runs_matching(tiny_sweep, "amc"))]
    for f in figs:
        assert f.axes and f.canvas is not None
        f.canvas.draw()
    with pytest.raises(ValueError):
        thesis.fig_6_10(ga_all)


def test_eval_chunk_pads_little():
    for n in (6, 20, 100, 1200, 1605, 4000):
        ch = sweep.eval_chunk(n, devices=2)
        assert ch % 16 == 0 and ch <= 256
        per_dev = -(-n // 2)
        padded = -(-per_dev // ch) * ch
        assert padded - per_dev < max(16 * (-(-per_dev // 256)), 16)


@pytest.mark.slow  # long; `make test-all` runs it
def test_sweep_killed_mid_run_resumes_to_the_uninterrupted_result(tmp_path):
    """SIGKILL a sweep subprocess while it runs (runs may stop at different generations); the same
    command continues every run, and the files equal those of a sweep that was never interrupted."""
    import signal
    import subprocess
    import sys
    import time

    from cpgjax.io.results import read_attrs

    def argv(out):
        return ["sweep", "analytic:sphere:10", "--population", "4", "--gamma", "0,1", "--pocket", "0,2",
                "--seeds", "2", "--generations", "150", "--baselines", "amc3", "--out", str(out), "--quiet"]

    out = tmp_path / "killed"
    proc = subprocess.Popen([sys.executable, "-m", "cpgjax.cli", *argv(out)], stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    probe = out / "ga_n4_mu0.2_g0_p0_xoff" / "s0.h5"
    try:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and proc.poll() is None:
            try:
                if read_attrs(probe)["completed"] >= 5:
                    break
            except (OSError, KeyError, ResultsError):
                pass
            time.sleep(0.01)
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == -signal.SIGKILL, "the sweep finished before it could be killed"
    done = [read_run(p).completed for fs in sweepdir.find_runs(out).values() for p in fs]
    assert 0 < min(done) and max(done) < 150
    assert cli.main(argv(out)) == 0
    ref = tmp_path / "ref"
    assert cli.main(argv(ref)) == 0
    for cell, files in sweepdir.find_runs(ref).items():
        for p in files:
            same_rows(read_run(p), read_run(out / cell / os.path.basename(p)))


def test_bad_arguments_are_named(tmp_path, capsys):
    out = str(tmp_path / "s")
    assert cli.main(["sweep", WL, "--gamma", "0,x", "--out", out]) == 2
    assert "'x' in '0,x'" in capsys.readouterr().err
    assert cli.main(["sweep", WL, "--preset", "tiny", "--pocket", "0,4", "--out", out]) == 2
    assert "drop --pocket" in capsys.readouterr().err
    assert cli.main(["sweep", WL, "--pocket", "0,30", "--out", out, "--dry-run"]) == 2
    assert "pocket must be in [0, population]" in capsys.readouterr().err
    assert cli.main(["sweep", WL, "--preset", "tiny", "--out", out, "--dry-run"]) == 0
    assert "18 runs" in capsys.readouterr().out
    assert not os.path.exists(out)                      # a dry run writes nothing


def test_resume_with_another_episode_length_is_refused(tmp_path):
    """A sweep's runs are resumed through open_run: a different --time is refused before anything is computed."""
    from cpgjax.experiments.runner import open_run, run_keys
    from cpgjax.optim.algorithm import make_algorithm

    out = str(tmp_path / "s")
    specs = sweep.plan(out, sweep.ga_grid(population=(6,), generations=GENS), [0])
    made = sweep.sweep_problem({"model": WL, "time": 0.3})
    for sp in specs:                                   # the files as a sweep at 0.3 s leaves them (no generation yet)
        algo = make_algorithm(made, sp.cfg)
        open_run(made, algo, sp.path, jax.tree.map(jax.numpy.asarray, algo.params), run_keys(sp.seed)[0],
                 resume=False, overwrite=False, metrics={})
    before = open(specs[0].path, "rb").read()
    with pytest.raises(ResultsError, match=r"cannot resume: --time 0.5 differs from the run's 0.3 s"):
        sweep.run_sweep(sweep.sweep_problem({"model": WL, "time": 0.5}), specs, progress=False)
    assert open(specs[0].path, "rb").read() == before


@pytest.mark.slow  # long; `make test-all` runs it
def test_a_sweep_mixing_ga_and_evolution_strategies_equals_the_runs_made_one_by_one(tmp_path):
    """The GA (population 6) and two evolution strategies (population 8) in one program: every run holds bit
    for bit the rows of the same run made alone with `cpgjax evolve` / `cpgjax search`."""
    m, out = "analytic:diverging:10", str(tmp_path / "mixed")
    assert cli.main(["sweep", m, "--population", "6", "--generations", "4", "--pocket", "2", "--seeds", "2",
                     "--baselines", "cmaes,openes", "--es-population", "8", "--es-sigma", "0.3",
                     "--chunk", "2", "--out", out, "--quiet"]) == 0
    cells = sweepdir.find_runs(out)
    assert sorted(cells) == ["cmaes_n8_s0.3", "ga_n6_mu0.2_g0_p2_xoff", "openes_n8_s0.3_lr0.05"]
    single = str(tmp_path / "one.h5")
    for seed in (0, 1):
        for cell, argv in (("ga_n6_mu0.2_g0_p2_xoff", ["evolve", "--population", "6", "--generations", "4",
                                                       "--pocket", "2"]),
                           ("cmaes_n8_s0.3", ["search", "--method", "cmaes", "--population", "8", "--samples", "24",
                                              "--sigma", "0.3"]),
                           ("openes_n8_s0.3_lr0.05", ["search", "--method", "openes", "--population", "8",
                                                      "--samples", "24", "--sigma", "0.3"])):
            assert cli.main([argv[0], m, *argv[1:], "--seed", str(seed), "--chunk", "2", "--out", single,
                             "--overwrite", "--quiet"]) == 0
            a = read_run(os.path.join(out, cell, f"s{seed}.h5"))
            same_rows(a, read_run(single))
            assert a.kind == cell.split("_n")[0] and a.completed == (4 if cell.startswith("ga") else 3)
    # the report has a row per evolution strategy against the GA, and draws Fig. 6.12 with every method
    fig = str(tmp_path / "f612.png")
    assert cli.main(["report", out, "--fig-6-12", fig]) == 0
    text = open(os.path.join(out, "report.md")).read()
    assert text.count("(not in the thesis) The GA against") == 2 and "CMA-ES, N=8, σ0=0.3" in text
    assert os.path.getsize(fig) > 10_000


@pytest.mark.slow  # 9 s; fast: a change of pipeline refused (experiments/test_pipeline_runs.py)
def test_new_seeds_scored_otherwise_than_the_sweep_are_refused(tmp_path, capsys):
    """Seeds added to a sweep folder must be scored as its runs are: a robust sweep does not take thesis seeds."""
    out = str(tmp_path / "s")
    base = ["sweep", WL, "--time", "0.3", "--population", "4", "--generations", "1", "--out", out, "--quiet"]
    robust = ["--evaluation", "robust", "--perturb", "replicas=2"]
    assert cli.main([*base, *robust, "--seeds", "1"]) == 0
    assert cli.main([*base, "--seeds", "1:2"]) == 2             # seed 1 alone, without the robust evaluation
    err = capsys.readouterr().err
    assert "s0.h5: cannot add runs to this sweep: --evaluation thesis differs from the run's robust" in err
    assert "(use the sweep's settings, or another --out)" in err
    assert cli.main([*base, "--seeds", "1:2", "--ray"]) == 2        # refused before any Ray task starts
    assert "cannot add runs to this sweep: --evaluation thesis" in capsys.readouterr().err
    assert sorted(sweepdir.find_runs(out)["ga_n4_mu0.2_g0_p0_xoff"]) == [os.path.join(out, "ga_n4_mu0.2_g0_p0_xoff",
                                                                                      "s0.h5")]
    assert cli.main([*base, *robust, "--seeds", "1:2"]) == 0     # the sweep's own settings add it
    assert len(sweepdir.find_runs(out)["ga_n4_mu0.2_g0_p0_xoff"]) == 2


def test_a_run_file_another_writer_holds_stops_the_sweep_before_it_writes(tmp_path, capsys):
    """One writer per run file: a sweep whose run is being written elsewhere (here: its lock held) stops with one
    line naming that file, exit 2, and creates, replaces or resumes none of its runs."""
    from cpgjax.io import runlock

    out = str(tmp_path / "s")
    args = [*SMALL, "--generations", str(GENS), "--out", out]
    held = os.path.join(out, "ga_n6_mu0.2_g0_p0_xoff", "s1.h5")
    with runlock.hold(held):
        capsys.readouterr()
        assert cli.main(args + ["--overwrite"]) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and held in err and f"pid {os.getpid()}" in err
        assert sweepdir.find_runs(out) == {}                      # no run file created, not even s0's
    assert cli.main(args) == 0 and len(sweepdir.find_runs(out)["ga_n6_mu0.2_g0_p0_xoff"]) == 2
    assert len(sweepdir.find_runs(out)["ga_n6_mu0.2_g1_p0_xoff"]) == 2
    assert not [f for _, _, fs in os.walk(out) for f in fs if f.endswith(".lock")]   # every lock let go
