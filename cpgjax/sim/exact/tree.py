"""The kinematic tree of the exact-joint pipeline: generalized coordinates from a `.wl` model's joints.

The thesis's pipeline (`sim.springs`) keeps every body free and holds its joints with pivot springs (eq. 3.6).
The exact-joint pipeline (`sim.exact`) instead describes the robot by *generalized coordinates*:
each tree of bodies has a floating base (its root body's CM position and orientation, 6 velocity DOFs;
none if the root is ``Fixed``) and one angle per revolute joint, so that the joints hold exactly and the
step is no longer bound by the pivot springs' stiffness.

The tree comes from the joints and is rooted at the tracked body (``Track``); a joint written from child
to parent is walked the other way (its angle keeps the file's sign).  :class:`Levels` groups the bodies
by depth: `sim.exact` works one depth at a time, a root's six DOFs (3 linear, then 3 angular) above
its first level's joints, each joint's DOF above its children's (the sparsity its factorization keeps).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cpgjax.errors import DescriptionError


@dataclass(frozen=True, eq=False)
class Tree:
    """Static description of the kinematic forest (plain Python and numpy: compile-time constants)."""

    order: tuple[int, ...]        # bodies, parents before children
    parent: tuple[int, ...]       # [nb] parent body (-1 for a root)
    root: tuple[int, ...]         # [nb] the root of each body's tree
    roots: tuple[int, ...]        # the tree roots, in order
    free_root: tuple[bool, ...]   # [nb] for a root: has a floating base (6 DOFs)
    joint: tuple[int, ...]        # [nb] the joint that carries the body from its parent (-1 for a root)
    sign: np.ndarray              # [nj] +1 when the joint's body_b is the tree child, -1 when walked the other way
    r_parent: np.ndarray          # [3, nj] the pivot in the tree parent's frame, from its CM
    r_child: np.ndarray           # [3, nj] the pivot in the tree child's frame, from its CM
    axis: np.ndarray              # [3, nj] the joint axis (the same in both frames)
    axis_index: tuple[int, ...]   # [nj] 0, 1, 2 for an axis along x, y, z


def build_tree(model, desc) -> Tree:
    """The forest of ``model`` (built from ``desc``) for the exact-joint pipeline; :class:`DescriptionError`
    (``path:line``) for what it cannot express."""
    path = desc.path
    nb, nj = model.nb, model.nj
    names = model.body_names
    jd = desc.joints
    adj: dict[int, list[tuple[int, int]]] = {b: [] for b in range(nb)}   # body -> [(joint, other body)]
    for k in range(nj):
        a, b = int(model.j_a[k]), int(model.j_b[k])
        adj[a].append((k, b))
        adj[b].append((k, a))
    parent, joint, root = [-1] * nb, [-1] * nb, [-1] * nb
    sign = np.ones(nj)
    order: list[int] = []
    roots: list[int] = []
    # a child's tree parent must be the joint's other body; roots: the tracked body, then each
    # remaining tree's forest root (the body the file places the others from)
    forest_root = [b for b in range(nb) if b not in set(int(x) for x in model.j_b)]
    starts = [model.track] + [b for b in forest_root if b != model.track] + list(range(nb))
    seen = set()
    for r in starts:
        if r in seen:
            continue
        roots.append(r)
        seen.add(r)
        root[r] = r
        stack = [r]
        while stack:          # depth first, children in file order
            b = stack.pop()
            order.append(b)
            kids = []
            for k, o in adj[b]:
                if o in seen:
                    if joint[b] != k:
                        raise DescriptionError(path, jd[k].line, f"Joint '{jd[k].name}' closes a loop of joints; "
                                                                 "exact joints need a tree: remove it, or use "
                                                                 "Pipeline springs")
                    continue
                seen.add(o)
                parent[o], joint[o], root[o] = b, k, r
                sign[k] = 1.0 if int(model.j_b[k]) == o else -1.0
                kids.append(o)
            stack.extend(reversed(kids))
    for b in range(nb):
        if model.fixed[b] and parent[b] >= 0:
            k = joint[b]
            raise DescriptionError(path, jd[k].line, f"Joint '{jd[k].name}': body '{names[b]}' is Fixed but hangs "
                                                     f"from '{names[parent[b]]}' in the tree rooted at "
                                                     f"'{names[root[b]]}'; exact joints need a Fixed body at the "
                                                     "root of its tree (Track it), or use Pipeline springs")
    # pivots relative to each body's CM, in its frame: the middle of the joint's two pivot-spring ends
    pa = 0.5 * (model.pt_local[:, model.sp_a[0::2]] + model.pt_local[:, model.sp_a[1::2]])   # on j_a
    pb = 0.5 * (model.pt_local[:, model.sp_b[0::2]] + model.pt_local[:, model.sp_b[1::2]])   # on j_b
    r_parent = np.where(sign[None] > 0, pa, pb)
    r_child = np.where(sign[None] > 0, pb, pa)
    axis_index = tuple("XYZ".index(j.axis.upper()) for j in jd)
    return Tree(order=tuple(order), parent=tuple(parent), root=tuple(root), roots=tuple(roots),
                free_root=tuple(parent[b] < 0 and not bool(model.fixed[b]) for b in range(nb)),
                joint=tuple(joint), sign=sign, r_parent=r_parent, r_child=r_child,
                axis=np.asarray(model.j_axis, float), axis_index=axis_index)


@dataclass(frozen=True, eq=False)
class Levels:
    """The tree by depth, for straight-line code whose size grows with the depth, not the number of bodies.

    Level 0 holds the roots, level l the bodies l joints below theirs.  Every array is static (numpy);
    ``items`` index a body within its level.
    """

    bodies: tuple[np.ndarray, ...]     # [n_l] the bodies of each level
    parent: tuple[np.ndarray, ...]     # [n_l] the parent's item in level l-1 (level 0: unused)
    anc: tuple[tuple[np.ndarray, ...], ...]   # anc[l][a] [n_l]: the item of the level-a ancestor (a < l)
    joint: tuple[np.ndarray, ...]      # [n_l] the joint carrying each body (level 0: -1)
    sign: tuple[np.ndarray, ...]       # [n_l] +-1 (see Tree.sign)
    axis_index: tuple[np.ndarray, ...]  # [n_l]
    r_parent: tuple[np.ndarray, ...]   # [3, n_l]
    r_child: tuple[np.ndarray, ...]    # [3, n_l]
    free: np.ndarray                   # [n_0] the root has a floating base
    below: tuple[tuple[np.ndarray, ...], ...]  # below[l][a] [k, n_a]: level-l descendants of each level-a item
    level_of: np.ndarray               # [nb]
    item_of: np.ndarray                # [nb]

    @property
    def depth(self) -> int:
        return len(self.bodies) - 1


def pad_slots(groups: list[list[int]]) -> np.ndarray:
    """Lists of indices, padded with -1 into a [k, n] array (k = the longest list, at least 1)."""
    k = max([len(g) for g in groups] + [1])
    out = -np.ones((k, len(groups)), np.int64)
    for i, g in enumerate(groups):
        out[:len(g), i] = g
    return out


def build_levels(tree: Tree) -> Levels:
    nb = len(tree.parent)
    depth = [0] * nb
    for b in tree.order:
        if tree.parent[b] >= 0:
            depth[b] = depth[tree.parent[b]] + 1
    L = max(depth) + 1 if nb else 1
    bodies = [np.array([b for b in tree.order if depth[b] == lv], np.int64) for lv in range(L)]
    level_of = np.array(depth, np.int64)
    item_of = np.zeros(nb, np.int64)
    for lv in range(L):
        item_of[bodies[lv]] = np.arange(len(bodies[lv]))

    def ancestor(b, lv):
        while depth[b] > lv:
            b = tree.parent[b]
        return b

    parent, anc, joint, sign, axis_index, rp, rc, below = [], [], [], [], [], [], [], []
    for lv in range(L):
        bs = bodies[lv]
        parent.append(np.array([item_of[tree.parent[b]] if lv else -1 for b in bs], np.int64))
        anc.append(tuple(np.array([item_of[ancestor(b, a)] for b in bs], np.int64) for a in range(lv)))
        js = np.array([tree.joint[b] for b in bs], np.int64)
        joint.append(js)
        if lv:
            sign.append(tree.sign[js])
            axis_index.append(np.array([tree.axis_index[k] for k in js], np.int64))
            rp.append(tree.r_parent[:, js])
            rc.append(tree.r_child[:, js])
        else:
            sign.append(np.ones(len(bs)))
            axis_index.append(np.zeros(len(bs), np.int64))
            rp.append(np.zeros((3, len(bs))))
            rc.append(np.zeros((3, len(bs))))
        below.append(tuple(pad_slots([[i for i, d in enumerate(bs) if ancestor(d, a) == up] for up in bodies[a]])
                           for a in range(lv)))
    return Levels(bodies=tuple(bodies), parent=tuple(parent), anc=tuple(anc), joint=tuple(joint), sign=tuple(sign),
                  axis_index=tuple(axis_index), r_parent=tuple(rp), r_child=tuple(rc),
                  free=np.array([tree.free_root[b] for b in bodies[0]], bool), below=tuple(below),
                  level_of=level_of, item_of=item_of)


@dataclass(frozen=True, eq=False)
class ExactModel:
    """The exact pipeline's part of a `~cpgjax.sim.model.Model`: its tree, the tree by depth, and whether its
    step's stages are computed once into memory (`sim.tricks.keep`; False only to measure what that buys,
    ``cpgjax bench --tricks``: the values are the same)."""

    tree: Tree
    levels: Levels
    materialize: bool = True


def build_exact(model, desc, materialize: bool = True) -> ExactModel:
    """The exact pipeline's part of ``model`` (built from ``desc``; :class:`DescriptionError` for what exact joints
    cannot express)."""
    tree = build_tree(model, desc)
    return ExactModel(tree=tree, levels=build_levels(tree), materialize=materialize)
