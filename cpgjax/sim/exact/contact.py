"""The ground on exact joints: eq. 3.7's spring and damper and the friction bristle, solved implicitly and coupled
over the whole robot through the joint-space inertia.

A touching vertex pushes with ``f = A d n - k z_t - (B n n^T + b' (I - n n^T)) v'`` (`sim.contact`'s law: the normal
spring and the bristle explicit, their dampers on the vertex's velocity at the end of the step,
``v' = J (u + dt qacc)``).  The dampers go into the joint-space inertia,
``(qM + dt D + dt J^T K J) qacc = tau + J^T (a - K J u)``, as the servos' do: one solve with the factor gives every
vertex's force together, however many push at once and through whatever joints (no per-vertex estimate of the
others' push).  ``J^T K J`` keeps the tree's sparsity (a vertex moves only with its ancestors' DOFs), so the same
factorization solves it.

Which vertices push and how much friction the cone allows are taken from the stick law's forces at the start of
the step (``v' = v``): a vertex pushes while ``A d - B v_n > 0``, and a second solve releases the vertices the
first would have pulled (``A d - B v'_n < 0``: a foot lifting off; the trot had such a vertex in 70 of 5,000
steps, up to 34 N, without it); its bristle (spring and damper) acts in full while its pull is within
``mu_s f_n``, else scaled by ``lam = mu_d f_n / |f_t|``, so that the friction is the cone's share of the bristle's
pull and changes continuously as a foot starts to slip.  A hard switch between a sticking (implicit) and a
sliding (explicit) foot made the walk chaotic (the trot's score under 1e-6 gene jitter: sd 0.0010-0.0013, against
0.0001 with ``lam``), and taking ``lam`` again from the first solve's forces made it less steady (sd 0.0008).  At
rest ``v' = 0``, so ``f_n = A d`` exactly and the penetration is ``m g / (A contacts)``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from cpgjax.sim.contact import bristle, contact_frame, friction, ground, trail_anchor
from cpgjax.sim.exact.levels import Dofs, dofs_add, dofs_axpy, state_dofs
from cpgjax.sim.exact.smooth import com_vel, factor_m, project, solve_m
from cpgjax.sim.exact.tree import pad_slots
from cpgjax.sim.exact.types import Com, JointSpaceInertia
from cpgjax.sim.rotation import cross, dot
from cpgjax.sim.tricks import gather_sum, mul, rot_const, stage, take


class Points(NamedTuple):
    """The contact vertices [3, nc, B]: from their body's CM (``r``), from their tree root's CM (``p``), in the
    world (``world``)."""

    r: jax.Array
    p: jax.Array
    world: jax.Array


def _bodies(model):
    return model.pt_body[model.ct_pt]


@stage
def contact_points(model, com: Com) -> Points:
    """Where the contact vertices are, from the bodies' poses."""
    lv = model.exact.levels
    cb = _bodies(model)
    r = rot_const(take(com.body_xmat, cb), model.pt_local[:, model.ct_pt])
    p = take(com.body_offset, cb) + r
    root_item = np.array([lv.item_of[model.exact.tree.root[b]] for b in cb])
    return Points(r, p, p + take(com.root_com, root_item))


def _vertex_velocities(model, pts: Points, w, v):
    """Vertex velocities [3, nc, B] from body velocities [3, nb, B]."""
    cb = _bodies(model)
    return take(v, cb) + cross(take(w, cb), pts.r)


def _wrenches(model, pts: Points, f):
    """Body wrenches per level of vertex forces f [3, nc, B]: the force, and its torque about the root's CM (the
    vertices summed level by level, no concatenation per slot)."""
    cb = _bodies(model)
    by_level = [pad_slots([list(np.nonzero(cb == b)[0]) for b in bs]) for bs in model.exact.levels.bodies]
    n = cross(pts.p, f)
    return [gather_sum(f, s) for s in by_level], [gather_sum(n, s) for s in by_level]


@dataclass(frozen=True)
class ContactJacobian:
    """Each vertex's Jacobian along the terrain frame's directions ``e`` (the normal ``n``, ``t1``, ``t2``): ``w_e = (e,
    p x e)`` on its root's six DOFs (p: the vertex from the root's CM) and ``j_e = e . (a x (p - pivot))`` on each
    joint above it.  On flat ground the directions are the world's axes and the zero entries of ``w_e`` are None
    (left out)."""

    w: tuple            # [e] six entries each: arrays [nc, B], 1.0 or None
    normal: int         # which e is the normal
    joint: dict         # [a] [e] [nc, B]: on the joint of each vertex's level-a ancestor (0 where it has none)
    slots: dict         # [a] the vertices of each level-a item's subtree (static, -1 padded)


