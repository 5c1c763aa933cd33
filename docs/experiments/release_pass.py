"""What the contact solve's second pass costs (how often a batch takes it, the step with and without it), and its
dampers' ``J^T K J``.

    CPGJAX_DEVICES=1 CPGJAX_COMPILE_CACHE=0 taskset -c 1 python docs/experiments/release_pass.py [BATCH] [STEPS]

`sim.exact.contact` solves once, then again (`_release`, a `while_loop`) in the steps where some robot of the batch
would pull a vertex, for every robot of the batch.  BATCH quadrupeds (default 16: the GA's robots per device) hold
random servo targets (the first BATCH of 256 drawn with seed 0, so that every batch's first 16 robots are the same)
for STEPS steps (default 500) from the standing start, in one `jax.lax.scan`:

1. the share of steps in which some robot of the batch releases a vertex (the second pass runs), and the share of
   robot-steps in which that robot does (what the second pass is for);
2. the CPU time per step (best of 5 calls) of cpgjax's step; of the same physics with the first solve outside the
   loop and the second in a loop of zero or one trip; and of the step with one pass only (the release left out:
   other physics, so an upper bound on what a cheaper release could buy); and of that one pass without the contact
   dampers in the joint-space inertia (no ``J^T K J``: the dampers explicit, other physics again); two rounds
   alternating, and each one's compile; the first 16 robots' final state hashed, to compare bits across batch
   widths and XLA options; in the first round, the largest body speed of any robot in any step (a step that
   diverges shows there).
"""

import hashlib
import sys
import time

import jax
import jax.numpy as jnp
import numpy as np

import cpgjax  # noqa: F401  (first: the host devices)
from cpgjax.io.wl import load_model
from cpgjax.sim import initial_state, step
from cpgjax.sim.exact import contact as C

RELEASE = C._release
DAMPED = C._damped


def undamped(model, qM, jac, beta, gamma):
    """``qM`` without the contact dampers' ``J^T K J``: the dampers then act on the start-of-step velocities alone."""
    return qM


def one_pass(solve, push, lam, qfrc):
    """The first solve alone: a vertex that would pull keeps its (pulling) damper."""
    qacc, f = solve(push, lam)
    return push, lam, qacc, f


def split(solve, push, lam, qfrc):
    """cpgjax's physics with the first solve outside the loop, the second in a loop of zero or one trip."""
    qacc, f = solve(push, lam)

    def body(c):
        k, push, lam, _, f = c
        held = (f[0] > 0.0).astype(lam.dtype)
        push, lam = push * held, lam * held
        qacc, f = solve(push, lam)
        return k + 1, push, lam, qacc, f

    def again(c):
        k, push, _, _, f = c
        return (k == 0) & jnp.any((push > 0.0) & (f[0] <= 0.0))

    _, push, lam, qacc, f = jax.lax.while_loop(again, body, (jnp.int32(0), push, lam, qacc, f))
    return push, lam, qacc, f


def counted(seen):
    """cpgjax's release, reporting which robots would pull a vertex after the first solve."""
    def release(solve, push, lam, qfrc):
        qacc, f = solve(push, lam)
        jax.debug.callback(lambda p: seen.append(np.asarray(p)), jnp.any((push > 0.0) & (f[0] <= 0.0), axis=0))
        return RELEASE(solve, push, lam, qfrc)
    return release


def scan(model, ctrl, steps):
    return jax.jit(lambda s: jax.lax.scan(lambda s, _: (step(model, s, ctrl), None), s, None, length=steps)[0])


def per_step(model, ctrl, s, steps):
    t0 = time.perf_counter()
    f = scan(model, ctrl, steps).lower(s).compile()
    compile_s = time.perf_counter() - t0
    best = np.inf
    for _ in range(5):
        t0 = time.process_time()
        out = jax.block_until_ready(f(s))
        best = min(best, time.process_time() - t0)
    h = hashlib.sha1(b"".join(np.asarray(x)[..., :16].tobytes() for x in jax.tree.leaves(out) if np.ndim(x)))
    return 1e6 * best / steps, compile_s, h.hexdigest()[:10]


def top_speed(model, ctrl, s, steps):
    """The largest body speed [m/s] of any robot in any step: a step that diverges shows here."""
    def body(s, _):
        s = step(model, s, ctrl)
        return s, jnp.max(jnp.sqrt(jnp.sum(s.v * s.v, axis=0)))
    return float(jnp.max(jax.jit(lambda s: jax.lax.scan(body, s, None, length=steps)[1])(s)))


def setup(batch: int):
    """The quadruped on exact joints, its servo targets (the first ``batch`` of 256 random ones) and start."""
    model = load_model("models/quadruped.wl", pipeline="exact")
    tgt = np.random.default_rng(0).uniform(-0.3, 0.3, (model.n_ctrl, max(256, batch)))[:, :batch]
    tgt = jnp.asarray(tgt, jnp.float32)
    return model, (tgt, jnp.zeros_like(tgt)), initial_state(model, batch)


def main(batch: int, steps: int) -> None:
    model, ctrl, s = setup(batch)
    seen = []
    C._release = counted(seen)
    jax.block_until_ready(scan(model, ctrl, steps)(s))
    jax.effects_barrier()
    pulled = np.array(seen)
    print(f"quadruped, exact joints, {batch} robots, {steps} steps: the second pass ran in {pulled.any(1).mean():.1%} "
          f"of the steps; a robot released a vertex in {pulled.mean():.1%} of its steps", flush=True)
    print("us per step (CPU, best of 5), compile, first 16 robots' final state, top body speed")
    for r in range(2):
        for name, release, damped in (("cpgjax (second pass where needed)", RELEASE, DAMPED),
                                      ("first pass outside the loop", split, DAMPED),
                                      ("one pass only", one_pass, DAMPED),
                                      ("one pass, no J^T K J", one_pass, undamped)):
            C._release, C._damped = release, damped
            us, compile_s, h = per_step(model, ctrl, s, steps)
            top = f"  {top_speed(model, ctrl, s, steps):.2f} m/s" if r == 0 else ""
            print(f"  round {r + 1}, {name:34s} {us:7.1f} us  compile {compile_s:4.1f} s  {h}{top}", flush=True)
    C._release, C._damped = RELEASE, DAMPED


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 16, int(sys.argv[2]) if len(sys.argv) > 2 else 500)
