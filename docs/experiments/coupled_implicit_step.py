"""A coupled implicit step for the penalty simulator: measured, NOT part of cpgjax (docs/simulator.md).

Linearly implicit (backward) Euler on every body's velocity at once,

    (M + dt C + dt^2 K) u' = M u + dt F(x, u),

with the damping C and stiffness K of every spring-like element acting on a relative velocity J u:
the pivot springs (eq. 3.6), the servos (kd, kp), the joint limits, the ground (eq. 3.7) and the
sticking friction (the bristle).  The joints of a `.wl` model are a forest, so the matrix is
block-tree structured (a 6x6 block per body, one off-diagonal block per joint; a contact adds to its
own body's block only) and is factored exactly leaf to root (`solve`).  The unilateral and capped
forces (normal >= 0, friction within mu f_n, servo within tau_max) are found in two passes.

What it measured (2-core AMD EPYC, 2026-11-24; numbers in docs/simulator.md, "A coupled implicit
step"): stable with pivot springs 10x stiffer (3e6 N/m) at 2 ms; the standing height exactly the
explicit step's; within 1 mm / 0.004 rad of the converged trajectory over 0.3 s at 0.5 ms; but
10x the explicit step's cost per step on XLA CPU (small dense 6x6 blocks), and at steps >= 0.25 ms
the trot loses 8-10 % of its speed (0.135 against the converged 0.147), far more with a stiff bristle;
more stick/slip passes do not recover it (backward Euler on eq. 3.7's fast foot damper is much of
it).  Not adopted; kept so that the measurement can be rerun:

    .venv/bin/python docs/experiments/coupled_implicit_step.py models/quadruped-stiff.wl 2e-3

which runs the hand-written trot for 10 s with this step in place of `cpgjax.sim.step`.
"""


from __future__ import annotations

from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np

from cpgjax.sim.contact import contact_body_ranges, contact_frame
from cpgjax.sim.joints import joint_angles
from cpgjax.sim.rotation import cross, dot, matvec, quat_integrate, quat_to_mat


@dataclass(frozen=True)
class Plan:
    """The static structure of a model's forest, in the solve's (breadth-first) body order."""

    order: np.ndarray          # [nb] body index at each solve position
    position: np.ndarray       # [nb] solve position of each body
    parent: np.ndarray         # [nb] parent body of each body (-1: a root)
    joint: np.ndarray          # [nb] the joint between a body and its parent (-1: a root)
    levels: tuple              # (start, stop) solve positions of each depth, roots first
    runs: tuple                # per level > 0: for each parent in the level above, (first, stop) children
    free: np.ndarray           # [nb] in solve order: not a fixed body


def plan(model) -> Plan:
    nb = model.nb
    parent = np.full(nb, -1)
    joint = np.full(nb, -1)
    for j in range(model.nj):
        parent[model.j_b[j]] = model.j_a[j]
        joint[model.j_b[j]] = j
    # breadth first: roots in body order, then each level's children grouped by parent, parents in order
    levels_b = [[i for i in range(nb) if parent[i] < 0]]
    while True:
        nxt = [c for p in levels_b[-1] for c in range(nb) if parent[c] == p]
        if not nxt:
            break
        levels_b.append(nxt)
    order = np.array([i for lev in levels_b for i in lev])
    position = np.empty(nb, int)
    position[order] = np.arange(nb)
    levels, runs, start = [], [], 0
    for k, lev in enumerate(levels_b):
        levels.append((start, start + len(lev)))
        if k > 0:
            first = levels[k][0]
            run, c = [], first
            for p in levels_b[k - 1]:
                n = sum(1 for i in lev if parent[i] == p)
                run.append((c - first, c - first + n))
                c += n
            runs.append(tuple(run))
        start += len(lev)
    return Plan(order=order, position=position, parent=parent, joint=joint, levels=tuple(levels),
                runs=tuple(runs), free=~np.asarray(model.fixed)[order])


# ----------------------------------------------------------------------------- dense 6x6 algebra on stacks

