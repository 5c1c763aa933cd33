"""A sweep past one machine: its runs split into shards, each shard a Ray task (``cpgjax sweep --ray``).

Ray is an optional extra (``pip install -e .[cluster]``), imported here only, lazily; without it
:func:`require_ray` raises :class:`ClusterError` naming the extra.

**Shards.**  The runs of the plan (:mod:`cpgjax.experiments.sweep.plan`) are dealt into shards of
about equal cost (population x generations, largest first to the lightest shard).  Each shard is
one Ray task that runs :func:`cpgjax.experiments.sweep.driver.run_sweep` on its runs: the same
batched XLA program as an in-process sweep, over the host devices of its worker, writing the same
per-run HDF5 files (``OUT`` must be one folder every node sees: a shared file system).  By default
one task per node, sized by the node's CPUs (``workers=N``: N tasks of ``CPUs / N`` cores each).

**Same numbers.**  A robot's result does not depend on the batch it is in, its chunk, nor on the
number of host devices when there are two or more.  ONE host device is self-consistent (a sweep's
stored fitness equals its genomes evaluated alone: ``optim/algorithm.py: generation_step``), but XLA
compiles the program without ``shard_map`` and the robust evaluation rounds differently from two
devices, so a worker always has at least 2 host devices (two share one core when it has one).  Hence a sweep on
Ray holds bit for bit the files of the same sweep in one process (``tests/experiments/test_cluster.py``).

**Faults.**  A task whose worker dies is retried by Ray (``max_retries``); the retry resumes its runs
from their files, which hold complete generations, so at most the chunk of generations in flight is
lost.  A run's file is written by one task at a time: a task holds an exclusive POSIX lock
(``OUT/.locks/<cell>/s<seed>.lock``) on each of its runs while it works, and a retry racing a
predecessor that is not dead yet (a lost node that still runs) waits for it to let go.  Inside, the
driver takes each run's own writer lock (``RUN.h5.lock``, :mod:`cpgjax.io.runlock`, as every writer
does), which refuses at once a writer outside this sweep (another ``cpgjax sweep`` or ``evolve`` on
the same file).

**Progress.**  Tasks report the evaluations in their files to a small actor; the driver shows one
tqdm bar for the whole sweep, and returns each worker's throughput (``workers`` in the summary,
which ``cpgjax sweep`` appends to ``sweep-timing.jsonl``).
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import socket
import time
from collections.abc import Callable, Iterator, Sequence
from typing import Any

from cpgjax.errors import CpgjaxError
from cpgjax.experiments.sweep.plan import RunSpec, total_batch

EXTRA = "pip install -e .[cluster]"
MIN_DEVICES = 2             # see "Same numbers" above
LOCKS = ".locks"


class ClusterError(CpgjaxError, RuntimeError):
    """Ray is missing, or a shard of a sweep failed on the cluster."""


def require_ray():
    """The ``ray`` module, or :class:`ClusterError` naming the extra to install."""
    try:
        import ray
    except ImportError:
        raise ClusterError(f"--ray needs Ray, an optional extra: {EXTRA}") from None
    return ray


def run_cost(spec: RunSpec) -> int:
    """Evaluations of a whole run (population x generations)."""
    c = spec.cfg
    gens = c.generations if spec.kind == "ga" else c.iterations
    return int(c.population) * int(gens)


def run_done(spec: RunSpec) -> int:
    """Evaluations already in the run's file (0 when it is missing or unreadable)."""
    from cpgjax.errors import ResultsError
    from cpgjax.io.results import read_attrs

    if not os.path.exists(spec.path):
        return 0
    try:
        return int(read_attrs(spec.path)["completed"]) * int(spec.cfg.population)
    except (OSError, KeyError, ResultsError):
        return 0


def shards(specs: Sequence[RunSpec], n: int) -> list[list[RunSpec]]:
    """``specs`` dealt into at most ``n`` non-empty shards of about equal cost (each in plan order)."""
    n = max(1, min(int(n), len(specs)))
    order = sorted(range(len(specs)), key=lambda i: (-run_cost(specs[i]), i))
    load, members = [0] * n, [[] for _ in range(n)]
    for i in order:
        k = min(range(n), key=lambda j: (load[j], j))
        load[k] += run_cost(specs[i])
        members[k].append(i)
    return [[specs[i] for i in sorted(m)] for m in members if m]


