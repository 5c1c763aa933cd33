"""The exact pipeline's stages one by one (cpgjax/sim/exact/smooth.py) against MuJoCo C, on the exported MJCF of every
model in models/, at random poses and velocities.

Each model is drawn at random in MuJoCo's coordinates (its tree follows the file's joints; ours is rooted at the
tracked body), MuJoCo computes its stages in float64 (``mj_forward``), and ours, in float32, start from the same
generalized coordinates read off MuJoCo's data: the tracked body's CM position, orientation and velocities, and the
joint angles and rates.  The velocity coordinates differ (ours: the root's CM velocity and angular velocity in world
axes; MuJoCo's: its free joint's), related by ``u = T v`` with ``T`` from MuJoCo's Jacobians, so
``qM_mujoco = T^T qM T`` and ``qfrc_bias_mujoco = T^T (qfrc_bias + qM Tdot v)``.  Every tolerance is about 10x the
largest error measured over 32 draws of each model (float32 against float64), stated beside it.  One compiled
program per model (every stage in it), 8 draws each; the quadruped and the worm (a root with legs; a chain rooted in
its middle, whose velocity coordinates are not MuJoCo's) in the fast suite, the car and the hexapod marked slow.
"""

from __future__ import annotations

from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from cpgjax.crosscheck.mjcf import to_mjcf
from cpgjax.io.wl import load_model
from cpgjax.sim import initial_state
from cpgjax.sim.exact.levels import Dofs, to_levels
from cpgjax.sim.exact.smooth import com_pos, crb, factor_m, inertia, kinematics, rne, solve_m, subtree_com
from cpgjax.sim.rotation import quat_to_mat
from cpgjax.sim.state import ExactState

mujoco = pytest.importorskip("mujoco")

MODELS = Path(__file__).resolve().parents[3] / "models"
DRAWS = 8


def _dof_index(model):
    """Our DOFs in a dense order: each root's six (linear, angular), then each level's joints; for a joint DOF its
    file joint and the tree's sign."""
    lv = model.exact.levels
    n0 = len(lv.bodies[0])
    at, joint, sign = {}, [], []
    k = 6 * n0
    for lvl in range(1, lv.depth + 1):
        for i, (j, s) in enumerate(zip(lv.joint[lvl], lv.sign[lvl], strict=True)):
            at[lvl, i] = k
            joint.append(int(j))
            sign.append(float(s))
            k += 1
    return at, np.array(joint), np.array(sign), k


def _dense(model, qM) -> np.ndarray:
    """Our joint-space inertia (levels' layout) as a dense [nv, nv, B] matrix in :func:`_dof_index`'s order."""
    lv = model.exact.levels
    at, _, _, nv = _dof_index(model)
    B = qM.root.shape[-1]
    M = np.zeros((nv, nv, B))
    for r in range(len(lv.bodies[0])):
        M[6 * r:6 * r + 6, 6 * r:6 * r + 6] = qM.root[:, :, r]
    for lvl in range(1, lv.depth + 1):
        for i in range(len(lv.bodies[lvl])):
            k = at[lvl, i]
            M[k, k] = qM.diag[lvl][i]
            r = lv.anc[lvl][0][i]
            M[k, 6 * r:6 * r + 6] = M[6 * r:6 * r + 6, k] = qM.root_dof[lvl][:, i]
            for a in range(1, lvl):
                c = at[a, lv.anc[lvl][a][i]]
                M[k, c] = M[c, k] = qM.ancestor[lvl][a][i]
    return M


def _vector(model, x: Dofs) -> np.ndarray:
    lv = model.exact.levels
    parts = [np.asarray(x.root).transpose(1, 0, 2).reshape(-1, x.root.shape[-1])]
    parts += [np.asarray(x.joint[lvl]) for lvl in range(1, lv.depth + 1)]
    return np.concatenate(parts).astype(np.float64)


def _dofs(model, v: np.ndarray) -> Dofs:
    lv = model.exact.levels
    n0 = len(lv.bodies[0])
    root = jnp.asarray(v[:6 * n0].reshape(n0, 6, -1).transpose(1, 0, 2), jnp.float32)
    joint, k = [None], 6 * n0
    for lvl in range(1, lv.depth + 1):
        n = len(lv.bodies[lvl])
        joint.append(jnp.asarray(v[k:k + n], jnp.float32))
        k += n
    return Dofs(root, tuple(joint))


