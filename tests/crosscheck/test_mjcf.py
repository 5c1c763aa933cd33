"""MJCF export (cpgjax/mjcf_export.py) and the MuJoCo reference (cpgjax/reference.py)."""

import numpy as np
import pytest
from simcases import rig

from cpgjax.crosscheck.engines import joint_angles, mujoco_run
from cpgjax.crosscheck.mjcf import load, to_mjcf
from cpgjax.crosscheck.ranks import spearman, spearman_interval
from cpgjax.episode.batch import simulate
from cpgjax.io.ctl import read_ctl
from cpgjax.io.wl import load_model


@pytest.fixture(scope="module")
def quad():
    return load_model("models/quadruped.wl")


# the car slow (the longest MJX load; fast: the three walkers)
@pytest.mark.parametrize("name", ["quadruped", "hexapod", "worm", pytest.param("car", marks=pytest.mark.slow)])
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
    # 5 s recorded: the program of episode/test_rollout.py's standing quadruped
    met, _, _ = mujoco_run(quad, zero, time=5.0)
    pen = simulate(quad, zero[0], time=5.0, record=True)
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


@pytest.mark.slow  # 5 s in both engines; fast: the trot in both engines, crosscheck/test_compare.py
def test_hand_written_trot_moves_forward_in_both_engines(quad):
    trot = read_ctl("models/quadruped-trot.ctl", n_dof=8, harmonics=2).coeffs[None]
    # 6 s: the program of the trot's GIF caption replayed (tests/test_figures.py)
    met, _, _ = mujoco_run(quad, trot, time=6.0)
    pen = simulate(quad, trot[0], time=6.0)
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


LIGHT_HEAVY = [1.0, 13.8]
_DROPPED: list = []


def _dropped_boxes():
    """How deep the light and the heavy box sink here: one program for both (the 1 kg box's mass scaled per
    robot, tests/simcases.py), at a step small enough that the step in which a corner crosses the surface
    unopposed does not count."""
    from simcases import box, varied_run

    if not _DROPPED:
        m = box(z=0.06, mass=LIGHT_HEAVY[0], log_rate=2000).replace(dt=2e-5)
        r = varied_run(m, 0.15, mass=LIGHT_HEAVY)
        _DROPPED.extend((0.05 - r["traj"]["x"][:, 2, 0]).max(0).tolist())
    return _DROPPED


@pytest.mark.parametrize("mass", LIGHT_HEAVY)
def test_mujoco_ground_is_eq_3_7_for_a_light_and_a_heavy_body(mass):
    """MuJoCo's direct solref is per unit mass; eq. 3.7's A, B are forces.  A box dropped 1 cm onto its four
    bottom corners sinks as deep in MuJoCo as the closed form of eq. 3.7 says (and as it does here), for a
    light and a heavy box alike.  With ``solref = -A -B`` (the export before) both boxes sank 0.32 mm in MuJoCo,
    whatever their mass: 3.4x eq. 3.7's depth for the 1 kg box, 0.3x for the 13.8 kg one."""
    import mujoco
    from simcases import box

    m = box(z=0.06, mass=mass, log_rate=2000)                 # bottom 1 cm above the ground
    ours = _dropped_boxes()[LIGHT_HEAVY.index(mass)]
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


def _stool(terrain):
    """A 13.8 kg stool on three feet: on uneven ground its pose and the feet's loads follow from statics."""
    from simcases import STOOL, model_from

    return model_from("TimeMax 1.0\nLogRate 100\n" + STOOL, terrain=terrain)


def _roll_pitch(R):
    return np.degrees([np.arctan2(R[2, 1], R[2, 2]), -np.arcsin(R[2, 0])])


def _mujoco_rest(m, mj, time):
    """MuJoCo C from the exported initial pose for ``time`` s, no control: (MjData, normal force per contact vertex)."""
    import mujoco

    from cpgjax.crosscheck.mjcf import initial_qpos

    d = mujoco.MjData(mj)
    d.qpos[:] = initial_qpos(m, mj)
    mujoco.mj_forward(mj, d)
    for _ in range(int(round(time / mj.opt.timestep))):
        mujoco.mj_step(mj, d)
    f, f6 = np.zeros(len(m.ct_pt)), np.zeros(6)
    for j in range(d.ncon):
        mujoco.mj_contactForce(mj, d, j, f6)
        f[int(mj.geom(d.contact[j].geom2).name.rsplit("_c", 1)[1])] += f6[0]
    return d, f