def contact_jacobian(model, com: Com, pts: Points, fr) -> ContactJacobian:
    lv = model.exact.levels
    cb = _bodies(model)
    level, item = lv.level_of[cb], lv.item_of[cb]
    p = pts.p
    if fr.n is None:                            # (e components, p x e), per axis x, y, z; n is z
        w = ((1.0, None, None, None, p[2], -p[1]), (None, 1.0, None, -p[2], None, p[0]),
             (None, None, 1.0, p[1], -p[0], None))
        normal, dirs = 2, [0, 1, 2]
    else:
        w, dirs = [], [fr.n, fr.t1, fr.t2]
        for e in dirs:
            pe = cross(p, e)
            w.append((e[0], e[1], e[2], pe[0], pe[1], pe[2]))
        w, normal = tuple(w), 0
    anc_item, joint = {}, {}
    for up in range(lv.depth + 1):
        items = np.array([(lv.anc[lvl][up][i] if up < lvl else i) if up <= lvl else -1
                          for lvl, i in zip(level, item, strict=True)], np.int64)
        anc_item[up] = items
        if up == 0:
            continue
        mask = items >= 0
        at = np.maximum(items, 0)
        c = cross(take(com.xaxis[up], at), p - take(com.xanchor[up], at))
        if not mask.all():
            c = c * mask.astype(np.float32)[:, None]
        joint[up] = [c[e] if isinstance(e, int) else dot(c, e) for e in dirs]
    slots = {up: pad_slots([list(np.nonzero(anc_item[up] == b)[0]) for b in range(len(lv.bodies[up]))])
             for up in range(lv.depth + 1)}
    return ContactJacobian(w, normal, joint, slots)


@stage
def _damped(model, qM: JointSpaceInertia, jac: ContactJacobian, beta, gamma) -> JointSpaceInertia:
    """``qM + J^T (beta I + gamma n n^T) J`` (``beta``, ``gamma`` [nc, B]): the contact dampers made implicit, as three
    rank-one terms per vertex, ``sum_e kappa_e j_e j_e^T`` over the terrain frame's directions (the normal:
    ``beta + gamma``; the tangents: ``beta``)."""
    lv = model.exact.levels
    kappas = [beta + gamma if e == jac.normal else beta for e in range(3)]
    root = [[None] * 6 for _ in range(6)]
    for k_e, w in zip(kappas, jac.w, strict=True):
        for i in range(6):
            for j in range(i, 6):
                t = mul(mul(k_e, w[i]), w[j])
                if t is not None:
                    root[i][j] = t if root[i][j] is None else root[i][j] + t
    zero = jnp.zeros_like(beta)
    upper = {(i, j): gather_sum(root[i][j] if root[i][j] is not None else zero, jac.slots[0])
             for i in range(6) for j in range(i, 6)}
    c_root = jnp.stack([jnp.stack([upper[min(i, j), max(i, j)] for j in range(6)]) for i in range(6)])
    if not lv.free.all():
        c_root = c_root * lv.free.astype(np.float32)[:, None]
    ancestor, diag, root_dof = [None], [None], [None]
    for lvl in range(1, lv.depth + 1):
        kj = [k_e * j_e for k_e, j_e in zip(kappas, jac.joint[lvl], strict=True)]
        diag.append(gather_sum(sum(kj[e] * jac.joint[lvl][e] for e in range(3)), jac.slots[lvl]))
        ancestor.append((None,) + tuple(gather_sum(sum(kj[e] * jac.joint[up][e] for e in range(3)), jac.slots[lvl])
                                        for up in range(1, lvl)))
        r = []
        for i in range(6):
            t = None
            for e in range(3):
                x = mul(kj[e], jac.w[e][i])
                if x is not None:
                    t = x if t is None else t + x
            r.append(gather_sum(t if t is not None else zero, jac.slots[lvl]))
        r = jnp.stack(r)
        free = lv.free[lv.anc[lvl][0]]
        root_dof.append(r if free.all() else r * free.astype(np.float32)[:, None])
    damping = JointSpaceInertia(tuple(ancestor), tuple(diag), tuple(root_dof), c_root)
    return jax.tree.map(jnp.add, qM, damping)


