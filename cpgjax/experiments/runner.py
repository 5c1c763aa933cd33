"""The runner every driver builds on: keys, run files, resume, Ctrl-C, the machine check and compile-ahead.

The drivers (:func:`cpgjax.experiments.evolve.run_ga` and :func:`~cpgjax.experiments.evolve.run_search`,
:func:`cpgjax.experiments.sweep.run_sweep`, :func:`cpgjax.experiments.repertoire.run_repertoire`) differ in what
a generation writes; what they share is here:

- **Keys**: :func:`run_keys`, a run's whole randomness from its seed (so a run of a sweep equals the run made alone).
- **The chunk program**: :func:`cached_chunk_fn` (one run's jitted chunk of generations, reused and compiled
  once), :func:`one_run` and :func:`single_run_call` (a run as a group of one), :func:`compile_ahead`.
- **Run files**: :func:`open_run` creates a run file or finds where one stops (:func:`metrics_spec`: the
  metrics it stores); :func:`run_guard` holds its lock (:mod:`cpgjax.io.runlock`) with Ctrl-C deferred.
- **Ctrl-C**: while a driver runs (or inside :func:`deferred_sigint`, which the command line wraps around a
  whole command), the first SIGINT only asks to stop: the driver finishes the generation in flight, writes it,
  and raises ``KeyboardInterrupt`` at a clean point (:func:`check_stop`; never inside XLA's compiler); a second
  SIGINT interrupts at once.  Either way the file holds only complete generations.
- **Resume**: each row stores the algorithm's state after that generation (``/state/*``, by name:
  :meth:`~cpgjax.optim.algorithm.Algorithm.save`; for the GA the population bred from it).  Resuming reads the
  last complete row, rebuilds the state (``Algorithm.load``) and continues the scan from ``completed`` with that
  state; because keys depend only on (seed, GEN) and the program is the same, the resumed file holds bit for bit
  the rows an uninterrupted run would (wall times aside), provided the chunk size, the machine and the JAX
  version are the same.  A run file is continued only with what computed it: :func:`check_resume` refuses other
  settings of the algorithm, genome or population sizes, and (:func:`check_problem`, also what a sweep checks
  before it adds runs beside others) another episode length, terrain, evaluation, pipeline, time step or model
  file; :func:`check_machine` another machine or versions (:mod:`cpgjax.io.machine`) unless allowed, and then
  records the switch; :func:`check_stored_state` a stored state of another layout.  Each refusal is a
  :class:`ResultsError` that names the first difference and what to do.
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import sys
import threading
from collections.abc import Callable, Iterator
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from cpgjax.errors import ResultsError
from cpgjax.io import runlock
from cpgjax.io.machine import machine, machine_differences, run_machines
from cpgjax.io.results import RunWriter, create_run, read_attrs, read_resume_point
from cpgjax.optim.algorithm import Algorithm, chunk_args, make_chunk_fn
from cpgjax.optim.problem import Problem

# --- keys and the chunk program ------------------------------------------------------------------------------


def run_keys(seed: int) -> tuple[jax.Array, jax.Array, jax.Array]:
    """``(k_init, k_propose, k_update)`` of a run: its whole randomness, from the seed alone.

    Every driver (``cpgjax evolve``, ``search``, ``sweep``, ``repertoire``) takes its keys from here, which is what
    makes a run of a sweep equal, bit for bit, the same run made alone.
    """
    k_init, k_prop, k_upd = jax.random.split(jax.random.key(seed), 3)
    return k_init, k_prop, k_upd


def compile_ahead(fn, args: tuple) -> Callable:
    """Compile the jitted ``fn`` for ``args`` now; returns a callable that always runs that executable.

    Why (compiler behaviour, jax 0.10.2): the state a chunk returns comes back placed (sharded over
    the host devices) other than the initial one, so the *second* call of a jitted chunk traced and
    compiled the whole program again (what that cost: docs/sweeps.md).  Calling the ahead-of-time
    executable, with the arguments first put where it expects them (``device_put`` does nothing when they
    already are), compiles exactly once.
    """
    compiled = fn.lower(*args).compile()
    shardings = compiled.input_shardings[0]
    return lambda *a: compiled(*jax.device_put(a, shardings))


class _CompiledOnFirstCall:
    """A jitted function compiled ahead of time (:func:`compile_ahead`) for the arguments of its first call, each
    call's arguments followed by ``tail``."""

    def __init__(self, fn: Callable, tail: tuple = ()):
        self.fn, self.call, self.tail = fn, None, tail

    def __call__(self, *args):
        args = args + self.tail
        if self.call is None:
            self.call = compile_ahead(self.fn, args)
        return self.call(*args)


