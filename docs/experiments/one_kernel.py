"""The exact step compiled as one kernel: its speed and its rounding at each batch width, against the fused kernels.

    CPGJAX_DEVICES=1 CPGJAX_COMPILE_CACHE=0 python docs/experiments/one_kernel.py [WIDTHS] [STEPS]
    CPGJAX_COMPILE_CACHE=0 python docs/experiments/one_kernel.py rollout [BATCH] [SECONDS]

XLA's CPU compiler emits a ``call`` whose frontend attribute ``xla_cpu_small_call`` is "true" as one function, in
one kernel, instead of one kernel per fusion, copy and loop (the form it gives small while loops itself).  The
first form times a `jax.lax.scan` of STEPS steps (default 200) of the quadruped on exact joints at each width
(default 16,32,64,128,256 robots; random servo targets, the same for a robot at every width), as CPU and wall
seconds of the best of 5 calls, and prints a hash of the first 16 robots' final state: equal hashes, equal
bits.  The second times `episode.batch.evaluate` of BATCH random controllers (default 20, SECONDS 2 s episodes)
both ways, in alternation, four rounds, wall and CPU time.  Nothing here is used by cpgjax: the step is wrapped here.
"""

import hashlib
import sys
import time

# isort: off
import cpgjax  # noqa: F401  (cpgjax first: it sets the host devices before jax is imported)
# isort: on
import jax
import jax.numpy as jnp
import numpy as np
from jax.experimental.xla_metadata import set_xla_metadata

from cpgjax.episode.batch import evaluate
from cpgjax.experiments.bench import _controllers
from cpgjax.io.wl import load_model
from cpgjax.sim import initial_state, step

rollout_module = sys.modules["cpgjax.episode.rollout"]   # the module (cpgjax.episode.rollout is also a function)


def one_kernel(fn):
    jitted = jax.jit(fn)
    return lambda *a: set_xla_metadata(jitted(*a), xla_cpu_small_call="true", inlineable="false")


def as_one_kernel(model, s, c, v=None):
    return one_kernel(lambda s, c, v: step(model, s, c, v))(s, c, v)


def bare(model, width, steps, one):
    s = initial_state(model, width)
    tgt = jnp.asarray(np.random.default_rng(0).uniform(-0.3, 0.3, (model.n_ctrl, 1024))[:, :width], jnp.float32)
    ctrl = (tgt, jnp.zeros_like(tgt))
    f = as_one_kernel if one else step
    t0 = time.perf_counter()
    run = jax.jit(lambda s, c: jax.lax.scan(lambda s, _: (f(model, s, c), None), s, None, length=steps)[0])
    run = run.lower(s, ctrl).compile()
    compile_s = time.perf_counter() - t0
    out = jax.block_until_ready(run(s, ctrl))
    best, wall = np.inf, np.inf
    for _ in range(5):
        t0, w0 = time.process_time(), time.perf_counter()
        jax.block_until_ready(run(s, ctrl))
        best, wall = min(best, time.process_time() - t0), min(wall, time.perf_counter() - w0)
    bits = b"".join(np.ascontiguousarray(np.asarray(x)[..., :16]).tobytes() for x in jax.tree.leaves(out) if np.ndim(x))
    return 1e6 * best / steps, compile_s, hashlib.sha1(bits).hexdigest()[:10], 1e6 * wall / steps


if __name__ == "__main__":
    model = load_model("models/quadruped.wl", pipeline="exact")
    if sys.argv[1:2] == ["rollout"]:
        batch = int(sys.argv[2]) if len(sys.argv) > 2 else 20
        T = float(sys.argv[3]) if len(sys.argv) > 3 else 2.0
        c = jnp.asarray(_controllers(model, batch), jnp.float32)
        progs = {}
        for name, f in (("fused kernels", step), ("one kernel", as_one_kernel)):
            rollout_module.step = f
            t0 = time.perf_counter()
            progs[name] = jax.jit(lambda c: evaluate(model, c, time=T)).lower(c).compile()
            print(f"{name}: compile {time.perf_counter() - t0:.2f} s", flush=True)
            jax.block_until_ready(progs[name](c))
        rollout_module.step = step
        for r in range(4):
            cols = []
            for name, p in progs.items():
                w0, c0 = time.perf_counter(), time.process_time()
                jax.block_until_ready(p(c))
                w, cpu = time.perf_counter() - w0, time.process_time() - c0
                cols.append(f"{name} {batch * T / w:,.0f} robot-s per wall s, {batch * T / cpu:,.0f} per CPU s")
            print(f"batch {batch}, {len(jax.devices())} devices, round {r}: " + "; ".join(cols), flush=True)
    else:
        widths = [int(w) for w in sys.argv[1].split(",")] if len(sys.argv) > 1 else [16, 32, 64, 128, 256]
        steps = int(sys.argv[2]) if len(sys.argv) > 2 else 200
        for w in widths:
            for one in (False, True):
                us, comp, h, wall = bare(model, w, steps, one)
                print(f"{w} robots, {'one kernel   ' if one else 'fused kernels'}: {us:7.1f} us per step (CPU), "
                      f"{wall:7.1f} (wall), compile {comp:5.2f} s, bits {h}", flush=True)
