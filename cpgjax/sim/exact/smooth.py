"""The smooth dynamics of exact joints, stage by stage, after MuJoCo's (``engine_core_smooth.c``, MJX's ``smooth.py``).

- :func:`kinematics`: every body's pose and velocity from its tree root's and the joint angles and rates below
  it (MuJoCo's ``mj_kinematics`` and ``mj_comVel``);
- :func:`com_pos`: the bodies' poses, velocities and joint axes about their tree root's CM, level by level
  (``mj_comPos``; MuJoCo's frame is the subtree's centre of mass, ours the root body's CM);
- :func:`inertia`: each body's inertia in world axes and about the root's CM (``cinert``);
- :func:`crb`: the joint-space inertia ``qM`` by the composite-rigid-body algorithm (``mj_crb``);
- :func:`factor_m`, :func:`solve_m`: ``qM = L^T D L`` keeping the tree's sparsity (no fill-in), and
  ``qM^-1 b`` (``mj_factorM``, ``mj_solveM``);
- :func:`rne`: the bias forces ``qfrc_bias`` (gravity, Coriolis, gyroscopic) by recursive Newton-Euler with
  zero joint accelerations (``mj_rne``): :func:`bias_wrenches` forward, :func:`project` back;
- :func:`com_vel`: the bodies' velocities for given generalized velocities;
- :func:`subtree_com`: each subtree's centre of mass (MuJoCo's ``subtree_com``).

Each stage is `tricks.stage`: its result is computed once into memory.  Featherstone, *Rigid Body Dynamics
Algorithms* (2008), ch. 6-7 for the algorithms.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from cpgjax.sim.exact.levels import Dofs, at_parent, from_level_items, walk
from cpgjax.sim.exact.types import Com, Factor, Inertia, JointSpaceInertia
from cpgjax.sim.rotation import cross, dot, quat_to_mat
from cpgjax.sim.tricks import column, gather_sum, rot_const, rot_const_row, stage, sum0, take


def _mv(I, a):
    """``I a`` for I [3, 3, n, B] and a [3, n, B]."""
    return jnp.stack([I[i, 0] * a[0] + I[i, 1] * a[1] + I[i, 2] * a[2] for i in range(3)])


# ---------------------------------------------------------------------------------------------------------
# positions and velocities


@stage
def _joint_turns(model, root, angle):
    """The roots' new pose and velocities, and each joint's half-angle turn (cos, sin), computed once: each
    level's kinematics reads them per element."""
    return root, tuple(None if lvl == 0 else (jnp.cos(0.5 * a), jnp.sin(0.5 * a)) for lvl, a in enumerate(angle))


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


def kinematics(model, root, angle: tuple, rate: tuple):
    """Every body's CM position, orientation, CM velocity and angular velocity [.., nb, B] (the bodies' order).

    ``root = (x, q, v, w)`` of the tree roots [.., n0, B]; ``angle``, ``rate``: each level's joint angles and rates
    (`levels.to_levels`).  A body turns from its parent by its joint's angle about the joint's axis (fixed in
    both bodies), about the joint's pivot.
    """
    lv = model.exact.levels
    (x0, q0, v0, w0), turn = _joint_turns(model, root, angle)

    def level(lvl, parent):
        if lvl == 0:
            return x0, q0, v0, w0, quat_to_mat(q0)
        xp, qp, vp, wp, Rp = parent
        q = _quat_axis(qp, lv.axis_index[lvl], *turn[lvl])
        R = quat_to_mat(q)
        pivot = xp + rot_const(Rp, lv.r_parent[lvl])
        x = pivot - rot_const(R, lv.r_child[lvl])
        w = wp + rate[lvl] * column(Rp, lv.axis_index[lvl])
        v = vp + cross(wp, pivot - xp) + cross(w, x - pivot)
        return x, q, v, w, R

    out = walk(model, level, keep_each=True)
    return tuple(from_level_items(model, [o[k] for o in out]) for k in range(4))


@stage
def com_pos(model, state) -> Com:
    """The state's bodies level by level, about their tree root's CM, with their joints' axes and pivots."""
    lv = model.exact.levels
    body_xmat = quat_to_mat(state.q)
    root_com = state.x[:, lv.bodies[0]]
    root_item = np.array([lv.item_of[model.exact.tree.root[b]] for b in range(model.nb)])
    body_offset = state.x - take(root_com, root_item)

    def level(lvl, parent):
        bs = lv.bodies[lvl]
        R, d, w, v = take(body_xmat, bs), take(body_offset, bs), take(state.w, bs), take(state.v, bs)
        if lvl == 0:
            return R, d, w, v, None, None
        Rp, dp = parent[0], parent[1]
        return R, d, w, v, column(Rp, lv.axis_index[lvl]), dp + rot_const(Rp, lv.r_parent[lvl])

    out = walk(model, level)
    return Com(body_xmat, body_offset, root_com, *(tuple(o[k] for o in out) for k in range(6)))


