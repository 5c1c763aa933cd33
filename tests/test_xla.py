"""cpgjax/_xla.py: the persistent compilation cache kept between runs, one folder per CPU, and bench's cold compiles."""

from __future__ import annotations

import os
import subprocess
import sys

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
