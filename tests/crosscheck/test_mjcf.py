"""MJCF export (cpgjax/mjcf_export.py) and the MuJoCo reference (cpgjax/reference.py)."""

import numpy as np
import pytest
from simcases import rig

from cpgjax.crosscheck.engines import joint_angles, mujoco_run, spearman, spearman_interval
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


def test_spearman_interval_holds_the_estimate_and_narrows_with_more_controllers():
    rng = np.random.default_rng(3)
    widths = []
    for n in (24, 400):
        a = rng.normal(size=n)
        b = a + 0.8 * rng.normal(size=n)          # population rank correlation about 0.76
        lo, hi = spearman_interval(a, b)
        assert lo < spearman(a, b) < hi
        widths.append(hi - lo)
    assert widths[1] < widths[0] / 2               # the interval shrinks like 1/sqrt(n)
    assert spearman_interval(np.arange(10.0), np.arange(10.0) ** 3) == (1.0, 1.0)


@pytest.mark.parametrize("spec, tol", [("ramp:0.2", 1e-6), ("rough:0.04", 1.0e-3), ("bump:0.03@0.5:0.2", 1e-6)])
def test_the_exported_ground_is_ours_a_sphere_radius_lower(spec, tol):
    """A ray cast down onto MuJoCo's ground hits it a foot sphere's radius below our terrain, at 3000 points of the
    walking area.  The ramp would show a mirror image; the rough field the triangles (MuJoCo) against the bilinear
    cells (ours): sampled 4x finer, within 0.86 mm of ours on 4 cm roughness (measured; 14 mm unsampled); the bump's
    grid covers only the bump, the exported one the workspace (ours keeps the edge height beyond its grid)."""
    import mujoco

    from cpgjax.crosscheck.mjcf import CONTACT_RADIUS

    m = load_model("models/quadruped.wl", terrain=spec)
    mj = load(m)
    d = mujoco.MjData(mj)
    mujoco.mj_forward(mj, d)
    gid = mujoco.mj_name2id(mj, mujoco.mjtObj.mjOBJ_GEOM, "ground")
    rng = np.random.default_rng(0)
    xs, ys = rng.uniform(-0.5, 0.5, 3000), rng.uniform(-1.0, 3.0, 3000)
    down = np.array([0.0, 0.0, -1.0])
    hit = np.array([10.0 - mujoco.mj_rayHfield(mj, d, gid, np.array([x, y, 10.0]), down)
                    for x, y in zip(xs, ys, strict=True)])
    err = np.abs(hit + CONTACT_RADIUS - m.terrain.height_np(xs, ys))
    assert err.max() < tol, (spec, err.max())


def _max_penetration_closed_form(mass, n, A, B, v0, g=9.81):
    """Deepest penetration of a rigid body of `mass` landing at `v0` on `n` contacts of eq. 3.7 (linear ODE)."""
    w2, c, dt = n * A / mass, n * B / mass, 1e-6
    p, v, deepest = 0.0, v0, 0.0
    while v > 0 or p <= 0:                      # until the penetration turns back
        a = g - w2 * p - c * v
        v += a * dt
        p += v * dt
        deepest = max(deepest, p)
    return deepest


@pytest.mark.parametrize("mass", [1.0, 13.8])
def test_mujoco_ground_is_eq_3_7_for_a_light_and_a_heavy_body(mass):
    """MuJoCo's direct solref is per unit mass; eq. 3.7's A, B are forces.  A box dropped 1 cm onto its four
    bottom corners sinks as deep in MuJoCo as the closed form of eq. 3.7 says (and as it does here), for a
    light and a heavy box alike.  With ``solref = -A -B`` (the export before) both boxes sank 0.32 mm in MuJoCo,
    whatever their mass: 3.4x eq. 3.7's depth for the 1 kg box, 0.3x for the 13.8 kg one."""
    import mujoco
    from simcases import box

    m = box(z=0.06, mass=mass, log_rate=2000)                 # bottom 1 cm above the ground
    # ours at a step small enough that the step in which a corner crosses the surface unopposed does not count
    r = simulate(m.replace(dt=2e-5), np.zeros((0, 5)), time=0.15, record=True)
    ours = float((0.05 - r["traj"]["x"][:, 2, 0]).max())
    expect_ours = _max_penetration_closed_form(mass, 4, m.ground_A, m.ground_B, np.sqrt(2 * 9.81 * 0.01))
    # MuJoCo, at the same small step (its contact spheres rest where the corners do: the same 1 cm fall)
    mj = load(m, timestep=2e-5)
    d = mujoco.MjData(mj)
    deepest = 0.0
    for _ in range(7500):
        mujoco.mj_step(mj, d)
        if d.ncon:
            deepest = max(deepest, -float(d.contact.dist[: d.ncon].min()))
    expect_mj = expect_ours
    assert abs(ours - expect_ours) < 0.1 * expect_ours, (ours, expect_ours)
    assert abs(deepest - expect_mj) < 0.15 * expect_mj, (deepest, expect_mj)
