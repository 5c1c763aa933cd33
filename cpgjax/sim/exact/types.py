"""What the stages of the exact pipeline compute, as typed containers (pytrees) in the levels' layout.

Per-level fields are tuples indexed by level (``x[l]`` [..., n_l, B]); an entry that level 0 (the roots) has
not is None.  Vectors over the generalized velocities are `sim.exact.levels.Dofs`.  Symbols follow MuJoCo's
where they mean the same (``xmat``, ``xaxis``, ``xanchor``, ``cinert``, ``qM``, ``qLD``, ``qLDiagInv``): the motion
of a joint's DOF (MuJoCo's ``cdof``) is ``(xaxis, xanchor x xaxis)``, its angular and linear parts about the
tree root's CM.  Unlike MuJoCo's, every spatial quantity here is taken about the tree root's CM (MuJoCo's:
about the subtree's centre of mass), in world axes.
"""

from __future__ import annotations

from typing import NamedTuple

import jax


class Com(NamedTuple):
    """The bodies' poses and velocities about their tree root's CM (`smooth.com_pos`)."""

    body_xmat: jax.Array     # [3, 3, nb, B] every body's rotation (the bodies' order)
    body_offset: jax.Array   # [3, nb, B] every body's CM from its tree root's CM
    root_com: jax.Array      # [3, n0, B] the tree roots' CMs (world)
    xmat: tuple              # [l] [3, 3, n_l, B] rotations
    offset: tuple            # [l] [3, n_l, B] CMs from the tree root's CM
    w: tuple                 # [l] [3, n_l, B] angular velocities
    v: tuple                 # [l] [3, n_l, B] CM velocities
    xaxis: tuple             # [l] [3, n_l, B] the joint's axis (level 0: None)
    xanchor: tuple           # [l] [3, n_l, B] the joint's pivot from the tree root's CM (level 0: None)


class Inertia(NamedTuple):
    """Each body's mass and inertia (`smooth.inertia`): its own, and about its tree root's CM."""

    mass: tuple              # [l] [n_l, 1 | B] masses (per robot with a Variation's mass scale)
    ximat_inertia: tuple     # [l] [3, 3, n_l, B] inertia about the body's CM, in world axes
    cinert: tuple            # [l] (inertia about the root's CM [3, 3, n_l, B], mass x offset [3, n_l, B],
    #                               mass [n_l, B])


class JointSpaceInertia(NamedTuple):
    """The joint-space inertia ``qM`` in the levels' layout: only the entries the tree's sparsity keeps (a DOF
    and its ancestors').  Joint DOFs are in the tree's sign; the roots' six DOFs are (linear, angular)."""

    ancestor: tuple          # [l][a] [n_l, B] a level-l joint DOF's entry with its level-a ancestor's (1 <= a < l)
    diag: tuple              # [l] [n_l, B] a joint DOF's diagonal entry
    root_dof: tuple          # [l] [6, n_l, B] a joint DOF's entries with its tree root's six DOFs
    root: jax.Array          # [6, 6, n0, B] the roots' blocks


class Factor(NamedTuple):
    """``qM = L^T D L`` in the same layout (`smooth.factor_m`, as MuJoCo's ``qLD``): the unit lower triangle ``L``
    by its off-diagonal entries and ``D`` by its inverse (``qLDiagInv``); no fill-in."""

    diag_inv: tuple          # [l] [n_l, B] 1 / D of a joint DOF
    ancestor: tuple          # [l][a] [n_l, B] L to its level-a ancestor's DOF
    root_dof: tuple          # [l] [6, n_l, B] L to its tree root's six DOFs
    root_diag_inv: jax.Array  # [6, n0, B] 1 / D of the roots' six DOFs
    root_rows: tuple         # [k][i] [n0, B] L's entry (k, i < k) within a root's six DOFs (k = 0: None)