def _barrier(x):
    """Materialise ``x`` between stages.  Measured: after the substitution it took a solve from 3.4 ms to
    0.9 ms (batch 256); barriers inside the Cholesky changed nothing (XLA still recomputes its updates)."""
    return jax.lax.optimization_barrier(x)


def _chol(A):
    """Right-looking Cholesky of a stack of SPD matrices A [k, k, ...]: (columns below the diagonal, 1/diag)."""
    cols, inv = [], []
    S = A
    for _ in range(A.shape[0]):
        d = jnp.sqrt(jnp.maximum(S[0, 0], 1e-30))
        iv = 1.0 / d
        col = S[1:, 0] * iv
        cols.append(col)
        inv.append(iv)
        S = S[1:, 1:] - col[:, None] * col[None, :]
    return cols, inv


def _chol_solve(cols, inv, Bm):
    """Solve (L L^T) X = Bm for a stack of right-hand sides Bm [k, c, ...]."""
    k = len(inv)
    y, R = [], Bm
    for j in range(k):                       # forward: L y = b, column by column
        yj = R[0] * inv[j]
        y.append(yj)
        R = R[1:] - cols[j][:, None] * yj[None]
    x = [None] * k
    for j in reversed(range(k)):             # backward: L^T x = y
        s = y[j]
        for i, c in enumerate(range(j + 1, k)):
            s = s - cols[j][i] * x[c]
        x[j] = s * inv[j]
    return jnp.stack(x)


def _tmatmul(a, b):
    """a^T b for stacks [k, i, ...] and [k, j, ...] -> [i, j, ...] (unrolled over k)."""
    out = a[0][:, None] * b[0][None]
    for k in range(1, a.shape[0]):
        out = out + a[k][:, None] * b[k][None]
    return out


def _tmatvec(a, x):
    """a^T x for a stack [k, i, ...] and x [k, ...] -> [i, ...]."""
    out = a[0] * x[0]
    for k in range(1, a.shape[0]):
        out = out + a[k] * x[k]
    return out


def _matvec(a, x):
    """a x for a stack [i, k, ...] and x [k, ...] -> [i, ...]."""
    out = a[:, 0] * x[0]
    for k in range(1, a.shape[1]):
        out = out + a[:, k] * x[k]
    return out


def _segment_sum(x, run, axis):
    """Sum contiguous runs of ``x`` along ``axis`` (one output per run; 0 for an empty run)."""
    if all(b - a == 1 for a, b in run) and run[0][0] == 0 and run[-1][1] == x.shape[axis]:
        return x
    parts = []
    for a, b in run:
        sl = [slice(None)] * x.ndim
        if b > a:
            sl[axis] = slice(a, a + 1)
            s = x[tuple(sl)]
            for c in range(a + 1, b):
                sl[axis] = slice(c, c + 1)
                s = s + x[tuple(sl)]
        else:
            sl[axis] = slice(0, 1)
            s = jnp.zeros_like(x[tuple(sl)])
        parts.append(s)
    return jnp.concatenate(parts, axis)


def _expand(x, run, axis):
    """Repeat each entry of ``x`` along ``axis`` over its run of children."""
    counts = [b - a for a, b in run]
    if all(c == 1 for c in counts):
        return x
    parts = []
    for k, c in enumerate(counts):
        sl = [slice(None)] * x.ndim
        sl[axis] = slice(k, k + 1)
        for _ in range(c):
            parts.append(x[tuple(sl)])
    return jnp.concatenate(parts, axis)