@stage
def _level_velocities(model, com: Com, u: Dofs):
    def level(lvl, parent):
        if lvl == 0:
            return u.root[3:6], u.root[0:3]
        wp, vp = parent
        d = com.offset[lvl]
        axis, pivot = com.xaxis[lvl], com.xanchor[lvl]
        w = wp + u.joint[lvl] * axis
        return w, vp + cross(wp, pivot - at_parent(model, lvl, com.offset[lvl - 1])) + cross(w, d - pivot)

    out = walk(model, level)
    return [o[0] for o in out], [o[1] for o in out]


def com_vel(model, com: Com, u: Dofs):
    """Angular and CM velocities [3, nb, B] of every body (the bodies' order) for generalized velocities ``u``, at
    the poses of ``com``."""
    w, v = _level_velocities(model, com, u)
    return from_level_items(model, w), from_level_items(model, v)


# ---------------------------------------------------------------------------------------------------------
# the joint-space inertia


def world_inertia(R, inertia):
    """``R I R^T`` [3, 3, n, B] for constant body-frame inertias [3, 3, n]."""
    RI = [[rot_const_row(R, i, inertia[:, k]) for k in range(3)] for i in range(3)]
    return jnp.stack([jnp.stack([RI[i][0] * R[j, 0] + RI[i][1] * R[j, 1] + RI[i][2] * R[j, 2] for j in range(3)])
                      for i in range(3)])


def inertia(model, com: Com, var=None) -> Inertia:
    """Each body's mass and inertia in world axes, and its ``cinert`` about the tree root's CM (the parallel-axis
    theorem); ``var``: a per-robot `~cpgjax.sim.variation.Variation` (its mass scale)."""
    lv = model.exact.levels
    mass, ximat_inertia, cinert = [], [], []
    for lvl, bs in enumerate(lv.bodies):
        m = jnp.asarray(model.mass[bs], jnp.float32)[:, None]
        scale = None if var is None else take(var.mass, bs)
        m = m if scale is None else m * scale
        I = world_inertia(com.xmat[lvl], model.inertia[:, :, bs])
        if scale is not None:
            I = I * scale
        d = com.offset[lvl]
        dd = dot(d, d)
        outer = d[:, None] * d[None]
        eye = jnp.eye(3, dtype=d.dtype)[:, :, None, None]
        mass.append(m)
        ximat_inertia.append(I)
        cinert.append((I + m * (eye * dd - outer), m * d, jnp.broadcast_to(m, d.shape[1:])))
    return Inertia(tuple(mass), tuple(ximat_inertia), tuple(cinert))


def _skew(h):
    """The 3x3 block ``[h]x`` as nested lists of [n, B] (rows)."""
    z = jnp.zeros_like(h[0])
    return [[z, -h[2], h[1]], [h[2], z, -h[0]], [-h[1], h[0], z]]


def composite(model, inert: Inertia) -> list:
    """Each subtree's composite inertia, per level: the sums of its bodies' ``cinert`` (inertia about the root's CM,
    mass x offset, mass)."""
    return walk(model, lambda lvl, children, own: own if children is None else jax.tree.map(jnp.add, own, children),
                inert.cinert, reverse=True)


def subtree_com(model, com: Com, inert: Inertia):
    """Each body's subtree's centre of mass [3, nb, B] (world; the bodies' order), MuJoCo's ``subtree_com``."""
    lv = model.exact.levels
    return from_level_items(model, [take(com.root_com, lv.anc[lvl][0] if lvl else np.arange(len(lv.bodies[0])))
                                    + h / m for lvl, (_, h, m) in enumerate(composite(model, inert))])