def _draw(model, mj, seed):
    """``DRAWS`` random states in MuJoCo's coordinates, MuJoCo's stages for each, and our coordinates read off them."""
    rng = np.random.default_rng(seed)
    d = mujoco.MjData(mj)
    lv = model.exact.levels
    roots = lv.bodies[0]
    body = [mujoco.mj_name2id(mj, mujoco.mjtObj.mjOBJ_BODY, n) for n in model.body_names]
    dof = [mj.jnt_dofadr[mujoco.mj_name2id(mj, mujoco.mjtObj.mjOBJ_JOINT, n)] for n in model.joint_names]
    qadr = [mj.jnt_qposadr[mujoco.mj_name2id(mj, mujoco.mjtObj.mjOBJ_JOINT, n)] for n in model.joint_names]
    _, joint, sign, nv = _dof_index(model)
    out = {k: [] for k in ("root", "angle", "rate", "xipos", "xmat", "w", "v", "M", "bias", "T", "Tdot_v",
                           "subtree_com")}
    for _ in range(DRAWS):
        qpos = mj.qpos0.copy()
        for jid in range(mj.njnt):
            a = mj.jnt_qposadr[jid]
            if mj.jnt_type[jid] == mujoco.mjtJoint.mjJNT_FREE:
                qpos[a:a + 3] = rng.uniform(-0.5, 0.5, 3) + [0.0, 0.0, 0.5]
                quat = rng.normal(size=4)
                qpos[a + 3:a + 7] = quat / np.linalg.norm(quat)
            else:
                qpos[a] = rng.uniform(-1.0, 1.0)
        d.qpos[:] = qpos
        d.qvel[:] = rng.normal(0.0, 1.0, mj.nv)
        mujoco.mj_forward(mj, d)
        vel = np.zeros((len(body), 6))
        for b, i in enumerate(body):
            mujoco.mj_objectVelocity(mj, d, mujoco.mjtObj.mjOBJ_BODY, i, vel[b], 0)     # (rot, lin) at the CM
        T, Tdot_v = np.zeros((nv, mj.nv)), np.zeros(nv)
        for r, b in enumerate(roots):
            jacp, jacr, djp, djr = (np.zeros((3, mj.nv)) for _ in range(4))
            mujoco.mj_jacBodyCom(mj, d, jacp, jacr, body[b])
            mujoco.mj_jacDot(mj, d, djp, djr, d.xipos[body[b]], body[b])
            T[6 * r:6 * r + 3], T[6 * r + 3:6 * r + 6] = jacp, jacr
            Tdot_v[6 * r:6 * r + 3], Tdot_v[6 * r + 3:6 * r + 6] = djp @ d.qvel, djr @ d.qvel
        for k, (j, s) in enumerate(zip(joint, sign, strict=True)):
            T[6 * len(roots) + k, dof[j]] = s
        M = np.zeros((mj.nv, mj.nv))
        mujoco.mj_fullM(mj, d, M)
        quat = d.xquat[[body[b] for b in roots]]
        out["root"].append(np.concatenate([d.xipos[[body[b] for b in roots]], quat, vel[roots, 3:], vel[roots, :3]], 1))
        out["angle"].append(d.qpos[qadr])
        out["rate"].append(d.qvel[dof])
        out["xipos"].append(d.xipos[body])
        out["xmat"].append(d.xmat[body].reshape(-1, 3, 3))
        out["w"].append(vel[:, :3])
        out["v"].append(vel[:, 3:])
        out["M"].append(M)
        out["bias"].append(d.qfrc_bias.copy())
        out["T"].append(T)
        out["Tdot_v"].append(Tdot_v)
        out["subtree_com"].append(d.subtree_com[body])
    return {k: np.stack(v, -1) for k, v in out.items()}, body


def _ours(model, ref, b):
    """Every stage at once, in one compiled program (float32)."""
    B = DRAWS

    def run(root, angle, rate, b):
        x, q, v, w = kinematics(model, (root[:3], root[3:7], root[7:10], root[10:13]), to_levels(model, angle),
                                to_levels(model, rate))
        state = initial_state(model, B)._replace(x=x, q=q, v=v, w=w, exact=ExactState(angle, rate))
        com = com_pos(model, state)
        inert = inertia(model, com)
        qM = crb(model, com, inert)
        return (x, quat_to_mat(q), v, w, qM, rne(model, com, inert, to_levels(model, rate)),
                solve_m(model, factor_m(model, qM), b), subtree_com(model, com, inert))

    root = np.moveaxis(ref["root"], 0, 1)                  # [13, n0, B]
    args = [jnp.asarray(a, jnp.float32) for a in (root, ref["angle"], ref["rate"])] + [b]
    # compiled at XLA's backend optimization level 0: half the compile time (3.7 s against 7.6 s for the quadruped,
    # load 8); the same float32 program, rounded otherwise in places
    run = jax.jit(run).lower(*args).compile(compiler_options={"xla_backend_optimization_level": 0})
    return jax.tree.map(lambda a: np.asarray(a, np.float64), run(*args))


def _tree_descendants(parent):
    out = [{i} for i in range(len(parent))]
    for i in range(len(parent)):
        j = parent[i]
        while j >= 0:
            out[j].add(i)
            j = parent[j]
    return out