@stage
def _at_start(model, state, pts: Points, depth, fr, A):
    """The law's explicit part at the start of the step: the normal spring's push ``A d``, the bristles' stretch
    along the ground, and the vertices' velocities in the terrain frame."""
    _, z_1, z_2 = fr.comp(pts.world - state.anchor)
    fa = jnp.where(depth > 0, A * depth, 0.0)
    v_start = fr.comp(_vertex_velocities(model, pts, state.w, state.v))
    return fa, z_1, z_2, v_start


@stage
def _modes(model, f, touch, mu_s, mu_d):
    """Who pushes, and how much of the bristle's pull the friction cone allows (``lam``)."""
    f_n, f_1, f_2 = f
    push = touch & (f_n > 0.0)
    ft = jnp.sqrt(f_1 * f_1 + f_2 * f_2 + 1e-20)
    lam = jnp.where(push, jnp.where(ft <= mu_s * f_n, 1.0, mu_d * f_n / ft), 0.0)
    return push.astype(f_n.dtype), lam


def contact(model, state, com: Com, qM: JointSpaceInertia, qfrc: Dofs, var=None):
    """The step's generalized accelerations with the ground solved implicitly (``qfrc``: every other generalized
    force, ``qM``: the joint-space inertia with the servos' and limits' dampers); the bristles' new anchors and the
    vertices' normal forces [nc, B]."""
    dt = model.dt
    pts = contact_points(model, com)
    u = state_dofs(model, state)
    depth, fr = contact_frame(model, pts.world, var)
    touch = depth > 0
    A, B = ground(model, var)
    kb, bp = bristle(model, var)
    mu_s, mu_d = friction(model, var)
    fa, z_1, z_2, v_start = _at_start(model, state, pts, depth, fr, A)
    jac = contact_jacobian(model, com, pts, fr)

    def law(vel):                               # the stick law's forces (n, t1, t2) at end-of-step velocities
        v_n, v_1, v_2 = vel
        return fa - B * v_n, -kb * z_1 - bp * v_1, -kb * z_2 - bp * v_2

    def solve(push, lam):
        beta = dt * bp * lam                    # dt K = beta I + gamma n n^T
        gamma = dt * B * push - beta
        qLD = factor_m(model, _damped(model, qM, jac, beta, gamma))
        f0 = fr.world(push * f_start[0], lam * f_start[1], lam * f_start[2])
        qacc = solve_m(model, qLD, dofs_add(qfrc, project(model, com, *_wrenches(model, pts, f0))))
        w_1, v_1 = com_vel(model, com, dofs_axpy(u, dt, qacc))
        return qacc, law(fr.comp(_vertex_velocities(model, pts, w_1, v_1)))

    f_start = law(v_start)
    push, lam = _modes(model, f_start, touch, mu_s, mu_d)
    push, lam, qacc, f = _release(solve, push, lam, qfrc)
    f_n = push * f[0]
    anchor = trail_anchor(model, fr, pts.world, state.anchor, (z_1, z_2), touch, lam >= 1.0, f_n, var)
    return qacc, anchor, f_n


def _release(solve, push, lam, qfrc):
    """``solve(push, lam)``, then once more with the vertices it would have pulled released (the ground never
    pulls), the second pass only in the steps where some robot of the batch pulls a vertex.

    Why a loop: the release is needed in few steps (the trot: 70 of 5,000), and a second solve in every step
    was a third of the step's kernels at the GA's 10 robots per device.  Both passes run the one compiled body, so
    a robot that releases nothing gets the same bits whether or not a neighbour in its batch makes the loop take a
    second pass (batch-size independence), and the solve is compiled once (a ``cond`` around a second copy took
    15 % more CPU to compile and the thesis-scale GA 7 % more CPU to run).  The initial carry only gives the loop
    its shapes; the first pass overwrites it.
    """
    def body(c):
        k, push, lam, _, f = c
        held = jnp.where(k > 0, (f[0] > 0.0).astype(lam.dtype), 1.0)
        push, lam = push * held, lam * held
        qacc, f = solve(push, lam)
        return k + 1, push, lam, qacc, f

    def again(c):
        k, push, _, _, f = c
        return (k == 0) | ((k == 1) & jnp.any((push > 0.0) & (f[0] <= 0.0)))

    qacc0, f0 = jax.tree.map(jnp.zeros_like, qfrc), (jnp.zeros_like(lam),) * 3    # shapes only: not read
    _, push, lam, qacc, f = jax.lax.while_loop(again, body, (jnp.int32(0), push, lam, qacc0, f0))
    return push, lam, qacc, f
