"""The thesis's sigmoid fit (Ch. 6.1.1): it recovers a known sigmoid; the cut-off is its steepest point."""

from __future__ import annotations

import numpy as np
import pytest

from cpgjax.analysis.cutoff import fit_sigmoid, sigmoid


@pytest.mark.parametrize("a,b", [(8.0, 0.74), (0.3, 25.0)])
def test_fit_recovers_a_known_sigmoid(a, b):
    x = np.linspace(0.05, 3 * b, 12)
    fit = fit_sigmoid(x, sigmoid(x, a, b))
    assert fit["a"] == pytest.approx(a, rel=1e-3) and fit["b"] == pytest.approx(b, rel=1e-3)
    assert fit["rmse"] < 1e-3


def test_steepest_point_is_b():
    x = np.linspace(0, 2, 20001)
    slope = np.gradient(sigmoid(x, 6.0, 0.74), x)
    assert x[np.argmax(slope)] == pytest.approx(0.74, abs=1e-3)


def test_noisy_data_and_too_few_points():
    rng = np.random.default_rng(0)
    x = np.linspace(0.1, 2.0, 30)
    y = sigmoid(x, 6.0, 0.74) + rng.normal(0, 0.02, x.size)
    assert fit_sigmoid(x, y)["b"] == pytest.approx(0.74, abs=0.03)
    with pytest.raises(ValueError, match="at least 3"):
        fit_sigmoid([1.0, 2.0, np.nan], [0.1, 0.9, 0.5])