def test_every_model_is_checked_here():
    """Every model in models/ is one of the cases below, or a variant of the quadruped whose exported MJCF is the
    quadruped's: the stiff one (its pivot springs, which MJCF has not, are all that differ) and the one whose feet
    grip (its friction bristle, which MJCF has not either).  Their stages are the quadruped's."""
    variants = ["quadruped-stiff.wl", "quadruped-grip.wl"]
    assert sorted(p.name for p in MODELS.glob("*.wl")) == sorted(CASES + variants)
    base = to_mjcf(load_model(MODELS / "quadruped.wl"))
    for name in variants:
        assert to_mjcf(load_model(MODELS / name, pipeline="exact")).replace(name, "quadruped.wl") == base, name


CASES = ["quadruped.wl", "worm.wl", "car.wl", "hexapod.wl"]


@pytest.fixture(scope="module", params=[pytest.param(c, marks=[pytest.mark.slow] if c in ("car.wl", "hexapod.wl")
                                                     else []) for c in CASES])
def case(request):
    model = load_model(MODELS / request.param, pipeline="exact")
    mj = mujoco.MjModel.from_xml_string(to_mjcf(model))
    ref, body = _draw(model, mj, seed=0)
    b = np.random.default_rng(1).normal(size=(_dof_index(model)[3], DRAWS))
    ours = _ours(model, ref, _dofs(model, b))
    return model, mj, ref, body, b, ours


def test_body_poses_and_velocities_are_mujocos(case):
    """kinematics: every body's CM (``xipos``), rotation (``xmat``) and velocities from the root's and the joints'."""
    model, _, ref, _, _, ours = case
    x, R, v, w = ours[:4]
    # measured at most 2.1e-7 m, 4.9e-7, 4.6e-7 m/s and 5.7e-7 rad/s (float32 rounding)
    assert np.abs(np.moveaxis(x, 0, 1) - ref["xipos"]).max() < 3e-6
    assert np.abs(np.moveaxis(R, (0, 1), (1, 2)) - ref["xmat"]).max() < 5e-6
    assert np.abs(np.moveaxis(v, 0, 1) - ref["v"]).max() < 5e-6
    assert np.abs(np.moveaxis(w, 0, 1) - ref["w"]).max() < 5e-6


def test_the_joint_space_inertia_is_mujocos_and_its_factor_solves_it(case):
    """crb (``qM`` against ``mj_fullM``), and factor_m + solve_m against a dense solve of our own ``qM``."""
    model, _, ref, _, b, ours = case
    M = _dense(model, ours[4])
    T, M_mj = ref["T"], ref["M"]
    mapped = np.stack([T[..., k].T @ M[..., k] @ T[..., k] for k in range(DRAWS)], -1)
    scale = np.abs(M_mj).max()
    assert np.abs(mapped - M_mj).max() < 1e-6 * scale        # measured at most 9.3e-8 of the largest entry
    x = _vector(model, ours[6])
    dense = np.stack([np.linalg.solve(M[..., k], b[:, k]) for k in range(DRAWS)], -1)
    assert np.abs(x - dense).max() < 2e-5 * np.abs(dense).max()   # measured at most 1.4e-6 of the largest component


def test_the_bias_forces_are_mujocos(case):
    """rne: ``qfrc_bias`` (gravity, Coriolis, gyroscopic) against MuJoCo's, through the change of velocity
    coordinates."""
    model, _, ref, _, _, ours = case
    M, c = _dense(model, ours[4]), _vector(model, ours[5])
    T = ref["T"]
    mapped = np.stack([T[..., k].T @ (c[:, k] + M[..., k] @ ref["Tdot_v"][:, k]) for k in range(DRAWS)], -1)
    assert np.abs(mapped - ref["bias"]).max() < 2e-6 * np.abs(ref["bias"]).max()   # measured at most 1.5e-7 of it


def test_the_subtrees_centres_of_mass_are_mujocos(case):
    """subtree_com, for each of our subtrees that is also one of MuJoCo's (the same bodies; the trees are rooted
    differently where the tracked body is not the file's first): always the whole robot's, at our root."""
    model, mj, ref, body, _, ours = case
    tree = model.exact.tree
    mj_body = {i - 1: b for b, i in enumerate(body)}              # MuJoCo's bodies (less the world) -> ours
    mj_below = _tree_descendants([int(mj.body_parentid[i]) - 1 if mj.body_parentid[i] else -1
                                  for i in range(1, mj.nbody)])
    theirs = {frozenset(mj_body[c] for c in below): mj_body[i] for i, below in enumerate(mj_below)}
    pairs = [(b, theirs[frozenset(below)]) for b, below in enumerate(_tree_descendants(list(tree.parent)))
             if frozenset(below) in theirs]
    assert tree.roots[0] in [b for b, _ in pairs]
    ours_b, theirs_b = (list(x) for x in zip(*pairs, strict=True))
    err = np.abs(np.moveaxis(ours[7], 0, 1)[ours_b] - ref["subtree_com"][theirs_b]).max()
    assert err < 3e-6                                            # measured at most 2.1e-7 m
