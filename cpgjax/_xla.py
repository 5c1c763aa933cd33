"""XLA settings that must be in place before JAX is imported (one small, named place).

Why: on CPU, XLA runs one program mostly on one core; the fastest way we measured to
use every core for a batch of independent robots is one *host device* per core and
the batch split across them (`cpgjax.episode.batch`).  That needs
``--xla_force_host_platform_device_count`` set before JAX makes its CPU client.  This module is
imported first by ``cpgjax/__init__.py``.  XLA reads its flags when JAX first runs something, not when it is
imported, so a notebook's ``import jax`` before ``import cpgjax`` is fine: the settings below still take effect
(the compilation cache through ``jax.config``).  If JAX already ran something, they cannot: cpgjax then warns,
once, and goes on with the devices JAX has (without the second setting, a large batch's results may differ in
their last bits from the command line's: restart, and import cpgjax first).
One device per core the process may run on (:func:`default_devices`: a Slurm job's cpuset of 4 cores on a node of
64 makes 4, not 64), at least two on a machine of two cores or more.
Set ``CPGJAX_DEVICES=1`` to opt out, or to a number to choose the device count.  A process started by a cpgjax
process inherits the count it put in ``XLA_FLAGS`` (:data:`DEVICES_MARK` says which count that was); its own
``CPGJAX_DEVICES`` replaces it (a Ray worker's share of the cores, a script's ``CPGJAX_DEVICES=1`` runs), while
a count the user wrote in ``XLA_FLAGS`` is kept.
`cpgjax bench` reports robot-steps per second for 1 device and for all of them.

Second, ``--xla_cpu_experimental_ynn_fusion_type=`` (empty: no YNNPACK fusions).  Why: from 96 robots
per device, this jaxlib's XLA hands the simulator's ``reduce_sum`` reductions to the YNNPACK library,
which sums in another order, so a robot's score depended on the size of the batch it was in (from about 90
robots per device on; below that the programs are the same; docs/reproducibility.md has the figures).  A
sweep's results must equal the same run made alone (docs/sweeps.md), and a replay must score what the GA
recorded.  Without these fusions every batch size gives the same numbers and small batches are unchanged
bit for bit (``tests/episode/test_rollout.py``), and a large batch is not slower (docs/reproducibility.md).
The flag is specific to the pinned jaxlib (0.10.x).

Third, compiled programs are kept between runs: JAX's persistent compilation cache in
``$XDG_CACHE_HOME/cpgjax/xla/<cpu>`` (default ``~/.cache/...``; :func:`compile_cache_dir`).  Why: every
command compiles the simulator again (a sizeable share of a thesis-scale GA); from the second run of the same
program on, XLA's compile is a read from disk (docs/results/performance.md has both).  A
cached executable is the one XLA compiled for the same program, so results are the same bit for bit (the
test suite has always run on such a cache: tests/conftest.py).  JAX's key covers the program, jax/jaxlib
and the XLA flags; the folder adds the CPU's model and vector ISA, so that a home folder shared by
several machines never loads a program compiled for another CPU.  A size limit (2 GiB, least recently
used first out) also turns on JAX's file lock, for sweeps whose processes share it.
``CPGJAX_COMPILE_CACHE=0`` turns it off (``=1``: on, the default), ``CPGJAX_COMPILE_CACHE=DIR`` moves it; a
``JAX_COMPILATION_CACHE_DIR`` already set wins.  ``cpgjax bench`` turns it off for itself (its compile
column is a cold compile).

Fourth: nothing patches JAX.  An LLVM option that kept loops of 9 to 16 trips from being unrolled made the exact
pipeline at 16 robots per device faster with the same bits, but JAX's public ``compiler_options`` cannot set the
map-valued ``xla_backend_extra_options`` it needs, and set for the whole process (``XLA_FLAGS``) it changes the
springs pipeline's bits; it is left out (docs/results/performance-exact.md, *LLVM's full unrolling capped at 8
trips*, has the figures).

Fifth, XLA's thread pools sized to the host devices (``PJRT_NPROC``, :func:`thread_pools`).  Why: XLA's CPU client
gives each process two pools of one thread per core it may run on (at least one per host device): one runs the
devices' programs, the other takes the kernels a program's runtime hands off when several are ready at once.  A
step of 16 to 256 robots is hundreds of small kernels, and handing them to another thread costs more than it
buys: with one host device on the 2-core machine (``CPGJAX_DEVICES=1``, or two such processes side by side), a
pool of one thread ran both pipelines faster with the same bits (docs/results/performance.md, *XLA's thread
pools: one thread per host device*).  With one device per core (the default) the pools are the same size as
before.  A ``PJRT_NPROC`` or ``NPROC`` set by the user is kept; the one a cpgjax process set is set again by a
cpgjax process it starts (a Ray worker with other host devices).
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import platform
import re
import sys


def configure() -> None:
    late = "jax" in sys.modules         # imported before cpgjax: the flags still count unless JAX already ran
    n = os.environ.get("CPGJAX_DEVICES")
    count = int(n) if n else default_devices()
    flags, ours = device_flags(os.environ.get("XLA_FLAGS", ""), count, n is not None,
                               os.environ.pop(DEVICES_MARK, None))
    if ours is not None:
        os.environ[DEVICES_MARK] = ours
    if "xla_cpu_experimental_ynn_fusion_type" not in flags:
        flags += " --xla_cpu_experimental_ynn_fusion_type="
    os.environ["XLA_FLAGS"] = flags.strip()
    forced = re.findall(DEVICE_FLAG + r"=(\d+)", flags)         # the devices JAX will make
    thread_pools(os.environ, int(forced[-1]) if forced else 1)
    if "JAX_COMPILATION_CACHE_DIR" not in os.environ:
        d = compile_cache_dir()
        if d is not None:
            global _OURS
            _OURS = d
            os.environ["JAX_COMPILATION_CACHE_DIR"] = d
            if importlib.util.find_spec("filelock") is not None:    # JAX needs it for a size limit (pinned)
                os.environ.setdefault("JAX_COMPILATION_CACHE_MAX_SIZE", str(CACHE_MAX_BYTES))
            if late:                    # JAX read its environment when it was imported: its options instead
                import jax

                jax.config.update("jax_compilation_cache_dir", d)
                size = os.environ.get("JAX_COMPILATION_CACHE_MAX_SIZE")
                if size is not None:
                    jax.config.update("jax_compilation_cache_max_size", int(size))
    if late and forced:
        _late_warning(int(forced[-1]))


def _late_warning(devices: int) -> str | None:
    """After a late :func:`configure` (JAX imported first): a warning, and its text, when JAX's CPU client was made
    before XLA's flags were set (it has other than ``devices`` host devices); else None."""
    import warnings

    import jax

    have = len(jax.devices("cpu"))
    if have == devices:
        return None
    text = (f"JAX ran before cpgjax was imported, so cpgjax's XLA settings did not take effect ({have} host "
            f"device(s), not {devices}): a large batch's results may differ in their last bits from the command "
            "line's; restart and import cpgjax before running anything on JAX (docs/reproducibility.md)")
    warnings.warn(text, RuntimeWarning, stacklevel=3)
    return text


