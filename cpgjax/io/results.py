"""Run results in HDF5: one file per run, appended and flushed generation by generation.

Layout (``format = "cpgjax-run"``, ``format_version = 1``)::

    /                       attributes
        format, format_version   "cpgjax-run", 1
        kind                     "ga" | "random" | "amc"
        config                   JSON of the full run configuration (GAConfig / SearchConfig);
                                 every field is also stored as its own attribute ``cfg_<name>``
        seed                     the run's seed (jax.random.key(seed))
        population               N, individuals per generation (per batch for the searches)
        generations              the planned number of generations (batches / iterations)
        completed                generations fully written; the datasets may hold more rows
                                 (a write interrupted by a kill): readers truncate to it
        problem, n_genes, lower, upper
        meta                     JSON of Problem.meta; each entry is also an attribute of its
                                 own (model_path, model_text (the .wl file's text), time,
                                 terrain, delta, dt, pipeline, n_dof, harmonics, ...)
        versions                 JSON {python, cpgjax, jax, jaxlib, mujoco, numpy, h5py, platform, device,
                                 cpu, isa, xla_flags}: cpu the CPU's model name, isa the widest vector
                                 instructions XLA may use here (AVX512, AVX2, ..., or the cap of
                                 XLA_FLAGS=--xla_cpu_max_isa=...)
        machines                 JSON list of {from_generation, cpu, isa, cpgjax, jax, jaxlib, mujoco}:
                                 the machine (and versions) that computed the run from that generation on;
                                 more than one entry only after ``--resume --allow-other-machine``
                                 (docs/reproducibility.md)
        created                  ISO time the run was created
    /genomes        float32 [G_done, N, n_genes]  every genome evaluated in each generation
    /fitness        float32 [G_done, N]           fitness as evaluated (NaN kept when diverged)
    /diverged       bool    [G_done, N]           diverged flag, or fitness not finite
    /n_diverged     int32   [G_done]              diverged individuals per generation
    /mutation_rate  float32 [G_done]              mu(GEN) of eq. 6.1 used to breed GEN+1 from GEN
                                                  (NaN for the searches)
    /wall_time      float64 [G_done]              seconds since the run started, at the end of
                                                  the chunk holding GEN (summed over resumes)
    /metrics/<name> float32 [G_done, N]           optional per-individual metrics of the problem
                                                  (distance, speed, tilt, ...)
    /state/<name>   [G_done, ...]                 the algorithm's state *after* GEN (GA: the
                                                  population bred from GEN; AMC: centres, best
                                                  fitness); the last row is what ``--resume``
                                                  continues from

Every dataset is chunked by generation with an unlimited first axis.  Writes of one
generation are: resize, write the rows, flush, set ``completed``, flush.  HDF5 writes its
cached metadata to disk in an order of its own, so ``completed`` is only set once the rows are
on disk: a ``completed`` read from disk never counts a row that is not there.  The writer opens
the file only while it writes a chunk of generations and closes it between chunks, so a run
killed while it computes leaves a closed, consistent file; a kill during a write loses at most
the generation being written.  Readers and writers trust no more generations than every
dataset holds (files written before the second flush may count one more).

What a run records of its machine (``versions``, ``machines``): :mod:`cpgjax.io.machine`; a run read back
(:class:`Run`): :mod:`cpgjax.io.run`.
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import json
import os
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import h5py
import numpy as np

from cpgjax._xla import ISAS, cpu_model, isa  # noqa: F401  (re-exported: the machine a run records)
from cpgjax.errors import ResultsError
from cpgjax.io import runlock
from cpgjax.io.machine import (  # noqa: F401  (re-exported: the machine a run records)
    MACHINE_KEYS,
    describe_machine,
    machine,
    machine_differences,
    run_machines,
    versions,
)
from cpgjax.io.run import Run, nanreduce  # noqa: F401  (nanreduce re-exported)

FORMAT = "cpgjax-run"
FORMAT_VERSION = 1
ROW_DATASETS = ("genomes", "fitness", "diverged", "n_diverged", "mutation_rate", "wall_time")


def _attr_value(v: Any) -> Any:
    """A value HDF5 can store as an attribute (numbers, strings, bools); others as JSON text."""
    if isinstance(v, (bool, np.bool_)):
        return bool(v)
    if isinstance(v, (int, float, str, np.integer, np.floating)):
        return v
    if v is None:
        return ""
    if isinstance(v, np.ndarray) and v.dtype.kind in "biuf":
        return v
    return json.dumps(v, default=str)


def _json(v: Any) -> str:
    return json.dumps(v, default=lambda o: o.tolist() if hasattr(o, "tolist") else str(o))


@dataclass
class Row:
    """One generation's results, as numpy arrays."""

    genomes: np.ndarray
    fitness: np.ndarray
    diverged: np.ndarray
    mutation_rate: float
    wall_time: float
    metrics: dict[str, np.ndarray] = field(default_factory=dict)
    state: dict[str, np.ndarray] = field(default_factory=dict)


