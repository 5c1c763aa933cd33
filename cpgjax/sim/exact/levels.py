"""The tree walked level by level, and vectors over the generalized velocities in the levels' layout.

Every algorithm of the exact pipeline walks the tree, and the bodies at one depth (the four hips, the four
knees) are independent of each other: each depth is one set of ``[3, n_l, B]`` array operations (`sim.exact.tree.
Levels`), so the program grows with the tree's depth, not with its number of bodies.  :func:`walk` is the one
walk from the roots to the leaves (each level reads its parent's values) and back (each level adds its
children's), as MJX's ``scan.body_tree``; sums over a body's children use static slots in a fixed order, so a
robot's result does not depend on the batch it is in.
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from cpgjax.sim.tricks import gather_sum, keep, take


def walk(model, fn, *per_level, reverse: bool = False, keep_each: bool = False) -> list:
    """``out[l] = fn(l, carry, *args_l)`` for every level ``l``; ``per_level``: lists of each level's arguments.

    From the roots (``reverse=False``): ``carry`` is the level above's ``out`` taken at each item's parent (None at
    level 0).  From the leaves (``reverse=True``): ``carry`` is the sum of the level below's ``out`` over each
    item's children (zero for an item without; None at the deepest level).  ``keep_each``: each level's ``out``
    below the roots is computed once into memory (:func:`~cpgjax.sim.tricks.keep`) before the next level
    reads it.
    """
    lv = model.exact.levels
    depth = lv.depth
    out = [None] * (depth + 1)
    for lvl in (range(depth, -1, -1) if reverse else range(depth + 1)):
        if reverse:
            carry = None if lvl == depth else \
                jax.tree.map(lambda x, s=lv.below[lvl + 1][lvl]: gather_sum(x, s), out[lvl + 1])
        else:
            carry = None if lvl == 0 else jax.tree.map(lambda x, p=lv.parent[lvl]: take(x, p), out[lvl - 1])
        out[lvl] = fn(lvl, carry, *(a[lvl] for a in per_level))
        if keep_each and lvl:
            out[lvl] = keep(out[lvl], model.exact.materialize)
    return out


def at_parent(model, lvl, x):
    """Level ``lvl - 1``'s ``x`` [..., n_{l-1}, B] at each level-``lvl`` item's parent."""
    return take(x, model.exact.levels.parent[lvl])


class Dofs(NamedTuple):
    """A vector over the generalized velocities in the levels' layout (velocities, accelerations, forces).

    ``root`` [6, n0, B]: each tree root's six DOFs, its CM's linear velocity then its angular velocity (world
    axes); ``joint[l]`` [n_l, B]: the joint DOFs of level l, in the tree's sign (``joint[0]`` is None).
    """

    root: jax.Array
    joint: tuple


def dofs_add(a: Dofs, b: Dofs) -> Dofs:
    """``a + b`` (``b.root`` may be None: zero)."""
    root = a.root if b.root is None else a.root + b.root
    return Dofs(root, tuple(x if y is None else x + y for x, y in zip(a.joint, b.joint, strict=True)))


def dofs_axpy(x: Dofs, a, y: Dofs) -> Dofs:
    """``x + a y``."""
    return jax.tree.map(lambda u, v: u + a * v, x, y)


def to_levels(model, x_joint) -> tuple:
    """A per-joint array [nj, B] (the file's order and sign) as each level's joint DOFs (the tree's sign)."""
    lv = model.exact.levels
    return (None,) + tuple(take(x_joint, lv.joint[lvl]) * jnp.asarray(lv.sign[lvl], x_joint.dtype)[:, None]
                           for lvl in range(1, lv.depth + 1))


def from_levels(model, x: tuple):
    """Each level's joint DOFs (the tree's sign) as [nj, B] in the file's order and sign (None without joints)."""
    lv = model.exact.levels
    if not lv.depth:
        return None
    js = np.concatenate([lv.joint[lvl] for lvl in range(1, lv.depth + 1)])
    inv = np.empty_like(js)
    inv[js] = np.arange(len(js))
    cat = jnp.concatenate([x[lvl] * jnp.asarray(lv.sign[lvl], x[lvl].dtype)[:, None] for lvl in range(1, lv.depth + 1)])
    return take(cat, inv)


def from_level_items(model, per_level: list):
    """Each level's [..., n_l, B] as one [..., nb, B] in the bodies' order."""
    lv = model.exact.levels
    order = np.concatenate(lv.bodies)
    inv = np.empty_like(order)
    inv[order] = np.arange(len(order))
    return take(jnp.concatenate(per_level, axis=1), inv)


def state_dofs(model, state) -> Dofs:
    """The state's generalized velocities: the roots' CM velocities and angular velocities, the joints' rates."""
    roots = model.exact.levels.bodies[0]
    return Dofs(jnp.concatenate([take(state.v, roots), take(state.w, roots)]), to_levels(model, state.exact.rate))
