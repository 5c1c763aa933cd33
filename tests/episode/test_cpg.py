"""The CPG (cpgjax/cpg.py) and the fitness (cpgjax/fitness.py, eq. 4.5-4.6)."""

import jax.numpy as jnp
import numpy as np

from cpgjax.episode.cpg import sinusoid_genome, targets
from cpgjax.episode.fitness import stability


def test_fourier_series_and_its_rate():
    c = np.array([[0.1, 0.2, 0.3, 0.4, 0.5]])[..., None]
    t = 0.37
    w = 2 * np.pi * 0.5
    q, dq = targets(jnp.asarray(c), jnp.asarray(t), 2, 0.5)
    exp = 0.1 + 0.2 * np.sin(w * t) + 0.3 * np.cos(w * t) + 0.4 * np.sin(2 * w * t) + 0.5 * np.cos(2 * w * t)
    dexp = w * (0.2 * np.cos(w * t) - 0.3 * np.sin(w * t) + 2 * 0.4 * np.cos(2 * w * t) - 2 * 0.5 * np.sin(2 * w * t))
    np.testing.assert_allclose(float(q[0, 0]), exp, rtol=1e-5)
    np.testing.assert_allclose(float(dq[0, 0]), dexp, rtol=1e-5)


def test_thesis_genome_size_is_40_for_8_dofs():
    assert sinusoid_genome(8, 2).shape == (40,)


def test_stability_is_one_upright_zero_upside_down_and_monotone():
    th = np.linspace(0, np.pi, 50)
    for delta in (0.5, 2.0, 8.0, 64.0):
        s = np.asarray(stability(jnp.cos(th), delta))
        assert abs(s[0] - 1) < 1e-6 and s[-1] == 0.0
        assert np.all(np.diff(s) <= 1e-7)
        assert np.all(s[th > np.pi / 2] == 0)  # turned over scores as fallen
    # larger delta: flatter near the top (Fig. 4.5)
    assert stability(jnp.cos(0.5), 64.0) > stability(jnp.cos(0.5), 2.0)
