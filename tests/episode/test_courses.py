"""The perturbation experiments' ground (cpgjax/episode/courses.py): lanes, bumps, rough fields, placement."""

import numpy as np
import pytest
from runcases import TINY_TIME

from cpgjax.episode.batch import simulate
from cpgjax.episode.courses import CELL_Y, LANE, ROUGH_CELL, conditions, course, placement
from cpgjax.io.ctl import read_ctl
from cpgjax.io.wl import load_model
from cpgjax.sim.terrain import height_and_normal

QUAD = "models/quadruped.wl"
TROT = "models/quadruped-trot.ctl"


@pytest.mark.slow  # two programs; fast: the bump of 0 lanes against flat ground, experiments/test_stability.py
def test_a_bump_of_zero_is_flat_ground():
    """A bump of 0 is flat ground: the heightfield path gives the flat fast path's episode.

    Not bit for bit: the flat fast path (sim/contact.py: _Frame) is another compiled program, whose
    fused multiply-adds XLA may contract differently; the experiment compares lanes of one heightfield,
    which are equal bit for bit (tests/experiments/test_stability.py).
    """
    flat, bump0 = load_model(QUAD), load_model(QUAD, terrain="bump:0")
    assert flat.terrain.flat and not bump0.terrain.flat       # the heightfield path, not the flat fast path
    c = read_ctl(TROT, n_dof=8, harmonics=2).coeffs
    a = simulate(flat, c, time=TINY_TIME, record=True)     # the suite's tiny episode: episode/test_rollout.py's
    b = simulate(bump0, c, time=TINY_TIME, record=True)    # recording program on flat ground
    for k in ("fitness", "distance", "tilt", "height", "depth"):
        np.testing.assert_allclose(a[k], b[k], rtol=1e-2, atol=1e-4, err_msg=k)
    for k in ("x", "q", "angle"):
        np.testing.assert_allclose(a["traj"][k], b["traj"][k], atol=1e-2, err_msg=k)


def _h(terrain, x, y):
    z, _ = height_and_normal(terrain, np.asarray([x], np.float32), np.asarray([y], np.float32))
    return float(z[0])


def test_lanes_hold_their_ground():
    conds = conditions([0.02], [0.03], seeds=2)
    assert [c.label for c in conds] == ["flat", "bump 2 cm", "rough 3 cm #0", "rough 3 cm #1"]
    t = course(conds, (-2.0, 4.0), bump_y=1.0, bump_width=0.3)
    assert _h(t, 0.3, 1.15) == 0.0                                       # lane 0: flat
    assert _h(t, LANE + 0.3, 1.15) == pytest.approx(0.02)                # lane 1: on the bump
    assert _h(t, LANE + 0.3, 0.9) == 0.0 and _h(t, LANE + 0.3, 1.4) == 0.0   # before and after it
    # lane 2 at a roughness grid node: the seeded uniform draw of the `rough:` terrain's grid
    rows = np.arange(np.floor((-2.0) / ROUGH_CELL), np.ceil(4.0 / ROUGH_CELL) + 1)
    draw = np.random.default_rng(0).uniform(0.0, 0.03, size=(len(rows), int(LANE / ROUGH_CELL)))
    iy = int(np.nonzero(rows == 10)[0][0])                               # y = 1.0 m
    assert _h(t, 2 * LANE - LANE / 2 + 3 * ROUGH_CELL, 1.0) == pytest.approx(draw[iy, 3], abs=1e-6)
    hs = t.heights[:, 2 * 60:4 * 60]
    assert hs.min() >= 0 and hs.max() <= 0.03 and not np.array_equal(hs[:, :60], hs[:, 60:])   # two fields
    assert t.dy == pytest.approx(CELL_Y)


def test_placement_meets_the_bump_halfway_and_lifts_rough_robots():
    conds = conditions([0.02], [0.03], seeds=1)
    lane = np.array([0, 1, 1, 1, 2])
    d = np.array([2.0, 2.0, 0.1, -2.0, 2.0])
    shift, lift, (lo, hi) = placement(conds, lane, d, 0.0, 5.0, 0.3, reach=(0.25, 0.25))
    np.testing.assert_allclose(shift[0], lane * LANE)
    assert shift[1, 0] == 0 and shift[1, 4] == 0
    assert 1.0 + shift[1, 1] == pytest.approx(5.0)                        # body at 1 m (half of 2) meets y = 5
    assert 0.3 + shift[1, 2] == pytest.approx(5.0)                        # not closer than the feet + 5 cm
    assert -1.0 + shift[1, 3] == pytest.approx(5.3)                       # backwards: meets the far edge
    np.testing.assert_allclose(lift, [0, 0, 0, 0, 0.03], rtol=1e-6)
    assert lo <= -2.0 + 6.0 - 1.5 + 1e-6 and hi >= 2.0 + 1.5 - 1e-6


def test_a_stair_or_a_bar_is_a_ground_of_its_own_met_halfway():
    """A stair or a bar has vertical faces across every x (sim/ledges.py): it is a ground of its own, not a lane; its
    first face stands where a bump's near edge would, and a robot walking backwards starts on the stair's top."""
    from cpgjax.episode.courses import STAIR_STEPS, STAIR_TREAD

    conds = conditions((), (), 1, stairs=(0.04,), bars=(0.03,))
    assert [c.label for c in conds] == ["flat", "stair 4 cm", "bar 3 cm"]
    stair, bar = course([conds[1]], (0.0, 5.0), 0.2, 0.3), course([conds[2]], (0.0, 5.0), 0.2, 0.3)
    assert stair.heights is None and bar.heights is None
    np.testing.assert_allclose(stair.ledges.edges, 0.2 + STAIR_TREAD * np.arange(STAIR_STEPS))
    np.testing.assert_allclose(stair.height_np(np.zeros(3), np.array([0.19, 0.21, 9.0])), [0, 0.04, 0.12], atol=1e-7)
    np.testing.assert_allclose(bar.height_np(np.zeros(3), np.array([0.19, 0.21, 0.26])), [0, 0.03, 0], atol=1e-7)
    shift, lift, _ = placement(conds, np.array([1, 1, 2]), np.array([2.0, -2.0, 2.0]), 0.0, 0.2, 0.3)
    np.testing.assert_allclose(shift[1], [0.2 - 1.0, 0.2 + 1.0 + STAIR_STEPS * STAIR_TREAD, 0.2 - 1.0])
    np.testing.assert_allclose(lift, [0.0, STAIR_STEPS * 0.04, 0.0], atol=1e-7)
