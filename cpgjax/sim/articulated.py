"""Exact joints: one step of the robot in generalized coordinates (Featherstone's algorithms).

The thesis's pipeline (`sim.step`) integrates every body free and holds the joints with stiff pivot springs
(eq. 3.6); its step is bound by those springs.  This pipeline keeps the same bodies, servo (PID with
saturation, its derivative implicit, Ch. 5), joint limits, eq. 3.7's ground with the project's implicit
damper and friction bristle (`sim.contact.contact_law`, shared), terrain and `Variation`s, but describes the
robot by a floating base and one angle per revolute joint (`sim.tree`), so that the joints hold exactly:

1. the joint-space inertia ``M`` by the composite-rigid-body algorithm, in world axes about each tree root's
   CM, and its ``M = L^T D L`` factorization, which keeps the tree's sparsity (no fill-in: MuJoCo's
   ``mj_factorM``);
2. the bias forces ``C`` (gravity, Coriolis, gyroscopic) by recursive Newton-Euler with zero joint accelerations;
3. ``M qdd = tau - C + J^T f_prev``: the servo's PI torque, the joint limits and every contact's force of the
   previous step (the warm start); the servo's derivative, implicit on its joint's exact inverse inertia
   ``(M^-1)_jj``; then each contact vertex's force from the contact law against the vertex's real inverse mass
   ``K_c = J_c M^-1 J_c^T``, scaled for the vertices that push at once (below), and the change of the forces
   added to ``qdd``;
4. semi-implicit Euler on the generalized velocities and positions, and forward kinematics for the bodies'
   poses and velocities (``State.x, q, v, w``: what the rest of cpgjax reads, as from the other pipeline).

The vertices are solved one by one (a Jacobi step from the previous step's forces).  So that vertices pushing
together cannot overshoot, each vertex's inverse mass is scaled by ``s_c = max(1, sum_j K_cj / K_cc)`` over the
touching vertices ``j`` (normal components): the response of the vertex when every touching vertex pushes at
once, one solve for all; for the vertices of one free body this is the other pipeline's count of touching
vertices.

Arrays are batch-last; the structure (which DOF moves which body, the zeros of the root block) is static,
so the step is straight-line code over ``[B]`` arrays that XLA fuses.
"""

from __future__ import annotations

import jax.numpy as jnp

from cpgjax.sim.contact import contact_frame, contact_law
from cpgjax.sim.joints import limit_torques
from cpgjax.sim.rotation import quat_integrate, quat_to_mat
from cpgjax.sim.servo import servo_pi, servo_torques

# ---------------------------------------------------------------------------------------------------------
# 3-vectors as tuples of [B] arrays (or the Python float 0.0 for a structural zero: no operation is emitted)


def _z(a):
    return isinstance(a, float) and a == 0.0


def _add(a, b):
    return b if _z(a) else a if _z(b) else a + b


def _sub(a, b):
    return a if _z(b) else (-b if _z(a) else a - b)


def _mul(a, b):
    if _z(a) or _z(b):
        return 0.0
    if isinstance(a, float) and a in (1.0, -1.0):
        return b if a == 1.0 else -b
    if isinstance(b, float) and b in (1.0, -1.0):
        return a if b == 1.0 else -a
    return a * b


def vadd(a, b):
    return tuple(_add(x, y) for x, y in zip(a, b, strict=True))


def vsub(a, b):
    return tuple(_sub(x, y) for x, y in zip(a, b, strict=True))


def vscale(s, a):
    return tuple(_mul(s, x) for x in a)


def vdot(a, b):
    out = 0.0
    for x, y in zip(a, b, strict=True):
        out = _add(out, _mul(x, y))
    return out


def vcross(a, b):
    return (_sub(_mul(a[1], b[2]), _mul(a[2], b[1])), _sub(_mul(a[2], b[0]), _mul(a[0], b[2])),
            _sub(_mul(a[0], b[1]), _mul(a[1], b[0])))


def mvec(m, v):
    return tuple(vdot(row, v) for row in m)


def rvec_const(R, r):
    """R @ r for R [3, 3, B] and a constant vector r (its zero components skipped)."""
    out = [0.0, 0.0, 0.0]
    for j in range(3):
        if r[j] != 0.0:
            for i in range(3):
                out[i] = _add(out[i], R[i, j] * float(r[j]))
    return tuple(out)


def _col(R, j):
    return (R[0, j], R[1, j], R[2, j])


def _vec(a):
    return (a[0], a[1], a[2])


