"""Rotations in component form for batch-last arrays.

Vectors are arrays whose first axis holds the components (``[3, ...]``), quaternions
``[4, ...]`` as (w, x, y, z), rotation matrices ``[3, 3, ...]``; the trailing axes are
(item, robot) so that every operation broadcasts over any batch without `vmap`.
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np


def cross(a, b):
    """a x b for component-first arrays (broadcasting over trailing axes)."""
    return jnp.stack(
        [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    )


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def matvec(m, v):
    """m @ v with m [3, 3, ...], v [3, ...]."""
    return jnp.stack([m[i, 0] * v[0] + m[i, 1] * v[1] + m[i, 2] * v[2] for i in range(3)])


def matTvec(m, v):
    """m.T @ v with m [3, 3, ...], v [3, ...]."""
    return jnp.stack([m[0, i] * v[0] + m[1, i] * v[1] + m[2, i] * v[2] for i in range(3)])


def quat_to_mat(q):
    """Rotation matrix [3, 3, ...] of unit quaternions q [4, ...] (w, x, y, z)."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    xx, yy, zz = x * x, y * y, z * z
    xy, xz, yz = x * y, x * z, y * z
    wx, wy, wz = w * x, w * y, w * z
    return jnp.stack(
        [
            jnp.stack([1 - 2 * (yy + zz), 2 * (xy - wz), 2 * (xz + wy)]),
            jnp.stack([2 * (xy + wz), 1 - 2 * (xx + zz), 2 * (yz - wx)]),
            jnp.stack([2 * (xz - wy), 2 * (yz + wx), 1 - 2 * (xx + yy)]),
        ]
    )


def quat_integrate(q, omega, dt):
    """q <- normalize(q + dt/2 * (0, omega) * q), omega in the world frame."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    ox, oy, oz = omega[0], omega[1], omega[2]
    h = 0.5 * dt
    dq = jnp.stack(
        [
            -(ox * x + oy * y + oz * z),
            ox * w + oy * z - oz * y,
            oy * w + oz * x - ox * z,
            oz * w + ox * y - oy * x,
        ]
    )
    q = q + h * dq
    return q * jnp.reciprocal(jnp.sqrt(q[0] ** 2 + q[1] ** 2 + q[2] ** 2 + q[3] ** 2))


# ----------------------------------------------------------------------------- numpy side (model building)

def euler_to_mat(rx: float, ry: float, rz: float) -> np.ndarray:
    """R = Rz @ Ry @ Rx (XYZ Euler angles, radians), the `.wl` convention."""
    cx, sx, cy, sy, cz, sz = np.cos(rx), np.sin(rx), np.cos(ry), np.sin(ry), np.cos(rz), np.sin(rz)
    Rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    Ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    Rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return Rz @ Ry @ Rx


def mat_to_euler(R):
    """Inverse of `euler_to_mat` (works on numpy arrays [3, 3, ...])."""
    ry = np.arcsin(np.clip(-R[2, 0], -1.0, 1.0))
    rx = np.arctan2(R[2, 1], R[2, 2])
    rz = np.arctan2(R[1, 0], R[0, 0])
    return rx, ry, rz


def mat_to_quat(R: np.ndarray) -> np.ndarray:
    """Unit quaternion (w, x, y, z) of a rotation matrix."""
    t = np.trace(R)
    if t > 0:
        s = 2.0 * np.sqrt(1.0 + t)
        q = [0.25 * s, (R[2, 1] - R[1, 2]) / s, (R[0, 2] - R[2, 0]) / s, (R[1, 0] - R[0, 1]) / s]
    elif R[0, 0] > R[1, 1] and R[0, 0] > R[2, 2]:
        s = 2.0 * np.sqrt(1.0 + R[0, 0] - R[1, 1] - R[2, 2])
        q = [(R[2, 1] - R[1, 2]) / s, 0.25 * s, (R[0, 1] + R[1, 0]) / s, (R[0, 2] + R[2, 0]) / s]
    elif R[1, 1] > R[2, 2]:
        s = 2.0 * np.sqrt(1.0 + R[1, 1] - R[0, 0] - R[2, 2])
        q = [(R[0, 2] - R[2, 0]) / s, (R[0, 1] + R[1, 0]) / s, 0.25 * s, (R[1, 2] + R[2, 1]) / s]
    else:
        s = 2.0 * np.sqrt(1.0 + R[2, 2] - R[0, 0] - R[1, 1])
        q = [(R[1, 0] - R[0, 1]) / s, (R[0, 2] + R[2, 0]) / s, (R[1, 2] + R[2, 1]) / s, 0.25 * s]
    q = np.asarray(q)
    return q / np.linalg.norm(q)


def quat_to_mat_np(q) -> np.ndarray:
    """Rotation matrix of quaternion(s) q = (w, x, y, z) for numpy (q may be [4, ...])."""
    w, x, y, z = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])
