"""Ledges in both engines (``sim/ledges.py``; MuJoCo's boxes, ``crosscheck/ground.py: ledge_boxes``): boxes set on
a stair, on its edge and across it, come to rest where MuJoCo C's do; the export's boxes are the profile lowered
by the foot spheres' radius.  MuJoCo C at 0.25 ms, as for rough ground; measured with MuJoCo 4.0.0 on x86-64, the
tolerances stated where they are used."""

from __future__ import annotations

import functools

import numpy as np
import pytest
from simcases import box, model_from, varied_run

from cpgjax.crosscheck.engines import mujoco_run
from cpgjax.crosscheck.mjcf import CONTACT_RADIUS, load

STAIRS = "Terrain stairs 0.04 0.3 5"
# A 10 kg, 10 cm box (its 8 corners the contact vertices), set down with its lowest corner touching: where it stands
# (its centre's y; the first riser is at y = 1.0, the first tread 4 cm up) and how high its bottom starts.
# On the tread; on it with 1 cm to the edge; its back corners 2 cm over the edge (its centre 3 cm on the tread:
# on its corners alone it tips back onto the floor); its front corners 2 cm onto the tread (it leans back onto
# the floor); on the floor 1 cm before the riser.
PLACES = dict(y=[1.15, 1.06, 1.03, 0.97, 0.94], bottom=[0.04, 0.04, 0.04, 0.04, 0.0])
TIME = 2.0


@functools.cache
def _ours():
    m = box(z=0.05, friction=1.0, extra=STAIRS, log_rate=50)
    n = len(PLACES["y"])
    run = varied_run(m, TIME, lift=PLACES["bottom"], shift=np.stack([np.zeros(n), PLACES["y"]]))
    return run["traj"]["x"][-1, :, 0, :] + np.stack([np.zeros(n), PLACES["y"], np.zeros(n)])   # [3, B] world


def _mujoco(y, bottom):
    m = box(z=0.05 + bottom, friction=1.0, extra=STAIRS)
    m = model_from(m.description.text.replace("Position 0 0 ", f"Position 0 {y} "))
    _, qpos, _ = mujoco_run(m, np.zeros((1, 0, 5), np.float32), time=TIME, timestep=0.00025)
    return qpos[0, -1, :3]


def test_boxes_on_a_stair_rest_where_mujocos_do():
    """After 2 s each box's centre in both engines: within 1 cm along the path and 1 mm in height (measured: 3.1
    mm and 0.30 mm, the boxes across the edge; 0 and 0.24 mm for those that rest on a tread or the floor, whose sink
    differs: eq. 3.7's m g / (4 A) = 0.25 mm here, MuJoCo's regularised contact less).  The boxes on the tread rest
    at its height plus half their size (0.09 m), those across the edge lean on it at 6.6 cm."""
    ours = _ours()
    for k, (y, bottom) in enumerate(zip(PLACES["y"], PLACES["bottom"], strict=True)):
        mj = _mujoco(y, bottom)
        assert abs(ours[1, k] - mj[1]) < 0.01 and abs(ours[2, k] - mj[2]) < 1e-3, (y, ours[:, k], mj)
    assert ours[2, :2] == pytest.approx(0.09 - 98.1 / 4 / 1e5, abs=2e-5)
    assert ours[2, 2:4] == pytest.approx(0.0657, abs=1e-3)
    assert ours[2, 4] == pytest.approx(0.05, abs=5e-4)


def _rays(spec, n=801):
    """(our surface, MuJoCo's ground + the foot radius) under ``n`` random points of the walking area, a radius
    or more from every riser (where a sphere's centre meets the riser's face a radius in front of it)."""
    import mujoco

    from cpgjax.io.wl import load_model

    m = load_model("models/quadruped.wl", terrain=spec)
    mj = load(m)
    d = mujoco.MjData(mj)
    d.qpos[0] = 100.0                                  # the robot out of the rays' way
    mujoco.mj_forward(mj, d)
    rng = np.random.default_rng(0)
    xs, ys = rng.uniform(-0.6, 0.6, n), rng.uniform(-0.5, 7.0, n)
    far = np.min(np.abs(ys[:, None] - m.terrain.ledges.edges[None]), 1) > CONTACT_RADIUS + 1e-3
    xs, ys = xs[far], ys[far]
    gid = np.zeros(1, np.int32)
    hit = np.array([10.0 - mujoco.mj_ray(mj, d, np.array([x, y, 10.0]), np.array([0.0, 0.0, -1.0]), None, 1, -1,
                                         gid) for x, y in zip(xs, ys, strict=True)])
    return m.terrain.height_np(xs, ys), hit + CONTACT_RADIUS


@pytest.mark.parametrize("spec", ["stairs:0.04:0.3:5", "stairs:-0.04:0.3:3", "bar:0.03@1.0:0.05", "gap:0.2@1.5",
                                  "course:flat:1,stairs:0.04:0.3:5,stairs:-0.04:0.3:5,gap:0.1,flat:1"])
def test_mujocos_boxes_are_the_profile_lowered_by_the_foot_radius(spec):
    """Rays cast down onto MuJoCo's boxes hit the profile less the foot spheres' radius, to 1e-6 m (measured 3.6e-9 m),
    everywhere but within a radius of a riser."""
    ours, mj = _rays(spec)
    np.testing.assert_allclose(mj, ours, atol=1e-6)


def test_a_courses_rough_items_are_heightfields_of_our_surface():
    """On the course of docs/wl-format.md, rays hit MuJoCo's ground where they hit ours but for its rough item's
    triangles (sampled 4x finer than its cells, as the rough kind's heightfield): 99 % of 789 rays within 2 mm,
    the median within 0.1 mm (measured 0.66 mm, 3e-9 m, and 1.5 mm at most; a ray cast exactly along a row of a
    heightfield's samples may pass through it, so not every ray: that is MuJoCo's ray cast, not its collision)."""
    ours, mj = _rays("course:flat:1,rough:0.02:2,stairs:0.04:0.3:3,bar:0.03,flat:1")
    err = np.abs(mj - ours)
    assert np.percentile(err, 99) < 2e-3 and np.median(err) < 1e-4


@pytest.mark.slow
def test_the_trot_meets_a_bar_alike_in_both_engines():
    """The thesis's trot (exact joints) for 10 s towards a 3 cm bar 0.5 m ahead: it stays up in both engines, the bar
    holds it back in both (measured: 0.72 m here, 0.77 m in MuJoCo C, against 1.44 m and 1.74 m on flat ground), and
    the engines' distances differ by less than 15 % (measured 7 %; 21 % on flat ground)."""
    from cpgjax.episode.batch import simulate
    from cpgjax.io.ctl import read_ctl
    from cpgjax.io.wl import load_model

    c = read_ctl("models/quadruped-trot.ctl", n_dof=8, harmonics=2).coeffs.astype(np.float32)[None]
    m = load_model("models/quadruped.wl", terrain="bar:0.03@0.5", pipeline="exact")
    ours = simulate(m, c, time=10.0)
    mj, _, _ = mujoco_run(m, c, time=10.0, timestep=0.00025)
    here, there = float(ours["distance"][0]), float(np.ravel(mj["distance"])[0])
    assert not ours["fallen"][0] and not np.ravel(mj["fallen"])[0]
    assert here < 0.6 * 1.44 and there < 0.6 * 1.74, (here, there)
    assert abs(there / here - 1) < 0.15, (here, there)
