"""Log files in the thesis format (Ch. 3.5.4).

Two ``#`` comment lines name the body and the `.wl`/`.ctl` files used, a third names the
columns, then one row per sample (``LogRate`` per simulated second):
``T X Y Z theta phi psi`` — time, the body's CM position and its orientation as XYZ
Euler angles (roll about x, pitch about y, yaw about z; the `.wl` convention).
"""

from __future__ import annotations

import os

import numpy as np

from cpgjax.sim.rotation import mat_to_euler, quat_to_mat_np


def pose_rows(traj, body: int) -> np.ndarray:
    """[S, 7] rows T X Y Z theta phi psi of one body from a recorded single-robot trajectory."""
    t = np.asarray(traj["t"])
    x = np.asarray(traj["x"])[:, :, body]
    q = np.asarray(traj["q"])[:, :, body]
    R = quat_to_mat_np(np.moveaxis(q, 1, 0))  # [3, 3, S]
    ang = np.stack(mat_to_euler(R), 1)
    return np.column_stack([t, x, ang])


def write_log(path, kind: str, body_name: str, wl_name: str, ctl_name: str, rows: np.ndarray) -> None:
    """Write one log file; the directory is created if needed."""
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    with open(path, "w") as f:
        f.write(f"# Log file for {kind} {body_name}\n")
        f.write(f"# {wl_name} {ctl_name}\n")
        f.write("#   T       X       Y       Z       theta    phi     psi\n")
        for r in rows:
            f.write("  ".join(f"{v:.6f}" for v in r) + "\n")


def read_log(path) -> np.ndarray:
    """Rows of a log file [S, 7] (comments skipped)."""
    return np.loadtxt(path, comments="#", ndmin=2)