def create_run(path: str | os.PathLike[str], *, kind: str, config: Mapping[str, Any], problem,
               population: int, generations: int, metrics: Mapping[str, tuple[tuple[int, ...], Any]],
               state: Mapping[str, tuple[tuple[int, ...], Any]], overwrite: bool = False) -> None:
    """Create an empty run file with its attributes and (empty, growable) datasets.

    ``metrics`` and ``state`` map names to (shape of one generation's row, dtype).
    Refuses to replace an existing file unless ``overwrite``.
    """
    p = os.fspath(path)
    if os.path.exists(p) and not overwrite:
        raise ResultsError(f"{p} exists; use --resume to continue it or --overwrite to replace it")
    d = os.path.dirname(p)
    if d:
        os.makedirs(d, exist_ok=True)
    n, g = int(population), int(problem.n_genes)
    tmp = p + ".tmp"
    try:
        _create(tmp, kind=kind, config=config, problem=problem, n=n, g=g, generations=generations,
                metrics=metrics, state=state)
        os.replace(tmp, p)
    except OSError as e:
        with contextlib.suppress(OSError):
            os.remove(tmp)
        raise ResultsError(f"{p}: cannot write the run file ({_reason(e)})") from None


def _reason(e: BaseException) -> str:
    """h5py's message without its boilerplate (``Unable to synchronously open file (...)``)."""
    text = str(e).strip()
    if "(" in text and text.endswith(")"):
        text = text[text.index("(") + 1:-1]
    return text or type(e).__name__


def _create(tmp: str, *, kind: str, config: Mapping[str, Any], problem, n: int, g: int, generations: int,
            metrics: Mapping[str, tuple[tuple[int, ...], Any]], state: Mapping[str, tuple[tuple[int, ...], Any]]
            ) -> None:
    with h5py.File(tmp, "w") as f:
        a = f.attrs
        a["format"], a["format_version"], a["kind"] = FORMAT, FORMAT_VERSION, kind
        a["config"] = _json(dict(config))
        for k, v in config.items():
            a[f"cfg_{k}"] = _attr_value(v)
        a["seed"] = int(config.get("seed", 0))
        a["population"], a["generations"], a["completed"] = n, int(generations), 0
        a["problem"], a["n_genes"] = str(problem.name), g
        a["lower"], a["upper"] = float(problem.lower), float(problem.upper)
        a["meta"] = _json(dict(problem.meta))
        for k, v in problem.meta.items():
            if k not in a:
                a[k] = _attr_value(v)
        v = versions()
        a["versions"] = _json(v)
        a["machines"] = _json([{"from_generation": 0, **machine(v)}])
        a["created"] = _dt.datetime.now().isoformat(timespec="seconds")

        def make(name: str, row: tuple[int, ...], dtype: Any) -> None:
            f.create_dataset(name, shape=(0, *row), maxshape=(None, *row), dtype=dtype,
                             chunks=(1, *row) if row else (256,))

        make("genomes", (n, g), np.float32)
        make("fitness", (n,), np.float32)
        make("diverged", (n,), bool)
        make("n_diverged", (), np.int32)
        make("mutation_rate", (), np.float32)
        make("wall_time", (), np.float64)
        for name, (shape, dtype) in metrics.items():
            make(f"metrics/{name}", tuple(shape), dtype)
        for name, (shape, dtype) in state.items():
            make(f"state/{name}", tuple(shape), dtype)


