"""cpgjax/_xla.py: the persistent compilation cache kept between runs, one folder per CPU, and bench's cold compiles."""

from __future__ import annotations

import functools
import os
import subprocess
import sys

import pytest

from cpgjax import _xla

# One child process: cpgjax's set-up as a user's run gets it, then one jitted program. Prints the result's bytes
# and whether its executable came from the persistent cache (JAX's own monitoring event).
CHILD = r"""
import sys
import cpgjax
from cpgjax import _xla
if sys.argv[1] == "cold":
    _xla.cold_compiles()
import os
import jax, jax.numpy as jnp
hits = []
jax.monitoring.register_event_listener(lambda name, **kw: hits.append(name == "/jax/compilation_cache/cache_hits"))
x = jnp.linspace(0.1, 2.0, 64, dtype=jnp.float32).reshape(8, 8)
y = jax.jit(lambda a: jnp.tanh(a @ a.T) / (1.0 + jnp.exp(-a)))(x)
print(bytes(jax.device_get(y)).hex(), any(hits), os.environ.get("JAX_COMPILATION_CACHE_DIR", "-"))
"""


def test_the_cache_folder_is_per_cpu_and_can_be_moved_or_turned_off(tmp_path):
    env = {"XDG_CACHE_HOME": str(tmp_path), "XLA_FLAGS": ""}
    d = _xla.compile_cache_dir(env)
    assert os.path.dirname(d) == str(tmp_path / "cpgjax" / "xla") and os.path.isdir(d)
    assert os.path.basename(d).startswith(_xla.isa("") + "-")
    if _xla.isa("") in _xla.ISAS[1:]:          # a capped ISA is another folder
        capped = _xla.compile_cache_dir({**env, "XLA_FLAGS": "--xla_cpu_max_isa=SSE4_2"})
        assert os.path.basename(capped).startswith("SSE4_2-") and capped != d
    assert _xla.compile_cache_dir({**env, "CPGJAX_COMPILE_CACHE": "1"}) == d             # on: the default folder
    assert _xla.compile_cache_dir({**env, "CPGJAX_COMPILE_CACHE": str(tmp_path / "mine")}).startswith(
        str(tmp_path / "mine") + os.sep)
    assert _xla.compile_cache_dir({**env, "CPGJAX_COMPILE_CACHE": "0"}) is None
    (tmp_path / "a-file").write_text("")          # a folder that cannot be made: no cache, the run goes on
    assert _xla.compile_cache_dir({**env, "CPGJAX_COMPILE_CACHE": str(tmp_path / "a-file")}) is None


def test_a_second_run_loads_the_program_the_first_compiled_with_the_same_bits(tmp_path):
    env = {k: v for k, v in os.environ.items()
           if k not in ("JAX_COMPILATION_CACHE_DIR", "JAX_COMPILATION_CACHE_MAX_SIZE", "CPGJAX_COMPILE_CACHE")}
    env.update(XDG_CACHE_HOME=str(tmp_path), JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS="0")

    def run(mode):
        out = subprocess.run([sys.executable, "-c", CHILD, mode], env=env, capture_output=True, text=True,
                             check=True).stdout.split()
        return out[0], out[1] == "True", out[2]

    first, hit1, folder = run("warm")
    assert folder.startswith(str(tmp_path / "cpgjax" / "xla")) and not hit1
    entries = sorted(os.listdir(folder))
    assert entries, "the first run wrote no compiled program"
    second, hit2, _ = run("warm")
    assert hit2 and second == first                       # read from disk, bit for bit the program compiled
    cold, hit3, folder3 = run("cold")                     # cpgjax bench: XLA compiles again, the same bits
    assert not hit3 and cold == first and folder3 == "-"


# --- per-program compile options (cpgjax/_xla.py, fourth part) ---

@functools.cache
def test_the_package_reaches_into_no_jax_internals():
    """JAX only through its public API: no module of the package imports ``jax._src``."""
    from pathlib import Path

    root = Path(__file__).resolve().parents[1] / "cpgjax"
    assert not [str(f) for f in root.rglob("*.py") if "jax._src" in f.read_text()]


# --- XLA's thread pools sized to the host devices (cpgjax/_xla.py, fifth part) ---

def test_the_pools_are_sized_to_the_devices_unless_the_user_sized_them():
    env = {}
    _xla.thread_pools(env, 1)
    assert env == {"PJRT_NPROC": "1", _xla.POOL_MARK: "1"}
    _xla.thread_pools(env, 3)                          # a child cpgjax process inherits it: set again for its own
    assert env["PJRT_NPROC"] == "3"
    for user in ({"PJRT_NPROC": "4"}, {"PJRT_NPROC": "4", _xla.POOL_MARK: "2"}, {"NPROC": "4"}):
        env = dict(user)
        _xla.thread_pools(env, 1)
        assert env.get("PJRT_NPROC") == user.get("PJRT_NPROC")        # the user's kept (NPROC: XLA reads it)


