"""Sweeps: many GA / baseline runs (settings x seeds) batched into one XLA program.

A *cell* is one setting (e.g. GA with gamma 0.1, pocket 4, no cross-over; or AMC with M = 5);
a *run* is a cell with one seed.  Every run is written to its own HDF5 file in the layout
of :mod:`cpgjax.results` (``OUT/<cell>/s<seed>.h5``), so ``cpgjax plot`` and ``cpgjax best``
work on any of them, and ``OUT/sweep.json`` records the plan.

**Batching.**  Runs are grouped by what their algorithm compiles to (GA: population and
initial spread, every other GA setting is a traced :class:`cpgjax.ga.GAParams` field, the
cross-over flag included; a search: its whole configuration but the seed).  One generation
of the sweep is one jitted function: for every group ``vmap(propose)`` over its runs, the
``[R, N, G]`` genomes of *all* groups are concatenated to ``[sum R*N, G]`` for ONE
``problem.evaluate`` call (which splits the batch across the host devices, i.e. the CPU
cores, with ``shard_map``), split back, and ``vmap(update)`` per group.  ``chunk``
generations run in one ``lax.scan``; the host writes chunk k while chunk k+1 computes.

**Same numbers as single runs.**  A run uses the keys of :func:`cpgjax.evolve.run_ga` for
its seed (``k_init, k_propose, k_update = split(key(seed), 3)``, ``fold_in(k, GEN)``), its
initial state is made by the same jitted ``init``, and the simulator's result for a robot
does not depend on the batch it is in, so a run of a sweep holds bit for bit the rows of
``cpgjax evolve`` / ``cpgjax search`` with the same settings (``tests/test_sweep.py``).

**Resume, cell by cell.**  A run whose file is complete is skipped; a partially written one
continues from its last complete generation (its stored state, as ``--resume`` does); a
missing one starts.  Runs at different generations share a batch: every run carries its
own generation counter, and a run past its end is computed but neither updated nor
written.  Stored settings must match the plan (else :class:`ResultsError`), except the
number of generations, which may be extended.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import partial
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from cpgjax import ga, search
from cpgjax.evolve import (
    Algorithm,
    compile_ahead,
    ga_algorithm,
    metrics_spec,
    open_run,
    run_keys,
    search_algorithm,
)
from cpgjax.problem import Problem
from cpgjax.results import ResultsError, Row, RunWriter, read_attrs

MANIFEST = "sweep.json"


@dataclass(frozen=True)
class RunSpec:
    """One run of a sweep: a cell (setting), its configuration (with the seed) and its file."""

    cell: str
    kind: str                                  # "ga" | "random" | "amc"
    cfg: ga.GAConfig | search.SearchConfig
    path: str

    @property
    def seed(self) -> int:
        return int(self.cfg.seed)


def _fmt(v: float) -> str:
    return f"{float(v):g}"


def ga_cell_name(cfg: ga.GAConfig) -> str:
    """``ga_n20_mu0.2_g0.01_p4_xoff`` (plus the non-default mutation settings)."""
    name = (f"ga_n{cfg.population}_mu{_fmt(cfg.mu_max)}_g{_fmt(cfg.gamma)}_p{cfg.pocket}"
            f"_x{'on' if cfg.crossover else 'off'}")
    d = ga.GAConfig()
    if cfg.mutation != d.mutation:
        name += f"_{cfg.mutation}"
    if cfg.sigma != d.sigma:
        name += f"_s{_fmt(cfg.sigma)}"
    if cfg.selection != d.selection:
        name += f"_{cfg.selection}"
    return name


def search_cell_name(cfg: search.SearchConfig) -> str:
    """``random`` or ``amc_M5``."""
    return "random" if cfg.method == "random" else f"amc_M{cfg.M}"


def ga_grid(*, gamma: Sequence[float] = (0.0,), pocket: Sequence[int] = (0,), crossover: Sequence[bool] = (False,),
            population: Sequence[int] = (20,), **common: Any) -> list[ga.GAConfig]:
    """Every combination of the listed GA settings (``common``: other GAConfig fields, seed excluded)."""
    return [ga.GAConfig(population=n, gamma=float(g), pocket=int(p), crossover=bool(x), **common)
            for n in population for p in pocket for x in crossover for g in gamma]


def baseline_cells(methods: Sequence[str], *, samples: int = 3000, batch: int = 20,
                   **common: Any) -> list[search.SearchConfig]:
    """Baseline cells from names ``random``, ``amc3``, ``amc5``, ... (``amcM``: adaptive MC with M variables)."""
    out = []
    for m in methods:
        m = m.strip().lower()
        if m == "random":
            out.append(search.SearchConfig(method="random", samples=samples, batch=batch, **common))
        elif m.startswith("amc") and m[3:].isdigit():
            out.append(search.SearchConfig(method="amc", M=int(m[3:]), samples=samples, batch=batch, **common))
        else:
            raise ValueError(f"unknown baseline {m!r}: expected random or amcM (e.g. amc5)")
    return out


def plan(out_dir: str | os.PathLike[str], cells: Sequence[ga.GAConfig | search.SearchConfig],
         seeds: Sequence[int], chunk: int | None = None) -> list[RunSpec]:
    """The runs of ``cells`` x ``seeds`` with their files under ``out_dir``."""
    specs, seen = [], set()
    for c in cells:
        if isinstance(c, ga.GAConfig):
            kind, name = "ga", ga_cell_name(c)
        else:
            kind, name = c.method, search_cell_name(c)
        if name in seen:
            continue
        seen.add(name)
        for s in seeds:
            cfg = dataclasses.replace(c, seed=int(s), **({} if chunk is None else {"chunk": int(chunk)}))
            specs.append(RunSpec(name, kind, cfg, os.path.join(os.fspath(out_dir), name, f"s{int(s)}.h5")))
    return specs


# --- the thesis experiment, at two scales (shared by the CLI preset and the notebook) -------------------

SCALES: dict[str, dict[str, Any]] = {
    # thesis Ch. 6.2-6.3: population 20, 150 generations (3000 evaluations), mu_max 20 %, pocket 4
    "full": {"model": "models/quadruped.wl", "time": None, "population": 20, "generations": 150,
             "mu_max": 0.2, "gammas": (0.0, 0.01, 0.1, 1.0), "pocket": 4, "seeds": 5, "samples": 3000,
             "Ms": (3, 5, 10)},
    # for the tests: the quadruped, 0.5 s episodes, 6 individuals, 3 generations, 2 seeds
    "tiny": {"model": "models/quadruped.wl", "time": 0.5, "population": 6, "generations": 3,
             "mu_max": 0.2, "gammas": (0.0, 1.0), "pocket": 2, "seeds": 2, "samples": 18,
             "Ms": (3, 5)},
}


def thesis_cells(scale: str | dict[str, Any] = "full") -> list[ga.GAConfig | search.SearchConfig]:
    """The cells of Fig. 6.5-6.12: GA gamma x pocket {0, P} without cross-over, gamma x pocket P with
    cross-over; random search and adaptive MC (M = 3, 5, 10) on the GA's budget."""
    s = SCALES[scale] if isinstance(scale, str) else scale
    common = {"population": (s["population"],), "generations": s["generations"], "mu_max": s["mu_max"]}
    cells: list[ga.GAConfig | search.SearchConfig] = []
    cells += ga_grid(gamma=s["gammas"], pocket=(0, s["pocket"]), crossover=(False,), **common)
    cells += ga_grid(gamma=s["gammas"], pocket=(s["pocket"],), crossover=(True,), **common)
    cells += baseline_cells(["random"] + [f"amc{m}" for m in s["Ms"]], samples=s["samples"],
                            batch=s["population"])
    return cells