class RunWriter:
    """Append generations to a run file: ``with RunWriter(path) as w: w.append(row)``.

    Opens the file on enter and closes it on exit (the driver holds it open only while it
    writes one chunk).  Rows beyond ``completed`` (left by an interrupted write) are dropped
    on open.
    """

    def __init__(self, path: str | os.PathLike[str]):
        self.path = os.fspath(path)
        self.f: h5py.File | None = None
        self.ds: dict[str, h5py.Dataset] = {}     # every dataset by its path, looked up once per open

    def __enter__(self) -> RunWriter:
        self.f = _open(self.path, "a")
        self.ds = _datasets(self.f)
        n = _consistent(self.f, self.ds)
        if n != int(self.f.attrs["completed"]):
            self.f.attrs["completed"] = n
        _truncate(self.ds, n)
        return self

    def __exit__(self, *exc: object) -> None:
        assert self.f is not None
        self.ds = {}
        self.f.close()
        self.f = None

    @property
    def completed(self) -> int:
        assert self.f is not None
        return int(self.f.attrs["completed"])

    def append(self, row: Row) -> int:
        """Write one generation, set ``completed`` and flush; returns the generation's index."""
        f = self.f
        assert f is not None
        i = int(f.attrs["completed"])
        values: dict[str, Any] = {
            "genomes": row.genomes, "fitness": row.fitness, "diverged": row.diverged,
            "n_diverged": np.int32(np.sum(row.diverged)), "mutation_rate": np.float32(row.mutation_rate),
            "wall_time": np.float64(row.wall_time)}
        values.update({f"metrics/{k}": v for k, v in row.metrics.items() if f"metrics/{k}" in self.ds})
        values.update({f"state/{k}": v for k, v in row.state.items()})
        for name, v in values.items():
            ds = self.ds[name]
            ds.resize(i + 1, axis=0)
            ds[i] = v
        f.flush()  # the rows on disk before the count that names them (module docstring)
        f.attrs["completed"] = i + 1
        f.flush()
        return i

    def set_attr(self, name: str, value: Any) -> None:
        assert self.f is not None
        self.f.attrs[name] = _attr_value(value)


def _datasets(f: h5py.File) -> dict[str, h5py.Dataset]:
    """Every dataset of the file by its path (``genomes``, ``metrics/speed``, ...)."""
    out: dict[str, h5py.Dataset] = {}
    f.visititems(lambda name, obj: out.__setitem__(name, obj) if isinstance(obj, h5py.Dataset) else None)
    return out


def _consistent(f: h5py.File, ds: Mapping[str, h5py.Dataset] | None = None) -> int:
    """The generations complete on disk: ``completed``, or fewer where a dataset holds fewer rows (a write
    killed while HDF5 had put the count on disk before a dataset's new extent).  ``ds``: the file's datasets
    (:func:`_datasets`), where the caller has them."""
    ds = _datasets(f) if ds is None else ds
    return min([int(f.attrs["completed"])] + [d.shape[0] for d in ds.values()])


def _truncate(ds: Mapping[str, h5py.Dataset], n: int) -> None:
    for d in ds.values():
        if d.shape[0] > n:
            d.resize(n, axis=0)


def _decode(v: Any) -> Any:
    if isinstance(v, bytes):
        return v.decode()
    if isinstance(v, np.generic):
        return v.item()
    return v


