"""The contact solve with less arithmetic: each pass applies the contact Jacobian directly, against cpgjax's.

    CPGJAX_DEVICES=1 CPGJAX_COMPILE_CACHE=0 taskset -c 1 python docs/experiments/direct_jacobian.py [BATCH] [STEPS]

A pass of `sim.exact.contact` turns the vertices' forces into body wrenches and projects them on the DOFs
(`_wrenches`, `project`: ``J^T f`` through the tree), and after the solve computes every body's velocity
(`com_vel`) to get the vertices' (``J (u + dt qacc)``).  Here a pass reads the contact Jacobian that
`contact_jacobian` already built: ``J^T f`` as ``sum_e f_e J_e`` gathered per DOF, and the vertices' velocities as
``v_start + dt J qacc`` (the same quantities, other arithmetic and so other rounding).  BATCH quadrupeds (default
16) hold random servo targets for STEPS steps (default 500); CPU time per step, best of 5 calls, two rounds
alternating, and robot 0's final position from each (they agree to the rounding).
"""

import sys

import jax
import jax.numpy as jnp
import numpy as np

import cpgjax  # noqa: F401  (first: the host devices)
from cpgjax.sim.contact import bristle, contact_frame, friction, ground, trail_anchor
from cpgjax.sim.exact import contact as C
from cpgjax.sim.exact import step as ST
from cpgjax.sim.exact.levels import Dofs, dofs_add
from cpgjax.sim.exact.smooth import factor_m, solve_m
from cpgjax.sim.tricks import gather_sum, keep, mul, take

sys.path.insert(0, "docs/experiments")
import release_pass as R  # noqa: E402

CONTACT = C.contact


def ancestors(model):
    """Each vertex's ancestor item on every level (its root's on level 0; -1 where it has none)."""
    lv = model.exact.levels
    cb = C._bodies(model)
    level, item = lv.level_of[cb], lv.item_of[cb]
    return {up: np.array([(lv.anc[lvl][up][i] if up < lvl else i) if up <= lvl else -1
                          for lvl, i in zip(level, item, strict=True)], np.int64) for up in range(lv.depth + 1)}


def jt(model, jac, fe):
    """``J^T f`` for ``f`` along the Jacobian's directions (3 arrays [nc, B])."""
    lv = model.exact.levels
    zero = jnp.zeros_like(fe[0])
    root = []
    for i in range(6):
        t = None
        for e in range(3):
            x = mul(fe[e], jac.w[e][i])
            if x is not None:
                t = x if t is None else t + x
        root.append(gather_sum(t if t is not None else zero, jac.slots[0]))
    root = jnp.stack(root)
    if not lv.free.all():
        root = root * lv.free.astype(np.float32)[:, None]
    joint = (None,) + tuple(gather_sum(sum(fe[e] * jac.joint[lvl][e] for e in range(3)), jac.slots[lvl])
                            for lvl in range(1, lv.depth + 1))
    return Dofs(root, joint)


def jv(model, jac, anc, q):
    """``J q`` along the Jacobian's directions (3 arrays [nc, B])."""
    lv = model.exact.levels
    qr = take(q.root, anc[0])
    qj = {lvl: take(q.joint[lvl], np.maximum(anc[lvl], 0)) for lvl in range(1, lv.depth + 1)}
    out = []
    for e in range(3):
        t = None
        for i in range(6):
            x = mul(jac.w[e][i], qr[i])
            if x is not None:
                t = x if t is None else t + x
        for lvl in range(1, lv.depth + 1):
            t = t + jac.joint[lvl][e] * qj[lvl]
        out.append(t)
    return out


def contact(model, state, com, qM, qfrc, var=None):
    """`sim.exact.contact` with the passes above (the same law, modes and release)."""
    dt = model.dt
    pts = C.contact_points(model, com)
    depth, fr = contact_frame(model, pts.world, var)
    touch = depth > 0
    A, B = ground(model, var)
    kb, bp = bristle(model, var)
    mu_s, mu_d = friction(model, var)
    fa, z_1, z_2, v_start = C._at_start(model, state, pts, depth, fr, A)
    jac = C.contact_jacobian(model, com, pts, fr)
    arrays = keep(({(e, i): x for e, w in enumerate(jac.w) for i, x in enumerate(w) if hasattr(x, "shape")},
                   jac.joint))
    w = tuple(tuple(arrays[0].get((e, i), x) for i, x in enumerate(we)) for e, we in enumerate(jac.w))
    jac = C.ContactJacobian(w, jac.normal, arrays[1], jac.slots)
    anc = ancestors(model)
    order = [jac.normal] + [e for e in range(3) if e != jac.normal]     # the law's (n, t1, t2) as directions e
    inv = [order.index(e) for e in range(3)]

    def law(vel):
        v_n, v_1, v_2 = vel
        return fa - B * v_n, -kb * z_1 - bp * v_1, -kb * z_2 - bp * v_2

    def solve(push, lam):
        beta = dt * bp * lam
        gamma = dt * B * push - beta
        qLD = factor_m(model, C._damped(model, qM, jac, beta, gamma))
        f0 = (push * f_start[0], lam * f_start[1], lam * f_start[2])
        qacc = solve_m(model, qLD, dofs_add(qfrc, keep(jt(model, jac, [f0[k] for k in inv]))))
        dv = keep(jv(model, jac, anc, qacc))
        return qacc, law(tuple(v + dt * dv[e] for v, e in zip(v_start, order, strict=True)))

    f_start = law(v_start)
    push, lam = C._modes(model, f_start, touch, mu_s, mu_d)
    push, lam, qacc, f = C._release(solve, push, lam, qfrc)
    f_n = push * f[0]
    anchor = trail_anchor(model, fr, pts.world, state.anchor, (z_1, z_2), touch, lam >= 1.0, f_n, var)
    return qacc, anchor, f_n


def main(batch: int, steps: int) -> None:
    model, ctrl, s = R.setup(batch)
    print(f"quadruped, exact joints, {batch} robots, {steps} steps: us per step (CPU, best of 5), compile, "
          "robot 0's final position")
    for r in range(2):
        for name, fn in (("cpgjax", CONTACT), ("the Jacobian applied directly", contact)):
            ST.contact = fn
            us, compile_s, _ = R.per_step(model, ctrl, s, steps)
            x = jax.jit(lambda s: R.scan(model, ctrl, steps)(s).x[:, 0, 0])(s)
            print(f"  round {r + 1}, {name:30s} {us:7.1f} us  compile {compile_s:4.1f} s  "
                  f"{np.array2string(np.asarray(x), precision=6)}", flush=True)
    ST.contact = CONTACT


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 16, int(sys.argv[2]) if len(sys.argv) > 2 else 500)