# --- the batched driver --------------------------------------------------------------------------------

def _group_key(spec: RunSpec) -> tuple:
    c = spec.cfg
    if isinstance(c, ga.GAConfig):
        return ("ga", c.population, c.init_spread)
    return ("search",) + tuple(sorted((k, v) for k, v in c.to_dict().items() if k not in ("seed", "chunk")))


def _algorithm(problem: Problem, spec: RunSpec) -> Algorithm:
    if isinstance(spec.cfg, ga.GAConfig):
        return ga_algorithm(problem, spec.cfg)
    return search_algorithm(problem, spec.cfg)


def make_sweep_chunk_fn(problem: Problem, algos: Sequence[Algorithm], sizes: Sequence[int], chunk: int):
    """Jitted ``(params, states, k_prop, k_upd, gen0, target) -> (states, rows)`` for groups of runs.

    Per group (lists, one entry per group): ``params`` and ``states`` stacked over its runs,
    ``k_prop``/``k_upd`` ``[R]`` keys, ``gen0``/``target`` ``[R]`` int32 (next generation and
    end of each run).  Each step evaluates every group's proposals in one ``problem.evaluate``;
    a run with ``gen >= target`` keeps its state.  ``rows`` per group: ``[chunk, R, ...]``.
    """
    G = problem.n_genes

    def generation(params, states, kps, kus, gens, targets):
        proposals = []
        for a, p, s, kp, gen in zip(algos, params, states, kps, gens, strict=True):
            keys = jax.vmap(jax.random.fold_in)(kp, gen)
            proposals.append(jax.vmap(a.propose)(p, s, keys, gen))
        # the barrier keeps XLA from fusing (and re-rounding) the proposals into the simulation
        proposals = jax.lax.optimization_barrier(proposals)
        flat = jnp.concatenate([x.reshape(-1, G) for x in proposals], axis=0)
        ev = problem.evaluate(flat)
        new_states, rows, off = [], [], 0
        for a, p, s, ku, gen, tgt, x, r in zip(algos, params, states, kus, gens, targets, proposals, sizes,
                                              strict=True):
            n = a.population
            part = {k: jax.lax.slice_in_dim(v, off, off + r * n) for k, v in ev.items()}
            off += r * n
            fit = jnp.asarray(part["fitness"], jnp.float32).reshape(r, n)
            div = jnp.asarray(part["diverged"], bool).reshape(r, n) | ~jnp.isfinite(fit)
            keys = jax.vmap(jax.random.fold_in)(ku, gen)
            upd = jax.vmap(a.update)(p, s, x, fit, div, keys, gen)
            active = gen < tgt
            new = jax.tree.map(partial(_keep, active), upd, s)
            metrics = {k: jnp.asarray(v, jnp.float32).reshape(r, n) for k, v in part.items()
                       if k not in ("fitness", "diverged")}
            rate = jnp.broadcast_to(jnp.asarray(jax.vmap(a.rate)(p, gen), jnp.float32), (r,))
            rows.append({"genomes": x.astype(jnp.float32), "fitness": fit, "diverged": div, "rate": rate,
                         "metrics": metrics, "state": new})
            new_states.append(new)
        return new_states, rows

    def run_chunk(params, states, kps, kus, gen0, targets):
        def body(states, i):
            gens = [g + i for g in gen0]
            return generation(params, states, kps, kus, gens, targets)

        return jax.lax.scan(body, states, jnp.arange(chunk, dtype=jnp.int32))

    return jax.jit(run_chunk)


