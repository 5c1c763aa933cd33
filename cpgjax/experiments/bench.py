"""`cpgjax bench`: how fast the penalty simulator scores controllers.

Reports, for the quadruped at several batch sizes, robot-steps per second and simulated
robot-seconds per wall second, with the compile time apart: the ahead-of-time ``lower().compile()``
of the program, timed alone (not "first call minus a steady call", which is no compile time and
came out negative for MJX under load); the run is the best of the calls of that compiled program.
``--tricks`` also measures what each speed trick buys, side by side in one run: all
host devices vs one, the polynomial atan2 vs the library one, the chunk size, and on exact joints
the stages computed once into memory (`sim.tricks.keep`) vs left to XLA's fusion, and XLA's thread pools.
Table A.1 (``--table-a1``): :mod:`cpgjax.experiments.slowdown`.
"""

from __future__ import annotations

import dataclasses
import os
import platform
import time

import numpy as np

from cpgjax.experiments.slowdown import THESIS_A1, table_a1  # noqa: F401  (re-exported: `bench --table-a1`)

DEFAULT_BATCHES = (1, 20, 256, 1024, 4096)
AGAINST_BATCHES = (20, 256, 1024)      # --against: the thesis's population of 20 beside large batches
# --against: each engine's wall time is the fastest of this many calls (one call varied by about 10 % on the
# 2-core host; the same count for ours and MuJoCo C, whose rollouts take no compile; MJX's one call takes seconds)
AGAINST_REPEATS = 3


def _controllers(model, n, seed=0):
    from cpgjax.episode.cpg import GENE_BOX, sinusoid_genome

    rng = np.random.default_rng(seed)
    base = sinusoid_genome(model.n_ctrl, model.episode.harmonics).reshape(model.n_ctrl, model.n_coeff)
    return np.clip(base[None] + rng.uniform(-0.3, 0.3, (n, model.n_ctrl, model.n_coeff)), -GENE_BOX, GENE_BOX)


def episode_program(model, batch: int, time_s: float, *, chunk: int = 256, devices=None):
    """The program the bench times, and its argument: one episode of ``time_s`` for ``batch`` jittered sinusoids
    (``jax.jit`` of ``evaluate``, not yet compiled; ``benchmarks/compile_anatomy.py`` dissects its compile)."""
    import jax

    from cpgjax.episode.batch import evaluate

    coeffs = jax.numpy.asarray(_controllers(model, batch), jax.numpy.float32)
    return jax.jit(lambda c: evaluate(model, c, time=time_s, chunk=chunk, devices=devices)), coeffs


def measure(model, batch: int, time_s: float, *, chunk: int = 256, devices=None, repeats: int = 1):
    """(compile_s, run_s) of one episode of ``time_s`` for ``batch`` robots (fresh compile)."""
    f, coeffs = episode_program(model, batch, time_s, chunk=chunk, devices=devices)
    return _compile_and_run(f, coeffs, repeats)


def _compile_and_run(f, x, repeats: int = 1) -> tuple[float, float]:
    """(compile_s, run_s): the ahead-of-time compile of jitted ``f`` for ``x`` timed alone, then the fastest of
    ``repeats`` calls of the compiled program after one untimed call (its one-off buffer allocations)."""
    import jax

    t0 = time.perf_counter()
    compiled = f.lower(x).compile()
    compile_s = time.perf_counter() - t0
    jax.block_until_ready(compiled(x))
    runs = []
    for _ in range(max(1, repeats)):
        t0 = time.perf_counter()
        jax.block_until_ready(compiled(x))
        runs.append(time.perf_counter() - t0)
    return compile_s, min(runs)


# One child process of `measure_alone`: cpgjax's set-up from its environment, then `measure` on the model.
_ALONE = """
import json, sys
import cpgjax
from cpgjax.experiments.bench import measure
from cpgjax.io.wl import load_model
path, pipeline, batch, time_s, chunk, repeats = json.loads(sys.argv[1])
print(json.dumps(measure(load_model(path, pipeline=pipeline), batch, time_s, chunk=chunk, repeats=repeats)))
"""


