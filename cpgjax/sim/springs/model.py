"""The springs pipeline's part of a `~cpgjax.sim.model.Model`: what its step precomputes from the bodies and joints.

Every point (pivot-spring end, contact vertex) gets a conservative effective mass for the implicit dampers
(mass splitting): ``1/m_eff <= n_b (1/m + |r|^2 / I_min)``, ``n_b`` the points sharing its body, so that the
local updates cannot add up to an overshoot (docs/simulator.md, *Implicit dampers, explicit springs*).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cpgjax.sim.description import DescriptionError


@dataclass(frozen=True, eq=False)
class SpringsModel:
    """The springs pipeline's settings and static arrays (numpy: compile-time constants)."""

    alpha: float             # the pivot springs' stiffness [N/m] (eq. 3.6; the .wl file's JointSpring)
    beta: float              # and their damping [N s/m]
    pt_src: np.ndarray       # [npt] where each point's force comes from in [spring a-ends, b-ends, contacts]
    sp_inv_meff: np.ndarray  # [ns] conservative 1/effective mass of each pivot spring, for its implicit damper
    j_inv_ieff: np.ndarray   # [nj] a.(Ia^-1 + Ib^-1).a, for the implicit joint dampers (servo, limits)


def build_springs(model, alpha: float, beta: float) -> SpringsModel:
    """The springs pipeline's part of ``model``, its pivot springs ``alpha``, ``beta`` (eq. 3.6);
    :class:`DescriptionError` when a point's effective mass overflows (a pivot or contact vertex too far from its
    body's CM for its inertia)."""
    nb, fixed = model.nb, np.asarray(model.fixed, bool)
    pt_body, pt_local = model.pt_body, model.pt_local
    i_min = np.array([np.linalg.eigvalsh(model.inertia[:, :, b]).min() for b in range(nb)])
    share = np.bincount(pt_body, minlength=nb).astype(float)
    r2 = (pt_local**2).sum(0)
    inv_m_pt = share[pt_body] * (1.0 / model.mass[pt_body] + r2 / i_min[pt_body])
    inv_m_pt = np.where(fixed[pt_body], 0.0, inv_m_pt)
    bad = ~np.isfinite(inv_m_pt) | ~np.all(np.isfinite(pt_local), axis=0)
    if bad.any():
        name = model.body_names[int(pt_body[np.argmax(bad)])]
        desc = model.description
        raise DescriptionError(desc.path if desc else "<model>", desc.body_line(name) if desc else 1,
                               f"body '{name}': a joint pivot or contact vertex is too far from its centre of "
                               "mass for its inertia (the effective mass overflows); check its lengths")
    ns = len(model.sp_a)
    pt_src = np.zeros(len(pt_body), np.int32)
    pt_src[model.sp_a] = np.arange(ns)
    pt_src[model.sp_b] = ns + np.arange(ns)
    pt_src[model.ct_pt] = 2 * ns + np.arange(len(model.ct_pt))
    j_inv_ieff = np.array([sum(0.0 if fixed[k] else model.j_axis[:, j] @ model.inv_inertia[:, :, k] @ model.j_axis[:, j]
                               for k in (model.j_a[j], model.j_b[j])) for j in range(model.nj)]).reshape(-1)
    return SpringsModel(alpha=float(alpha), beta=float(beta), pt_src=pt_src,
                        sp_inv_meff=inv_m_pt[model.sp_a] + inv_m_pt[model.sp_b], j_inv_ieff=j_inv_ieff)
