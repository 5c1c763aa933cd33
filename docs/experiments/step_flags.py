"""An XLA option against the exact step at a small batch: its cost per step on one core and its results' bits.

The quadruped on exact joints, BATCH robots holding random servo targets for STEPS steps in one `jax.lax.scan`,
compiled ahead of time (compile time printed), then the best of 5 calls timed as the process's CPU time; the
final state's bits hashed.  Run it once per option, each in a fresh process (XLA reads its flags at start):

    CPGJAX_DEVICES=1 CPGJAX_COMPILE_CACHE=0 taskset -c 1 python docs/experiments/step_flags.py 16 500
    XLA_FLAGS=--xla_cpu_prefer_vector_width=256 CPGJAX_DEVICES=1 CPGJAX_COMPILE_CACHE=0 taskset -c 1 \\
        python docs/experiments/step_flags.py 16 500
"""

import hashlib
import os
import sys
import time

import jax
import jax.numpy as jnp
import numpy as np

import cpgjax  # noqa: F401  (first: the host devices)
from cpgjax.io.wl import load_model
from cpgjax.sim import initial_state, step


def main(batch: int, steps: int) -> None:
    m = load_model("models/quadruped.wl", pipeline="exact")
    s = initial_state(m, batch)
    tgt = jnp.asarray(np.random.default_rng(0).uniform(-0.3, 0.3, (m.n_ctrl, batch)), jnp.float32)
    ctrl = (tgt, jnp.zeros_like(tgt))
    f = jax.jit(lambda s: jax.lax.scan(lambda s, _: (step(m, s, ctrl), None), s, None, length=steps)[0])
    t0 = time.perf_counter()
    c = f.lower(s).compile()
    compile_s = time.perf_counter() - t0
    best = float("inf")
    for _ in range(5):
        t0 = time.process_time()
        out = jax.block_until_ready(c(s))
        best = min(best, time.process_time() - t0)
    h = hashlib.sha1(b"".join(np.asarray(x).tobytes() for x in jax.tree.leaves(out))).hexdigest()[:10]
    print(f"{os.environ.get('XLA_FLAGS') or '(none)'}: {batch} robots, compile {compile_s:.2f} s, "
          f"{best / steps * 1e6:.1f} us per step (CPU), final state {h}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 16, int(sys.argv[2]) if len(sys.argv) > 2 else 500)