def default_devices(cores: int | None = None, usable: int | None = None) -> int:
    """One host device per core this process may run on (``usable``: its CPU affinity, which a Slurm job's or a
    container's cpuset narrows; ``cores``: the machine's), and at least two on a machine of two cores or more, where
    a robot's result does not depend on the number of devices (with one, a sweep's program compiles otherwise:
    docs/sweeps.md)."""
    cores = cores if cores is not None else (os.cpu_count() or 1)
    if usable is None:
        try:
            usable = len(os.sched_getaffinity(0))
        except (AttributeError, OSError):       # not on Linux
            usable = cores
    return max(min(2, cores), min(usable, cores))


DEVICE_FLAG = "--xla_force_host_platform_device_count"
DEVICES_MARK = "CPGJAX_XLA_DEVICES"     # the device count configure() put in XLA_FLAGS (not the user's)


def device_flags(flags: str, count: int, chosen: bool, inherited: str | None) -> tuple[str, str | None]:
    """``(XLA_FLAGS, ours)``: the flags with ``count`` host devices where they have no count (none for one device);
    where they have one, kept, unless it is the one a cpgjax parent process set (``inherited``, its
    :data:`DEVICES_MARK`) and this process chose its own (``chosen``: ``CPGJAX_DEVICES`` set).  ``ours``: the count
    in the flags that cpgjax set (for :data:`DEVICES_MARK`), None where the flags have none or the user's."""
    tokens = flags.split()
    parents = inherited is not None and f"{DEVICE_FLAG}={inherited}" in tokens
    if parents and chosen:
        tokens = [t for t in tokens if not t.startswith(DEVICE_FLAG)]
    elif any(t.startswith(DEVICE_FLAG) for t in tokens):
        return " ".join(tokens), inherited if parents else None
    if count > 1:
        tokens.append(f"{DEVICE_FLAG}={count}")
        return " ".join(tokens), str(count)
    return " ".join(tokens), None


POOL_MARK = "CPGJAX_PJRT_NPROC"     # the PJRT_NPROC that thread_pools() set (not the user's)


def thread_pools(environ, devices: int) -> None:
    """Size XLA's CPU thread pools to ``devices`` threads (``PJRT_NPROC``, read by XLA when JAX makes its CPU
    client; XLA keeps at least one thread per host device), unless ``environ`` has a ``PJRT_NPROC`` or ``NPROC``
    of the user's.  A ``PJRT_NPROC`` equal to :data:`POOL_MARK`'s was set by a cpgjax process this one was started
    from (its environment inherited), and is set again for this process's devices."""
    ours = environ.get(POOL_MARK)
    user = environ.get("PJRT_NPROC")
    if (user is not None and user != ours) or (user is None and "NPROC" in environ):
        return
    environ["PJRT_NPROC"] = environ[POOL_MARK] = str(devices)


