"""Steering by a repertoire (cpgjax.experiments.follow): the paths, the distance to them, the walk."""

from __future__ import annotations

import numpy as np
import pytest

from cpgjax.experiments import follow as fw


def test_paths_and_their_errors():
    np.testing.assert_array_equal(fw.waypoints("square:2"), [[0, 2], [-2, 2], [-2, 0], [0, 0]])
    c = fw.waypoints("circle:0.5")
    assert c.shape == (16, 2)
    np.testing.assert_allclose(np.hypot(c[:, 0] + 0.5, c[:, 1]), 0.5, atol=1e-12)     # all on the circle
    np.testing.assert_allclose(c[-1], [0, 0], atol=1e-12)                             # back at the start
    f8 = fw.waypoints("figure8:1")
    assert f8.shape == (32, 2) and np.all(f8[:16, 0] <= 1e-12) and np.all(f8[16:, 0] >= -1e-12)
    np.testing.assert_array_equal(fw.waypoints("points:1,2;3,4"), [[1, 2], [3, 4]])
    for bad, msg in (("spiral:1", "expected one of"), ("square:-1", "> 0"), ("square:x", "> 0"),
                     ("points:1,2;3", "points:X,Y")):
        with pytest.raises(ValueError, match=msg):
            fw.waypoints(bad)


def test_distance_to_a_polyline():
    path = np.asarray([[0.0, 0.0], [0.0, 1.0], [-1.0, 1.0]])
    p = np.asarray([[0.5, 0.5], [-0.5, 1.2], [0.3, 1.4], [0.0, -2.0]])
    np.testing.assert_allclose(fw.path_distance(p, path), [0.5, 0.2, 0.5, 2.0], rtol=1e-12)
