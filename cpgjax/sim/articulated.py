"""Exact joints: one step of the robot in generalized coordinates (Featherstone's algorithms).

The thesis's pipeline (`sim.step`) integrates every body free and holds the joints with stiff pivot springs
(eq. 3.6); its step is bound by those springs.  This pipeline keeps the same bodies, servo (PID with
saturation, its derivative implicit, Ch. 5), joint limits, eq. 3.7's ground with the project's implicit
damper and friction bristle (`sim.contact`: the terrain's frame, the law's constants, the bristle's anchor),
terrain and `Variation`s, but describes the robot by a floating base and one angle per revolute joint
(`sim.tree`), so that the joints hold exactly:

1. the joint-space inertia ``M`` by the composite-rigid-body algorithm, in world axes about each tree root's
   CM, and its ``M = L^T D L`` factorization, which keeps the tree's sparsity (no fill-in, as MuJoCo's
   ``mj_factorM``);
2. the bias forces (gravity, Coriolis, gyroscopic) by recursive Newton-Euler with zero joint accelerations;
3. ``(M + dt D + dt J^T K J) qdd = tau - C + J^T (a - K J u)``: the servos' torque (saturated) and the joint
   limits on the joint rates at the start of the step, their dampers ``D`` implicit (a saturated servo adds
   none, as in MuJoCo's implicit integrators), and the ground's: eq. 3.7's spring and the friction bristle's
   explicit (``a``), their dampers ``K`` on every touching vertex's velocity at the end of the step, so that one
   solve gives all the contact forces together, coupled through the whole robot (`_contact_step`);
4. semi-implicit Euler on the generalized velocities and positions, then forward kinematics for the bodies'
   poses and velocities (``State.x, q, v, w``: what the rest of cpgjax reads, as from the other pipeline).

Why levels: every algorithm here walks the tree, and the bodies at one depth (the four hips, the four knees)
are independent of each other.  Each depth is one set of ``[n_l, B]`` array operations (`sim.tree.Levels`), so
the program's size grows with the tree's depth, not with its number of bodies: XLA compiles it in seconds and
runs it as a few wide loops.  Sums over a body's children use static slots in a fixed order, so a robot's
result does not depend on the batch it is in.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from cpgjax.sim.contact import bristle, contact_frame, friction, ground, trail_anchor
from cpgjax.sim.joints import limit_torques
from cpgjax.sim.rotation import cross, dot, quat_integrate, quat_to_mat
from cpgjax.sim.servo import servo_gains, servo_pi, servo_torques
from cpgjax.sim.tree import _slots

# ---------------------------------------------------------------------------------------------------------
# static helpers on the item axis (the one before the batch axis)


MATERIALIZE = True  # read at trace time; `cpgjax bench --tricks --pipeline exact` flips it to measure what it buys


def keep(tree, token):
    """``tree``, computed once into memory (a compiler trick; ``token``: :func:`keep_token` of the step).

    Why: XLA's CPU fusion (jaxlib 0.10) puts an intermediate into every fusion that reads it and computes it
    there again, per element read: the root's 6x6 solve, for instance, was recomputed for each of the nine
    bodies' velocity components, and a concatenation of computed parts evaluated every part for each output
    element.  `jax.lax.optimization_barrier` does not stop it (XLA's CPU compiler drops the barriers before
    fusion); a loop does (its operands must be in memory), so the intermediates pass through a ``while_loop``
    that runs zero times: its condition is always false but opaque to the compiler (:func:`keep_token`).  (A
    ``cond`` with an always true predicate, the first form, did the same but copied every array in its taken
    branch, about 130 copy kernels per step of the quadruped: a zero-trip loop keeps its operands' buffers,
    1.1x the robot-steps per second at 16 robots.)  The loop's body must change its carry (``+ 1``): XLA
    would forward an unchanged one.  Measured on one core (CPU time, the quadruped): 4.7x as many robot-steps
    per second at 256 robots, 2.2x at 16 (docs/exact-joints.md); `cpgjax bench --tricks --pipeline exact`
    compares it with ``MATERIALIZE = False`` in one run.  The values are the same; only where they are
    computed changes (and with it, at some batch sizes, the rounding of a few robots: docs/exact-joints.md,
    *What is left*).  The bodies' world inertias are left out: materialized, the root's was rounded
    differently in batches of 16 and 32 robots.
    """
    if not MATERIALIZE or token is None:
        return tree
    return jax.lax.while_loop(lambda t: token, lambda t: jax.tree.map(lambda a: a + 1.0, t), tree)


def keep_token(x):
    """A predicate that is always false but that XLA cannot fold (it depends on the bits of a state value: even
    a step counter ``n < 0`` is folded by the loop analysis), for :func:`keep`: its loops' condition reads it as
    it is (computed once per step, not once per loop)."""
    bits = jax.lax.bitcast_convert_type(x.reshape(-1)[0], jnp.int32)
    return (bits | 1) == 0


def sum0(x):
    """``x.sum(0)`` as a chain of adds in a fixed order (XLA's CPU reduce over a 6-long leading axis was the
    slowest kernel of the step in a profile, about 200 us of 1,000)."""
    out = x[0]
    for i in range(1, x.shape[0]):
        out = out + x[i]
    return out


def take(x, idx):
    """``x[..., idx, :]`` for static indices, as a slice or a broadcast wherever it is one (a gather does not
    fuse with what follows in XLA's CPU code: the step ran 1.7x slower with gathers everywhere)."""
    idx = np.asarray(idx)
    n = len(idx)
    if n == x.shape[-2] and np.array_equal(idx, np.arange(n)):
        return x
    i0 = int(idx[0]) if n else 0
    if n and (idx == i0).all():                 # one item to many: a broadcast
        one = x[..., i0:i0 + 1, :]
        return one if n == 1 else jnp.broadcast_to(one, x.shape[:-2] + (n, x.shape[-1]))
    if n and np.array_equal(idx, np.arange(i0, i0 + n)):
        return x[..., i0:i0 + n, :]
    step = int(idx[1] - idx[0]) if n > 1 else 0
    if step > 1 and np.array_equal(idx, i0 + step * np.arange(n)):   # every step-th item: a strided slice
        return jax.lax.slice_in_dim(x, i0, i0 + step * (n - 1) + 1, stride=step, axis=x.ndim - 2)
    # runs of consecutive or repeated items, each a slice or a broadcast, concatenated (a gather made XLA
    # put the items in front of the components, with a transpose in every fusion reading it)
    runs, start = [], 0
    for i in range(1, n + 1):
        if i == n or not (idx[i] == idx[i - 1] + 1 and idx[start] != idx[start + 1 if start + 1 < n else start]
                          or idx[i] == idx[i - 1] and (i - start == 1 or idx[start] == idx[start + 1])):
            runs.append(take(x, idx[start:i]))
            start = i
    return jnp.concatenate(runs, axis=-2)


def gather_sum(x, slots):
    """``out[..., i, :] = sum_s x[..., slots[s, i], :]`` over the valid slots (static, -1 padded), in slot order."""
    out = None
    for row in slots:
        valid = row >= 0
        if not valid.any():
            continue
        t = take(x, np.maximum(row, 0))
        if not valid.all():
            t = t * valid.astype(np.float32)[:, None]
        out = t if out is None else out + t
    if out is None:
        return jnp.zeros(x.shape[:-2] + (slots.shape[1], x.shape[-1]), x.dtype)
    return out


def rot_const(R, r):
    """``R @ r`` for R [3, 3, n, B] and constant vectors r [3, n] (components zero for every item skipped)."""
    out = 0.0
    for j in range(3):
        if np.any(r[j]):
            out = out + R[:, j] * jnp.asarray(r[j], R.dtype)[:, None]
    return out if not isinstance(out, float) else jnp.zeros(R.shape[:1] + R.shape[2:], R.dtype)


def column(R, axis_index):
    """Column ``axis_index[i]`` of each item's R [3, 3, n, B]."""
    ai = np.asarray(axis_index)
    if (ai == ai[0]).all():
        return R[:, int(ai[0])]
    out = 0.0
    for j in range(3):
        if (ai == j).any():
            out = out + R[:, j] * jnp.asarray((ai == j).astype(np.float32), R.dtype)[:, None]
    return out


def world_inertia(R, inertia):
    """``R I R^T`` [3, 3, n, B] for constant body-frame inertias [3, 3, n]."""
    RI = [[rot_const_row(R, i, inertia[:, l]) for l in range(3)] for i in range(3)]
    return jnp.stack([jnp.stack([RI[i][0] * R[j, 0] + RI[i][1] * R[j, 1] + RI[i][2] * R[j, 2] for j in range(3)])
                      for i in range(3)])


def rot_const_row(R, i, col):
    """``(R @ c)[i]`` for constant vectors c [3, n]."""
    out = 0.0
    for k in range(3):
        if np.any(col[k]):
            out = out + R[i, k] * jnp.asarray(col[k], R.dtype)[:, None]
    return out if not isinstance(out, float) else jnp.zeros(R.shape[2:], R.dtype)


def _skew_T_times(h):
    """The 3x3 block ``[h]x`` as nested lists of [n, B] (rows)."""
    z = jnp.zeros_like(h[0])
    return [[z, -h[2], h[1]], [h[2], z, -h[0]], [-h[1], h[0], z]]


# ---------------------------------------------------------------------------------------------------------
# kinematics


class Kin:
    """Per level: rotations, positions from the tree root's CM, velocities, joint axes and pivots."""

    def __init__(self, model, x, q, v, w):
        lv = model.levels
        self.lv = lv
        self.pred = keep_token(x)
        self.R_all = quat_to_mat(q)                                  # [3, 3, nb, B]
        self.O = x[:, lv.bodies[0]]                                  # [3, n0, B] the roots' CMs
        root_item = np.array([lv.item_of[model.tree.root[b]] for b in range(model.nb)])
        self.d_all = x - take(self.O, root_item)                     # [3, nb, B]
        self.R, self.d, self.W, self.V, self.a, self.p = [], [], [], [], [], []
        for lvl, bs in enumerate(lv.bodies):
            self.R.append(take(self.R_all, bs))
            self.d.append(take(self.d_all, bs))
            self.W.append(take(w, bs))
            self.V.append(take(v, bs))
            if lvl == 0:
                self.a.append(None)
                self.p.append(None)
                continue
            Rp = take(self.R[lvl - 1], lv.parent[lvl])
            self.a.append(column(Rp, lv.axis_index[lvl]))
            self.p.append(take(self.d[lvl - 1], lv.parent[lvl]) + rot_const(Rp, lv.r_parent[lvl]))
        (self.R_all, self.d_all, self.O, self.R, self.d, self.W, self.V, self.a, self.p) = keep(
            (self.R_all, self.d_all, self.O, self.R, self.d, self.W, self.V, self.a, self.p), self.pred)


def _masses(model, var, lv):
    """Per level: masses [n, 1|B] and body-frame inertias [3, 3, n] (and their scale [n, B] or None)."""
    m, inertia, scale = [], [], []
    for bs in lv.bodies:
        mm = jnp.asarray(model.mass[bs], jnp.float32)[:, None]
        s = None if var is None else take(var.mass, bs)
        m.append(mm if s is None else mm * s)
        inertia.append(model.inertia[:, :, bs])
        scale.append(s)
    return m, inertia, scale


# ---------------------------------------------------------------------------------------------------------
# M = L^T D L, level by level (the deepest first): a DOF's row only updates its ancestors' entries


class Factor:
    """The factorization of the joint-space inertia, in the levels' layout.

    Joint DOFs: ``Dinv[l]`` [n_l, B]; ``La[l][a]`` [n_l, B] to the level-a ancestor (1 <= a < l); ``Lr[l]``
    [6, n_l, B] to the root's six.  Root DOFs (per root, a chain of six): ``Dr`` [6, n0, B], ``Lrr[k][i]`` (i < k).
    """

    def __init__(self, model, M, pred=None):
        lv = model.levels
        D = lv.depth
        Md, Ma, Mr = dict(M["d"]), {k: dict(v) for k, v in M["a"].items()}, dict(M["r"])
        S = M["root"]                           # [6, 6, n0, B]: the root's block, less its joints' rows
        self.Dinv, self.La, self.Lr = {}, {}, {}
        for lvl in range(D, 0, -1):
            dinv = 1.0 / Md[lvl]
            self.Dinv[lvl] = dinv
            self.La[lvl] = {a: Ma[lvl][a] * dinv for a in range(1, lvl)}
            self.Lr[lvl] = Mr[lvl] * dinv
            for a in range(1, lvl):             # the level-a ancestor's diagonal, its row to its own ancestors
                slots = lv.below[lvl][a]
                La = self.La[lvl][a]
                Md[a] = Md[a] - gather_sum(La * Ma[lvl][a], slots)
                for a2 in range(1, a):
                    Ma[a][a2] = Ma[a][a2] - gather_sum(La * Ma[lvl][a2], slots)
                Mr[a] = Mr[a] - gather_sum(La[None] * Mr[lvl], slots)
            S = S - gather_sum(self.Lr[lvl][:, None] * Mr[lvl][None], lv.below[lvl][0])
        # the root's dense 6x6 block, a chain of six DOFs: each step one operation on the whole remaining
        # block (whose upper triangle is computed and never read), materialized, since the next step reads
        # each entry several times
        S = keep(S, pred)
        Dr, self.Lrr = [None] * 6, {}
        for k in range(5, -1, -1):
            Dr[k] = 1.0 / S[k, k]
            if k:
                Lk = S[k, :k] * Dr[k]          # [k, n0, B]: row k of L
                S, Lk = keep((S[:k, :k] - Lk[:, None] * S[k, None, :k], Lk), pred)
                for i in range(k):
                    self.Lrr[(k, i)] = Lk[i]
        self.Dr = jnp.stack(Dr)
        self.lv = lv
        self.pred = pred
        self.Dinv, self.La, self.Lr, self.Dr = keep((self.Dinv, self.La, self.Lr, self.Dr), pred)

    def solve(self, b):
        """``M^-1 b`` for ``b = {0: [6, n0, B], l: [n_l, B]}`` (missing levels: zero)."""
        lv, D = self.lv, self.lv.depth
        y = {lvl: b.get(lvl) for lvl in range(1, D + 1)}
        yr = b.get(0)
        for lvl in range(D, 0, -1):             # L^T y = b, from the leaves up
            if y[lvl] is None:
                continue
            for a in range(1, lvl):
                add = gather_sum(self.La[lvl][a] * y[lvl], lv.below[lvl][a])
                y[a] = -add if y[a] is None else y[a] - add
            add = gather_sum(self.Lr[lvl] * y[lvl][None], lv.below[lvl][0])
            yr = -add if yr is None else yr - add
        if yr is None:
            n0 = len(lv.bodies[0])
            some = next(v for v in y.values() if v is not None)
            yr = jnp.zeros((6, n0, some.shape[-1]), some.dtype)
        yr = [yr[i] for i in range(6)]
        for k in range(5, -1, -1):
            for i in range(k):
                yr[i] = yr[i] - self.Lrr[(k, i)] * yr[k]
        xr = [None] * 6
        for k in range(6):                      # L x = D^-1 y, from the root down
            xk = yr[k] * self.Dr[k]
            for i in range(k):
                xk = xk - self.Lrr[(k, i)] * xr[i]
            xr[k] = xk
        x = {0: jnp.stack(xr)}
        for lvl in range(1, D + 1):
            xl = y[lvl] * self.Dinv[lvl] if y[lvl] is not None else 0.0
            for a in range(1, lvl):
                xl = xl - self.La[lvl][a] * take(x[a], lv.anc[lvl][a])
            xl = xl - sum0(self.Lr[lvl] * take(x[0], lv.anc[lvl][0]))
            x[lvl] = xl
        return keep(x, self.pred)


# ---------------------------------------------------------------------------------------------------------
# the dynamics


def mass_matrix(model, kin, masses):
    """Joint-space inertia in the levels' layout (composite-rigid-body algorithm, about each root's CM)."""
    lv = model.levels
    D = lv.depth
    m, inertia, scale = masses
    mc, hc, Ic, Iw = [], [], [], []
    for lvl in range(D + 1):
        I = world_inertia(kin.R[lvl], inertia[lvl])
        if scale[lvl] is not None:
            I = I * scale[lvl]
        Iw.append(I)
        d = kin.d[lvl]
        dd = dot(d, d)
        outer = d[:, None] * d[None]
        eye = jnp.eye(3, dtype=d.dtype)[:, :, None, None]
        mc.append(jnp.broadcast_to(m[lvl], d.shape[1:]))
        hc.append(m[lvl] * d)
        Ic.append(I + m[lvl] * (eye * dd - outer))
    for lvl in range(D, 0, -1):                # composite inertias: children into parents
        slots = lv.below[lvl][lvl - 1]
        mc[lvl - 1] = mc[lvl - 1] + gather_sum(mc[lvl], slots)
        hc[lvl - 1] = hc[lvl - 1] + gather_sum(hc[lvl], slots)
        Ic[lvl - 1] = Ic[lvl - 1] + gather_sum(Ic[lvl], slots)
    M = {"d": {}, "a": {}, "r": {}}
    free = lv.free
    for lvl in range(1, D + 1):
        a, p = kin.a[lvl], kin.p[lvl]
        pa = cross(p, a)
        H = _mv(Ic[lvl], a) + cross(hc[lvl], pa)
        Lm = mc[lvl] * pa - cross(hc[lvl], a)
        M["d"][lvl] = dot(a, H) + dot(pa, Lm)
        M["a"][lvl] = {}
        for a2 in range(1, lvl):
            anc = lv.anc[lvl][a2]
            M["a"][lvl][a2] = dot(take(kin.a[a2], anc), H) + dot(take(cross(kin.p[a2], kin.a[a2]), anc), Lm)
        rows = jnp.concatenate([Lm, H])                                  # [6, n, B]: (lin, ang) root DOFs
        fmask = free[lv.anc[lvl][0]]
        M["r"][lvl] = rows if fmask.all() else rows * fmask.astype(np.float32)[:, None]
    h = hc[0]
    hx = _skew_T_times(h)
    z = jnp.zeros_like(h[0])
    top = [[mc[0] if i == j else z for j in range(3)] + [-hx[i][j] for j in range(3)] for i in range(3)]
    bot = [[hx[i][j] for j in range(3)] + [Ic[0][i, j] for j in range(3)] for i in range(3)]
    root = jnp.stack([jnp.stack(r) for r in top + bot])                 # [6, 6, n0, B]
    if not free.all():                          # a fixed root: identity, so that its DOFs stay at rest
        f = free.astype(np.float32)[:, None]
        root = root * f + jnp.eye(6, dtype=root.dtype)[:, :, None, None] * (1.0 - f)
    M["root"] = root
    return keep(M, kin.pred), Iw    # Iw not materialized: see keep()


def _mv(I, a):
    return jnp.stack([I[i, 0] * a[0] + I[i, 1] * a[1] + I[i, 2] * a[2] for i in range(3)])


def project(model, kin, F, N):
    """Generalized forces of body wrenches: ``F[l]``, ``N[l]`` [3, n_l, B] (N about the root's CM) summed over
    each subtree and projected on its DOFs (the backward pass of recursive Newton-Euler)."""
    lv = model.levels
    F, N = list(F), list(N)
    for lvl in range(lv.depth, 0, -1):
        slots = lv.below[lvl][lvl - 1]
        F[lvl - 1] = F[lvl - 1] + gather_sum(F[lvl], slots)
        N[lvl - 1] = N[lvl - 1] + gather_sum(N[lvl], slots)
    tau = {0: jnp.concatenate([F[0], N[0]]) * lv.free.astype(np.float32)[:, None]}
    for lvl in range(1, lv.depth + 1):
        tau[lvl] = dot(kin.a[lvl], N[lvl] - cross(kin.p[lvl], F[lvl]))
    return keep(tau, kin.pred)


def inertial_wrenches(model, kin, masses, Iw, rates):
    """Each body's wrench of gravity and its velocity-product accelerations (``qdd = 0``): ``F = m (a_vp - g)``,
    ``N = I alpha_vp + w x I w + d x F`` about the root's CM (the forward pass of recursive Newton-Euler)."""
    lv = model.levels
    m = masses[0]
    lin, ang, F, N = [], [], [], []
    g = jnp.asarray([0.0, 0.0, model.gravity], jnp.float32)[:, None, None]
    for lvl in range(lv.depth + 1):
        W = kin.W[lvl]
        if lvl == 0:
            ang.append(jnp.zeros_like(W))
            lin.append(jnp.zeros_like(W))
        else:
            par = lv.parent[lvl]
            Wp, angp, linp, dp = take(kin.W[lvl - 1], par), take(ang[lvl - 1], par), take(lin[lvl - 1], par), \
                take(kin.d[lvl - 1], par)
            a, p = kin.a[lvl], kin.p[lvl]
            ang.append(angp + rates[lvl] * cross(Wp, a))
            rp = p - dp
            ap = linp + cross(angp, rp) + cross(Wp, cross(Wp, rp))
            rb = kin.d[lvl] - p
            lin.append(ap + cross(ang[lvl], rb) + cross(W, cross(W, rb)))
        f = m[lvl] * (lin[lvl] + g)
        n = _mv(Iw[lvl], ang[lvl]) + cross(W, _mv(Iw[lvl], W))
        F.append(f)
        N.append(n + cross(kin.d[lvl], f))
    return keep((F, N), kin.pred)


def body_velocities(model, kin, u):
    """Angular and CM velocities [3, nb, B] of every body for generalized velocities ``u`` (levels' layout)."""
    lv = model.levels
    W, V = [u[0][3:6]], [u[0][0:3]]
    for lvl in range(1, lv.depth + 1):
        par = lv.parent[lvl]
        Wp, Vp, dp = take(W[lvl - 1], par), take(V[lvl - 1], par), take(kin.d[lvl - 1], par)
        a, p = kin.a[lvl], kin.p[lvl]
        W.append(Wp + u[lvl] * a)
        V.append(Vp + cross(Wp, p - dp) + cross(W[lvl], kin.d[lvl] - p))
    inv = _inverse(lv)
    W, V = keep((W, V), kin.pred)
    return take(jnp.concatenate(W, axis=1), inv), take(jnp.concatenate(V, axis=1), inv)


def _inverse(lv):
    order = np.concatenate(lv.bodies)
    inv = np.empty_like(order)
    inv[order] = np.arange(len(order))
    return inv


def _joint_perm(lv):
    """Static maps between the file's joint order and the levels' (level 1, 2, ...) order."""
    js = np.concatenate([lv.joint[lvl] for lvl in range(1, lv.depth + 1)]) if lv.depth else np.zeros(0, np.int64)
    inv = np.empty_like(js)
    inv[js] = np.arange(len(js))
    return js, inv


def to_levels(model, x_joint):
    """A per-joint array [nj, B] (file order, file sign) as the levels' DOFs (tree sign)."""
    lv = model.levels
    return {lvl: take(x_joint, lv.joint[lvl]) * jnp.asarray(lv.sign[lvl], x_joint.dtype)[:, None]
            for lvl in range(1, lv.depth + 1)}


def from_levels(model, x):
    """The levels' joint DOFs (tree sign) as [nj, B] in the file's order and sign."""
    lv = model.levels
    if not lv.depth:
        return None
    _, inv = _joint_perm(lv)
    cat = jnp.concatenate([x[lvl] * jnp.asarray(lv.sign[lvl], x[lvl].dtype)[:, None] for lvl in range(1, lv.depth + 1)])
    return take(cat, inv)


def _add(a, b):
    return {k: a[k] + b[k] if k in b else a[k] for k in a} | {k: b[k] for k in b if k not in a}


class _Contacts:
    """The contact vertices: their bodies, offsets, and the static maps onto bodies and levels."""

    def __init__(self, model, kin):
        lv = model.levels
        self.cb = model.pt_body[model.ct_pt]
        self.nc = len(self.cb)
        local = model.pt_local[:, model.ct_pt]                                   # [3, nc]
        self.r = rot_const(take(kin.R_all, self.cb), local)                       # [3, nc, B]
        self.p = take(kin.d_all, self.cb) + self.r                                # from the root's CM
        root_item = np.array([lv.item_of[model.tree.root[b]] for b in self.cb])
        self.world = self.p + take(kin.O, root_item)
        self.r, self.p, self.world = keep((self.r, self.p, self.world), kin.pred)
        # each level's bodies' vertices: the wrenches sum them level by level (no concatenation per slot)
        self.by_level = [_slots([list(np.nonzero(self.cb == b)[0]) for b in bs]) for bs in lv.bodies]
        self.level = lv.level_of[self.cb]
        self.item = lv.item_of[self.cb]

    def wrenches(self, model, kin, f):
        """Body wrenches (per level) of vertex forces f [3, nc, B]: force, and torque about the root's CM."""
        n = cross(self.p, f)
        return [gather_sum(f, s) for s in self.by_level], [gather_sum(n, s) for s in self.by_level]

    def velocities(self, w, v):
        """Vertex velocities [3, nc, B] from body velocities [3, nb, B]."""
        return take(v, self.cb) + cross(take(w, self.cb), self.r)


def _slots_by(owner, n):
    return _slots([list(np.nonzero(owner == b)[0]) for b in range(n)])


def _dofs(model, state):
    """The state's generalized velocities in the levels' layout."""
    lv = model.levels
    roots = lv.bodies[0]
    u = {0: jnp.concatenate([take(state.v, roots), take(state.w, roots)])}
    return u | to_levels(model, state.gv)


def _axpy(x, a, y):
    """x + a y over dof dicts."""
    return {k: x[k] + a * y[k] for k in x}


def step(model, state, ctrl, var=None):
    """Advance a batch of robots by ``model.dt`` on exact joints (``state``: an `ExactState`)."""
    lv = model.levels
    dt = model.dt
    target, target_rate = ctrl
    gain = None if var is None else var.gain
    kin = Kin(model, state.x, state.q, state.v, state.w)
    masses = _masses(model, var, lv)
    M, Iw = mass_matrix(model, kin, masses)
    # servo and joint limits: their torques on the rates at the start of the step, their dampers implicit in
    # the joint-space inertia (M + dt D), as MuJoCo's implicit integration does (a saturated servo adds none)
    tau_pi, err = servo_pi(model, state.gq, target, state.e_int, gain)
    tau_j = limit_torques(model, state.gq, state.gv, implicit=False)
    if model.nj:
        lo, hi = model.j_lo[:, None], model.j_hi[:, None]
        damp = jnp.where((state.gq > hi) | (state.gq < lo), model.limit_c, 0.0)
        if model.n_ctrl:
            cj = model.ctrl_joint
            torque = None if var is None else var.torque
            tau_s = servo_torques(model, tau_pi, state.gv[cj], target_rate, gain, implicit=False, torque=torque)
            _, _, kd, tmax = servo_gains(model, gain, implicit=False, torque=torque)
            tau_j = tau_j.at[cj].add(tau_s)
            damp = damp.at[cj].add(jnp.where(jnp.abs(tau_s) < tmax, kd, 0.0))
        for lvl in range(1, lv.depth + 1):
            M["d"][lvl] = M["d"][lvl] + dt * take(damp, lv.joint[lvl])
    rates = to_levels(model, state.gv)
    Fi, Ni = inertial_wrenches(model, kin, masses, Iw, rates)
    tau = project(model, kin, [-f for f in Fi], [-n for n in Ni])
    if model.nj:
        tau = _add(tau, to_levels(model, tau_j))
    if len(model.ct_pt):
        qdd, fc, anchor, fn = _contact_step(model, state, kin, M, tau, var)
    else:
        qdd = Factor(model, M, kin.pred).solve(tau)
        fc, anchor, fn = state.f_c, state.anchor, state.f_n
    return _integrate(model, state, keep(qdd, kin.pred), dt, kin.pred)._replace(
        e_int=state.e_int + dt * err, anchor=anchor, f_n=fn, f_c=fc, n=state.n + 1)


def _contact_step(model, state, kin, M, tau, var):
    """The step's joint accelerations with eq. 3.7's ground and the friction bristle solved implicitly, coupled over
    the whole robot; the contact forces, the bristles' anchors and the normal forces.

    A touching vertex pushes with ``f = A d n - k z_t - (B n n^T + b' (I - n n^T)) v'`` (the normal spring and
    bristle explicit, their dampers on the vertex's velocity at the end of the step, ``v' = J (u + dt qdd)``).
    The dampers go into the joint-space inertia, ``(M + dt D + dt J^T K J) qdd = tau + J^T (a - K J u)``, as the
    servos' do: one solve with the factor gives every vertex's force together, however many push at once and
    through whatever joints (no per-vertex estimate of the others' push).

    Which vertices push and how much friction the cone allows are taken from the stick law's forces at the
    start of the step (``v' = v``): a vertex pushes while ``A d - B v_n > 0``, and a second solve releases the
    vertices the first would have pulled (``A d - B v'_n < 0``: a foot lifting off; the trot had such a vertex in
    70 of 5,000 steps, up to 34 N, without it); its bristle (spring and damper)
    acts in full while its pull is within ``mu_s f_n``, else scaled by ``lam = mu_d f_n / |f_t|``, so that the
    friction is the cone's share of the bristle's pull and changes continuously as a foot starts to slip.
    Why not a switch between a sticking (implicit) and a sliding (explicit) foot: a hard switch made the walk
    chaotic (the trot's score under 1e-6 gene jitter: sd 0.0010-0.0013, against 0.0001 with ``lam``), and
    taking ``lam`` again from the first solve's forces made it less steady (sd 0.0008; docs/exact-joints.md).
    At rest ``v' = 0``, so ``f_n = A d`` exactly and the penetration is ``m g / (A contacts)``.
    """
    dt = model.dt
    con = _Contacts(model, kin)
    u = _dofs(model, state)
    depth, fr = contact_frame(model, con.world, var)
    touch = depth > 0
    A, B = ground(model, var)
    kb, bp = bristle(model, var)
    mu_s, mu_d = friction(model, var)
    _, z_1, z_2 = fr.comp(con.world - state.anchor)
    fa = jnp.where(touch, A * depth, 0.0)
    v_start = fr.comp(con.velocities(state.w, state.v))
    fa, z_1, z_2, v_start = keep((fa, z_1, z_2, v_start), kin.pred)
    geo = _ContactJacobian(model, kin, con, fr)

    def law(vel):                               # the stick law's forces (n, t1, t2) at end-of-step velocities
        v_n, v_1, v_2 = vel
        return fa - B * v_n, -kb * z_1 - bp * v_1, -kb * z_2 - bp * v_2

    def modes(f):                               # who pushes, and how much of the bristle's pull the cone allows
        f_n, f_1, f_2 = f
        push = touch & (f_n > 0.0)
        ft = jnp.sqrt(f_1 * f_1 + f_2 * f_2 + 1e-20)
        lam = jnp.where(push, jnp.where(ft <= mu_s * f_n, 1.0, mu_d * f_n / ft), 0.0)
        return push.astype(fa.dtype), lam

    def solve(push, lam):
        beta = dt * bp * lam                    # dt K = beta I + gamma n n^T
        gamma = dt * B * push - beta
        fac = Factor(model, keep(_add_m(M, _contact_damping(model, geo, beta, gamma)), kin.pred), kin.pred)
        f0 = fr.world(push * f_start[0], lam * f_start[1], lam * f_start[2])
        qdd = fac.solve(_add(tau, project(model, kin, *con.wrenches(model, kin, f0))))
        w_1, v_1 = body_velocities(model, kin, _axpy(u, dt, qdd))
        return qdd, law(fr.comp(con.velocities(w_1, v_1)))

    f_start = law(v_start)
    push, lam = keep(modes(f_start), kin.pred)
    push, lam, qdd, f = _release(solve, push, lam, tau)
    f_n, f_1, f_2 = push * f[0], lam * f[1], lam * f[2]
    anchor = trail_anchor(model, fr, con.world, state.anchor, (z_1, z_2), touch, lam >= 1.0, f_n, var)
    return qdd, keep(fr.world(f_n, f_1, f_2), kin.pred), anchor, f_n


def _release(solve, push, lam, tau):
    """``solve(push, lam)``, then once more with the vertices it would have pulled released (the ground never
    pulls), the second pass only in the steps where some robot of the batch pulls a vertex.

    Why a loop: the release is needed in few steps (the trot: 70 of 5,000), and a second solve in every step
    was a third of the step's kernels at the GA's 10 robots per device (310 against 236 kernels, 32.4 against
    24.1 us per step; docs/exact-joints.md).  Both passes run the one compiled body, so a robot that releases
    nothing gets the same bits whether or not a neighbour in its batch makes the loop take a second pass
    (batch-size independence), and the solve is compiled once (a ``cond`` around a second copy took 15 % more
    CPU to compile and the thesis-scale GA 7 % more CPU to run: docs/exact-joints.md).  The initial carry only
    gives the loop its shapes (``tau``'s and ``lam``'s); the first pass overwrites it.
    """
    def body(c):
        k, push, lam, _, f = c
        held = jnp.where(k > 0, (f[0] > 0.0).astype(lam.dtype), 1.0)
        push, lam = push * held, lam * held
        qdd, f = solve(push, lam)
        return k + 1, push, lam, qdd, f

    def again(c):
        k, push, _, _, f = c
        return (k == 0) | ((k == 1) & jnp.any((push > 0.0) & (f[0] <= 0.0)))

    qdd0, f0 = jax.tree.map(jnp.zeros_like, tau), (jnp.zeros_like(lam),) * 3    # shapes only: not read
    _, push, lam, qdd, f = jax.lax.while_loop(again, body, (jnp.int32(0), push, lam, qdd0, f0))
    return push, lam, qdd, f


def _add_m(M, C):
    """The joint-space inertia ``M`` plus ``C`` (the same layout; ``C`` may lack entries)."""
    out = {"d": _add(M["d"], C["d"]), "r": _add(M["r"], C["r"]), "root": M["root"] + C["root"],
           "a": {lvl: _add(M["a"].get(lvl, {}), C["a"].get(lvl, {})) for lvl in M["a"]}}
    return out


def _mul(a, b):
    """a * b where either may be None (zero) or the float 1.0."""
    if a is None or b is None:
        return None
    if isinstance(a, float):
        return b if a == 1.0 else a * b
    if isinstance(b, float):
        return a if b == 1.0 else a * b
    return a * b


class _ContactJacobian:
    """Each contact vertex's Jacobian along the terrain frame's directions ``e`` (the normal ``n``, ``t1``, ``t2``):
    ``w_e = (e, p x e)`` on the root's six DOFs (p: the vertex from the root's CM) and ``j_e = e . (a x (p -
    pivot))`` on each joint above it, with the static maps from vertices to their ancestors.  On flat ground the
    directions are the world's axes and the zero entries are ``None`` (left out)."""

    def __init__(self, model, kin, con, fr):
        lv = model.levels
        p = con.p
        if fr.n is None:                        # (e components, p x e), per axis x, y, z; n is z
            self.ws = [(1.0, None, None, None, p[2], -p[1]), (None, 1.0, None, -p[2], None, p[0]),
                       (None, None, 1.0, p[1], -p[0], None)]
            self.normal = 2
            dirs = [0, 1, 2]
        else:
            self.ws, dirs = [], [fr.n, fr.t1, fr.t2]
            for e in dirs:
                pe = cross(p, e)
                self.ws.append((e[0], e[1], e[2], pe[0], pe[1], pe[2]))
            self.normal = 0
        # per level a: each vertex's Jacobian on its level-a ancestor's joint (zero where it is above level a)
        anc_item, self.jac = {}, {}
        for a in range(lv.depth + 1):
            items = np.array([(lv.anc[L][a][i] if a < L else i) if a <= L else -1
                              for L, i in zip(con.level, con.item, strict=True)], np.int64)
            anc_item[a] = items
            if a == 0:
                continue
            mask = items >= 0
            ai = np.maximum(items, 0)
            c = cross(take(kin.a[a], ai), p - take(kin.p[a], ai))
            if not mask.all():
                c = c * mask.astype(np.float32)[:, None]
            self.jac[a] = [c[e] if isinstance(e, int) else dot(c, e) for e in dirs]
        self.slots = {a: _slots_by(anc_item[a], len(lv.bodies[a])) for a in range(lv.depth + 1)}


def _contact_damping(model, geo, beta, gamma):
    """``J^T (beta I + gamma n n^T) J`` in the joint-space inertia's layout, for every contact vertex (``beta``,
    ``gamma`` [nc, B]; ``geo``: the vertices' :class:`_ContactJacobian`): the contact dampers made implicit.

    Written as three rank-one terms per vertex, ``sum_e kappa_e j_e j_e^T`` over the terrain frame's directions
    (the normal: ``beta + gamma``; the tangents: ``beta``).
    """
    lv = model.levels
    D = lv.depth
    ws, jac, slots = geo.ws, geo.jac, geo.slots
    kappas = [beta + gamma if e == geo.normal else beta for e in range(3)]
    out = {"d": {}, "a": {}, "r": {}}
    root = [[None] * 6 for _ in range(6)]
    for k_e, w in zip(kappas, ws, strict=True):
        for i in range(6):
            for j in range(i, 6):
                t = _mul(_mul(k_e, w[i]), w[j])
                if t is not None:
                    root[i][j] = t if root[i][j] is None else root[i][j] + t
    zero = jnp.zeros_like(beta)
    upper = {(i, j): gather_sum(root[i][j] if root[i][j] is not None else zero, slots[0])
             for i in range(6) for j in range(i, 6)}
    Croot = jnp.stack([jnp.stack([upper[min(i, j), max(i, j)] for j in range(6)]) for i in range(6)])
    if not lv.free.all():
        Croot = Croot * lv.free.astype(np.float32)[:, None]
    out["root"] = Croot
    for a in range(1, D + 1):
        kj = [k_e * j_e for k_e, j_e in zip(kappas, jac[a], strict=True)]
        out["d"][a] = gather_sum(sum(kj[e] * jac[a][e] for e in range(3)), slots[a])
        out["a"][a] = {a2: gather_sum(sum(kj[e] * jac[a2][e] for e in range(3)), slots[a]) for a2 in range(1, a)}
        r = []
        for i in range(6):
            t = None
            for e in range(3):
                x = _mul(kj[e], ws[e][i])
                if x is not None:
                    t = x if t is None else t + x
            r.append(gather_sum(t if t is not None else zero, slots[a]))
        r = jnp.stack(r)
        fm = lv.free[lv.anc[a][0]]
        out["r"][a] = r if fm.all() else r * fm.astype(np.float32)[:, None]
    return out


def _integrate(model, state, qdd, dt, pred=None):
    """Semi-implicit Euler on the generalized coordinates, then the bodies' poses and velocities."""
    lv = model.levels
    roots = lv.bodies[0]
    free = lv.free.astype(np.float32)[:, None]
    v0 = take(state.v, roots) + dt * qdd[0][0:3] * free
    w0 = take(state.w, roots) + dt * qdd[0][3:6] * free
    x0 = take(state.x, roots) + dt * v0
    q0 = quat_integrate(take(state.q, roots), w0, dt)
    if not lv.free.all():
        q0 = jnp.where(lv.free[:, None], q0, take(state.q, roots))
    if model.nj:
        gv = state.gv + dt * from_levels(model, qdd)
        gq = state.gq + dt * gv
    else:
        gv, gq = state.gv, state.gq
    phi = to_levels(model, gq) if model.nj else {}
    rate = to_levels(model, gv) if model.nj else {}
    # each level's poses and velocities read its parent's: materialized level by level (and the joints' half
    # angles' cosines and sines once), else every level computes all those above it again, per element read
    cs = {lvl: (jnp.cos(0.5 * phi[lvl]), jnp.sin(0.5 * phi[lvl])) for lvl in range(1, lv.depth + 1)}
    x0, q0, v0, w0, cs = keep((x0, q0, v0, w0, cs), pred)
    X, Q, V, W, R = [x0], [q0], [v0], [w0], [quat_to_mat(q0)]
    for lvl in range(1, lv.depth + 1):
        par = lv.parent[lvl]
        qp, Rp, xp, vp, wp = (take(a, par) for a in (Q[lvl - 1], R[lvl - 1], X[lvl - 1], V[lvl - 1], W[lvl - 1]))
        q = _quat_axis(qp, lv.axis_index[lvl], *cs[lvl])
        Rb = quat_to_mat(q)
        p = xp + rot_const(Rp, lv.r_parent[lvl])
        x = p - rot_const(Rb, lv.r_child[lvl])
        w = wp + rate[lvl] * column(Rp, lv.axis_index[lvl])
        v = vp + cross(wp, p - xp) + cross(w, x - p)
        x, q, v, w, Rb = keep((x, q, v, w, Rb), pred)
        X.append(x)
        Q.append(q)
        V.append(v)
        W.append(w)
        R.append(Rb)
    inv = _inverse(lv)
    cat = [take(jnp.concatenate(a, axis=1), inv) for a in (X, Q, V, W)]
    return state._replace(x=cat[0], q=cat[1], v=cat[2], w=cat[3], gq=gq, gv=gv)


def _quat_axis(qa, axis_index, c, s):
    """qa * (c, s e_axis) per item: a turn by the angle whose half has cosine c and sine s about each item's
    body axis (x, y or z)."""
    w, x, y, z = qa[0], qa[1], qa[2], qa[3]
    forms = {0: (w * c - x * s, x * c + w * s, y * c + z * s, z * c - y * s),
             1: (w * c - y * s, x * c - z * s, y * c + w * s, z * c + x * s),
             2: (w * c - z * s, x * c + y * s, y * c - x * s, z * c + w * s)}
    ai = np.asarray(axis_index)
    if (ai == ai[0]).all():
        return jnp.stack(forms[int(ai[0])])
    out = 0.0
    for j in range(3):
        if (ai == j).any():
            out = out + jnp.stack(forms[j]) * jnp.asarray((ai == j).astype(np.float32), c.dtype)[:, None]
    return out