def child_environ(environ=None) -> dict[str, str]:
    """A copy of the environment (``environ``: default this process's) for a child process that makes its own host
    devices and thread pools (``CPGJAX_DEVICES``, then :func:`configure`): without the device count this process put
    in ``XLA_FLAGS`` and without the pools' size it set."""
    env = dict(os.environ if environ is None else environ)
    if env.get("PJRT_NPROC") is not None and env.get("PJRT_NPROC") == env.get(POOL_MARK):
        del env["PJRT_NPROC"]
    env.pop(POOL_MARK, None)
    env.pop(DEVICES_MARK, None)
    env["XLA_FLAGS"] = " ".join(f for f in env.get("XLA_FLAGS", "").split() if not f.startswith(DEVICE_FLAG))
    return env


CACHE_MAX_BYTES = 2 * 2**30
_OURS: str | None = None       # the cache folder configure() chose (not one set in the environment before it)


def cold_compiles() -> None:
    """Compile without the persistent cache from here on, in this process and the ones it starts (``cpgjax
    bench``: its compile column is XLA's compile, not a read from disk).  Only the cache :func:`configure`
    turned on: a ``JAX_COMPILATION_CACHE_DIR`` set beforehand (by the user, or the test suite's own cache) is
    kept.  JAX decides at a process's first compile whether it uses the cache, so call it before that."""
    global _OURS
    if _OURS is None or os.environ.get("JAX_COMPILATION_CACHE_DIR") != _OURS:
        return
    import jax

    jax.config.update("jax_enable_compilation_cache", False)
    os.environ["CPGJAX_COMPILE_CACHE"] = "0"
    del os.environ["JAX_COMPILATION_CACHE_DIR"]
    _OURS = None


# --- Third: the persistent compilation cache's folder, and the CPU that names it ------------------------------------

def compile_cache_dir(environ=None) -> str | None:
    """The persistent compilation cache's folder for this CPU, made if missing; None when turned off
    (``CPGJAX_COMPILE_CACHE=0``) or when it cannot be written (a read-only home: the run goes on uncached).
    ``CPGJAX_COMPILE_CACHE=1`` is the default folder, not one named "1"."""
    env = os.environ if environ is None else environ
    choice = env.get("CPGJAX_COMPILE_CACHE", "")
    if choice == "0":
        return None
    if choice == "1":
        choice = ""
    base = choice or os.path.join(env.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache"),
                                  "cpgjax", "xla")
    cpu = cpu_model()
    tag = isa(env.get("XLA_FLAGS", "")) + "-" + hashlib.sha256(cpu.encode()).hexdigest()[:12]
    d = os.path.join(base, tag)
    try:
        os.makedirs(d, exist_ok=True)
    except OSError:
        return None
    return d if os.access(d, os.W_OK) else None


# The CPU, read without importing JAX (configure() runs before it): both decide a run's numbers bit for bit
# (docs/reproducibility.md); cpgjax.io.results records them in every run file, compile_cache_dir keys by them.

def cpu_model() -> str:
    """The CPU's model name (``/proc/cpuinfo``; elsewhere what :mod:`platform` knows)."""
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine() or "unknown"


# x86-64 vector instruction sets XLA's CPU backend chooses between, narrowest first (--xla_cpu_max_isa)
ISAS = ("SSE4_2", "AVX", "AVX2", "AVX512")
_CPU_FLAG = {"SSE4_2": "sse4_2", "AVX": "avx", "AVX2": "avx2", "AVX512": "avx512f"}


def isa(xla_flags: str | None = None) -> str:
    """The widest vector instruction set XLA may use here: the CPU's (``/proc/cpuinfo`` flags), capped by
    ``--xla_cpu_max_isa=...`` in ``XLA_FLAGS`` (``xla_flags``; default the environment's).  Another
    architecture than x86-64: its name (``aarch64``)."""
    flags = os.environ.get("XLA_FLAGS", "") if xla_flags is None else xla_flags
    cpu: set[str] = set()
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("flags"):
                    cpu = set(line.split(":", 1)[1].split())
                    break
    except OSError:
        pass
    have = [i for i in ISAS if _CPU_FLAG[i] in cpu]
    if not have:
        return platform.machine() or "unknown"
    best = have[-1]
    for tok in flags.split():
        if tok.startswith("--xla_cpu_max_isa="):
            cap = tok.split("=", 1)[1].upper().replace("AVX512F", "AVX512").replace("AVX512_", "AVX512")
            if cap in ISAS and ISAS.index(cap) < ISAS.index(best):
                best = cap
    return best