def _world_inertia(R, I):
    """R I R^T [3x3 tuple of [B]] for a constant symmetric I (its zeros skipped)."""
    out = [[0.0] * 3 for _ in range(3)]
    for i in range(3):
        for j in range(i, 3):
            acc = 0.0
            for k in range(3):
                for m in range(3):
                    if I[k, m] != 0.0:
                        acc = _add(acc, R[i, k] * R[j, m] * float(I[k, m]))
            out[i][j] = out[j][i] = acc
    return out


# ---------------------------------------------------------------------------------------------------------
# M = L^T D L with the tree's sparsity (MuJoCo's mj_factorM / mj_solveM)


def factor(tree, M):
    """``M = L^T D L`` of a dict ``M[(k, i)]`` (i = k or an ancestor of k): returns ``(L, Dinv)``.

    ``L[(k, i)]`` for each ancestor i of k; ``Dinv[k] = 1 / D_k``.  Eliminating from the last DOF up, a DOF's
    row only updates its ancestors' entries: no fill-in.
    """
    M = dict(M)
    L, Dinv = {}, {}
    for k in reversed(range(tree.nv)):
        anc = tree.ancestors(k)
        Dinv[k] = 1.0 / M[(k, k)]
        row = {i: M.get((k, i), 0.0) for i in anc}
        for i in anc:
            L[(k, i)] = _mul(row[i], Dinv[k])
        for n, i in enumerate(anc):             # i and j both above k: j is i or above i
            if _z(L[(k, i)]):
                continue
            for j in anc[n:]:
                if not _z(row[j]):
                    M[(i, j)] = _sub(M.get((i, j), 0.0), L[(k, i)] * row[j])
    return L, Dinv


def solve(tree, L, Dinv, b):
    """``M^-1 b`` for a dense right-hand side ``b`` (a list of [B] arrays or 0.0 over the DOFs)."""
    y = list(b)
    for k in reversed(range(tree.nv)):          # L^T y = b: from the leaves up
        if _z(y[k]):
            continue
        for i in tree.ancestors(k):
            y[i] = _sub(y[i], _mul(L[(k, i)], y[k]))
    x = [_mul(y[k], Dinv[k]) for k in range(tree.nv)]
    for k in range(tree.nv):                    # L x = D^-1 y: from the root down
        for i in tree.ancestors(k):
            x[k] = _sub(x[k], _mul(L[(k, i)], x[i]))
    return x


def half_solve(tree, L, path, b):
    """``y = L^-T b`` for ``b`` supported on ``path`` (a DOF and its ancestors, nearest first): ``y`` is too, so
    that ``b^T M^-1 b' = sum_i y_i y'_i / D_i``.  ``b``: a dict DOF -> [B] array (missing: zero)."""
    y = {d: b.get(d, 0.0) for d in path}
    for k in path:                              # nearest first = descending DOF index
        if _z(y[k]):
            continue
        for i in tree.ancestors(k):
            y[i] = _sub(y[i], _mul(L[(k, i)], y[k]))
    return y


# ---------------------------------------------------------------------------------------------------------
# kinematics


class _Kin:
    """The bodies' rotations, positions (from their tree root's CM), velocities, joint axes and pivots."""

    def __init__(self, model, state):
        tree = model.tree
        self.R = quat_to_mat(state.q)                              # [3, 3, nb, B]
        self.O = {r: _vec(state.x[:, r]) for r in tree.roots}
        self.d, self.w, self.v = {}, {}, {}
        for b in tree.order:
            r = tree.root[b]
            self.d[b] = (0.0, 0.0, 0.0) if b == r else vsub(_vec(state.x[:, b]), self.O[r])
            self.w[b] = _vec(state.w[:, b])
            self.v[b] = _vec(state.v[:, b])
        self.axis, self.pivot = {}, {}
        for b in tree.order:
            k = tree.joint[b]
            if k < 0:
                continue
            a = tree.parent[b]
            Ra = self.R[:, :, a]
            self.axis[k] = _col(Ra, tree.axis_index[k])
            self.pivot[k] = vadd(self.d[a], rvec_const(Ra, tree.r_parent[:, k]))


def _masses(model, var):
    """Each body's mass [B] (or a float) and its inertia scale (None: nominal)."""
    if var is None:
        return [float(m) for m in model.mass], None
    return [float(model.mass[b]) * var.mass[b] for b in range(model.nb)], var.mass


# ---------------------------------------------------------------------------------------------------------
# the step


