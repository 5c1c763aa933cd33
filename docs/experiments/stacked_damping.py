"""What fewer, larger array operations would buy in the contact solve: its dampers' ``J^T K J`` written stacked.

    CPGJAX_DEVICES=1 CPGJAX_COMPILE_CACHE=0 taskset -c 1 python docs/experiments/stacked_damping.py [BATCH] [STEPS]

`sim.exact.contact._damped` adds the ground's dampers to the joint-space inertia: for the roots' 6x6 blocks, 21
entries each a separate product and sum over the vertices of a robot, with the entries that are zero on flat
ground left out (`sim.tricks.mul`).  Here the same sums are written as a few operations on stacked arrays: the
vertices' Jacobian rows ``[3 directions, 6, vertices, robots]``, every 6x6 product at once (the zero entries
multiplied too), the upper triangle mirrored; the joints' entries as stacked sums over the three directions.  It
is the same arithmetic grouped otherwise, so it rounds otherwise: not used by cpgjax, only timed.

Prints, for BATCH quadrupeds (default 16) on one core: CPU us per step of a scan of STEPS steps (default 500)
with cpgjax's ``_damped`` and with the stacked one, two rounds alternating, best of 5 calls each; and how far the
two runs' final states are apart (the largest difference of any body position, in metres).
"""

import sys
import time

import jax
import jax.numpy as jnp
import numpy as np

from cpgjax.io.wl import load_model
from cpgjax.sim import initial_state, step
from cpgjax.sim.exact import contact as C
from cpgjax.sim.exact.types import JointSpaceInertia
from cpgjax.sim.tricks import gather_sum, stage, sum0

ORIGINAL = C._damped


@stage
def stacked(model, qM: JointSpaceInertia, jac, beta, gamma) -> JointSpaceInertia:
    """``qM + J^T (beta I + gamma n n^T) J``, as `sim.exact.contact._damped`, in stacked operations."""
    lv = model.exact.levels

    def full(x):
        if x is None:
            return jnp.zeros_like(beta)
        return jnp.full_like(beta, x) if isinstance(x, float) else x

    K = jnp.stack([beta + gamma if e == jac.normal else beta for e in range(3)])      # [3, nc, B]
    W = jnp.stack([jnp.stack([full(x) for x in jac.w[e]]) for e in range(3)])         # [3, 6, nc, B]
    KW = K[:, None] * W
    M = sum0(KW[:, :, None] * W[:, None, :])                                          # [6, 6, nc, B]
    upper = np.triu(np.ones((6, 6), bool))[:, :, None, None]
    c_root = gather_sum(jnp.where(upper, M, jnp.swapaxes(M, 0, 1)), jac.slots[0])
    if not lv.free.all():
        c_root = c_root * lv.free.astype(np.float32)[:, None]
    ancestor, diag, root_dof = [None], [None], [None]
    for lvl in range(1, lv.depth + 1):
        KJ = K * jnp.stack(jac.joint[lvl])                                            # [3, nc, B]
        diag.append(gather_sum(sum0(KJ * jnp.stack(jac.joint[lvl])), jac.slots[lvl]))
        ancestor.append((None,) + tuple(gather_sum(sum0(KJ * jnp.stack(jac.joint[up])), jac.slots[lvl])
                                        for up in range(1, lvl)))
        r = gather_sum(sum0(KJ[:, None] * W), jac.slots[lvl])                         # [6, n_l, B]
        free = lv.free[lv.anc[lvl][0]]
        root_dof.append(r if free.all() else r * free.astype(np.float32)[:, None])
    damping = JointSpaceInertia(tuple(ancestor), tuple(diag), tuple(root_dof), c_root)
    return jax.tree.map(jnp.add, qM, damping)


def run(model, ctrl, batch, steps, damped):
    C._damped = damped
    try:
        s = initial_state(model, batch)
        f = jax.jit(lambda s: jax.lax.scan(lambda s, _: (step(model, s, ctrl), None), s, None,
                                           length=steps)[0]).lower(s).compile()
    finally:
        C._damped = ORIGINAL
    out = jax.block_until_ready(f(s))
    best = np.inf
    for _ in range(5):
        t0 = time.process_time()
        jax.block_until_ready(f(s))
        best = min(best, time.process_time() - t0)
    return 1e6 * best / steps, np.asarray(out.x)


if __name__ == "__main__":
    batch = int(sys.argv[1]) if len(sys.argv) > 1 else 16
    steps = int(sys.argv[2]) if len(sys.argv) > 2 else 500
    model = load_model("models/quadruped.wl", pipeline="exact")
    tgt = jnp.asarray(np.random.default_rng(0).uniform(-0.3, 0.3, (model.n_ctrl, batch)), jnp.float32)
    ctrl = (tgt, jnp.zeros_like(tgt))
    print(f"quadruped, exact joints, {batch} robots, {steps} steps, {len(jax.devices())} host device(s); "
          "us per step (CPU time)")
    for r in range(2):
        a, xa = run(model, ctrl, batch, steps, ORIGINAL)
        b, xb = run(model, ctrl, batch, steps, stacked)
        print(f"  round {r + 1}: cpgjax's _damped {a:.1f}, stacked {b:.1f}; final positions differ by up to "
              f"{np.max(np.abs(xa - xb)):.1e} m", flush=True)