NOT_A_RUN = "is not a readable cpgjax run"
START_ANEW = "start anew with --overwrite, or name another file"


class UnreadableRun(ResultsError):
    """Not a readable run; its ``advice`` (``--overwrite``) is added only by the commands that have that option."""

    def __init__(self, message: str, advice: str):
        super().__init__(message)
        self.advice = advice


def _open(path: str | os.PathLike[str], mode: str = "r") -> h5py.File:
    """Open a run file; what h5py raises becomes a :class:`ResultsError` that names the file and what to do."""
    p = os.fspath(path)
    if not os.path.exists(p):
        raise ResultsError(f"{p}: no such file")
    if os.path.isdir(p):
        raise ResultsError(f"{p}: is a folder, not a run file (.h5)")
    try:
        if mode == "r":
            return h5py.File(p, "r", locking=False)
        return h5py.File(p, mode)
    except PermissionError:
        raise ResultsError(f"{p}: cannot {'read' if mode == 'r' else 'write'}: permission denied") from None
    except OSError as e:
        raise UnreadableRun(f"{p}: {NOT_A_RUN} (HDF5: {_reason(e)})", START_ANEW) from None


def read_attrs(path: str | os.PathLike[str]) -> dict[str, Any]:
    """The root attributes of a run file (no datasets); safe on a file another process is writing (a read torn
    by a write tried again, as :func:`read_run`)."""
    return _while_written(os.fspath(path), _read_attrs)[1]


def _read_attrs(p: str) -> dict[str, Any]:
    with _open(p) as f:
        _check(f, p)
        return {k: _decode(v) for k, v in f.attrs.items()}


def _check(f: h5py.File, path: Any) -> None:
    if f.attrs.get("format") != FORMAT:
        raise UnreadableRun(f"{os.fspath(path)} {NOT_A_RUN}: it is an HDF5 file without the attribute "
                            f"format = {FORMAT!r}", START_ANEW)
    missing = [k for k in ("kind", "config", "completed", "population", "n_genes") if k not in f.attrs]
    if missing:
        raise UnreadableRun(f"{os.fspath(path)} {NOT_A_RUN}: attributes {', '.join(missing)} are missing",
                            START_ANEW)


def _unreadable(p: str, what: str, e: BaseException, last_ok: int | None = None) -> ResultsError:
    hint = (f"the last readable generation is {last_ok - 1}" if last_ok else "no generation can be read")
    return UnreadableRun(f"{p}: {what} cannot be read (HDF5: {_reason(e)}); {hint}", START_ANEW)


READ_TRIES = 10        # a file being written: tries to read a consistent state (0.2 s apart) before giving up


def _while_written(p: str, read):
    """``(writer, read(p))``: while another process writes the file (``writer``, :func:`runlock.holder`), a read
    torn by a write (HDF5's own errors, or the file not yet whole) is tried again, 0.2 s apart, READ_TRIES
    times; with nobody writing, the error is the file's."""
    for attempt in range(READ_TRIES):
        writer = runlock.holder(p)
        # this process holding the lock (a resume checking its file) is not writing while it reads
        other = writer is not None and not runlock.is_mine(writer)
        try:
            try:
                return writer, read(p)
            except (OSError, RuntimeError, KeyError) as e:    # HDF5's own errors of a read torn by a write
                if not other:
                    raise
                raise _unreadable(p, "the file's structure", e) from e
        except ResultsError:
            if not other or attempt == READ_TRIES - 1:
                raise
            time.sleep(0.2)
    raise AssertionError("unreachable")  # pragma: no cover


def read_run(path: str | os.PathLike[str]) -> Run:
    """Read a run file; safe on a file another process is writing (opened without HDF5's locking, the
    rows cut to the generations complete in every dataset, a read torn by a write tried again).
    ``Run.writer`` says who is writing it (None: nobody)."""
    writer, run = _while_written(os.fspath(path), _read_run)
    run.writer = writer
    return run


