"""Projection stability: the support-polygon distance against hand-computed cases (thesis Ch. 6.4.2)."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from cpgjax.episode.support import projection_stability, support_distance

# jitted: one compiled program per number of feet (run op by op, each operation compiled for itself)
_SUPPORT = jax.jit(support_distance)


def _d(points, down, c):
    p = jnp.asarray(np.asarray(points, np.float32).T)
    d, n = _SUPPORT(p[0], p[1], jnp.asarray(down), jnp.float32(c[0]), jnp.float32(c[1]))
    return float(d), int(n)


SQUARE = [(0, 0), (1, 0), (1, 1), (0, 1)]     # unit square, listed in any order below


@pytest.mark.parametrize("order", [[0, 1, 2, 3], [2, 0, 3, 1]])
def test_square_of_four_feet(order):
    pts = [SQUARE[i] for i in order]
    down = [True] * 4
    assert _d(pts, down, (0.5, 0.5)) == (pytest.approx(0.5), 4)       # centre: 0.5 to every side
    assert _d(pts, down, (0.2, 0.5))[0] == pytest.approx(0.2)          # nearest side x = 0
    assert _d(pts, down, (0.5, 0.9))[0] == pytest.approx(0.1)          # nearest side y = 1
    assert _d(pts, down, (1.3, 0.5))[0] == pytest.approx(-0.3)         # outside: minus the distance
    assert _d(pts, down, (1.3, 1.4))[0] == pytest.approx(-0.5)         # outside past a corner: 0.3-0.4-0.5


def test_triangle_and_a_lifted_foot():
    # the square with the foot at (1, 1) lifted: the triangle (0,0), (1,0), (0,1)
    down = [True, True, False, True]
    d, n = _d(SQUARE, down, (0.25, 0.25))
    assert n == 3
    assert d == pytest.approx(0.25)                                    # legs: x = 0 and y = 0 at 0.25
    # hypotenuse x + y = 1: from (0.4, 0.4) it is (1 - 0.8) / sqrt(2)
    assert _d(SQUARE, down, (0.4, 0.4))[0] == pytest.approx(0.2 / np.sqrt(2), rel=1e-5)
    # (0.6, 0.6) is inside the square but outside the triangle
    assert _d(SQUARE, down, (0.6, 0.6))[0] == pytest.approx(-0.2 / np.sqrt(2), rel=1e-5)


def test_interior_point_is_not_a_vertex_of_the_hull():
    pts = SQUARE + [(0.5, 0.5)]
    assert _d(pts, [True] * 5, (0.5, 0.2))[0] == pytest.approx(0.2)


def test_two_feet_or_collinear_coincident_are_undefined():
    d, n = _d(SQUARE, [True, False, True, False], (0.5, 0.5))
    assert n == 2 and np.isnan(d)
    d, n = _d(SQUARE, [False] * 4, (0.5, 0.5))
    assert n == 0 and np.isnan(d)
    d, n = _d([(0.3, 0.3)] * 3, [True] * 3, (0.3, 0.3))                # three feet on one spot: no polygon
    assert n == 3 and np.isnan(d)


def test_projection_stability_is_distance_over_height_batched():
    p = jnp.asarray(np.asarray(SQUARE, np.float32).T)[:, :, None] * jnp.ones((1, 1, 2))   # [2, 4, B=2]
    down = jnp.asarray([[True, True], [True, True], [True, False], [True, True]])
    cm = (jnp.asarray([0.5, 0.25]), jnp.asarray([0.5, 0.25]), jnp.asarray([0.25, 0.5]))
    s, n = jax.jit(projection_stability)(p[0], p[1], down, cm)     # op by op: a compile for each operation
    np.testing.assert_allclose(np.asarray(s), [0.5 / 0.25, 0.25 / 0.5], rtol=1e-6)
    assert np.asarray(n).tolist() == [4, 3]