_CHUNK_CACHE: dict[tuple, tuple[Callable, Callable]] = {}


def cached_chunk_fn(problem: Problem, algo: Algorithm, chunk: int, static: tuple) -> Callable:
    """The jitted chunk of one run (:func:`cpgjax.optim.algorithm.make_chunk_fn` with one group of one run).

    Reused across calls with the same ``evaluate`` and static settings (``static``: what else the program
    depends on, e.g. a search's whole configuration but the seed; several runs of one problem in a process,
    tests, resume: compile once).  Compiled ahead of time on first use (:func:`compile_ahead`).  The episode's
    length is an argument of the program (``problem.length``, appended to every call: :func:`chunk_args`), not a
    constant in it: problems that differ by the length alone compile the same program (which the persistent
    compilation cache then holds once).
    """
    held = None if problem.held is None else (np.asarray(problem.held, bool).tobytes(),   # the GA's tell puts
                                               np.asarray(problem.base_genome, np.float32).tobytes())  # them back
    key = (id(problem.evaluate), problem.n_genes, problem.lower, problem.upper, algo.kind,
           algo.population, chunk, static, held)
    hit = _CHUNK_CACHE.get(key)
    if hit is not None and hit[0] is problem.evaluate:
        return hit[1]
    fn = _CompiledOnFirstCall(make_chunk_fn(problem, [algo], [1], chunk), chunk_args(problem))   # same shapes
    if len(_CHUNK_CACHE) >= 16:
        _CHUNK_CACHE.pop(next(iter(_CHUNK_CACHE)))
    _CHUNK_CACHE[key] = (problem.evaluate, fn)
    return fn


def one_run(tree):
    """A leading axis of 1 on every leaf (one run of a group)."""
    return jax.tree.map(lambda a: jnp.asarray(a)[None], tree)


def single_run_call(chunk_fn: Callable, params: Any, k_prop: jax.Array, k_upd: jax.Array) -> Callable:
    """``call(state1, gen0, target)``: one chunk of one run (a group of one run) from generation ``gen0``.

    ``chunk_fn``: :func:`cached_chunk_fn`'s; ``state1``: ``[one_run(state)]``; generations from ``target`` on are
    skipped (``call(state1, 0, 0)`` computes nothing: it compiles).  Returns ``(state1, rows)`` as
    :func:`cpgjax.optim.algorithm.make_chunk_fn` does.
    """
    params1, k_prop1, k_upd1 = [one_run(params)], [k_prop[None]], [k_upd[None]]

    def call(state1, gen0, target):
        return chunk_fn(params1, state1, k_prop1, k_upd1, [jnp.full((1,), gen0, jnp.int32)],
                        [jnp.full((1,), target, jnp.int32)])

    return call


# --- Ctrl-C --------------------------------------------------------------------------------------------------

_SIGINT = {"active": False, "requested": False}


@contextlib.contextmanager
def deferred_sigint():
    """Within: the first Ctrl-C (SIGINT) only sets a flag that the drivers check between generations.

    Does nothing outside the main thread, or when someone else already handles SIGINT.  The first
    SIGINT puts the default handler back, so a second one raises ``KeyboardInterrupt`` at once.
    """
    if (_SIGINT["active"] or threading.current_thread() is not threading.main_thread()
            or signal.getsignal(signal.SIGINT) is not signal.default_int_handler):
        yield
        return

    def handler(signum, frame):
        _SIGINT["requested"] = True
        signal.signal(signal.SIGINT, signal.default_int_handler)
        print("\nCtrl-C: stopping at the next safe point, after the compilation or generation in flight "
              "(Ctrl-C again to stop at once)",
              file=sys.stderr, flush=True)

    old = signal.signal(signal.SIGINT, handler)
    _SIGINT.update(active=True, requested=False)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old)
        _SIGINT.update(active=False, requested=False)