def _read_run(p: str) -> Run:
    with _open(p) as f:
        _check(f, p)
        attrs = {k: _decode(v) for k, v in f.attrs.items()}
        n = attrs["completed"] = _consistent(f)

        def rows(name: str) -> np.ndarray:
            try:
                return np.asarray(f[name][:n])
            except (OSError, KeyError, ValueError) as e:
                raise _unreadable(p, f"/{name}", e, _last_readable(f, name, n)) from None

        group = lambda g: {k: rows(f"{g}/{k}") for k in f[g]} if g in f else {}  # noqa: E731
        try:
            config, meta = json.loads(attrs["config"]), json.loads(attrs.get("meta") or "{}")
        except ValueError:
            raise ResultsError(f"{p} {NOT_A_RUN}: its config or meta attribute is not JSON") from None
        return Run(path=p, attrs=attrs, config=config, meta=meta,
                   genomes=rows("genomes"), fitness=rows("fitness"), diverged=rows("diverged"),
                   n_diverged=rows("n_diverged"), mutation_rate=rows("mutation_rate"),
                   wall_time=rows("wall_time"), metrics=group("metrics"), state=group("state"))


def writing_note(path: str | os.PathLike[str], attrs: Mapping[str, Any] | None = None,
                 writer: dict | None = None) -> str | None:
    """``RUN.h5: still being written by pid 12 on host (cpgjax evolve ...): read its 7 complete generations of 30``,
    or None when no process is writing it (``writer``: a :func:`cpgjax.io.runlock.holder` already asked)."""
    p = os.fspath(path)
    writer = runlock.holder(p) if writer is None else writer
    if writer is None:
        return None
    try:
        a = read_attrs(p) if attrs is None else attrs
        done = f": read its {int(a['completed'])} complete generations of {int(a['generations'])}"
    except (ResultsError, KeyError, ValueError):
        done = ""
    return f"{p}: still being written by {runlock.describe(writer)}{done}"


def machines_line(files) -> str | None:
    """One line naming the machines (CPU, ISA, versions) that computed ``files``' runs when there is more than one
    (results differ across machines beyond the last bits: docs/reproducibility.md), else None."""
    seen: dict[str, int] = {}
    for p in files:
        try:
            ms = run_machines(read_attrs(p))
        except ResultsError:
            continue
        for m in {describe_machine(m) for m in ms}:
            seen[m] = seen.get(m, 0) + 1
    if len(seen) < 2:
        return None
    return (f"Machines: these runs were computed on {len(seen)} machines or versions (their numbers are not "
            "comparable bit for bit, docs/reproducibility.md): "
            + "; ".join(f"{m}: {n} run{'s' if n > 1 else ''}" for m, n in seen.items()) + ".")


def _last_readable(f: h5py.File, name: str, n: int) -> int:
    """How many leading rows of ``f[name]`` can be read (a damaged file: up to where it is intact)."""
    for i in range(n - 1, -1, -1):
        try:
            np.asarray(f[name][i])
            return i + 1
        except (OSError, KeyError, ValueError):
            continue
    return 0


def read_resume_point(path: str | os.PathLike[str]) -> tuple[int, dict[str, np.ndarray], float]:
    """(completed generations, the state after the last one, its wall time) for ``--resume``."""
    p = os.fspath(path)
    with _open(p) as f:
        _check(f, p)
        n = _consistent(f)
        if n == 0:
            return 0, {}, 0.0
        try:
            state = {k: np.asarray(f[f"state/{k}"][n - 1]) for k in f["state"]} if "state" in f else {}
            return n, state, float(f["wall_time"][n - 1])
        except (OSError, KeyError, ValueError, IndexError) as e:
            raise _unreadable(p, f"generation {n - 1}", e, _last_readable(f, "wall_time", n)) from None
