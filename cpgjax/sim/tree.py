"""The kinematic tree of the exact-joint pipeline: generalized coordinates from a `.wl` model's joints.

The thesis's pipeline (`sim.step`) keeps every body free and holds its joints with pivot springs (eq. 3.6).
The exact-joint pipeline (`sim.articulated`) instead describes the robot by *generalized coordinates*:
each tree of bodies has a floating base (its root body's CM position and orientation, 6 velocity DOFs;
none if the root is ``Fixed``) and one angle per revolute joint, so that the joints hold exactly and the
step is no longer bound by the pivot springs' stiffness.

The tree comes from the joints and is rooted at the tracked body (``Track``); a joint written from child
to parent is walked the other way (its angle keeps the file's sign).  DOFs are numbered tree by tree:
the root's six (3 linear, then 3 angular) first, then the joints in depth-first order, so that every
DOF's parent comes before it (the sparsity that `sim.articulated`'s factorization keeps).
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
    nv: int                       # velocity DOFs
    dof_parent: tuple[int, ...]   # [nv] parent DOF (-1 for none)
    body_dof: tuple[int, ...]     # [nb] the last DOF that moves the body (-1: a fixed root)
    joint_dof: tuple[int, ...]    # [nj] the DOF of each joint
    root_dof: tuple[int, ...]     # [nb] for a free root: its first DOF (-1 otherwise)

    def ancestors(self, dof: int) -> list[int]:
        """The DOFs above ``dof``, nearest first."""
        out, d = [], self.dof_parent[dof]
        while d >= 0:
            out.append(d)
            d = self.dof_parent[d]
        return out

    def path(self, body: int) -> list[int]:
        """Every DOF that moves ``body``, from its own up to its root's first (nearest first)."""
        d = self.body_dof[body]
        return [] if d < 0 else [d, *self.ancestors(d)]


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
    # DOFs
    dof_parent: list[int] = []
    body_dof, root_dof, joint_dof = [-1] * nb, [-1] * nb, [-1] * nj
    for b in order:
        if parent[b] < 0:
            if not model.fixed[b]:
                first = len(dof_parent)
                dof_parent.extend([-1] + [first + i for i in range(5)])
                root_dof[b] = first
                body_dof[b] = first + 5
        else:
            k = joint[b]
            joint_dof[k] = len(dof_parent)
            dof_parent.append(body_dof[parent[b]])
            body_dof[b] = joint_dof[k]
    return Tree(order=tuple(order), parent=tuple(parent), root=tuple(root), roots=tuple(roots),
                free_root=tuple(parent[b] < 0 and not bool(model.fixed[b]) for b in range(nb)),
                joint=tuple(joint), sign=sign, r_parent=r_parent, r_child=r_child,
                axis=np.asarray(model.j_axis, float), axis_index=axis_index, nv=len(dof_parent),
                dof_parent=tuple(dof_parent), body_dof=tuple(body_dof), joint_dof=tuple(joint_dof),
                root_dof=tuple(root_dof))