@stage
def crb(model, com: Com, inert: Inertia) -> JointSpaceInertia:
    """The joint-space inertia ``qM`` by the composite-rigid-body algorithm (MuJoCo's ``mj_crb``).

    Each subtree's composite inertia (``crb``: the sum of its bodies' ``cinert``) times a DOF's motion
    ``cdof = (a, p x a)`` is the 6D force ``(torque, force)`` that moving the DOF needs per unit of acceleration;
    its dot products with the DOF's own and its ancestors' motions are their entries (Featherstone eq. 6.5).
    """
    lv = model.exact.levels
    crb_ = composite(model, inert)
    ancestor, diag, root_dof = [None], [None], [None]
    for lvl in range(1, lv.depth + 1):
        I, h, m = crb_[lvl]
        axis, pivot = com.xaxis[lvl], com.xanchor[lvl]
        cdof_lin = cross(pivot, axis)
        torque = _mv(I, axis) + cross(h, cdof_lin)          # crb * cdof: about the root's CM
        force = m * cdof_lin - cross(h, axis)
        diag.append(dot(axis, torque) + dot(cdof_lin, force))
        up = [None]
        for anc in range(1, lvl):
            items = lv.anc[lvl][anc]
            up.append(dot(take(com.xaxis[anc], items), torque)
                      + dot(take(cross(com.xanchor[anc], com.xaxis[anc]), items), force))
        ancestor.append(tuple(up))
        rows = jnp.concatenate([force, torque])                          # [6, n, B]: the root's (lin, ang) DOFs
        free = lv.free[lv.anc[lvl][0]]
        root_dof.append(rows if free.all() else rows * free.astype(np.float32)[:, None])
    I, h, m = crb_[0]
    hx = _skew(h)
    z = jnp.zeros_like(h[0])
    top = [[m if i == j else z for j in range(3)] + [-hx[i][j] for j in range(3)] for i in range(3)]
    bot = [[hx[i][j] for j in range(3)] + [I[i, j] for j in range(3)] for i in range(3)]
    root = jnp.stack([jnp.stack(r) for r in top + bot])                 # [6, 6, n0, B]
    if not lv.free.all():                          # a fixed root: identity, so that its DOFs stay at rest
        f = lv.free.astype(np.float32)[:, None]
        root = root * f + jnp.eye(6, dtype=root.dtype)[:, :, None, None] * (1.0 - f)
    return JointSpaceInertia(tuple(ancestor), tuple(diag), tuple(root_dof), root)


# ---------------------------------------------------------------------------------------------------------
# qM = L^T D L, level by level (the deepest first): a DOF's row only updates its ancestors' entries


@stage
def _factor_joints(model, qM: JointSpaceInertia):
    """The joint DOFs' part of the factor, the deepest level first, and what remains of the roots' blocks."""
    lv = model.exact.levels
    depth = lv.depth
    diag = list(qM.diag)
    off = [list(x) if x is not None else None for x in qM.ancestor]    # the entries with the ancestors' DOFs
    rdof = list(qM.root_dof)
    S = qM.root
    diag_inv, L_anc, L_root = [None] * (depth + 1), [None] * (depth + 1), [None] * (depth + 1)
    for lvl in range(depth, 0, -1):
        dinv = 1.0 / diag[lvl]
        diag_inv[lvl] = dinv
        L_anc[lvl] = (None,) + tuple(off[lvl][up] * dinv for up in range(1, lvl))
        L_root[lvl] = rdof[lvl] * dinv
        for up in range(1, lvl):            # the level-`up` ancestor's diagonal, its row to its own ancestors
            slots = lv.below[lvl][up]
            L = L_anc[lvl][up]
            diag[up] = diag[up] - gather_sum(L * off[lvl][up], slots)
            for up2 in range(1, up):
                off[up][up2] = off[up][up2] - gather_sum(L * off[lvl][up2], slots)
            rdof[up] = rdof[up] - gather_sum(L[None] * rdof[lvl], slots)
        S = S - gather_sum(L_root[lvl][:, None] * rdof[lvl][None], lv.below[lvl][0])
    return tuple(diag_inv), tuple(L_anc), tuple(L_root), S


@stage
def _root_pivot(model, S, k, d_inv):
    """One pivot of a root's dense 6x6 block, as one operation on the whole remaining block (whose upper triangle is
    computed and never read): row k of L, and the block left for the DOFs before k."""
    Lk = S[k, :k] * d_inv                          # [k, n0, B]
    return S[:k, :k] - Lk[:, None] * S[k, None, :k], Lk


def factor_m(model, qM: JointSpaceInertia) -> Factor:
    """``qM = L^T D L`` (MuJoCo's ``mj_factorM``): the joints' DOFs from the leaves up, then each root's six (a
    chain), each part a stage."""
    diag_inv, L_anc, L_root, S = _factor_joints(model, qM)
    root_diag_inv, rows = [None] * 6, [None] * 6
    for k in range(5, -1, -1):
        root_diag_inv[k] = 1.0 / S[k, k]
        if k:
            S, rows[k] = _root_pivot(model, S, k, root_diag_inv[k])
    return Factor(diag_inv, L_anc, L_root, jnp.stack(root_diag_inv),
                  tuple(None if k == 0 else tuple(rows[k][i] for i in range(k)) for k in range(6)))


