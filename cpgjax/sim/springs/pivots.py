"""Joints as stiff damped pivot springs (eq. 3.6).

A revolute joint is two pivot springs a small distance apart along its axis: together
they hold the pivot and the axis; rotation about the axis stays free.  The spring
force on the first body's pivot is ``F = alpha (p_b - p_a) + beta (v_b - v_a)`` and
``-F`` acts on the second (eq. 3.6).  The damper is integrated implicitly, locally per
spring: ``beta_eff = beta / (1 + dt beta / m_eff)`` with a conservative (mass-split)
effective mass (`sim.springs.model`), which is what lets the step grow past the explicit
limit ``dt < 2 m/beta`` while the static stiffness stays exactly ``alpha``.
"""

from __future__ import annotations


def pivot_spring_forces(model, p, pv):
    """Force on the first end of every pivot spring [3, ns, B] (its negative acts on the second)."""
    dpos = p[:, model.sp_b] - p[:, model.sp_a]
    dvel = pv[:, model.sp_b] - pv[:, model.sp_a]
    sp = model.springs
    beta_eff = (sp.beta / (1.0 + model.dt * sp.beta * sp.sp_inv_meff))[:, None]
    return sp.alpha * dpos + beta_eff * dvel