def solve(p: Plan, D, O, r):
    """Solve the block-tree system; every argument in solve order.

    D [6, 6, nb, B]: diagonal blocks; O [6, 6, nb, B]: each body's block with its parent (row: the body;
    zero for roots); r [6, nb, B].  Returns u [6, nb, B] in solve order.
    """
    levels = p.levels
    Dl = [D[:, :, a:b] for a, b in levels]
    rl = [r[:, a:b] for a, b in levels]
    fac = [None] * len(levels)
    for k in range(len(levels) - 1, 0, -1):
        a, b = levels[k]
        Ok = O[:, :, a:b]
        cols, inv = _barrier(_chol(Dl[k]))
        sol = _barrier(_chol_solve(cols, inv, jnp.concatenate([Ok, rl[k][:, None]], 1)))
        X, y = sol[:, :6], sol[:, 6]
        fac[k] = (X, y)
        S = _tmatmul(Ok, X)                              # O^T D^-1 O  [6, 6, n, B]
        s = _tmatvec(Ok, y)                              # O^T D^-1 r  [6, n, B]
        Dl[k - 1], rl[k - 1] = _barrier((Dl[k - 1] - _segment_sum(S, p.runs[k - 1], 2),
                                         rl[k - 1] - _segment_sum(s, p.runs[k - 1], 1)))
    cols, inv = _barrier(_chol(Dl[0]))
    u = [_chol_solve(cols, inv, rl[0][:, None])[:, 0]]
    for k in range(1, len(levels)):
        X, y = fac[k]
        up = _expand(u[-1], p.runs[k - 1], 1)
        u.append(y - _matvec(X, up))
    return jnp.concatenate(u, 1)


def gtg(r1, r2):
    """G(r1)^T G(r2) [6, 6, ...] with G(r) = [I, -[r]x] (a point's velocity v + w x r = G u)."""
    one = jnp.ones_like(r1[0])
    zero = jnp.zeros_like(r1[0])
    x1, y1, z1 = r1[0], r1[1], r1[2]
    x2, y2, z2 = r2[0], r2[1], r2[2]
    d = x1 * x2 + y1 * y2 + z1 * z2
    rows = [
        [one, zero, zero, zero, z2, -y2],
        [zero, one, zero, -z2, zero, x2],
        [zero, zero, one, y2, -x2, zero],
        [zero, -z1, y1, d - x2 * x1, -x2 * y1, -x2 * z1],
        [z1, zero, -x1, -y2 * x1, d - y2 * y1, -y2 * z1],
        [-y1, x1, zero, -z2 * x1, -z2 * y1, d - z2 * z1],
    ]
    return jnp.stack([jnp.stack(r) for r in rows])


def _rot(e, c):
    """c e e^T in the rotational corner of a [6, 6, ...] block."""
    z = jnp.zeros_like(e[0] * c)
    ee = [[e[i] * e[j] * c for j in range(3)] for i in range(3)]
    rows = [[z] * 6 for _ in range(3)] + [[z, z, z] + ee[i] for i in range(3)]
    return jnp.stack([jnp.stack(r) for r in rows])


def _pick(x, idx, axis):
    """x[..., idx, ...] for static indices, as concatenated slices (-1: zeros)."""
    parts = []
    for i in idx:
        sl = [slice(None)] * x.ndim
        sl[axis] = slice(max(i, 0), max(i, 0) + 1)
        v = x[tuple(sl)]
        parts.append(v if i >= 0 else jnp.zeros_like(v))
    return jnp.concatenate(parts, axis)


def _body_sums(x, groups, nb, axis):
    """Sum items of x along axis onto bodies: groups[b] = (lo, hi) contiguous items of body b (or None)."""
    parts = []
    for b in range(nb):
        g = groups.get(b)
        sl = [slice(None)] * x.ndim
        if g is None:
            sl[axis] = slice(0, 1)
            parts.append(jnp.zeros_like(x[tuple(sl)]))
        else:
            lo, hi = g
            sl[axis] = slice(lo, hi)
            parts.append(x[tuple(sl)].sum(axis, keepdims=True) if hi - lo > 1 else x[tuple(sl)])
    return jnp.concatenate(parts, axis)


