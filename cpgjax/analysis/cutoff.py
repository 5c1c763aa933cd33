"""The servo's cut-off frequency: the thesis's sigmoid fit of tracking error vs frequency (Ch. 6.1.1).

The thesis fitted the mean tracking error against the drive frequency with the sigmoid
``y = 1 / (1 + exp(-a (x - b)))`` and put the cut-off where its first derivative is largest:
at ``x = b`` (Fig. 6.2: 0.74 Hz for the robot).  :func:`fit_sigmoid` is that least-squares fit,
made with optax (Adam on ``(log a, b)`` in frequencies scaled to [0, 1], started from the best
point of a coarse grid) so that no curve-fitting library is needed: scipy is not a dependency.

:func:`linear_servo_error` is the closed form the experiment is checked against: a PD servo
``tau = kp (q* - q) + kd (q*' - q')`` on a pure inertia ``I`` (no gravity, no saturation) tracks
``q* = A sin(w t)`` with error ``E(jw) q*``, ``E(s) = I s^2 / (I s^2 + kd s + kp)``, so the mean
absolute error over a period divided by the target's (``2A/pi``) is ``|E(jw)|``.
"""

from __future__ import annotations

import numpy as np


def sigmoid(x, a: float, b: float):
    """``1 / (1 + exp(-a (x - b)))`` (thesis Ch. 6.1.1)."""
    with np.errstate(over="ignore"):
        return 1.0 / (1.0 + np.exp(-a * (np.asarray(x, float) - b)))


def linear_servo_error(freq, inertia: float, kp: float, kd: float):
    """``|E(j 2 pi f)|`` of a linear PD servo on a pure inertia: relative mean tracking error [len(freq)]."""
    w = 2 * np.pi * np.asarray(freq, float)
    return inertia * w**2 / np.sqrt((kp - inertia * w**2) ** 2 + (kd * w) ** 2)


def fit_sigmoid(x, y, *, steps: int = 2000, learning_rate: float = 0.05) -> dict:
    """Least-squares fit of :func:`sigmoid` to (x, y); returns ``{"a", "b", "rmse"}`` (b: the cut-off).

    Points with a non-finite y are left out; at least 3 points are needed.
    """
    import jax
    import jax.numpy as jnp
    import optax

    x = np.asarray(x, float)
    y = np.asarray(y, float)
    ok = np.isfinite(x) & np.isfinite(y)
    x, y = x[ok], y[ok]
    if len(x) < 3:
        raise ValueError(f"a sigmoid fit needs at least 3 points, got {len(x)}")
    scale = float(np.max(np.abs(x))) or 1.0
    xs = x / scale
    # coarse grid: slope from 1 to 1000 per unit of scaled x, centre across the data
    la = np.log(np.geomspace(1.0, 1000.0, 40))
    bs = np.linspace(xs.min(), xs.max(), 60)
    A, Bc = np.meshgrid(la, bs, indexing="ij")
    err = ((sigmoid(xs, np.exp(A)[..., None], Bc[..., None]) - y) ** 2).sum(-1)
    i, k = np.unravel_index(np.argmin(err), err.shape)
    p0 = jnp.asarray([la[i], bs[k]], jnp.float32)
    xj, yj = jnp.asarray(xs, jnp.float32), jnp.asarray(y, jnp.float32)

    def loss(p):
        return jnp.mean((jax.nn.sigmoid(jnp.exp(p[0]) * (xj - p[1])) - yj) ** 2)

    opt = optax.adam(learning_rate)

    def body(carry, _):
        p, s = carry
        g = jax.grad(loss)(p)
        u, s = opt.update(g, s, p)
        return (optax.apply_updates(p, u), s), None

    (p, _), _ = jax.lax.scan(body, (p0, opt.init(p0)), None, length=steps)
    p = np.asarray(p, float)
    a, b = float(np.exp(p[0]) / scale), float(p[1] * scale)
    return {"a": a, "b": b, "rmse": float(np.sqrt(np.mean((sigmoid(x, a, b) - y) ** 2)))}
