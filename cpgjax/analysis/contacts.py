"""Post-processing of recorded trajectories (numpy): contact points and feet on the ground."""

from __future__ import annotations

import numpy as np

from cpgjax.io.logs import quat_to_mat_np


def contact_points(model, traj) -> np.ndarray:
    """World positions [S, 3, nc] of every contact vertex of a single-robot trajectory."""
    x = np.asarray(traj["x"], float)  # [S, 3, nb]
    q = np.asarray(traj["q"], float)  # [S, 4, nb]
    pts = model.ct_pt
    bodies = model.pt_body[pts]
    R = quat_to_mat_np(np.moveaxis(q[:, :, bodies], 1, 0))  # [3, 3, S, nc]
    local = model.pt_local[:, pts]  # [3, nc]
    world = np.einsum("ijsc,jc->sic", R, local)
    return x[:, :, bodies] + world


def feet_down(model, traj, feet: list[str], tol: float = 2e-3) -> np.ndarray:
    """Number of the named bodies' contact vertices within ``tol`` of the terrain, per sample [S]."""
    p = contact_points(model, traj)
    idx = [k for k, pt in enumerate(model.ct_pt) if model.body_names[model.pt_body[pt]] in feet]
    z = p[:, 2, idx]
    ground = model.terrain.height_np(p[:, 0, idx], p[:, 1, idx])
    return ((z - ground) < tol).sum(-1)
