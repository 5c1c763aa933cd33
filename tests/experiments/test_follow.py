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


def test_the_look_ahead_walks_the_safe_candidate_that_leaves_the_least_path():
    """judge/pick on hand-made cycles of four candidates towards the waypoints (0, 1), (0, 2)."""
    pts = np.asarray([[0.0, 1.0], [0.0, 2.0]])
    S = 5
    t = np.linspace(0, 1, S)[:, None]
    ends = np.asarray([[0.0, 0.5], [0.0, 1.5], [0.0, 1.7], [0.4, 1.0]])       # where each candidate ends
    xy = np.transpose(t[..., None] * ends[None], (0, 2, 1))                  # straight from the origin [S, 2, 4]
    up = np.cos(np.asarray([0.3, 0.3, 1.2, 0.3]))[None].repeat(S, 0)        # candidate 2 tilts 1.2 rad
    psi_end = np.asarray([0.0, 0.0, 0.0, -np.pi / 2])                        # candidate 3 ends facing +x
    ok = np.asarray([True, True, True, True])
    passed, done_at, tilt, cost = fw.judge(xy, up, psi_end, ok, pts, 0, reach=0.2, deviation=1.0, aim=0.3)
    np.testing.assert_array_equal(passed, [0, 1, 1, 0])
    np.testing.assert_array_equal(done_at, -1)
    np.testing.assert_allclose(tilt, [0.3, 0.3, 1.2, 0.3])
    np.testing.assert_allclose(cost[:3], [1.5, 0.5, 0.3], atol=1e-12)       # path still to walk (on the path)
    # candidate 3: 0.4 + 1 still to walk, 0.2 m from the path on average, facing away from (0, 1) (pi rad)
    assert cost[3] == pytest.approx(1.4 + 0.2 + 0.3 * np.pi, abs=1e-12)
    assert fw.pick(cost, tilt, 0.8) == 1              # candidate 2 leaves less path but tilts past the bound
    assert fw.pick(cost, tilt, 1.5) == 2
    assert fw.pick(cost, np.asarray([1.0, 0.9, 1.2, 1.1]), 0.8) == 1       # none safe: the least tilted
    # finishing beats anything, the sooner the better; a diverged candidate is never taken
    xy2 = np.transpose(t[..., None] * np.asarray([[0.0, 2.0], [0.0, 2.1], [0.0, 1.9]])[None], (0, 2, 1))
    _, done2, _, cost2 = fw.judge(xy2, up[:, :3], psi_end[:3], np.asarray([True, True, False]), pts, 1)
    assert done2[0] >= 0 and done2[1] >= 0 and cost2[0] < 0 and cost2[1] < 0 and cost2[2] == np.inf
    assert fw.pick(cost2, np.zeros(3)) == int(np.argmin(done2[:2]))