def measure_alone(model_path: str, pipeline: str | None, batch: int, time_s: float, *, chunk: int = 256,
                  repeats: int = 1, **env) -> tuple[float, float]:
    """`measure` in a process of its own whose environment has ``env`` (e.g. ``CPGJAX_DEVICES``, ``PJRT_NPROC``):
    what XLA reads once per process (its host devices, its thread pools), which one process cannot change.  The
    persistent compile cache off, as in this process."""
    import json
    import subprocess
    import sys

    from cpgjax import _xla

    base = _xla.child_environ()
    base.pop("JAX_COMPILATION_CACHE_DIR", None)
    base["CPGJAX_COMPILE_CACHE"] = "0"
    arg = json.dumps([model_path, pipeline, batch, time_s, chunk, repeats])
    r = subprocess.run([sys.executable, "-c", _ALONE, arg], env={**base, **env}, capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError(f"measuring {model_path} in a process of its own ({env}) failed:\n{r.stderr[-2000:]}")
    compile_s, run_s = json.loads(r.stdout.strip().splitlines()[-1])
    return compile_s, run_s


def measure_vmap(model, batch: int, time_s: float):
    """(compile_s, run_s) with `jax.vmap` of a one-robot rollout instead of the batch-last layout."""
    import jax
    import jax.numpy as jnp

    from cpgjax.episode.rollout import rollout

    coeffs = jnp.asarray(_controllers(model, batch), jnp.float32)
    one = lambda c: rollout(model, c[..., None], time=time_s)  # noqa: E731
    return _compile_and_run(jax.jit(jax.vmap(one)), coeffs)


def row(model, batch, time_s, label="", vmap=False, alone=None, **kw):
    """A table row; ``alone``: ``(model_path, pipeline, env)`` to measure in a process of its own
    (`measure_alone`)."""
    from cpgjax.episode.rollout import schedule

    if alone is not None:
        path, pipeline, env = alone
        compile_s, run_s = measure_alone(path, pipeline, batch, time_s, **kw, **env)
    else:
        compile_s, run_s = measure_vmap(model, batch, time_s) if vmap else measure(model, batch, time_s, **kw)
    inner, outer = schedule(model, time_s)
    steps = inner * outer
    T = steps * model.dt
    return {
        "label": label, "batch": batch, "dt": model.dt, "sim_time": T, "compile_s": compile_s, "wall_s": run_s,
        "robot_steps_per_s": batch * steps / run_s, "robot_s_per_s": batch * T / run_s,
    }


def print_table(rows, title=""):
    if title:
        print(title)
    print(f"{'what':<28}{'batch':>7}{'dt [s]':>9}{'compile [s]':>13}{'wall [s]':>10}"
          f"{'robot-steps/s':>15}{'robot-s/s':>11}")
    notes = ["compile: the ahead-of-time lower().compile() of the program, timed alone, never a read of the persistent "
             "cache (MuJoCo C: none)",
             "wall: a call of the compiled program, after a first one (MuJoCo C: after a warm-up)"]
    for r in rows:
        print(f"{r['label']:<28}{r['batch']:>7}{r['dt']:>9.0e}{r['compile_s']:>13.2f}{r['wall_s']:>10.3f}"
              f"{r['robot_steps_per_s']:>15,.0f}{r['robot_s_per_s']:>11,.1f}")
    print("; ".join(notes))


def machine() -> str:
    import jax

    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return f"{cpu}, {os.cpu_count()} cores, jax {jax.__version__}, {len(jax.devices())} host device(s)"


def step_cost(model, batch: int = 256) -> dict:
    """XLA's own count of flops and transcendentals per robot-step (cost analysis of one step)."""
    import jax
    import jax.numpy as jnp

    from cpgjax.sim.pipeline import step
    from cpgjax.sim.state import initial_state

    s = initial_state(model, batch)
    ctrl = (jnp.zeros((model.n_ctrl, batch)), jnp.zeros((model.n_ctrl, batch)))
    ca = jax.jit(lambda s, c: step(model, s, c)).lower(s, ctrl).compile().cost_analysis()
    ca = ca[0] if isinstance(ca, list) else ca
    return {"flops": ca.get("flops", float("nan")) / batch,
            "transcendentals": ca.get("transcendentals", float("nan")) / batch}


def cpu_peak_gflops() -> tuple[float, str]:
    """Single-precision peak of all cores: 32 flops/cycle/core (two 256-bit FMA pipes) x clock."""
    mhz = 0.0
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("cpu MHz"):
                    mhz = float(line.split(":")[1])
                    break
    except OSError:
        pass
    n = os.cpu_count() or 1
    return 32 * mhz * 1e-3 * n, f"{n} cores x {mhz:.0f} MHz x 32 flops/cycle"


def run_bench(model_path: str, batches=DEFAULT_BATCHES, time_s: float = 2.0, chunk: int = 256,
              tricks: bool = False, progress=True, pipeline: str | None = None):
    """The main table (and the tricks table); returns the rows.  ``pipeline``: our simulator's physics pipeline
    (None: the model file's, else springs)."""
    import jax

    from cpgjax.io.wl import load_model

    model = load_model(model_path, pipeline=pipeline)
    print(f"machine: {machine()}")
    print(f"model: {model_path}  ({model.nb} bodies, {model.nj} joints, {len(model.ct_pt)} contact vertices), "
          f"pipeline {model.pipeline}, dt {model.dt:g} s, episode {time_s} s simulated, chunk {chunk}")
    rows = []
    for b in batches:
        rows.append(row(model, b, time_s, label=f"penalty sim, {len(jax.devices())} dev", chunk=chunk))
        if progress:
            print(f"  batch {b}: {rows[-1]['robot_s_per_s']:,.1f} robot-s/s", flush=True)
    print()
    print_table(rows)
    cost = step_cost(model)
    peak, how = cpu_peak_gflops()
    best = max(r["robot_steps_per_s"] for r in rows)
    achieved = best * cost["flops"] * 1e-9
    print(f"\nper robot-step (XLA cost analysis): {cost['flops']:,.0f} flops, "
          f"{cost['transcendentals']:.0f} transcendentals")
    if peak > 0:
        print(f"best rate {best:,.0f} robot-steps/s = {achieved:.1f} GFLOP/s = {100 * achieved / peak:.0f}% of "
              f"the CPU's fp32 peak ({peak:.0f} GFLOP/s: {how})")
    if tricks:
        b = 1024 if 1024 in batches else max(batches)
        trows = [row(model, b, time_s, label="all tricks", chunk=chunk)]
        trows.append(row(model, b, time_s, label="1 host device", chunk=chunk, devices=jax.devices()[:1]))
        trows.append(row(model, b, time_s, label="vmap of 1 robot, 1 device", vmap=True))
        from cpgjax.sim.terrain import make_terrain

        rough = model.replace(terrain=make_terrain("rough:0.02"))
        trows.append(row(rough, b, time_s, label="heightfield (rough:0.02)", chunk=chunk))
        trows.append(row(model.replace(poly_atan2=not model.poly_atan2), b, time_s, chunk=chunk,
                         label="library atan2" if model.poly_atan2 else "polynomial atan2"))
        if model.pipeline == "exact":         # the exact pipeline's stages computed once into memory, or not
            plain = model.replace(exact=dataclasses.replace(model.exact, materialize=False))
            trows.append(row(plain, b, time_s, chunk=chunk, label="no materialized stages"))
        cores = os.cpu_count() or 1
        if cores > 1:       # XLA's thread pools, sized once per process (cpgjax/_xla.py: thread_pools)
            for threads in (1, cores):
                trows.append(row(model, 20, time_s, chunk=chunk, repeats=AGAINST_REPEATS,
                                 label=f"batch 20, 1 dev, {threads} thr",
                                 alone=(model_path, pipeline, {"CPGJAX_DEVICES": "1", "PJRT_NPROC": str(threads)})))
        for c in (32, 64, 128, 512):
            trows.append(row(model, b, time_s, label=f"chunk {c}", chunk=c))
        print()
        print_table(trows, "what each trick buys (same run)")
        rows += trows
    return rows


def bench_against_mjx(model_path: str, batches=AGAINST_BATCHES, time_s: float = 1.0, chunk: int = 256,
                      pipeline: str | None = None):
    """The quadruped in the penalty simulator, MJX (fast settings) and MuJoCo C's threaded rollout.

    Each engine at its own stable step (penalty 0.5 ms, MuJoCo/MJX 2 ms), same batch, same
    controllers, measured one after the other in this run; compile time apart.  ``pipeline``: our
    simulator's (None: the model file's, else springs); MuJoCo's model does not depend on it.
    """
    import jax

    from cpgjax.crosscheck.engines import mjx_run, mujoco_run
    from cpgjax.crosscheck.mjcf import MJ_TIMESTEP, load
    from cpgjax.io.wl import load_model

    model = load_model(model_path, pipeline=pipeline)
    print(f"machine: {machine()}")
    print(f"model: {model_path}, {time_s:g} s episodes; MuJoCo C and MJX at dt {MJ_TIMESTEP:g} s "
          f"(MJX: 2 solver and 2 line-search iterations), penalty simulator ({model.pipeline} pipeline) at dt "
          f"{model.dt:g} s")
    rows = []
    mj = load(model)
    nthreads = os.cpu_count() or 1
    for b in batches:
        c = _controllers(model, b)
        r = row(model, b, time_s, label=f"penalty sim ({len(jax.devices())} dev)", chunk=chunk,
                repeats=AGAINST_REPEATS)
        rows.append(r)
        mujoco_run(model, c[:2], time=0.1, mj=mj)  # warm up
        wall = min(mujoco_run(model, c, time=time_s, mj=mj, nthread=nthreads)[2] for _ in range(AGAINST_REPEATS))
        steps = int(round(time_s / MJ_TIMESTEP))
        rows.append({"label": f"MuJoCo C rollout ({nthreads} thr)", "batch": b, "dt": MJ_TIMESTEP,
                     "sim_time": steps * MJ_TIMESTEP, "compile_s": 0.0, "wall_s": wall,
                     "robot_steps_per_s": b * steps / wall, "robot_s_per_s": b * steps * MJ_TIMESTEP / wall})
        _, _, comp, run = mjx_run(model, c, time=time_s, fast=True, sample_every=steps)
        rows.append({"label": "MJX (vmap, jit, CPU)", "batch": b, "dt": MJ_TIMESTEP,
                     "sim_time": steps * MJ_TIMESTEP, "compile_s": comp, "wall_s": run,
                     "robot_steps_per_s": b * steps / run, "robot_s_per_s": b * steps * MJ_TIMESTEP / run})
        pen, mjc, mjx_ = rows[-3]["robot_s_per_s"], rows[-2]["robot_s_per_s"], rows[-1]["robot_s_per_s"]
        print(f"  batch {b}: penalty {pen:,.0f}, MuJoCo C {mjc:,.0f}, MJX {mjx_:,.0f} robot-s/s "
              f"(penalty/MJX {pen / mjx_:.1f}x, penalty/MuJoCo C {pen / mjc:.2f}x; compile: penalty "
              f"{rows[-3]['compile_s']:.2f} s, MJX {rows[-1]['compile_s']:.2f} s)", flush=True)
    print()
    print_table(rows)
    print(f"wall (this table): the fastest of {AGAINST_REPEATS} calls, ours and MuJoCo C's (MJX: one call)")
    return rows


def _thesis_cells_for(preset: str, generations: int) -> list:
    """The cells of ``cpgjax sweep --preset PRESET``, each cut to ``generations`` generations."""
    import dataclasses

    from cpgjax.experiments import sweep
    from cpgjax.optim import ga

    return [dataclasses.replace(c, generations=generations) if isinstance(c, ga.GAConfig)
            else dataclasses.replace(c, samples=c.batch * generations) for c in sweep.thesis_cells(preset)]


def bench_sweep(model_path: str, *, time_s: float = 2.0, generations: int = 5, seeds: int = 5,
                preset: str = "full", progress: bool = True, pipeline: str | None = None) -> dict:
    """Evaluations per second of one GA run against a sweep of the thesis experiment, side by side.

    (1) one GA run as ``cpgjax evolve`` makes it (population 20, pocket 4), (2) the cells of
    ``cpgjax sweep --preset PRESET`` (12 GA settings and the 4 baselines) x ``seeds``, all in one
    XLA program, both for ``generations`` generations of ``time_s`` s episodes.  Compile time
    apart; "cores busy" is the process's CPU seconds per wall second (2 = both cores of this machine).
    """
    import tempfile

    import jax

    from cpgjax.experiments import evolve, sweep
    from cpgjax.optim import ga

    print(f"machine: {machine()}, {len(jax.devices())} host devices")
    print(f"model: {model_path}, {time_s:g} s episodes, {generations} generations per run"
          + (f", pipeline {pipeline}" if pipeline else ""))
    pa = {"model": model_path, "time": time_s, "terrain": None, "delta": None, "pipeline": pipeline}
    cells = _thesis_cells_for(preset, generations)
    rows = []

    problem = sweep.sweep_problem(pa)
    cfg = ga.GAConfig(population=20, generations=generations, pocket=4, seed=0)
    first = evolve.run_ga(problem, cfg)                 # compiles (the chunk function is cached)
    c0, t0 = time.process_time(), time.perf_counter()
    s = evolve.run_ga(problem, cfg)
    busy = (time.process_time() - c0) / (time.perf_counter() - t0)
    compile_s = first["compile_time"] + first["wall_time_this_call"] - s["wall_time_this_call"]
    rows.append({"label": "one GA run (cpgjax evolve)", "runs": 1, "batch": 20,
                 "evals_s": s["evals_per_second"], "cores": busy, "compile_s": compile_s})
    if progress:
        print(f"  one run: {s['evals_per_second']:.1f} evaluations/s", flush=True)

    with tempfile.TemporaryDirectory() as d:
        specs = sweep.plan(d, cells, range(seeds))
        batch = sweep.total_batch(specs)
        problem = sweep.sweep_problem(pa, batch=batch)
        s = sweep.run_sweep(problem, specs, progress=progress)
    rows.append({"label": f"sweep, {len(specs)} runs in one program", "runs": len(specs), "batch": batch,
                 "evals_s": s["evals_per_second"], "cores": s["cores_busy"], "compile_s": s["compile_time"]})
    print()
    print("| what | runs | robots per generation | compile [s] | evaluations/s | "
          "simulated robot-s per wall s | cores busy |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        print(f"| {r['label']} | {r['runs']} | {r['batch']} | {r['compile_s']:.1f} | {r['evals_s']:,.1f} | "
              f"{r['evals_s'] * time_s:,.0f} | {r['cores']:.2f} |")
    ratio = rows[1]["evals_s"] / rows[0]["evals_s"]
    print(f"\nsweep / one run: {ratio:.2f}x evaluations per second")
    return {"rows": rows, "ratio": ratio}


def bench_sweep_ray(model_path: str, *, time_s: float = 2.0, generations: int = 5, seeds: int = 5,
                    preset: str = "full", workers: int = 2, address: str | None = None,
                    progress: bool = True, pipeline: str | None = None) -> dict:
    """Evaluations per second of the thesis sweep in this process against the same sweep on Ray, side by side.

    (1) the cells of ``cpgjax sweep --preset PRESET`` x ``seeds`` in one program, in process (every core
    a host device); (2) the same runs as ``workers`` Ray tasks (``cpgjax sweep --ray --workers N``), on a
    local Ray instance (or the cluster at ``address``).  "steady" is evaluations per second once
    compiled (Ray: the workers' rates summed); "end to end" is every evaluation over the whole wall time,
    Ray's start, the workers' start-up and compilation included: their difference is Ray's overhead.
    """
    import tempfile

    from cpgjax.experiments import sweep
    from cpgjax.experiments.sweep import cluster

    cluster.require_ray()
    print(f"machine: {machine()}")
    print(f"model: {model_path}, {time_s:g} s episodes, {generations} generations per run, {seeds} seeds"
          + (f", pipeline {pipeline}" if pipeline else ""))
    pa = {"model": model_path, "time": time_s, "terrain": None, "delta": None, "pipeline": pipeline}
    cells = _thesis_cells_for(preset, generations)
    rows = []
    with tempfile.TemporaryDirectory() as d:
        specs = sweep.plan(os.path.join(d, "here"), cells, range(seeds))
        t0 = time.perf_counter()
        s = sweep.run_sweep(sweep.sweep_problem(pa, batch=sweep.total_batch(specs)), specs, progress=progress)
        wall = time.perf_counter() - t0
        rows.append({"label": "in process, one program", "runs": len(specs), "evals": s["evaluations"],
                     "steady": s["evals_per_second"], "e2e": s["evaluations"] / wall, "wall": wall,
                     "compile": s["compile_time"], "start": 0.0, "busy": s["cores_busy"]})
        specs = sweep.plan(os.path.join(d, "ray"), cells, range(seeds))
        r = cluster.run_on_ray(pa, specs, address=address, workers=workers, progress=progress)
        rows.append({"label": f"Ray, {len(r['workers'])} workers ({address or 'local'})", "runs": len(specs),
                     "evals": r["evaluations"], "steady": r["evals_per_second"],
                     "e2e": r["evals_per_second_end_to_end"], "wall": r["wall_time"], "compile": r["compile_time"],
                     "start": r["ray_start"], "busy": r["cores_busy"]})
    print()
    for x in rows:        # CPU seconds, unlike wall seconds, do not depend on what else the machine runs
        x["per_cpu"] = x["steady"] / x["busy"] if x["busy"] > 0 else float("nan")
    print(f"load average while measuring: {os.getloadavg()[0]:.1f} (on {os.cpu_count()} cores)")
    print("| what | runs | evaluations | Ray start [s] | compile [s] | wall [s] | steady evaluations/s | "
          "cores busy | evaluations per CPU-s | end-to-end evaluations/s |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for x in rows:
        print(f"| {x['label']} | {x['runs']} | {x['evals']} | {x['start']:.1f} | {x['compile']:.1f} | "
              f"{x['wall']:.1f} | {x['steady']:,.1f} | {x['busy']:.2f} | {x['per_cpu']:,.1f} | {x['e2e']:,.1f} |")
    a, b = rows
    print(f"\nRay / in process: {b['per_cpu'] / a['per_cpu']:.2f}x evaluations per CPU-s, "
          f"{b['steady'] / a['steady']:.2f}x steady, {b['e2e'] / a['e2e']:.2f}x end to end; "
          f"wall {b['wall'] - a['wall']:+.1f} s ({b['start']:.1f} s of it Ray's start)")
    print(f"per-core throughput (in process): {a['per_cpu']:,.1f} evaluations per CPU-s")
    return {"rows": rows, "per_core": a["per_cpu"]}