def mass_matrix(model, kin, var=None):
    """Joint-space inertia ``M[(k, i)]`` (composite-rigid-body algorithm, about each tree root's CM)."""
    tree = model.tree
    m, s = _masses(model, var)
    mc, hc, Ic, Iw = {}, {}, {}, {}
    for b in tree.order:
        Ib = _world_inertia(kin.R[:, :, b], model.inertia[:, :, b])
        if s is not None:
            Ib = [[_mul(x, s[b]) for x in row] for row in Ib]
        Iw[b] = Ib
        d = kin.d[b]
        dd = vdot(d, d)
        IO = [[_add(Ib[i][j], _mul(m[b], _sub(dd if i == j else 0.0, _mul(d[i], d[j])))) for j in range(3)]
              for i in range(3)]
        mc[b], hc[b], Ic[b] = m[b], vscale(m[b], d), IO
    for b in reversed(tree.order):              # composite inertias: children into parents
        a = tree.parent[b]
        if a >= 0:
            mc[a] = _add(mc[a], mc[b])
            hc[a] = vadd(hc[a], hc[b])
            Ic[a] = [[_add(Ic[a][i][j], Ic[b][i][j]) for j in range(3)] for i in range(3)]
    M = {}
    for b in tree.order:
        k = tree.joint[b]
        if k < 0:
            if tree.free_root[b]:
                f = tree.root_dof[b]
                h = hc[b]
                hx = ((0.0, -h[2], h[1]), (h[2], 0.0, -h[0]), (-h[1], h[0], 0.0))
                for i in range(3):
                    for j in range(i + 1):
                        M[(f + i, f + j)] = mc[b] if i == j else 0.0
                        M[(f + 3 + i, f + 3 + j)] = Ic[b][i][j]
                    for j in range(3):
                        M[(f + 3 + i, f + j)] = hx[i][j]
            continue
        dof = tree.joint_dof[k]
        a, p = kin.axis[k], kin.pivot[k]
        pa = vcross(p, a)
        H = vadd(mvec(Ic[b], a), vcross(hc[b], pa))
        Lm = vsub(vscale(mc[b], pa), vcross(hc[b], a))
        M[(dof, dof)] = _add(vdot(a, H), vdot(pa, Lm))
        for i in tree.ancestors(dof):
            M[(dof, i)] = _row(tree, kin, i, H, Lm)
    return M, (m, Iw)


def _dof_kind(tree, i):
    """('lin'|'ang', component, root body) for a floating-base DOF, ('joint', k, None) for a joint's."""
    for b in tree.roots:
        f = tree.root_dof[b]
        if f >= 0 and f <= i < f + 6:
            return ("lin", i - f, b) if i < f + 3 else ("ang", i - f - 3, b)
    return ("joint", tree.joint_dof.index(i), None)


def _row(tree, kin, i, H, Lm):
    """``S_i . (H, L)``: the DOF i's component of a spatial force (H about the root's CM, L)."""
    kind, c, _ = _dof_kind(tree, i)
    if kind == "lin":
        return Lm[c]
    if kind == "ang":
        return H[c]
    a, p = kin.axis[c], kin.pivot[c]
    return _add(vdot(a, H), vdot(vcross(p, a), Lm))