def test_one_device_per_core_the_process_may_use_and_two_at_least():
    assert _xla.default_devices(cores=64, usable=4) == 4          # a job's cpuset on a larger node
    assert _xla.default_devices(cores=2, usable=2) == 2
    assert _xla.default_devices(cores=64, usable=1) == 2          # two at least: the numbers of two or more
    assert _xla.default_devices(cores=1, usable=1) == 1
    assert _xla.default_devices() >= 1


def test_the_device_count_is_the_users_or_this_processes_not_a_parents():
    flag = _xla.DEVICE_FLAG
    assert _xla.device_flags("--a", 2, False, None) == (f"--a {flag}=2", "2")
    assert _xla.device_flags("--a", 1, True, None) == ("--a", None)                    # one device: no flag
    parents = f"--a {flag}=2"                                                          # inherited from cpgjax
    assert _xla.device_flags(parents, 1, True, "2") == ("--a", None)                   # CPGJAX_DEVICES=1 wins
    assert _xla.device_flags(parents, 4, True, "2") == (f"--a {flag}=4", "4")
    assert _xla.device_flags(parents, 8, False, "2") == (parents, "2")                 # none chosen: the parent's
    users = f"--a {flag}=3"                                                            # written by the user
    assert _xla.device_flags(users, 1, True, None) == (users, None)
    assert _xla.device_flags(users, 1, True, "2") == (users, None)


def test_a_child_process_gets_neither_this_ones_devices_nor_its_pools():
    ours = {"XLA_FLAGS": "--xla_cpu_max_isa=AVX2 --xla_force_host_platform_device_count=2", "PJRT_NPROC": "2",
            _xla.POOL_MARK: "2", _xla.DEVICES_MARK: "2", "HOME": "/h"}
    assert _xla.child_environ(ours) == {"XLA_FLAGS": "--xla_cpu_max_isa=AVX2", "HOME": "/h"}
    users = {"PJRT_NPROC": "3", _xla.POOL_MARK: "2"}                   # the user's own size stays
    assert _xla.child_environ(users) == {"PJRT_NPROC": "3", "XLA_FLAGS": ""}
    child = {**_xla.child_environ(ours), "PJRT_NPROC": "2"}            # bench's "1 dev, 2 thr": a size of its own,
    _xla.thread_pools(child, 1)                                        # even the one this process had
    assert child["PJRT_NPROC"] == "2"


@pytest.mark.skipif(not os.path.isdir("/proc/self/task"), reason="counts threads by their names in /proc")
def test_one_host_device_runs_with_one_pool_thread():
    """A process started from this one (its environment inherited) with ``CPGJAX_DEVICES=1``: one host device, and
    XLA's intra-op pool (threads named ``tf_XLAEigen``) one thread, not one per core; with a ``PJRT_NPROC`` of the
    user's, that many."""
    child = ("import os, cpgjax, jax\n"
             "jax.numpy.ones(3).block_until_ready()\n"
             "names = [open(f'/proc/self/task/{t}/comm').read().strip() for t in os.listdir('/proc/self/task')]\n"
             "print(len(jax.devices()), names.count('tf_XLAEigen'))")
    base = {k: v for k, v in os.environ.items() if k != "NPROC"}      # this process's devices and pools, inherited

    def run(**env):
        out = subprocess.run([sys.executable, "-c", child], env={**base, "CPGJAX_DEVICES": "1", **env},
                             capture_output=True, text=True, check=True).stdout.split()
        return int(out[0]), int(out[1])

    assert run() == (1, 1)
    assert run(PJRT_NPROC="3") == (1, 3)


def test_jax_imported_first_still_gets_cpgjaxs_settings_and_jax_run_first_a_warning():
    """A notebook's ``import jax`` before ``import cpgjax``: XLA reads its flags when JAX first runs something, so
    cpgjax's device count and flags still take effect, without a warning.  JAX run before: the flags come too late,
    and cpgjax says so in one warning.  Two processes, side by side."""
    env = {**_xla.child_environ(), "CPGJAX_DEVICES": "2"}
    late = ("import os, jax\n{}import cpgjax\n"
            "print(len(jax.devices('cpu')), 'ynn_fusion_type=' in os.environ['XLA_FLAGS'])")
    procs = [subprocess.Popen([sys.executable, "-W", "default", "-c", late.format(ran)], env=env, text=True,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE)
             for ran in ("", "jax.numpy.ones(1).block_until_ready()\n")]
    (imported, err1), (ran, err2) = (p.communicate(timeout=120) for p in procs)
    assert [p.returncode for p in procs] == [0, 0], err1 + err2
    assert imported.split() == ["2", "True"] and "RuntimeWarning" not in err1, err1
    assert ran.split()[0] == "1"
    warning = [line for line in err2.splitlines() if "RuntimeWarning" in line]
    assert len(warning) == 1 and "JAX ran before cpgjax was imported" in warning[0] and "not 2" in warning[0], err2