def lock_path(spec: RunSpec) -> str:
    cell_dir = os.path.dirname(spec.path)
    return os.path.join(os.path.dirname(cell_dir), LOCKS, os.path.basename(cell_dir),
                        os.path.splitext(os.path.basename(spec.path))[0] + ".lock")


@contextlib.contextmanager
def holding(specs: Sequence[RunSpec]) -> Iterator[None]:
    """Exclusive POSIX locks on the runs' lock files (waits for a holder to let go; released at exit or death)."""
    files = []
    try:
        for s in specs:
            p = lock_path(s)
            os.makedirs(os.path.dirname(p), exist_ok=True)
            f = open(p, "a+")
            files.append(f)
            fcntl.lockf(f, fcntl.LOCK_EX)
        yield
    finally:
        for f in files:
            with contextlib.suppress(OSError):
                fcntl.lockf(f, fcntl.LOCK_UN)
            f.close()


def shard_task(problem_args: dict[str, Any], specs: list[RunSpec], *, shard: int, chunk: int, group: str,
               progress_actor: Any = None, allow_other_machine: bool = False) -> dict[str, Any]:
    """One shard, in a Ray worker: lock its runs, resume them from their files, report progress."""
    import jax

    from cpgjax.experiments.sweep.driver import run_sweep, sweep_problem

    t0 = time.perf_counter()
    pid = os.getpid()
    with holding(specs):
        done0 = sum(run_done(s) for s in specs)

        def report(evals: int) -> None:
            if progress_actor is not None:
                progress_actor.report.remote(shard, done0 + evals, pid)

        report(0)
        problem = sweep_problem(problem_args, batch=total_batch(specs))
        s = run_sweep(problem, specs, chunk=chunk, overwrite=False, progress=False, group=group,
                      callback=lambda step, info: report(info["evaluations"]),
                      allow_other_machine=allow_other_machine)
        report(s["evaluations"])
    return {**s, "shard": shard, "host": socket.gethostname(), "pid": pid, "devices": len(jax.devices()),
            "runs": len(specs), "task_time": time.perf_counter() - t0}


class _Progress:
    """Evaluations in the files of each shard, and the pid of the worker running it (a Ray actor)."""

    def __init__(self) -> None:
        self.done: dict[int, int] = {}
        self.pids: dict[int, int] = {}

    def report(self, shard: int, evals: int, pid: int) -> None:
        self.done[shard] = evals
        self.pids[shard] = pid

    def get(self) -> tuple[dict[int, int], dict[int, int]]:
        return dict(self.done), dict(self.pids)