def total_batch(specs: Sequence[RunSpec]) -> int:
    """Evaluations per sweep generation when every run of ``specs`` is in one batch."""
    return sum(s.cfg.population for s in specs)


def eval_chunk(n: int, devices: int | None = None, max_chunk: int = 256, lanes: int = 16) -> int:
    """A simulator chunk size that pads a batch of ``n`` robots little (the simulator pads to whole chunks)."""
    nd = devices or len(jax.devices())
    per_dev = max(-(-n // nd), 1)
    k = -(-per_dev // max_chunk)          # chunks per device
    per_chunk = -(-per_dev // k)
    return max(lanes, -(-per_chunk // lanes) * lanes)


def write_manifest(out_dir: str | os.PathLike[str], specs: Sequence[RunSpec], problem_args: dict[str, Any]) -> str:
    """``OUT/sweep.json``: the problem and every run (merged with an existing manifest)."""
    path = os.path.join(os.fspath(out_dir), MANIFEST)
    old: dict[str, Any] = {}
    if os.path.exists(path):
        with open(path) as f:
            old = json.load(f)
    runs = {r["path"]: r for r in old.get("runs", [])}
    for s in specs:
        rel = os.path.relpath(s.path, os.fspath(out_dir))
        runs[rel] = {"path": rel, "cell": s.cell, "kind": s.kind, "seed": s.seed, "config": s.cfg.to_dict()}
    data = {"format": "cpgjax-sweep", "problem": problem_args, "runs": sorted(runs.values(), key=lambda r: r["path"])}
    os.makedirs(os.fspath(out_dir), exist_ok=True)
    with open(path + ".tmp", "w") as f:
        json.dump(data, f, indent=1)
    os.replace(path + ".tmp", path)
    return path


def run_sweep(problem: Problem, specs: Sequence[RunSpec], *, chunk: int = 1, overwrite: bool = False,
              progress: bool = True, stop_after: int | None = None, group: str = "all",
              callback: Callable[[int, dict[str, Any]], None] | None = None) -> dict[str, Any]:
    """Run every spec (skipping complete files, continuing partial ones); returns a summary.

    ``group``: ``"all"`` puts every run in one XLA program (one evaluate call per generation);
    ``"kind"`` makes one program per group of same-shaped runs, run one after the other.
    ``stop_after``: stop after that many sweep generations (tests of resume).
    """
    from tqdm.auto import tqdm

    t_begin = time.perf_counter()
    by_group: dict[tuple, list[RunSpec]] = {}
    for s in specs:
        by_group.setdefault(_group_key(s), []).append(s)

    todo: list[dict[str, Any]] = []     # per group: algo, specs, params, states, keys, completed, targets, wall0
    skipped = 0
    metrics: dict[int, dict] = {}
    for key, members in by_group.items():
        algo0 = _algorithm(problem, members[0])
        init = jax.jit(algo0.init)
        if algo0.population not in metrics:
            metrics[algo0.population] = metrics_spec(problem, algo0.population)
        live, states, params, keys, comp, walls, tgts = [], [], [], [], [], [], []
        for s in members:
            # the same keys, init and file handling as cpgjax evolve / search (init and metric shapes
            # are traced once per group: every run of a group has the same ones, the seed apart)
            algo = _algorithm(problem, s)
            p = jax.tree.map(jnp.asarray, algo.params)
            k = run_keys(s.seed)
            completed, state, wall0 = open_run(problem, algo, s.path, p, k[0], resume=not overwrite, overwrite=True,
                                               init=init, metrics=metrics[algo0.population])
            if completed >= algo.generations:
                skipped += 1
                continue
            live.append(s)
            states.append(state)
            params.append(p)
            keys.append(k)
            comp.append(completed)
            walls.append(wall0)
            tgts.append(algo.generations)
        if not live:
            continue
        todo.append({
            "key": key, "algo": algo0, "specs": live,
            "params": ga.stack_params(params) if algo0.kind == "ga" else (),
            "states": jax.tree.map(lambda *xs: jnp.stack(xs), *states),
            "k_prop": jnp.stack([k[1] for k in keys]), "k_upd": jnp.stack([k[2] for k in keys]),
            "completed": np.asarray(comp, np.int64), "targets": np.asarray(tgts, np.int64),
            "wall0": np.asarray(walls, np.float64)})

    batches = ([todo] if todo else []) if group == "all" else [[g] for g in todo]
    total_evals = sum(int(np.sum((g["targets"] - g["completed"]) * g["algo"].population)) for g in todo)
    bar = tqdm(total=total_evals, desc="sweep", unit="eval", unit_scale=True, disable=not progress,
               dynamic_ncols=True)
    evals_done, compile_time, sim_evals = 0, 0.0, 0
    # Speed is measured in the steady state, from the end of each program's first chunk to the end of
    # its last (the first chunk carries one-off costs: buffer allocation, the first HDF5 writes).
    steady = {"wall": 0.0, "cpu": 0.0, "evals": 0}
    t_run = time.perf_counter()
    try:
        for groups in batches:
            algos = [g["algo"] for g in groups]
            sizes = [len(g["specs"]) for g in groups]
            fn = make_sweep_chunk_fn(problem, algos, sizes, chunk)
            args = partial(_chunk_args, groups)
            t0 = time.perf_counter()
            fn = compile_ahead(fn, args())
            compile_time += time.perf_counter() - t0
            t_start = time.perf_counter()
            steps = 0
            pending = None
            first = None                                   # (wall, cpu, evaluations) at the end of chunk 1
            new_evals = 0
            while any(np.any(g["completed"] < g["targets"]) for g in groups):
                if stop_after is not None and steps >= stop_after:
                    break
                gen0 = [g["completed"].copy() for g in groups]
                out = fn(*args())                          # dispatched asynchronously
                if pending is not None:
                    evals_done += _write(pending, t_start)
                new_states, rows = out
                rows = jax.device_get(rows)
                t_now = time.perf_counter()
                for g, st in zip(groups, new_states, strict=True):
                    g["states"] = st
                    g["completed"] = np.minimum(g["completed"] + chunk, g["targets"])
                sim_evals += chunk * sum(a.population * r for a, r in zip(algos, sizes, strict=True))
                pending = (groups, rows, gen0, t_now)
                steps += 1
                n_new = sum(int(np.sum((g["completed"] - g0) * g["algo"].population))
                            for g, g0 in zip(groups, gen0, strict=True))
                new_evals += n_new
                if first is None:
                    first = (t_now, time.process_time(), new_evals)
                bar.update(n_new)
                if callback is not None:
                    callback(steps, {"evaluations": evals_done})
            if pending is not None:
                evals_done += _write(pending, t_start)
            if first is not None and steps > 1:
                steady["wall"] += time.perf_counter() - first[0]
                steady["cpu"] += time.process_time() - first[1]
                steady["evals"] += new_evals - first[2]
    finally:
        bar.close()
    wall = time.perf_counter() - t_run
    if steady["wall"] > 0:
        rate, cores_busy = steady["evals"] / steady["wall"], steady["cpu"] / steady["wall"]
    else:                                                  # one chunk per program: no steady state to time
        rate, cores_busy = evals_done / max(wall - compile_time, 1e-9), float("nan")
    return {"runs": len(specs), "skipped": skipped, "evaluations": evals_done, "evaluated": sim_evals,
            "wall_time": time.perf_counter() - t_begin, "compile_time": compile_time,
            "evals_per_second": rate, "cores_busy": cores_busy}


def _keep(active, new, old):
    """``new`` for the runs where ``active`` (leading axis), else ``old``."""
    return jnp.where(active.reshape(active.shape + (1,) * (new.ndim - 1)), new, old)


def _chunk_args(groups):
    return ([g["params"] for g in groups], [g["states"] for g in groups],
            [g["k_prop"] for g in groups], [g["k_upd"] for g in groups],
            [jnp.asarray(g["completed"], jnp.int32) for g in groups],
            [jnp.asarray(g["targets"], jnp.int32) for g in groups])


def _write(pending, t_start: float) -> int:
    """Append the rows of one chunk to every run's file; returns the evaluations written."""
    groups, rows, gen0, t_now = pending
    n = 0
    for g, grows, g0 in zip(groups, rows, gen0, strict=True):
        chunk = grows["fitness"].shape[0]
        for r, spec in enumerate(g["specs"]):
            n_valid = int(min(chunk, g["targets"][r] - g0[r]))
            if n_valid <= 0:
                continue
            with RunWriter(spec.path) as w:
                for i in range(n_valid):
                    w.append(Row(genomes=grows["genomes"][i, r], fitness=grows["fitness"][i, r],
                                 diverged=grows["diverged"][i, r], mutation_rate=float(grows["rate"][i, r]),
                                 wall_time=float(g["wall0"][r] + t_now - t_start),
                                 metrics={k: v[i, r] for k, v in grows["metrics"].items()},
                                 state={k: v[i, r] for k, v in grows["state"].items()}))
            n += n_valid * g["algo"].population
    return n


# --- reading a sweep back -------------------------------------------------------------------------------

def find_runs(out_dir: str | os.PathLike[str]) -> dict[str, list[str]]:
    """``{cell: [run files sorted by seed]}`` for the run files under ``out_dir`` (``<cell>/s<seed>.h5``)."""
    root = os.fspath(out_dir)
    cells: dict[str, list[str]] = {}
    if not os.path.isdir(root):
        return cells
    for cell in sorted(os.listdir(root)):
        d = os.path.join(root, cell)
        if not os.path.isdir(d):
            continue
        files = [f for f in os.listdir(d) if f.startswith("s") and f.endswith(".h5")]
        files.sort(key=lambda f: int(f[1:-3]) if f[1:-3].isdigit() else math.inf)
        if files:
            cells[cell] = [os.path.join(d, f) for f in files]
    return cells


def select(out_dir: str | os.PathLike[str], kind: str | None = None, **settings: Any) -> list[str]:
    """Run files of ``out_dir`` whose kind and stored config match ``settings`` (e.g. ``pocket=0``)."""
    out = []
    for files in find_runs(out_dir).values():
        for p in files:
            a = read_attrs(p)
            cfg = json.loads(a["config"])
            if kind is not None and a["kind"] != kind:
                continue
            if all(_same(cfg.get(k), v) for k, v in settings.items()):
                out.append(p)
    return out


def _same(a: Any, b: Any) -> bool:
    if isinstance(b, (list, tuple, set)):
        return any(_same(a, x) for x in b)
    if isinstance(b, float) or isinstance(a, float):
        try:
            return math.isclose(float(a), float(b), rel_tol=1e-9, abs_tol=1e-12)
        except (TypeError, ValueError):
            return False
    return a == b


def complete(specs: Sequence[RunSpec]) -> bool:
    """True when every run of ``specs`` has a complete file."""
    for s in specs:
        if not os.path.exists(s.path):
            return False
        try:
            a = read_attrs(s.path)
        except (OSError, ResultsError):
            return False
        if int(a["completed"]) < int(a["generations"]):
            return False
    return True


def make_problem(problem_args: dict[str, Any], batch: int | None = None) -> Problem:
    """The Problem of a sweep (``{"model", "time", "terrain", "delta"}``), as ``cpgjax evolve`` makes it.

    ``batch``: the sweep's evaluations per generation; the simulator's chunk is chosen to pad it
    little (results do not depend on the chunk).  The settings are recorded in the run files'
    meta (``cli_problem_args``) as ``cpgjax evolve`` does, so ``cpgjax evolve --resume`` works on them.
    """
    model = problem_args["model"]
    if model.startswith("analytic:"):
        from cpgjax.problem import analytic_problem

        problem = analytic_problem(model)
    else:
        from cpgjax.fitness import make_problem as make_wl_problem

        kw: dict[str, Any] = {"time": problem_args.get("time"), "terrain": problem_args.get("terrain")}
        if problem_args.get("delta") is not None:
            kw["delta"] = problem_args["delta"]
        if batch:
            kw["chunk"] = eval_chunk(batch)
        problem = make_wl_problem(model, **kw)
    cli = {"time": problem_args.get("time"), "terrain": problem_args.get("terrain"),
           "delta": problem_args.get("delta"), "replicas": None}
    return dataclasses.replace(problem, meta={**problem.meta, "cli_problem_args": json.dumps(cli)})


# --- the summary table and the thesis's claims (cpgjax report) ------------------------------------------

PLATEAU = 20   # generations at the end over which the GA's best-of-generation is averaged ("plateau")


def _ms(v) -> str:
    v = np.asarray(v, float)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return "–"
    return f"{v.mean():.3g} ± {v.std(ddof=1) if v.size > 1 else 0.0:.2g}"


def _mean(v) -> float:
    v = np.asarray(v, float)
    v = v[np.isfinite(v)]
    return float(v.mean()) if v.size else float("nan")


def cell_stats(cell) -> dict[str, Any]:
    """Per-seed numbers of a cell (:class:`cpgjax.plots.thesis.Cell`): best found, plateau, t90, mean, oscillation."""
    bpg = cell.best_per_generation()                    # [S, G]
    bsf = cell.best_so_far()
    g = bpg.shape[1]
    k = max(1, min(PLATEAU, g // 3 or 1))
    plateau = np.nanmean(bpg[:, -k:], axis=1) if cell.kind == "ga" else bsf[:, -1]
    # generation at which a 10-generation running mean of the best first reaches 90 % of the plateau
    w = max(1, min(10, g // 5 or 1))
    run = np.stack([np.convolve(np.nan_to_num(b, nan=-1.0), np.ones(w) / w, mode="valid") for b in bpg])
    start = bpg[:, 0]
    t90 = np.array([int(np.argmax(r >= s + 0.9 * (p - s))) + w - 1 if p > s else 0
                    for r, s, p in zip(run, start, plateau, strict=True)], float)
    tail = bpg[:, -max(1, min(50, g // 3 or 1)):]
    osc = np.nanstd(tail, axis=1) / np.abs(np.nanmean(tail, axis=1))
    return {"best": np.nanmax(bsf, axis=1), "plateau": plateau, "t90": t90,
            "mean_all": np.nanmean(cell.fitness, (1, 2)), "diversity": np.nanmean(cell.diversity[:, -k:], axis=1),
            "oscillation": osc, "evaluations": int(cell.evaluations()[-1]), "seeds": len(cell.seeds)}


def _verdict(ok: bool | None, text: str) -> str:
    return {True: "**yes**", False: "**no**", None: "n/a"}[ok] + f" — {text}"


def _tally(flags: Sequence[bool], what: str) -> str:
    """Verdict of a claim checked once per γ: yes (every γ), partly (some), no (none)."""
    k, n = sum(bool(f) for f in flags), len(flags)
    if k == n:
        return f"**yes** — {what} for every γ"
    return ("**partly**" if k else "**no**") + f" — {what} for {k} of {n} γ"


def report(out_dir: str | os.PathLike[str]) -> str:
    """The markdown summary of a sweep: every cell (mean ± sd over seeds) and the thesis's claims checked."""
    from cpgjax.plots.thesis import load_cells

    files = [p for fs in find_runs(out_dir).values() for p in fs]
    if not files:
        raise ValueError(f"no run files under {out_dir}")
    cells = load_cells(files)
    stats = [(c, cell_stats(c)) for c in cells]
    lines = [f"# Sweep report: `{os.fspath(out_dir)}`", "",
             f"Best = best valid fitness found in the run; plateau = GA: mean of the best of each generation "
             f"over the last {PLATEAU} generations (searches: best so far at the end); t90 = first generation at "
             "which the 10-generation running mean of the best reaches 90 % of the way from generation 0 to "
             "the plateau; oscillation = sd / mean of the best of each generation over the last 50 "
             "generations; mean = mean fitness of every sample.  All: mean ± sd over seeds.", "",
             "| method | setting | seeds | evaluations | best | plateau | t90 (gen) | oscillation | mean of samples |",
             "|---|---|---|---|---|---|---|---|---|"]
    for c, s in stats:
        setting = c.label() if c.kind != "ga" else (
            f"N={c.config.get('population')}, μmax={c.config.get('mu_max')}, " + c.label())
        t90 = _ms(s["t90"]) if c.kind == "ga" else "–"
        osc = _ms(s["oscillation"]) if c.kind == "ga" else "–"
        lines.append(f"| {c.kind} | {setting} | {s['seeds']} | {s['evaluations']} | {_ms(s['best'])} | "
                     f"{_ms(s['plateau'])} | {t90} | {osc} | {_ms(s['mean_all'])} |")

    def find(kind, **kw):
        for c, s in stats:
            if c.kind == kind and all(_same(c.config.get(k), v) for k, v in kw.items()):
                return c, s
        return None, None

    def pairs(a: dict, b: dict):
        """``(gamma, stats with settings a, stats with settings b)`` for each gamma where both GA cells exist."""
        for g in gammas:
            s0, s1 = find("ga", gamma=g, **a)[1], find("ga", gamma=g, **b)[1]
            if s0 is not None and s1 is not None:
                yield g, s0, s1

    claims = ["", "## The thesis's claims (Ch. 6.2-6.3) against this sweep", "",
              "| thesis (Ch. 6.2-6.3) | measured here | verdict |", "|---|---|---|"]
    ga_cells = [(c, s) for c, s in stats if c.kind == "ga"]
    gammas = sorted({float(c.config.get("gamma", 0)) for c, _ in ga_cells})
    pockets = sorted({int(c.config.get("pocket", 0)) for c, _ in ga_cells if c.config.get("pocket")})
    # 1. pocketing doubles the plateau; 2. less relative oscillation
    if pockets:
        P = pockets[0]
        ratios, osc0, osc1, parts, single = [], [], [], [], []
        for g, s0, s1 in pairs({"pocket": 0, "crossover": False}, {"pocket": P, "crossover": False}):
            r = _mean(s1["plateau"]) / _mean(s0["plateau"]) if _mean(s0["plateau"]) > 0 else float("inf")
            ratios.append(r)
            # the thesis compared single trials: every (with, without) pair of seeds is one such comparison
            pair = np.asarray(s1["plateau"], float)[:, None] / np.asarray(s0["plateau"], float)[None, :]
            single.append(float(np.mean(pair > 2)))
            osc0.append(_mean(s0["oscillation"]))
            osc1.append(_mean(s1["oscillation"]))
            parts.append(f"γ={g:g}: {_mean(s0['plateau']):.3f} → {_mean(s1['plateau']):.3f} (×{r:.2f})")
        if ratios:
            claims.append(f"| Pocketing ({P} of N) more than doubles the plateau (Fig. 6.8) | plateau without → with "
                          f"pocket: {'; '.join(parts)}"
                          + "; a single trial with pocketing against a single trial without (every pair of seeds) "
                          "more than doubles in " + ", ".join(f"{100 * x:.0f} %" for x in single) + " of pairs | "
                          + _tally([r > 2 for r in ratios], f"mean ratio {min(ratios):.2f}–{max(ratios):.2f}; more "
                                   "than 2") + " |")
            claims.append("| ... and the residual oscillation is much reduced, in relative terms | relative "
                          "oscillation (sd/mean of the best, last 50 gen.) without → with pocket: "
                          + "; ".join(f"{a:.3g} → {b:.3g}" for a, b in zip(osc0, osc1, strict=True)) + " | "
                          + _tally([b < a for a, b in zip(osc0, osc1, strict=True)], "lower") + " |")
    # 3. large gamma plateaus early
    if len(gammas) > 1:
        lo, hi = gammas[0], gammas[-1]
        for P in [0] + pockets[:1]:
            cl, sl = find("ga", gamma=lo, pocket=P, crossover=False)
            ch, sh = find("ga", gamma=hi, pocket=P, crossover=False)
            if cl is None or ch is None:
                continue
            early = _mean(sh["t90"]) < _mean(sl["t90"])
            lower = _mean(sh["plateau"]) < _mean(sl["plateau"])
            claims.append(f"| Large γ saturates early, reaching a plateau (Fig. 6.7; pocket {P}) | γ={hi:g}: t90 "
                          f"{_mean(sh['t90']):.0f}, plateau {_mean(sh['plateau']):.3f}; γ={lo:g}: t90 "
                          f"{_mean(sl['t90']):.0f}, plateau {_mean(sl['plateau']):.3f} | "
                          + _verdict(early, "plateaus earlier" + (" and lower" if lower else " (not lower)")
                                     if early else "does not plateau earlier") + " |")
    # 3b. smaller gamma, higher plateau (up to a point)
    if len(gammas) > 2:
        for P in [0] + pockets[:1]:
            found = [(g, find("ga", gamma=g, pocket=P, crossover=False)[1]) for g in gammas]
            found = [(g, s) for g, s in found if s is not None]
            if len(found) < 3:
                continue
            pl = [_mean(s["plateau"]) for _, s in found]
            top = found[int(np.argmax(pl))][0]
            lowest_at_max = int(np.argmin(pl)) == len(pl) - 1
            claims.append("| As γ decreases the fitness rises to higher plateaus, up to a point "
                          f"(Fig. 6.7; pocket {P}) | "
                          "plateau by γ: " + ", ".join(f"{g:g}: {p:.3f}" for (g, _), p in zip(found, pl, strict=True))
                          + " | " + _verdict(lowest_at_max, f"lowest at γ={found[-1][0]:g}, highest at γ={top:g}"
                                             if lowest_at_max else f"the largest γ is not the lowest (highest at "
                                             f"γ={top:g})") + " |")
    # 4. cross-over does not improve the performance within one trial
    if pockets:
        P = pockets[0]
        parts, better = [], []
        for g, s0, s1 in pairs({"pocket": P, "crossover": False}, {"pocket": P, "crossover": True}):
            d = _mean(s1["plateau"]) - _mean(s0["plateau"])
            sd = float(np.sqrt((np.nanvar(s0["plateau"], ddof=1) + np.nanvar(s1["plateau"], ddof=1))
                               / max(len(s0["plateau"]), 1)))
            better.append(d > 2 * sd)
            parts.append(f"γ={g:g}: {_mean(s0['plateau']):.3f} → {_mean(s1['plateau']):.3f}")
        if parts:
            claims.append("| Cross-over does not improve the performance over one trial (Fig. 6.9) | plateau "
                          f"without → with cross-over (pocket {P}): {'; '.join(parts)} | "
                          + _verdict(not any(better), "no significant gain (> 2 s.e.)" if not any(better)
                                     else "cross-over is better for some γ") + " |")
    # 4b. cross-over keeps oscillating near saturation even with a small mutation rate; more diverse populations
    if pockets:
        P = pockets[0]
        without, with_ = {"pocket": P, "crossover": False}, {"pocket": P, "crossover": True}

        def compare(metric: str) -> tuple[str, list[bool]]:
            """Per γ, ``metric`` without → with cross-over, and whether it is larger with it."""
            rows = [(g, _mean(s0[metric]), _mean(s1[metric])) for g, s0, s1 in pairs(without, with_)]
            return "; ".join(f"γ={g:g}: {a:.3g} → {b:.3g}" for g, a, b in rows), [b > a for _, a, b in rows]

        text, larger = compare("oscillation")
        if larger:
            claims.append("| With cross-over the fitness keeps oscillating near saturation, even for small mutation "
                          f"rates (Fig. 6.9) | relative oscillation without → with cross-over (pocket {P}): "
                          f"{text} | " + _tally(larger, "larger with cross-over") + " |")
        text, more = compare("diversity")
        if more:
            claims.append("| With cross-over the last generations are more varied; without it they cluster around "
                          "one set of parameters (Ch. 6.2.4) | genetic diversity (sd of a gene over the population, "
                          f"mean over genes, last generations) without → with cross-over: {text} | "
                          + _tally(more, "more diverse") + " |")
    # 5-8. baselines
    best_ga = max(ga_cells, key=lambda cs: _mean(cs[1]["best"]), default=(None, None))
    cr, sr = find("random")
    if best_ga[0] is not None and cr is not None:
        r = _mean(best_ga[1]["best"]) / _mean(sr["best"])
        span = [_mean(s["best"]) for _, s in ga_cells]
        claims.append(f"| Random search: best ≈ half the GA's (Fig. 6.10) | best found: GA ({best_ga[0].label()}, "
                      f"the best of {len(ga_cells)} GA settings; all of them: {min(span):.3f}–{max(span):.3f}) "
                      f"{_mean(best_ga[1]['best']):.3f}, random {_mean(sr['best']):.3f} (GA ×{r:.2f}) | "
                      + _verdict(1.5 <= r <= 3.0, f"ratio {r:.2f}" + ("" if 1.5 <= r <= 3.0 else
                                 " (not about 2)")) + " |")
    if cr is not None:
        m = _mean(sr["mean_all"])
        claims.append(f"| Random search: mean fitness ≈ 0 (Fig. 6.10) | mean of all samples {_ms(sr['mean_all'])} | "
                      + _verdict(abs(m) < 0.02, f"{m:.4f}") + " |")
    amcs = [(c, s) for c, s in stats if c.kind == "amc"]
    if amcs:
        ms = [_mean(s["mean_all"]) for _, s in amcs]
        pos = [m > 0 for m in ms]
        above = cr is not None and all(m > _mean(sr["mean_all"]) for m in ms)
        claims.append("| Adaptive MC: positive mean, unlike random search (Fig. 6.11) | mean of samples: "
                      + "; ".join(f"M={c.config.get('M')}: {m:.3f}" for (c, _), m in zip(amcs, ms, strict=True))
                      + " | " + _verdict(all(pos), "positive for every M" if all(pos) else "not positive for every M")
                      + (" and above random search's" if above else "") + " |")
    if best_ga[0] is not None and (amcs or cr is not None):
        others = amcs + ([(cr, sr)] if cr is not None else [])
        c5 = next(((c, s) for c, s in amcs if c.config.get("M") == 5), None)
        best_other = max(others, key=lambda cs: _mean(cs[1]["best"]))
        r = _mean(best_ga[1]["best"]) / _mean(best_other[1]["best"])
        txt = f"best found: GA {_mean(best_ga[1]['best']):.3f}; best other ({best_other[0].label()}) " \
              f"{_mean(best_other[1]['best']):.3f} (GA ×{r:.2f})"
        if c5 is not None:
            txt += f"; AMC M=5 {_mean(c5[1]['best']):.3f} (GA ×{_mean(best_ga[1]['best']) / _mean(c5[1]['best']):.2f})"
        claims.append(f"| GA outperforms the other methods roughly by a factor of 2 (Fig. 6.12) | {txt} | "
                      + _verdict(r >= 1.5, f"GA ×{r:.2f} the best other method") + " |")
    return "\n".join(lines + claims) + "\n"


def write_report(out_dir: str | os.PathLike[str], out: str | os.PathLike[str] | None = None) -> str:
    """:func:`report` written to ``out`` (default ``OUT/report.md``); returns the text."""
    text = report(out_dir)
    path = os.fspath(out) if out is not None else os.path.join(os.fspath(out_dir), "report.md")
    with open(path, "w") as f:
        f.write(text)
    return text
