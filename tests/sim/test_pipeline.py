"""`sim.pipeline`: the two entries of either pipeline, ``init`` and ``step``."""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np
import pytest

from cpgjax.io.wl import load_model
from cpgjax.sim import init
from cpgjax.sim.state import initial_state
from cpgjax.sim.variation import Variation


@pytest.mark.parametrize("pipeline", ["springs", "exact"])
def test_init_is_the_model_at_rest_and_a_variation_lifts_and_tilts_it(pipeline):
    m = load_model("models/quadruped.wl", pipeline=pipeline)
    s = init(m, 3)
    for a, b in zip(s, initial_state(m, 3), strict=True):
        assert (a is None and b is None) or np.array_equal(a, b)
    assert s.x.shape == (3, m.nb, 3) and not np.any(s.v) and not np.any(s.w)
    assert (s.exact is None) == (pipeline == "springs")
    if s.exact is not None:
        assert np.array_equal(s.exact.angle[:, 0], np.float32(m.j_q0)) and not np.any(s.exact.rate)
    nominal = init(m, 3, Variation.nominal(m, 3))
    assert np.array_equal(nominal.x, s.x) and np.array_equal(nominal.q, s.q)   # the identity, exactly
    var = Variation.nominal(m, 3)._replace(lift=jnp.asarray([0.0, 0.01, 0.0]), tilt=jnp.zeros((2, 3)).at[1, 2].set(0.1))
    v = init(m, 3, var)
    assert np.allclose(v.x[:, :, 1] - s.x[:, :, 1], [[0.0], [0.0], [0.01]], atol=1e-6)
    assert np.isclose(2 * np.arcsin(abs(float(v.q[2, m.track, 2]))), 0.1, atol=1e-5)   # pitched 0.1 rad