def step_implicit(model, state, ctrl, var=None):
    from cpgjax.sim.springs.step import sum_contacts_onto_bodies, sum_onto_bodies
    from cpgjax.sim.state import point_kinematics

    dt = model.dt
    P = plan(model)
    nb, nj = model.nb, model.nj
    target, target_rate = ctrl
    B = state.x.shape[-1]
    dtype = state.x.dtype
    R = quat_to_mat(state.q)
    r, p, pv = point_kinematics(model, state, R)
    ms = None if var is None else var.mass
    m = jnp.broadcast_to(model.mass[:, None] * (1.0 if ms is None else ms), (nb, B)).astype(dtype)
    Ib = model.inertia[:, :, :, None] * (1.0 if ms is None else ms[None, None])
    RI = jnp.stack([jnp.stack([sum(R[i, k] * Ib[k, j] for k in range(3)) for j in range(3)]) for i in range(3)])
    Iw = jnp.stack([jnp.stack([sum(RI[i, k] * R[j, k] for k in range(3)) for j in range(3)]) for i in range(3)])
    Iww = matvec(Iw, state.w)
    # --- explicit forces: gravity, gyroscopic, the springs' alpha d, joint torques (limits, servo PI + kd q*')
    sa, sb = model.sp_a, model.sp_b
    ra, rb = r[:, sa], r[:, sb]
    d = p[:, sb] - p[:, sa]
    fs = model.alpha * d
    no_contact = jnp.zeros((3, len(model.ct_pt), B), dtype)
    f_pt = jnp.concatenate([fs, -fs, no_contact], 1)[:, model.springs.pt_src]
    angle, _, axis = joint_angles(model, R, state.w)
    lo, hi = model.j_lo[:, None], model.j_hi[:, None]
    over = jnp.maximum(angle - hi, 0.0)
    under = jnp.minimum(angle - lo, 0.0)
    lim_c = jnp.where((over > 0) | (under < 0), model.limit_c + dt * model.limit_k, 0.0)
    tau_lim = -model.limit_k * (over + under)
    cj = model.ctrl_joint
    kp, ki, kd, tmax = (g[cj][:, None] for g in (model.j_kp, model.j_ki, model.j_kd, model.j_taumax))
    if var is not None:
        kp, ki, kd = kp * var.gain, ki * var.gain, kd * var.gain
    err = target - angle[cj]
    tau_s0 = kp * err + ki * state.e_int + kd * target_rate
    c_srv = kd + dt * kp + jnp.zeros_like(tau_s0)
    force = sum_onto_bodies(model, f_pt, None)
    torque0 = sum_onto_bodies(model, cross(r, f_pt), tau_lim * axis)
    force = force.at[2].add(-model.gravity * m)
    torque0 = torque0 - cross(state.w, Iww)
    rhs_base = jnp.concatenate([m[None] * state.v + dt * force, Iww + dt * torque0], 0)    # [6, nb, B]
    # --- base matrix: mass, pivot springs, limits
    cs = dt * (model.beta + dt * model.alpha)
    Jaa = cs * (gtg(ra, ra)[:, :, 0::2] + gtg(ra, ra)[:, :, 1::2])    # per joint [6, 6, nj, B]
    Jbb = cs * (gtg(rb, rb)[:, :, 0::2] + gtg(rb, rb)[:, :, 1::2])
    Jba = -cs * (gtg(rb, ra)[:, :, 0::2] + gtg(rb, ra)[:, :, 1::2])
    z3 = jnp.zeros((3, 3, nb, B), dtype)
    eye = jnp.eye(3, dtype=dtype)[:, :, None, None] * m[None, None]
    Mass = jnp.concatenate([jnp.concatenate([eye, z3], 1), jnp.concatenate([z3, Iw], 1)], 0)

    order = P.order
    jn = [int(P.joint[i]) for i in order]                     # joint of each body (solve order), -1 root

    def joint_to_solve(Jaa, Jbb, Jba):
        """Per-joint blocks -> diag and off contributions in solve order."""
        Db = _pick(Jbb, jn, 2)                                  # child side: its own joint
        Ob = _pick(Jba, jn, 2)
        # parent side: sum of children's joints, per level
        parts = [None] * len(P.levels)
        for k in range(1, len(P.levels)):
            a, b = P.levels[k]
            S = _pick(Jaa, jn[a:b], 2)
            parts[k - 1] = _segment_sum(S, P.runs[k - 1], 2)
        a, b = P.levels[-1]
        parts[-1] = jnp.zeros((6, 6, b - a, B), dtype)
        Da = jnp.concatenate(parts, 2)
        return Db + Da, Ob

    D_sp, O_sp = joint_to_solve(Jaa, Jbb, Jba)
    D0 = _pick(Mass, list(order), 2) + D_sp
    O0 = O_sp
    if np.isfinite(model.j_lo).any() or np.isfinite(model.j_hi).any():
        E = dt * _rot(axis, lim_c)
        Dl, Ol = joint_to_solve(E, E, -E)
        D0, O0 = D0 + Dl, O0 + Ol
    rhs0 = _pick(rhs_base, list(order), 1)
    D0, O0, rhs0 = _barrier((D0, O0, rhs0))

    # --- contacts
    ct = model.ct_pt
    nc = len(ct)
    cb = model.pt_body[ct]
    groups = {b: (lo_, hi_) for b, lo_, hi_ in contact_body_ranges(model)}
    if nc:
        cp, rc = p[:, ct], r[:, ct]
        depth, fr = contact_frame(model, cp, var)
        touch = depth > 0
        if fr.n is None:
            zz, oo = jnp.zeros_like(depth), jnp.ones_like(depth)
            n, t1, t2 = jnp.stack([zz, zz, oo]), jnp.stack([oo, zz, zz]), jnp.stack([zz, oo, zz])
        else:
            n, t1, t2 = (jnp.broadcast_to(a, cp.shape) for a in (fr.n, fr.t1, fr.t2))
        A_, B_ = model.ground_A, model.ground_B
        kb = model.friction_k * (1.0 if var is None else var.bristle)
        c_n = B_ + dt * A_
        c_t = model.friction_b + dt * kb
        z = cp - state.anchor
        z1, z2 = dot(z, t1), dot(z, t2)
        mu_s, mu_d = model.mu_static, model.mu_dynamic
        if var is not None:
            mu_s, mu_d = mu_s * var.friction, mu_d * var.friction
        G = gtg(rc, rc)
        gn = jnp.concatenate([n, cross(rc, n)], 0)
        GN = gn[:, None] * gn[None, :]
        G, GN = _barrier((G, GN))

    def assemble_solve(c_servo, tau_servo, cn_c, ct_c, f_c):
        E = dt * _rot(axis[:, cj], c_servo)
        every = len(cj) == nj and np.all(cj == np.arange(nj))
        Es = E if every else jnp.zeros((6, 6, nj, B), dtype).at[:, :, cj].set(E)
        Ds, Os = joint_to_solve(Es, Es, -Es)
        D, O = D0 + Ds, O0 + Os
        tq = jnp.zeros((nj, B), dtype).at[cj].set(tau_servo)
        torque = sum_onto_bodies(model, None, tq * axis)
        rhs = rhs0 + _pick(jnp.concatenate([jnp.zeros_like(torque), dt * torque], 0), list(order), 1)
        if nc:
            blk = dt * (ct_c * G + (cn_c - ct_c) * GN)            # [6, 6, nc, B]
            D = D + _pick(_body_sums(blk, groups, nb, 2), list(order), 2)
            Fc, Tc = sum_contacts_onto_bodies(model, f_c, rc)
            rhs = rhs + _pick(dt * jnp.concatenate([Fc, Tc], 0), list(order), 1)
        free = P.free
        if not free.all():
            eye6 = jnp.broadcast_to(jnp.eye(6, dtype=dtype)[:, :, None, None], D.shape)
            fm = jnp.asarray(free)[None, None, :, None]
            D = jnp.where(fm, D, eye6)
            rhs = jnp.where(jnp.asarray(free)[None, :, None], rhs, 0.0)
            pf = np.array([P.parent[i] < 0 or P.free[P.position[P.parent[i]]] for i in order]) & free
            O = jnp.where(jnp.asarray(pf)[None, None, :, None], O, 0.0)
        D, O, rhs = _barrier((D, O, rhs))
        u = solve(P, D, O, rhs)
        return _pick(u, list(P.position), 1)                      # back to body order

    def contact_vel(u):
        return u[:3, cb] + cross(u[3:, cb], rc)

    def servo_rate(u):
        return dot(u[3:, model.j_b[cj]] - u[3:, model.j_a[cj]], axis[:, cj])

    if nc:
        tf = touch.astype(dtype)
        fc1 = n * (A_ * depth * tf) - (t1 * (kb * z1) + t2 * (kb * z2)) * tf
        u1 = assemble_solve(c_srv, tau_s0, c_n * tf, c_t * tf, fc1)
        u1 = _barrier(u1)
        tau1 = tau_s0 - c_srv * servo_rate(u1)
        sat = jnp.abs(tau1) > tmax
        c2 = jnp.where(sat, 0.0, c_srv)
        t2_ = jnp.where(sat, jnp.clip(tau1, -tmax, tmax), tau_s0)
        vc = contact_vel(u1)
        fn1 = A_ * depth - c_n * dot(vc, n)
        ft1 = -kb * z1 - c_t * dot(vc, t1)
        ft2 = -kb * z2 - c_t * dot(vc, t2)
        push = touch & (fn1 > 0)
        fn1p = jnp.where(push, fn1, 0.0)
        ftm = jnp.sqrt(ft1 * ft1 + ft2 * ft2 + 1e-20)
        slip = push & (ftm > mu_s * fn1p)
        stick = push & ~slip
        pf = push.astype(dtype)
        sf = stick.astype(dtype)
        scale = jnp.where(slip, mu_d * fn1p / ftm, 0.0)
        fc2 = n * (A_ * depth * pf) - (t1 * (kb * z1) + t2 * (kb * z2)) * sf + (t1 * (scale * ft1) + t2 * (scale * ft2))
        u = assemble_solve(c2, t2_, c_n * pf, c_t * sf, fc2)
        vc2 = contact_vel(u)
        fn2 = jnp.where(push, A_ * depth - c_n * dot(vc2, n), 0.0)
        zmag = jnp.sqrt(z1 * z1 + z2 * z2 + 1e-18)
        trail = jnp.minimum(1.0, mu_d * fn1p / kb / zmag)
        trailed = cp - (t1 * (trail * z1) + t2 * (trail * z2))
        anchor = jnp.where(touch, jnp.where(stick, state.anchor, trailed), cp)
        f_n = jnp.maximum(fn2, 0.0)
    else:
        u1 = assemble_solve(c_srv, tau_s0, None, None, None)
        tau1 = tau_s0 - c_srv * servo_rate(u1)
        sat = jnp.abs(tau1) > tmax
        u = assemble_solve(jnp.where(sat, 0.0, c_srv), jnp.where(sat, jnp.clip(tau1, -tmax, tmax), tau_s0),
                           None, None, None)
        anchor, f_n = state.anchor, state.f_n
    v, w = u[:3], u[3:]
    return state._replace(x=state.x + dt * v, v=v, w=w, q=quat_integrate(state.q, w, dt),
                          e_int=state.e_int + dt * err, anchor=anchor, f_n=f_n, n=state.n + 1)


def install():
    """Use this step in every rollout of this process (`cpgjax.episode.rollout` calls ``step``)."""
    import importlib

    importlib.import_module("cpgjax.episode.rollout").step = step_implicit


if __name__ == "__main__":
    import sys

    from cpgjax.episode.batch import simulate
    from cpgjax.io.ctl import read_ctl
    from cpgjax.io.wl.parser import load_model

    install()
    model = load_model(sys.argv[1] if len(sys.argv) > 1 else "models/quadruped-stiff.wl",
                       dt=float(sys.argv[2]) if len(sys.argv) > 2 else 2e-3)
    trot = read_ctl("models/quadruped-trot.ctl").genome.reshape(model.n_ctrl, -1)
    out = simulate(model, trot, time=10.0)
    print(f"dt {model.dt:g} s, pivot springs {model.alpha:g} N/m: trot fitness {float(out['fitness']):.4f}, "
          f"diverged {bool(out['diverged'])}, mean height {float(out['height']):.4f} m")
