"""Where an exact-joint step's work goes: the step with and without its contact solve, and each stage's flops.

    CPGJAX_DEVICES=1 CPGJAX_COMPILE_CACHE=0 taskset -c 1 python docs/experiments/stage_times.py [BATCH] [STEPS]

Times a `jax.lax.scan` of STEPS steps (default 500) of BATCH quadrupeds (default 16: the GA's robots per device)
under random servo targets, from the standing start (its feet on the ground), as the process's CPU time, best of
5 calls: the quadruped as it is, then the same model without contact vertices (its step runs `factor_m` and
`solve_m` once instead of `sim.exact.contact`; the robots fall freely), two rounds alternating.  Then XLA's
cost analysis of each stage of `sim.exact.step` compiled alone (flops per robot-step; a loop's body counted once,
so the contact solve's one pass).
"""

import sys
import time

import jax
import jax.numpy as jnp
import numpy as np

from cpgjax.io.wl import load_model
from cpgjax.sim import initial_state, step
from cpgjax.sim.contact import contact_frame
from cpgjax.sim.exact import contact as C
from cpgjax.sim.exact import smooth as S
from cpgjax.sim.exact.levels import Dofs, dofs_add, to_levels
from cpgjax.sim.exact.step import integrate


def per_step(model, ctrl, batch, steps):
    s = initial_state(model, batch)
    run = jax.jit(lambda s: jax.lax.scan(lambda s, _: (step(model, s, ctrl), None), s, None, length=steps)[0])
    f = run.lower(s).compile()
    s = jax.block_until_ready(f(s))
    best = np.inf
    for _ in range(5):
        t0 = time.process_time()
        jax.block_until_ready(f(s))
        best = min(best, time.process_time() - t0)
    return 1e6 * best / steps


def flops(fn, *args, batch):
    ca = jax.jit(fn).lower(*args).compile().cost_analysis()
    ca = ca[0] if isinstance(ca, list) else ca
    return ca.get("flops", 0.0) / batch


if __name__ == "__main__":
    batch = int(sys.argv[1]) if len(sys.argv) > 1 else 16
    steps = int(sys.argv[2]) if len(sys.argv) > 2 else 500
    model = load_model("models/quadruped.wl", pipeline="exact")
    free = model.replace(ct_pt=np.zeros(0, np.int32))
    tgt = jnp.asarray(np.random.default_rng(0).uniform(-0.3, 0.3, (model.n_ctrl, batch)), jnp.float32)
    ctrl = (tgt, jnp.zeros_like(tgt))
    print(f"quadruped, exact joints, {batch} robots, {len(jax.devices())} host device(s); us per step (CPU time)")
    for r in range(2):
        print(f"  round {r + 1}: the step {per_step(model, ctrl, batch, steps):.1f}, without contact vertices "
              f"{per_step(free, ctrl, batch, steps):.1f}", flush=True)

    s = initial_state(model, batch)
    com = S.com_pos(model, s)
    inert = S.inertia(model, com)
    qM = S.crb(model, com, inert)
    rate = to_levels(model, s.exact.rate)
    qfrc = S.project(model, com, *S.bias_wrenches(model, com, inert, rate))
    pts = C.contact_points(model, com)
    nc = len(model.ct_pt)

    def damped(com, pts, qM, beta):
        _, fr = contact_frame(model, pts.world, None)
        return C._damped(model, qM, C.contact_jacobian(model, com, pts, fr), beta, beta)

    rows = [
        ("the whole step", lambda s, c: step(model, s, c), s, ctrl),
        ("com_pos", lambda s: S.com_pos(model, s), s),
        ("inertia", lambda com: S.inertia(model, com), com),
        ("crb", lambda com, i: S.crb(model, com, i), com, inert),
        ("bias_wrenches + project", lambda com, i, r: S.project(model, com, *S.bias_wrenches(model, com, i, r)),
         com, inert, rate),
        ("contact (one pass)", lambda s, com, qM, b: C.contact(model, s, com, qM, b), s, com, qM, qfrc),
        ("  of it: contact_points", lambda com: C.contact_points(model, com), com),
        ("  of it: contact_jacobian + _damped", damped, com, pts, qM, jnp.ones((nc, batch))),
        ("  of it: factor_m", lambda q: S.factor_m(model, q), qM),
        ("  of it: solve_m", lambda f, b: S.solve_m(model, f, b), S.factor_m(model, qM), qfrc),
        ("  of it: com_vel", lambda com, u: S.com_vel(model, com, u), com, dofs_add(qfrc, Dofs(None, rate))),
        ("integrate (and kinematics)", lambda s, q: integrate(model, s, q), s, qfrc),
    ]
    print("flops per robot-step (XLA's cost analysis of the stage compiled alone)")
    for name, fn, *args in rows:
        print(f"  {name:38s}{flops(fn, *args, batch=batch):8,.0f}", flush=True)