def stop_requested() -> bool:
    """True once a Ctrl-C arrived inside :func:`deferred_sigint`."""
    return bool(_SIGINT["requested"])


def check_stop() -> None:
    """Raise ``KeyboardInterrupt`` if a Ctrl-C arrived inside :func:`deferred_sigint` (a clean point to stop)."""
    if stop_requested():
        raise KeyboardInterrupt


@contextlib.contextmanager
def run_guard(path: str | None) -> Iterator[None]:
    """Within: Ctrl-C deferred (:func:`deferred_sigint`) and the run file ``path`` locked (one writer per run
    file: the lock is taken before anything is created, replaced or read for a resume, and held until the last
    generation is written, :mod:`cpgjax.io.runlock`; ``path=None``: nothing on disk, no lock)."""
    with deferred_sigint(), runlock.hold(path):
        yield


# --- run files -----------------------------------------------------------------------------------------------


def metrics_spec(problem: Problem, population: int) -> dict[str, tuple[tuple[int, ...], Any]]:
    """The per-individual metrics ``problem.evaluate`` returns besides fitness (shapes for the run file).

    Traces the simulator once (``eval_shape``): callers with many runs compute it once.
    """
    genomes = jax.ShapeDtypeStruct((population, problem.n_genes), jnp.float32)
    if problem.stochastic:     # the robust evaluation also takes one key per genome
        keys = jax.eval_shape(lambda: jax.random.split(jax.random.key(0), population))
        ev = jax.eval_shape(problem.evaluate, genomes, keys)
    else:
        ev = jax.eval_shape(problem.evaluate, genomes)
    return {k: ((population,), np.float32) for k in ev if k not in ("fitness", "diverged")}


def open_run(problem: Problem, algo: Algorithm, path: str | None, params: Any, k_init: jax.Array, *,
             resume: bool, overwrite: bool, init: Callable | None = None,
             metrics: dict | None = None, allow_other_machine: bool = False) -> tuple[int, Any, float]:
    """Where a run starts: ``(completed generations, algorithm state, wall time so far)``.

    ``resume`` and an existing file: its settings are checked against ``algo`` (the number of
    generations may be extended) and the run continues after its last complete row.  Otherwise a
    new file is created (an existing one only with ``overwrite``, else :class:`ResultsError`) and
    the state is ``algo.init`` with the run's ``k_init``.  ``path=None``: nothing on disk.
    ``init`` (a jitted ``algo.init``) and ``metrics`` (:func:`metrics_spec`) may be passed in by
    callers that open many runs of one shape, so that neither is traced again for each.
    The stored state must have the names and shapes this algorithm stores (:meth:`Algorithm.save`), else
    :class:`ResultsError`.
    A run to continue that was computed on another machine or with other versions (the CPU, its vector
    ISA, cpgjax, jax, jaxlib, mujoco: :func:`cpgjax.io.machine.machine`) is refused unless
    ``allow_other_machine``; then the file records from which generation on this machine computed it.
    """
    state_spec = jax.eval_shape(algo.init, params, k_init)
    saved_spec = jax.eval_shape(algo.save, state_spec)
    if path is not None and resume and os.path.exists(path):
        check_resume(path, algo, problem)
        completed, stored, wall0 = read_resume_point(path)
        if completed < algo.generations:
            check_machine(path, completed, allow_other_machine)
        if int(read_attrs(path)["generations"]) != algo.generations:
            with RunWriter(path) as w:
                w.set_attr("generations", algo.generations)
                w.set_attr("cfg_generations", algo.generations)
                w.set_attr("config", json.dumps(algo.config))
        if completed:
            check_stored_state(path, stored, saved_spec)
            return completed, algo.load(stored, state_spec), wall0
    elif path is not None:
        if os.path.exists(path) and not overwrite:
            raise ResultsError(f"{path} exists; use --resume to continue it or --overwrite to replace it")
        if metrics is None:
            metrics = metrics_spec(problem, algo.population)
        states = {k: (tuple(s.shape), s.dtype) for k, s in saved_spec.items()}
        create_run(path, kind=algo.kind, config=algo.config, problem=problem, population=algo.population,
                   generations=algo.generations, metrics=metrics, state=states, overwrite=overwrite)
    return 0, (init or jax.jit(algo.init))(params, k_init), 0.0