def test_a_stool_stands_on_a_rough_field_as_statics_says_in_both_engines():
    """Three feet on a 2 cm rough field: the pose and each foot's load are set by the field's heights under them.
    Measured: rest height 0.10895 m here, 0.10967 m in MuJoCo (whose soft contact sinks 0.7 mm deeper); roll 2.59
    and 2.87 deg; loads 38.6, 38.8, 58.3 N here (eq. 3.7's A d), 39.1, 39.6, 56.5 N in MuJoCo, 39.3, 39.4, 56.8 N
    by statics (the CM over the feet).  Tolerances: 2 mm, 0.5 deg, 3 N."""
    from cpgjax.sim.rotation import quat_to_mat_np

    m = _stool("rough:0.02")
    r = simulate(m, np.zeros((0, 5)), time=1.0, record=True)
    x, R = r["traj"]["x"][-1, :, 0], quat_to_mat_np(r["traj"]["q"][-1, :, 0])
    p = x[:, None] + R @ m.pt_local[:, m.ct_pt]
    ours = m.ground_A * np.clip(m.terrain.height_np(p[0], p[1]) - p[2], 0.0, None)
    statics = np.linalg.solve(np.vstack([p[:2], np.ones(3)]), [x[0], x[1], 1.0]) * m.total_mass * m.gravity
    d, theirs = _mujoco_rest(m, load(m), 1.0)
    assert abs(x[2] - d.xipos[1][2]) < 2e-3
    assert np.abs(_roll_pitch(R) - _roll_pitch(d.xmat[1].reshape(3, 3))).max() < 0.5
    assert np.abs(ours - theirs).max() < 3.0 and np.abs(ours - statics).max() < 3.0, (ours, theirs, statics)
    assert abs(_roll_pitch(R)[0]) > 1.0                     # the field tilts it: the test sees the heights


def test_a_box_slides_down_a_heightfield_ramp_as_coulomb_says_in_both_engines():
    """A 2 kg box on a 0.3 rad ramp (a heightfield in MuJoCo) with friction 0.1 slides g (sin a - mu cos a) t^2 / 2
    = 0.981 m in 1 s.  Ours: the sliding block of the shared slope run (tests/simcases.py: mu 0.4 scaled by
    0.25).  Measured: 0.982 m here, 0.979 m in MuJoCo (natively and under XLA_FLAGS=--xla_cpu_max_isa=AVX2);
    tolerance 5 %."""
    from simcases import SLOPE, SLOPES, block_on_slope, slopes

    mu = 0.4 * SLOPES["friction"][1]
    m = block_on_slope(SLOPE, mu)
    expect = 0.5 * 9.81 * (np.sin(SLOPE) - mu * np.cos(SLOPE))
    x = slopes()["traj"]["x"][:, :, 0, 1]                           # [samples, xyz] of the sliding block, 50 Hz
    ours = np.linalg.norm(x[50, 1:] - x[0, 1:])                     # 1 s
    met, qpos, _ = mujoco_run(m, np.zeros((1, 0, 5)), time=1.0)
    theirs = np.linalg.norm(qpos[0, -1, 1:3] - qpos[0, 0, 1:3])
    assert abs(ours - expect) < 0.05 * expect and abs(theirs - expect) < 0.05 * expect, (ours, theirs, expect)


@pytest.mark.slow
@pytest.mark.parametrize("pipeline", ["springs", "exact"])
def test_the_quadruped_stands_and_trots_on_a_rough_field_in_both_engines(pipeline):
    """The quadruped on a 2 cm rough field, standing (zero targets) and trotting (models/quadruped-trot.ctl), 3 s.
    Measured (springs / exact / MuJoCo): rest height 0.29450 / 0.29557 / 0.29436 m; roll 0.53 / 0.72 / 0.57 deg,
    pitch 0.79 / 0.92 / 0.69 deg; two diagonal feet carry it, the third 3.4 / 3.5 / 2.9 N, the fourth nothing; the trot
    walks 0.431 / 0.363 / 0.388 m and stays up (the same on AVX-512 and AVX2).  Tolerances: 2 mm, 0.5 deg, the same
    two feet carrying >= 90 % of the weight, distances within 25 %."""
    from cpgjax.sim.rotation import quat_to_mat_np

    m = load_model("models/quadruped.wl", terrain="rough:0.02", pipeline=pipeline)
    trot = read_ctl("models/quadruped-trot.ctl", n_dof=8, harmonics=2).coeffs
    r = simulate(m, np.stack([np.zeros_like(trot), trot]), time=3.0, record=True)
    x, q = r["traj"]["x"][-1][..., 0], r["traj"]["q"][-1][..., 0]
    b = m.pt_body[m.ct_pt]
    p = x[:, b] + np.einsum("ijc,jc->ic", quat_to_mat_np(q[:, b]), m.pt_local[:, m.ct_pt])
    ours = m.ground_A * np.clip(m.terrain.height_np(p[0], p[1]) - p[2], 0.0, None)
    mj = load(m)
    d, theirs = _mujoco_rest(m, mj, 3.0)
    bid = m.track + 1                                   # MuJoCo's bodies: the world, then ours in order
    assert mj.body(bid).name == m.body_names[m.track]
    assert abs(x[2, m.track] - d.xipos[bid][2]) < 2e-3
    R = quat_to_mat_np(q[:, m.track])
    assert np.abs(_roll_pitch(R) - _roll_pitch(d.xmat[bid].reshape(3, 3))).max() < 0.5
    pair = np.argsort(theirs)[-2:]
    weight = m.total_mass * m.gravity
    assert theirs[pair].sum() > 0.9 * weight and ours[pair].sum() > 0.9 * ours.sum(), (ours, theirs)
    met, _, _ = mujoco_run(m, trot[None], time=3.0, mj=mj)
    assert not r["fallen"][1] and not met["fallen"][0]
    assert abs(r["distance"][1] - met["distance"][0]) < 0.25 * met["distance"][0], (r["distance"][1], met["distance"])
