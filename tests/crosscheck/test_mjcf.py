"""MJCF export (cpgjax/mjcf_export.py) and the MuJoCo reference (cpgjax/reference.py)."""

import numpy as np
import pytest
from simcases import rig

from cpgjax.crosscheck.engines import joint_angles, mujoco_run, spearman
from cpgjax.crosscheck.mjcf import load, to_mjcf
from cpgjax.episode.batch import simulate
from cpgjax.io.ctl import read_ctl
from cpgjax.io.wl import load_model


@pytest.fixture(scope="module")
def quad():
    return load_model("models/quadruped.wl")


@pytest.mark.parametrize("name", ["quadruped", "hexapod", "worm", "car"])
def test_export_loads_in_mujoco_and_mjx_with_the_same_mass_joints_actuators(name):
    from mujoco import mjx

    m = load_model(f"models/{name}.wl")
    mj = load(m)
    assert mj.body_mass.sum() == pytest.approx(m.total_mass, rel=1e-6)
    n_hinge = sum(1 for t in mj.jnt_type if t == 3)
    assert n_hinge == m.nj and mj.nu == m.n_ctrl
    assert "<mujoco" in to_mjcf(m)
    mjx.put_model(mj)  # MJX accepts it


def test_standing_height_agrees_with_mujoco_within_1cm(quad):
    zero = np.zeros((1, 8, 5))
    met, _, _ = mujoco_run(quad, zero, time=3.0)
    pen = simulate(quad, zero[0], time=3.0, record=True)
    z_pen = pen["traj"]["x"][-1, 2, quad.track]
    z_mj = met["cm"][0, -1, 2]
    assert abs(z_pen - z_mj) < 0.01, (z_pen, z_mj)


def test_single_joint_on_a_fixed_base_follows_a_half_hertz_target_in_both():
    m = rig(time=4)
    c = np.array([[[0.0, 0.4, 0.0, 0.0, 0.0]]])
    pen = simulate(m, c[0], time=4.0, record=True)
    t = pen["traj"]["t"]
    err_pen = np.abs(pen["traj"]["angle"][:, 0] - pen["traj"]["target"][:, 0])[t > 1].mean()
    mj = load(m)
    _, qpos, _ = mujoco_run(m, c, time=4.0, mj=mj)
    ang = joint_angles(m, mj, qpos)[0, :, 0]
    tm = np.arange(len(ang)) * mj.opt.timestep
    target = 0.4 * np.sin(np.pi * tm)
    err_mj = np.abs(ang - target)[tm > 1].mean()
    assert err_pen < 0.05 and err_mj < 0.05
    assert abs(err_pen - err_mj) < 0.02, (err_pen, err_mj)


def test_hand_written_trot_moves_forward_in_both_engines(quad):
    trot = read_ctl("models/quadruped-trot.ctl", n_dof=8, harmonics=2).coeffs[None]
    met, _, _ = mujoco_run(quad, trot, time=5.0)
    pen = simulate(quad, trot[0], time=5.0)
    assert met["distance"][0] > 0.4 and pen["distance"] > 0.4
    assert not met["fallen"][0] and not pen["fallen"]


def test_spearman():
    assert spearman([1, 2, 3, 4], [10, 20, 30, 40]) == pytest.approx(1.0)
    assert spearman([1, 2, 3, 4], [4, 3, 2, 1]) == pytest.approx(-1.0)
    assert spearman([1, 2, 2, 3], [1, 2, 3, 4]) > 0.9


def test_the_exported_heightfield_has_our_heights_where_we_have_them():
    """A ray cast down in MuJoCo hits the ground at our terrain's height (a ramp, so a mirror image would show)."""
    import mujoco

    m = load_model("models/quadruped.wl", terrain="ramp:0.2")
    mj = load(m)
    d = mujoco.MjData(mj)
    mujoco.mj_forward(mj, d)
    geomid = np.zeros(1, np.int32)
    for x, y in ((0.0, -2.0), (0.5, 0.0), (-1.0, 3.0), (1.0, 8.0)):
        dist = mujoco.mj_ray(mj, d, np.array([x, y, 10.0]), np.array([0.0, 0.0, -1.0]), None, 1, -1, geomid)
        assert abs((10.0 - dist) - float(m.terrain.height_np(np.array(x), np.array(y)))) < 2e-3, (x, y)