# --- what refuses to continue a run --------------------------------------------------------------------------
# Problem settings that do not change a fitness (a moved model file, how the options were spelled).
_META_IGNORED = ("model_path", "cli_problem_args")
# meta key -> (option, what it is, unit); checked in this order, every other key after them
_META_OPTIONS = {"evaluation": ("--evaluation", "evaluation", ""), "pipeline": ("--pipeline", "physics pipeline", ""),
                 "time": ("--time", "episode length", " s"), "terrain": ("--terrain", "terrain", ""),
                 "delta": ("--delta", "delta of the fitness", ""), "replicas": ("--replicas", "replicas", ""),
                 "jitter": (None, "replicas' jitter", ""), "dt": ("--dt", "time step", " s"),
                 "controller": ("--controller", "controller", ""), "start": ("--start", "starting controller", ""),
                 "perturbations": ("--perturb", "perturbation ranges", ""), "free": ("--free", "genes evolved", "")}
_GIVEN_AS = {"perturbations": "perturb"}     # meta key -> its key in cli_problem_args, where they differ
_FIX = "(drop the option, or start anew with --overwrite)"


def _fmt(v: Any, unit: str = "") -> str:
    if isinstance(v, bool):
        return "on" if v else "off"
    if isinstance(v, float):
        return f"{v:g}{unit}"
    return f"{v}{unit}" if not isinstance(v, str) or v else "''"


def _show(k: str, v: Any, unit: str = "", other: Any = None) -> str:
    """A stored or new setting ``k`` as the command line spells it (``other``: the value it is compared with)."""
    if k == "controller":
        return v or "cpg"
    if k == "start":
        return json.loads(v).get("path", "?") if isinstance(v, str) else "none (the thesis's sinusoids)"
    if k == "perturbations" and isinstance(v, dict) and isinstance(other, dict):   # the keys that differ
        return ",".join(f"{n}={_fmt(v.get(n, 'unset'))}" for n in sorted(set(v) | set(other))
                        if v.get(n) != other.get(n))
    return _fmt(v, unit)


def check_resume(path: str, algo: Algorithm, problem: Problem) -> None:
    """Refuse to continue a run whose stored settings differ from these in anything that changes a fitness.

    Checked: the kind, every setting of the algorithm but ``algo.resumable_changes``, the genome and
    population sizes, and every entry of the problem's meta (episode length, terrain, delta,
    replicas and their jitter, time step, the model file's text, ...).
    """
    a = read_attrs(path)
    if a.get("kind") != algo.kind:
        kind = a.get("kind")
        what = (f"--method {algo.kind} differs from the run's {kind}" if "ga" not in (kind, algo.kind) else
                f"it holds a {'GA' if kind == 'ga' else repr(kind)} run, not a "
                f"{'GA' if algo.kind == 'ga' else repr(algo.kind)} one")
        raise ResultsError(f"{path}: cannot resume: {what} (choose another --out, or start anew with --overwrite)")
    stored = json.loads(a["config"])
    for k, v in algo.config.items():
        if k not in algo.resumable_changes and stored.get(k) != v:
            raise ResultsError(f"{path}: cannot resume: --{k.replace('_', '-')} {_fmt(v)} differs from the "
                               f"run's {_fmt(stored.get(k, 'unset'))} {_FIX}")
    check_problem(path, problem, a)     # first: a setting that differs (--controller, the model) explains the sizes
    if int(a["n_genes"]) != problem.n_genes or int(a["population"]) != algo.population:
        raise ResultsError(f"{path}: cannot resume: genome or population size differs from the stored run "
                           f"({problem.n_genes} genes x {algo.population} vs the run's {int(a['n_genes'])} x "
                           f"{int(a['population'])}) {_FIX}")


