"""The thesis's fitness (eq. 4.5-4.6): forward speed weighted by the vestibular stability.

Instantaneous fitness ``f = v_y S(theta)`` with the vestibular stability
``S = delta cos^2(theta) / ((delta - 1) cos^2(theta) + 1)`` (eq. 4.5, eq. 6.2), theta the
angle between the body normal and the vertical.  The episode fitness is its time
average (eq. 4.6), never above the mean forward speed.  A body turned over (normal
pointing down, cos(theta) < 0) has S = 0: it scores as fallen, not as upright, which
the symmetric cos^2 alone would not do.
"""

from __future__ import annotations

import jax.numpy as jnp

DEFAULT_DELTA = 8.0


def up_cos(model, q):
    """cos(theta) of the tracked body: the angle between its normal and the vertical (``R_zz`` of its quaternion
    ``q`` [4, nb, B])."""
    qb = q[:, model.track]
    return 1.0 - 2.0 * (qb[1] ** 2 + qb[2] ** 2)


def stability(cos_theta, delta=DEFAULT_DELTA):
    """Vestibular stability S(theta) in [0, 1] from cos(theta) (eq. 6.2); 0 when upside down."""
    c2 = jnp.square(jnp.maximum(cos_theta, 0.0))
    return delta * c2 / ((delta - 1.0) * c2 + 1.0)


def instantaneous(v_forward, cos_theta, delta=DEFAULT_DELTA):
    """eq. 4.5: forward speed weighted by the stability."""
    return v_forward * stability(cos_theta, delta)
