"""The exact-joint step alone, on one core: robot-steps per CPU second, with and without `keep`.

    CPGJAX_DEVICES=1 taskset -c 0 python docs/experiments/step_rate.py [MODEL.wl] [BATCH] [STEPS] [on]

A `jax.lax.scan` over STEPS steps of BATCH robots (default the quadruped, 256, 200) holding random servo
targets, compiled ahead of time; the best of 5 calls, timed as the process's CPU time (which, unlike wall
time, holds while other jobs share the machine).  Prints one line with the stages materialized (the model's
``exact.materialize``, `sim.tricks.keep`), one without; a fourth argument (``on``) skips the second.
"""

import dataclasses
import sys
import time

import jax
import jax.numpy as jnp
import numpy as np

from cpgjax.io.wl import load_model
from cpgjax.sim import initial_state, step


def rate(model, batch, steps):
    s = initial_state(model, batch)
    tgt = jnp.asarray(np.random.default_rng(0).uniform(-0.3, 0.3, (model.n_ctrl, batch)), jnp.float32)
    ctrl = (tgt, jnp.zeros_like(tgt))

    def run(s, c):
        return jax.lax.scan(lambda s, _: (step(model, s, c), None), s, None, length=steps)[0]

    f = jax.jit(run).lower(s, ctrl).compile()
    jax.block_until_ready(f(s, ctrl))
    best = np.inf
    for _ in range(5):
        t0 = time.process_time()
        jax.block_until_ready(f(s, ctrl))
        best = min(best, time.process_time() - t0)
    return best / steps, batch * steps / best


if __name__ == "__main__":
    wl = sys.argv[1] if len(sys.argv) > 1 else "models/quadruped.wl"
    batch = int(sys.argv[2]) if len(sys.argv) > 2 else 256
    steps = int(sys.argv[3]) if len(sys.argv) > 3 else 200
    model = load_model(wl, pipeline="exact")
    for on in (True, False) if len(sys.argv) < 5 else (True,):
        m = model.replace(exact=dataclasses.replace(model.exact, materialize=on))
        per_step, robot_steps = rate(m, batch, steps)
        print(f"{wl}, {batch} robots, keep {'on ' if on else 'off'}: {1e6 * per_step:8.1f} us per step, "
              f"{robot_steps:12,.0f} robot-steps per CPU second", flush=True)