def worker_plan(ray: Any, workers: int | None) -> list[dict[str, Any]]:
    """Ray task options per shard: one per alive node sized by its CPUs, or ``workers`` equal tasks."""
    from ray.util.scheduling_strategies import NodeAffinitySchedulingStrategy

    nodes = [n for n in ray.nodes() if n.get("Alive") and n.get("Resources", {}).get("CPU", 0) >= 1]
    if not nodes:
        raise ClusterError("the Ray cluster has no node with a CPU")
    if workers is None:
        return [{"num_cpus": int(n["Resources"]["CPU"]),
                 "scheduling_strategy": NodeAffinitySchedulingStrategy(n["NodeID"], soft=True)} for n in nodes]
    total = int(sum(n["Resources"]["CPU"] for n in nodes))
    return [{"num_cpus": max(1, total // workers)} for _ in range(workers)]


def run_on_ray(problem_args: dict[str, Any], specs: Sequence[RunSpec], *, address: str | None = None,
               workers: int | None = None, chunk: int = 1, overwrite: bool = False, progress: bool = True,
               group: str = "all", max_retries: int = 3, poll: float = 0.2,
               on_progress: Callable[[dict[str, Any]], None] | None = None,
               allow_other_machine: bool = False) -> dict[str, Any]:
    """Run the sweep's ``specs`` as Ray tasks; returns the summary of :func:`run_sweep` plus ``workers``.

    ``address``: an existing cluster (``ray start --head`` prints it; ``"auto"`` finds a local one);
    ``None`` starts a local Ray instance for this call (or uses the one this process already has).
    ``workers``: number of shards (default: one per node).  ``on_progress``: called in the driver at
    every poll with ``{"evaluations", "total", "pids": {shard: pid}, "done": {shard: evaluations},
    "shard_totals": {shard: evaluations}}`` (the tests kill a worker from it).
    """
    from tqdm.auto import tqdm

    ray = require_ray()
    if workers is not None and workers < 1:
        raise ValueError("workers must be >= 1")
    t_begin = time.perf_counter()
    if overwrite:               # here, not in the tasks: a retried task must resume, not start again
        from cpgjax.io import runlock

        for s in specs:         # not a file another process is writing (its lock: cpgjax.io.runlock)
            with runlock.hold(s.path):
                if os.path.exists(s.path):
                    os.remove(s.path)
    started = False
    if not ray.is_initialized():
        kw: dict[str, Any] = {"include_dashboard": False, "log_to_driver": False, "configure_logging": False}
        if address:
            ray.init(address=address, **kw)
        else:
            ray.init(num_cpus=os.cpu_count() or 1, object_store_memory=100 * 2**20, **kw)
        started = True
    try:
        t_ready = time.perf_counter()
        opts = worker_plan(ray, workers)
        parts = shards(specs, len(opts))
        total = sum(run_cost(s) for s in specs)
        # the files are read here only, before any task writes (h5py's file locks: a reader could block a writer)
        start = {k: sum(run_done(s) for s in part) for k, part in enumerate(parts)}
        shard_totals = {k: sum(run_cost(s) for s in part) for k, part in enumerate(parts)}
        actor = ray.remote(num_cpus=0)(_Progress).remote()
        task = ray.remote(shard_task)
        refs = []
        for k, (part, o) in enumerate(zip(parts, opts, strict=False)):
            env = {"CPGJAX_DEVICES": str(max(MIN_DEVICES, o["num_cpus"]))}
            refs.append(task.options(**o, max_retries=max_retries, retry_exceptions=False,
                                     runtime_env={"env_vars": env})
                        .remote(problem_args, part, shard=k, chunk=chunk, group=group, progress_actor=actor,
                                allow_other_machine=allow_other_machine))
        bar = tqdm(total=total, initial=sum(start.values()), desc="sweep (ray)", unit="eval",
                   unit_scale=True, disable=not progress, dynamic_ncols=True)
        try:
            pending = list(refs)
            while pending:
                _, pending = ray.wait(pending, num_returns=len(pending), timeout=poll)
                done, pids = ray.get(actor.get.remote())
                if done:
                    n = sum(done.get(k, v) for k, v in start.items())
                    if n != bar.n:
                        bar.update(n - bar.n)
                    if on_progress is not None:
                        on_progress({"evaluations": n, "total": total, "pids": pids, "done": done,
                                     "shard_totals": shard_totals})
            results = _gather(ray, refs)
        finally:
            bar.close()
        ray.kill(actor)
    finally:
        if started:
            ray.shutdown()
    wall = time.perf_counter() - t_begin
    evals = sum(r["evaluations"] for r in results)
    return {"runs": len(specs), "skipped": sum(r["skipped"] for r in results), "evaluations": evals,
            "evaluated": sum(r["evaluated"] for r in results), "wall_time": wall,
            "compile_time": max(r["compile_time"] for r in results),
            "evals_per_second": sum(r["evals_per_second"] for r in results),
            "evals_per_second_end_to_end": evals / max(wall, 1e-9),
            "cores_busy": sum(r["cores_busy"] for r in results), "ray_start": t_ready - t_begin,
            "ray": address or "local",
            "workers": [{k: r[k] for k in ("shard", "host", "pid", "devices", "runs", "evaluations",
                                           "evals_per_second", "cores_busy", "compile_time", "task_time")}
                        for r in results]}


def _gather(ray: Any, refs: list) -> list[dict[str, Any]]:
    """The tasks' results; a cpgjax error in a task is raised as itself, any other failure as ClusterError."""
    try:
        return ray.get(refs)
    except ray.exceptions.RayTaskError as e:
        cause = getattr(e, "cause", None)
        if isinstance(cause, CpgjaxError | ValueError | OSError):
            raise cause from None
        raise ClusterError(f"a shard of the sweep failed on the cluster: {e}") from None
    except ray.exceptions.RayError as e:
        raise ClusterError(f"a shard of the sweep failed on the cluster (after retries): {e}") from None