def check_problem(path: str, problem: Problem, attrs: dict | None = None, verb: str = "resume") -> None:
    """Refuse ``problem`` where the run in ``path`` was scored with other settings (episode length, terrain,
    delta, evaluation and its perturbations, physics pipeline, time step, the model file's text, ...):
    :class:`ResultsError` naming the first difference.  ``verb``: what is refused ("resume"; a sweep adding runs
    beside it: "add runs")."""
    a = attrs if attrs is not None else read_attrs(path)
    fix = _FIX if verb == "resume" else "(use the sweep's settings, or another --out)"
    old = json.loads(a.get("meta") or "{}")
    new = json.loads(json.dumps(dict(problem.meta), default=lambda o: o.tolist() if hasattr(o, "tolist") else str(o)))
    given = json.loads(new.get("cli_problem_args") or "{}")
    if "pipeline" in new and "pipeline" not in old:   # a run made before the pipeline was recorded: the thesis's
        old["pipeline"] = "springs"
    differ = [k for k in (set(old) | set(new)) - set(_META_IGNORED) if old.get(k) != new.get(k)]
    # first what an option given now changes, then the model file, then whatever else differs
    for k in [k for k in _META_OPTIONS
              if k in differ and _META_OPTIONS[k][0] and given.get(_GIVEN_AS.get(k, k)) is not None]:
        option, _, unit = _META_OPTIONS[k]
        raise ResultsError(f"{path}: cannot {verb}: {option} {_show(k, new.get(k), '', old.get(k))} differs from "
                           f"the run's {_show(k, old.get(k), unit, new.get(k))} {fix}")
    if "model_text" in differ and old.get("model_text") and new.get("model_text"):
        raise ResultsError(f"{path}: cannot {verb}: the model file {new.get('model_path', '')} changed since the "
                           "run started " + ("(restore it, or start anew with --overwrite)" if verb == "resume"
                                             else fix))
    for k in [k for k in _META_OPTIONS if k in differ] + sorted(set(differ) - set(_META_OPTIONS) - {"model_text"}):
        option, what, unit = _META_OPTIONS.get(k, (None, k, ""))
        why = fix if option or verb != "resume" else "(start anew with --overwrite)"    # no option to drop
        raise ResultsError(f"{path}: cannot {verb}: the {what} {_show(k, new.get(k), unit, old.get(k))} differs "
                           f"from the run's {_show(k, old.get(k), unit, new.get(k))} {why}")


def check_machine(path: str, completed: int, allow: bool) -> None:
    """Refuse to continue on another machine or versions than those that computed the run's last generations
    (unless ``allow``: then the file's ``machines`` attribute records the switch)."""
    machines = run_machines(read_attrs(path))
    diff = machine_differences(machines[-1])
    if not diff:
        return
    if not allow:
        raise ResultsError(f"{path}: cannot resume on another machine or versions ({'; '.join(diff)}): the numbers "
                           "would mix two machines' rounding in one run (docs/reproducibility.md); add "
                           "--allow-other-machine to go on anyway, or start anew with --overwrite")
    with RunWriter(path) as w:
        w.set_attr("machines", json.dumps(machines + [{"from_generation": completed, **machine()}]))


def check_stored_state(path: str, stored: dict[str, np.ndarray], spec: dict[str, Any]) -> None:
    """Refuse a stored state that is not what this algorithm stores (another layout, or another evosax's)."""
    for k, s in spec.items():
        if k not in stored:
            raise ResultsError(f"{path}: cannot resume: the run stores no state {k!r} (it stores "
                               f"{', '.join(sorted(stored)) or 'none'}); start anew with --overwrite")
        if tuple(np.shape(stored[k])) != tuple(s.shape):
            raise ResultsError(f"{path}: cannot resume: its state {k!r} has shape {tuple(np.shape(stored[k]))}, "
                               f"this version stores {tuple(s.shape)}; start anew with --overwrite")