def bias_forces(model, kin, inertia, gv):
    """``C`` over the DOFs: gravity, Coriolis and gyroscopic forces (recursive Newton-Euler, zero ``qdd``)."""
    tree = model.tree
    m, Iw = inertia
    g = model.gravity
    lin, ang, F, N = {}, {}, {}, {}
    for b in tree.order:
        k = tree.joint[b]
        if k < 0:
            lin[b], ang[b] = (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
        else:
            a = tree.parent[b]
            ax, p = kin.axis[k], kin.pivot[k]
            rate = _mul(float(tree.sign[k]), gv[k])
            ang[b] = vadd(ang[a], vscale(rate, vcross(kin.w[a], ax)))
            rp = vsub(p, kin.d[a])
            ap = vadd(vadd(lin[a], vcross(ang[a], rp)), vcross(kin.w[a], vcross(kin.w[a], rp)))
            rb = vsub(kin.d[b], p)
            lin[b] = vadd(vadd(ap, vcross(ang[b], rb)), vcross(kin.w[b], vcross(kin.w[b], rb)))
        f = vscale(m[b], vadd(lin[b], (0.0, 0.0, g)))
        Iwb = Iw[b]
        n = vadd(mvec(Iwb, ang[b]), vcross(kin.w[b], mvec(Iwb, kin.w[b])))
        F[b], N[b] = f, vadd(n, vcross(kin.d[b], f))
    for b in reversed(tree.order):
        a = tree.parent[b]
        if a >= 0:
            F[a], N[a] = vadd(F[a], F[b]), vadd(N[a], N[b])
    C = [0.0] * tree.nv
    for b in tree.order:
        k = tree.joint[b]
        if k < 0:
            if tree.free_root[b]:
                f = tree.root_dof[b]
                for c in range(3):
                    C[f + c], C[f + 3 + c] = F[b][c], N[b][c]
        else:
            ax, p = kin.axis[k], kin.pivot[k]
            C[tree.joint_dof[k]] = vdot(ax, vsub(N[b], vcross(p, F[b])))
    return C


def _point_jacobian_T(tree, kin, body, p, f):
    """``J^T f`` as a dict DOF -> [B]: the generalized force of a world force f at p (from the root's CM)."""
    out, pf = {}, None
    for i in tree.path(body):
        kind, c, _ = _dof_kind(tree, i)
        if kind == "lin":
            out[i] = f[c]
        elif kind == "ang":
            pf = vcross(p, f) if pf is None else pf
            out[i] = pf[c]
        else:
            out[i] = vdot(kin.axis[c], vcross(vsub(p, kin.pivot[c]), f))
    return out


def _add_into(tau, sparse):
    for i, x in sparse.items():
        tau[i] = _add(tau[i], x)


def joint_inverse_inertia(model, L, Dinv):
    """``(M^-1)_jj`` [nj] of every joint's DOF: 1 / the inertia its own torque meets in the articulated robot."""
    tree = model.tree
    out = []
    for k in range(model.nj):
        dof = tree.joint_dof[k]
        y = half_solve(tree, L, [dof, *tree.ancestors(dof)], {dof: 1.0})
        acc = 0.0
        for i, yi in y.items():
            acc = _add(acc, _mul(_mul(yi, yi), Dinv[i]))
        out.append(acc)
    return out


def body_velocities(model, kin, qd_root, gv):
    """World angular and CM velocities of every body for root velocities ``qd_root[b] = (v, w)`` and joint
    rates ``gv`` (file convention)."""
    tree = model.tree
    w, v = {}, {}
    for b in tree.order:
        k = tree.joint[b]
        if k < 0:
            v[b], w[b] = qd_root.get(b, ((0.0,) * 3, (0.0,) * 3))
            continue
        a = tree.parent[b]
        ax, p = kin.axis[k], kin.pivot[k]
        w[b] = vadd(w[a], vscale(_mul(float(tree.sign[k]), gv[k]), ax))
        v[b] = vadd(vadd(v[a], vcross(w[a], vsub(p, kin.d[a]))), vcross(w[b], vsub(kin.d[b], p)))
    return w, v


def _split(tree, x):
    """Root (v, w) per free root and joint rates (file convention) of a DOF vector."""
    root = {}
    for b in tree.roots:
        f = tree.root_dof[b]
        if f >= 0:
            root[b] = (tuple(x[f:f + 3]), tuple(x[f + 3:f + 6]))
    gv = [_mul(float(tree.sign[k]), x[tree.joint_dof[k]]) for k in range(len(tree.joint_dof))]
    return root, gv


def _arr(a, like):
    return jnp.zeros_like(like) if _z(a) else a


def step(model, state, ctrl, var=None):
    """Advance a batch of robots by ``model.dt`` on exact joints (``state``: an `ExactState`)."""
    tree = model.tree
    dt = model.dt
    target, target_rate = ctrl
    like = state.x[0, 0]
    gain = None if var is None else var.gain
    kin = _Kin(model, state)
    M, inertia = mass_matrix(model, kin, var)
    L, Dinv = factor(tree, M)
    C = bias_forces(model, kin, inertia, [state.gv[k] for k in range(model.nj)])
    tau = [(-c if not _z(c) else 0.0) for c in C]
    # servo (PI explicit), joint limits, both with their dampers implicit on the joint's exact inverse inertia
    inv_ieff = joint_inverse_inertia(model, L, Dinv)
    inv_ieff_arr = jnp.stack([_arr(x, like) for x in inv_ieff]) if model.nj else None
    angle, rate = state.gq, state.gv
    tau_pi, err = servo_pi(model, angle, target, state.e_int, gain)
    tau_j = limit_torques(model, angle, rate, inv_ieff_arr)
    if model.n_ctrl:
        tau_j = tau_j.at[model.ctrl_joint].add(tau_pi)
    for k in range(model.nj):
        dof = tree.joint_dof[k]
        tau[dof] = _add(tau[dof], float(tree.sign[k]) * tau_j[k])
    # the previous step's contact forces (the warm start of the contact solve)
    cb = model.pt_body[model.ct_pt]
    nc = len(cb)
    R = kin.R
    rc, pc = [], []
    for c in range(nc):
        b = int(cb[c])
        r = rvec_const(R[:, :, b], model.pt_local[:, model.ct_pt[c]])
        rc.append(r)
        pc.append(vadd(kin.d[b], r))
    for c in range(nc):
        _add_into(tau, _point_jacobian_T(tree, kin, int(cb[c]), pc[c], _vec(state.f_c[:, c])))
    qdd = solve(tree, L, Dinv, tau)
    # the servos' derivative: backward Euler on the joint rate the step would give
    if model.n_ctrl:
        cj = model.ctrl_joint
        pred = jnp.stack([_arr(_add(state.gv[k], _mul(dt * float(tree.sign[k]), qdd[tree.joint_dof[k]])), like)
                          for k in cj])
        extra = servo_torques(model, tau_pi, pred, target_rate, gain, inv_ieff_arr[cj]) - tau_pi
        rhs = [0.0] * tree.nv
        for n, k in enumerate(cj):
            rhs[tree.joint_dof[int(k)]] = float(tree.sign[int(k)]) * extra[n]
        qdd = [_add(x, y) for x, y in zip(qdd, solve(tree, L, Dinv, rhs), strict=True)]
    # contacts: each vertex's end-of-step velocity without its own change of force, and its inverse mass
    if nc:
        root_v = {b: (_vec(state.v[:, b]), _vec(state.w[:, b])) for b in tree.roots}
        qd = [0.0] * tree.nv
        for b, (v0, w0) in root_v.items():
            f = tree.root_dof[b]
            if f >= 0:
                qd[f:f + 6] = [*v0, *w0]
        for k in range(model.nj):
            qd[tree.joint_dof[k]] = float(tree.sign[k]) * state.gv[k]
        qstar = [_add(x, _mul(dt, y)) for x, y in zip(qd, qdd, strict=True)]
        roots_star, gv_star = _split(tree, qstar)
        w_s, v_s = body_velocities(model, kin, roots_star, gv_star)
        cp_world = jnp.stack([jnp.stack([_arr(_add(kin.O[tree.root[int(cb[c])]][i], pc[c][i]), like)
                                         for c in range(nc)]) for i in range(3)])
        vstar = jnp.stack([jnp.stack([_arr(x, like) for x in vadd(v_s[int(cb[c])], vcross(w_s[int(cb[c])], rc[c]))])
                           for c in range(nc)], 1)
        depth, fr = contact_frame(model, cp_world, var)
        touch = (depth > 0).astype(depth.dtype)
        ys = []                                 # per vertex: L^-T J^T e for e = n, t1, t2
        for c in range(nc):
            b = int(cb[c])
            path = tree.path(b)
            ys.append([half_solve(tree, L, path, _point_jacobian_T(tree, kin, b, pc[c], e))
                       for e in _frame_dirs(fr, c)])

        def kdot(ya, yb):
            acc = 0.0
            for i in ya.keys() & yb.keys():
                acc = _add(acc, _mul(_mul(ya[i], yb[i]), Dinv[i]))
            return acc

        knn = [_arr(kdot(ys[c][0], ys[c][0]), like) for c in range(nc)]
        push = {}                               # L^-T J^T n summed over the touching vertices
        for c in range(nc):
            for i, y in ys[c][0].items():
                push[i] = _add(push.get(i, 0.0), _mul(y, touch[c]))
        scale = []
        for c in range(nc):                     # sum_j K_cj t_j / K_cc: all touching vertices pushing at once
            if not ys[c][0]:                    # a vertex on a fixed body: nothing moves it
                scale.append(jnp.ones_like(like))
                continue
            scale.append(jnp.maximum(_arr(kdot(ys[c][0], push), like) / knn[c], 1.0))
        scale = jnp.stack(scale)
        kn = scale * jnp.stack(knn)
        k11 = scale * jnp.stack([_arr(kdot(ys[c][1], ys[c][1]), like) for c in range(nc)])
        k12 = scale * jnp.stack([_arr(kdot(ys[c][1], ys[c][2]), like) for c in range(nc)])
        k22 = scale * jnp.stack([_arr(kdot(ys[c][2], ys[c][2]), like) for c in range(nc)])
        fp_n, fp_1, fp_2 = fr.comp(state.f_c)
        carry_n = -dt * kn * fp_n
        carry_t = (-dt * (k11 * fp_1 + k12 * fp_2), -dt * (k12 * fp_1 + k22 * fp_2))
        fc, anchor, fn = contact_law(model, depth, fr, cp_world, state.anchor, fr.comp(vstar), (kn, k11, k12, k22),
                                     carry_n, carry_t, var)
        dfc = fc - state.f_c
        rhs = [0.0] * tree.nv
        for c in range(nc):
            _add_into(rhs, _point_jacobian_T(tree, kin, int(cb[c]), pc[c], _vec(dfc[:, c])))
        qdd = [_add(x, y) for x, y in zip(qdd, solve(tree, L, Dinv, rhs), strict=True)]
    else:
        fc, anchor, fn = state.f_c, state.anchor, state.f_n
    return _integrate(model, state, kin, qdd, dt)._replace(
        e_int=state.e_int + dt * err, anchor=anchor, f_n=fn, f_c=fc, n=state.n + 1)


def _frame_dirs(fr, c):
    """The contact frame's n, t1, t2 at vertex c, as 3-tuples of [B] arrays (floats on flat ground)."""
    if fr.n is None:
        return [(0.0, 0.0, 1.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0)]
    return [tuple(v[i, c] for i in range(3)) for v in (fr.n, fr.t1, fr.t2)]


def _integrate(model, state, kin, qdd, dt):
    """Semi-implicit Euler on the generalized coordinates, then the bodies' poses and velocities."""
    tree = model.tree
    like = state.x[0, 0]
    x, q, v, w = {}, {}, {}, {}
    for b in tree.roots:
        f = tree.root_dof[b]
        if f < 0:
            x[b], q[b], v[b], w[b] = state.x[:, b], state.q[:, b], state.v[:, b], state.w[:, b]
            continue
        v[b] = state.v[:, b] + dt * jnp.stack([_arr(a, like) for a in qdd[f:f + 3]])
        w[b] = state.w[:, b] + dt * jnp.stack([_arr(a, like) for a in qdd[f + 3:f + 6]])
        x[b] = state.x[:, b] + dt * v[b]
        q[b] = quat_integrate(state.q[:, b], w[b], dt)
    acc = jnp.stack([_arr(_mul(float(tree.sign[k]), qdd[tree.joint_dof[k]]), like) for k in range(model.nj)]) \
        if model.nj else state.gv
    gv = state.gv + dt * acc
    gq = state.gq + dt * gv
    R = {}
    for b in tree.order:
        k = tree.joint[b]
        if k >= 0:
            a = tree.parent[b]
            phi = float(tree.sign[k]) * gq[k]
            c, s = jnp.cos(0.5 * phi), jnp.sin(0.5 * phi)
            q[b] = _quat_axis(q[a], tree.axis_index[k], c, s)
            Ra, Rb = R[a], quat_to_mat(q[b])
            R[b] = Rb
            p = x[a] + jnp.stack([_arr(t, like) for t in rvec_const(Ra, tree.r_parent[:, k])])
            x[b] = p - jnp.stack([_arr(t, like) for t in rvec_const(Rb, tree.r_child[:, k])])
            ax = Ra[:, tree.axis_index[k]]
            wb = w[a] + (float(tree.sign[k]) * gv[k]) * ax
            w[b] = wb
            v[b] = v[a] + _cross(w[a], p - x[a]) + _cross(wb, x[b] - p)
        else:
            R[b] = quat_to_mat(q[b])
    order = range(model.nb)
    return state._replace(x=jnp.stack([x[b] for b in order], 1), q=jnp.stack([q[b] for b in order], 1),
                          v=jnp.stack([v[b] for b in order], 1), w=jnp.stack([w[b] for b in order], 1),
                          gq=gq, gv=gv)


def _cross(a, b):
    return jnp.stack([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def _quat_axis(qa, axis, c, s):
    """qa * (c, s e_axis): a turn by the angle whose half has cosine c and sine s about a body axis."""
    w, x, y, z = qa[0], qa[1], qa[2], qa[3]
    if axis == 0:
        out = (w * c - x * s, x * c + w * s, y * c + z * s, z * c - y * s)
    elif axis == 1:
        out = (w * c - y * s, x * c - z * s, y * c + w * s, z * c + x * s)
    else:
        out = (w * c - z * s, x * c + y * s, y * c - x * s, z * c + w * s)
    return jnp.stack(out)