@stage
def solve_m(model, qLD: Factor, b: Dofs) -> Dofs:
    """``qM^-1 b`` with the factor (MuJoCo's ``mj_solveM``): ``L^T y = b`` from the leaves up, then
    ``L x = D^-1 y`` from the roots down."""
    lv = model.exact.levels
    depth = lv.depth
    y, yr = list(b.joint), b.root
    for lvl in range(depth, 0, -1):
        for up in range(1, lvl):
            y[up] = y[up] - gather_sum(qLD.ancestor[lvl][up] * y[lvl], lv.below[lvl][up])
        yr = yr - gather_sum(qLD.root_dof[lvl] * y[lvl][None], lv.below[lvl][0])
    yr = [yr[i] for i in range(6)]
    for k in range(5, -1, -1):
        for i in range(k):
            yr[i] = yr[i] - qLD.root_rows[k][i] * yr[k]
    xr = [None] * 6
    for k in range(6):
        xk = yr[k] * qLD.root_diag_inv[k]
        for i in range(k):
            xk = xk - qLD.root_rows[k][i] * xr[i]
        xr[k] = xk
    root = jnp.stack(xr)
    x = [None] * (depth + 1)
    for lvl in range(1, depth + 1):
        xl = y[lvl] * qLD.diag_inv[lvl]
        for up in range(1, lvl):
            xl = xl - qLD.ancestor[lvl][up] * take(x[up], lv.anc[lvl][up])
        x[lvl] = xl - sum0(qLD.root_dof[lvl] * take(root, lv.anc[lvl][0]))
    return Dofs(root, tuple(x))


# ---------------------------------------------------------------------------------------------------------
# the bias forces


@stage
def bias_wrenches(model, com: Com, inert: Inertia, qvel: tuple):
    """Each body's wrench of gravity and its velocity-product accelerations (zero joint accelerations), the
    forward pass of recursive Newton-Euler: ``f = m (a - g)`` and ``n = I alpha + w x I w + d x f`` about the root's
    CM (``d``: the body's CM from it), per level."""
    g = jnp.asarray([0.0, 0.0, model.gravity], jnp.float32)[:, None, None]

    def level(lvl, parent):
        w = com.w[lvl]
        if lvl == 0:
            alpha, acc = jnp.zeros_like(w), jnp.zeros_like(w)
        else:
            alpha_p, acc_p = parent[0], parent[1]
            wp, dp = at_parent(model, lvl, com.w[lvl - 1]), at_parent(model, lvl, com.offset[lvl - 1])
            axis, pivot = com.xaxis[lvl], com.xanchor[lvl]
            alpha = alpha_p + qvel[lvl] * cross(wp, axis)
            r = pivot - dp
            acc_pivot = acc_p + cross(alpha_p, r) + cross(wp, cross(wp, r))
            r = com.offset[lvl] - pivot
            acc = acc_pivot + cross(alpha, r) + cross(w, cross(w, r))
        f = inert.mass[lvl] * (acc + g)
        I = inert.ximat_inertia[lvl]
        n = _mv(I, alpha) + cross(w, _mv(I, w))
        return alpha, acc, f, n + cross(com.offset[lvl], f)

    out = walk(model, level)
    return [o[2] for o in out], [o[3] for o in out]


@stage
def project(model, com: Com, force: list, torque: list) -> Dofs:
    """Generalized forces of body wrenches (``force[l]``, ``torque[l]`` [3, n_l, B], the torque about the root's CM):
    summed over each subtree and projected on its DOF's motion, the backward pass of recursive Newton-Euler
    (``J^T f``)."""
    lv = model.exact.levels
    sums = walk(model, lambda lvl, children, f, n: (f, n) if children is None else (f + children[0], n + children[1]),
                force, torque, reverse=True)
    root = jnp.concatenate([sums[0][0], sums[0][1]]) * lv.free.astype(np.float32)[:, None]
    joint = tuple(None if lvl == 0 else dot(com.xaxis[lvl], sums[lvl][1] - cross(com.xanchor[lvl], sums[lvl][0]))
                  for lvl in range(lv.depth + 1))
    return Dofs(root, joint)


def rne(model, com: Com, inert: Inertia, qvel: tuple) -> Dofs:
    """The bias forces ``qfrc_bias`` [Dofs]: what the DOFs must exert against gravity, Coriolis and gyroscopic
    forces for zero acceleration (MuJoCo's ``mj_rne`` with ``flg_acc = 0``); ``qvel``: each level's joint rates."""
    return project(model, com, *bias_wrenches(model, com, inert, qvel))
