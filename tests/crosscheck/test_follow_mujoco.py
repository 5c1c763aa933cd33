"""The path follower in MuJoCo C (cpgjax/crosscheck/follow.py): its numpy law against ours (steering.Course) on the
same poses, MuJoCo's pose against ours at t = 0, and a short walk whose command follows MuJoCo's pose."""

import math

import jax.numpy as jnp
import numpy as np
import pytest

from cpgjax.crosscheck import follow as mf
from cpgjax.crosscheck.engines import root_slice
from cpgjax.crosscheck.mjcf import initial_qpos, load
from cpgjax.episode import policy as pol
from cpgjax.episode import steering
from cpgjax.experiments.steer import measure
from cpgjax.io.ctl import read_ctl
from cpgjax.io.wl import load_model
from cpgjax.sim.rotation import euler_to_mat, mat_to_quat
from cpgjax.sim.state import initial_state

QUAD = "models/quadruped.wl"
# float32 (ours) against float64 (MuJoCo's follower): the CM to ~1e-7 m and the heading to ~1e-7 rad, a waypoint
# about 1 m away: the heading error agrees to ~1e-6 rad; the command, a gain of at most 1.5 times it, to 1e-5 rad/s
TOL = 1e-5


@pytest.fixture(scope="module")
def quad():
    m = load_model(QUAD)
    return m, load(m)


def _qpos(model, mj, xy, psi):
    """MuJoCo states [B, nq] whose tracked body's CM is at ``xy`` [B, 2] (at its initial height), turned by ``psi``
    about the vertical, and our states of the same poses (the tracked body's CM ``x`` and orientation ``q``)."""
    q0 = initial_qpos(model, mj)
    root = root_slice(model, mj)
    tr = model.track
    out, qs = [], []
    for (x, y), p in zip(xy, psi, strict=True):
        R = np.asarray(euler_to_mat(0.0, 0.0, float(p)))
        q = np.asarray(mat_to_quat(R), float)
        cm = np.asarray([x, y, model.x0[2, tr]])
        qp = q0.copy()
        qp[root] = np.concatenate([cm - R @ model.cm_local[:, tr], q])
        out.append(qp)
        qs.append(q)
    s = initial_state(model, len(psi))
    x = s.x.at[:2, tr].set(jnp.asarray(np.asarray(xy).T, s.x.dtype))
    return np.stack(out), s._replace(x=x, q=s.q.at[:, tr].set(jnp.asarray(np.stack(qs, 1), s.q.dtype)))


def test_the_numpy_follower_commands_as_ours_on_the_same_pose(quad):
    """Random poses and paths (some waypoints within reach, some behind the robot, some commands clipped): MuJoCo's
    pose reading and follower give our heading, CM, passed waypoints and command (to TOL)."""
    m, mj = quad
    rng = np.random.default_rng(0)
    B = 64
    xy = rng.uniform(-2, 2, (B, 2))
    psi = rng.uniform(-math.pi, math.pi, B)
    paths = [rng.uniform(-2, 2, (int(n), 2)) for n in rng.integers(1, 4, B)]
    for b in range(0, B, 4):                     # every 4th robot starts within reach of its first waypoint
        paths[b][0] = xy[b] + rng.uniform(-0.1, 0.1, 2)
    qpos, s = _qpos(m, mj, xy, psi)
    got_psi, got_xy, up = mf.pose(m, mj, qpos)
    ours_psi, ours_xy = steering.heading_of(m, s)
    np.testing.assert_allclose(got_psi, ours_psi, atol=1e-6)
    np.testing.assert_allclose(got_xy, np.asarray(ours_xy).T, atol=1e-6)
    np.testing.assert_allclose(up, 1.0, atol=1e-12)
    course = steering.course(paths, gain=1.5, limit=0.4)
    course = type(course)(jnp.moveaxis(course.points, 0, -1), course.count, 1.5, 0.4)   # batch-last, as in the scan
    mem = course.init(m, s)
    fol = mf.Follower(paths, gain=1.5, limit=0.4)
    for _ in range(2):                          # twice: the memory (waypoints passed) carried as ours carries it
        c, mem = course.command(m, s, mem)
        mine = fol.command(got_psi, got_xy)
        np.testing.assert_array_equal(fol.k, mem["waypoint"])
        np.testing.assert_allclose(mine, c, atol=TOL)
    assert (fol.k > 0).sum() >= B // 4 and (np.abs(mine) == 0.4).any() and (np.abs(mine) < 0.4).any()


def test_mujocos_robot_starts_where_ours_does_and_reads_our_command(quad):
    m, mj = quad
    psi, xy, up = mf.pose(m, mj, initial_qpos(m, mj)[None])
    s = initial_state(m, 1)
    ours_psi, ours_xy = steering.heading_of(m, s)
    np.testing.assert_allclose(psi, ours_psi, atol=1e-6)
    np.testing.assert_allclose(xy[0], np.asarray(ours_xy)[:, 0], atol=1e-6)
    np.testing.assert_allclose(up, 1.0, atol=1e-6)


def _steering_controller(model, n):
    """n copies of a closed loop that reads the command (a policy of zeros on the trot's CPG: it walks the trot
    whatever the command, which is what a test of the command's mechanism needs)."""
    fam = pol.parse_controller("pmtg:tilt+command+steer+bias")
    coeffs = read_ctl("models/quadruped-trot.ctl", n_dof=8, harmonics=2).coeffs.astype(np.float32)
    one = pol.ClosedLoop(fam, coeffs, np.zeros((fam.n_out(model), fam.n_in(model)), np.float32),
                         np.zeros((), np.float32))
    return pol.stack([one] * n, model)


def test_a_robot_off_the_path_is_commanded_back_towards_it_in_mujoco_as_in_ours(quad):
    """1 s in MuJoCo C: waypoints ahead on the left and ahead on the right; the command, set every step from MuJoCo's
    pose, turns towards each (left +, right -), equals ours at t = 0 (to TOL), and at every log sample is the law
    applied to the sample's pose (to 2e-3 rad/s: the command is that of the sample's last step, one step of 2 ms
    before it)."""
    m, _ = quad
    paths = [np.asarray([[-1.0, 1.0]]), np.asarray([[1.0, 1.0]])]
    gain, limit = 0.5, 10.0            # no clipping: the command is proportional to the heading error
    r = mf.walk(m, _steering_controller(m, 2), paths, time=1.0, gain=gain, limit=limit)
    S = r["t"].shape[0]
    assert S == int(round(1.0 * m.episode.log_rate)) + 1 and r["dt"] == 0.002 and r["up"].min() > 0.9
    c = r["command"]
    assert (c[0] > 0).all() and (c[1] < 0).all()
    course = steering.course(paths, gain, limit)
    course = type(course)(jnp.moveaxis(course.points, 0, -1), course.count, gain, limit)
    s0 = initial_state(m, 2)
    ours, _ = course.command(m, s0, course.init(m, s0))
    np.testing.assert_allclose(c[:, 0], ours, atol=TOL)
    for b, p in enumerate(paths):
        d = p[0] - r["xy"][b]
        law = gain * np.arctan2(np.sin(np.arctan2(-d[:, 0], d[:, 1]) - r["psi"][b]),
                                np.cos(np.arctan2(-d[:, 0], d[:, 1]) - r["psi"][b]))
        np.testing.assert_allclose(c[b], law, atol=2e-3)
        assert np.ptp(c[b]) > 0.01             # the robot walked, its pose changed the command
    np.testing.assert_array_equal(r["waypoint"], 0)


def test_the_walk_ends_at_the_first_sample_at_which_every_robot_has_finished(quad):
    """A waypoint 0.1 m ahead is within reach at t = 0: passed by the command at t = 0, the walk ends at the first log
    sample after it, measured as ours (finished at t = 0, the command 0)."""
    m, _ = quad
    r = mf.walk(m, _steering_controller(m, 1), [np.asarray([[0.0, 0.1]])], time=1.0)
    assert r["t"].tolist() == pytest.approx([0.0, 1.0 / m.episode.log_rate]) and r["xy"].shape == (1, 2, 2)
    w, end = measure(r["t"], r["waypoint"][0], r["up"][0], r["xy"][0], r["command"][0], np.asarray([[0.0, 0.1]]))
    assert end == 0 and w["finished"] and w["time"] == 0.0 and w["reached"] == 1 and w["command_mean_abs"] == 0.0


def test_at_a_shorter_mujoco_step_the_walk_samples_and_ends_as_at_ours(quad):
    """MuJoCo C at a quarter of the model's step: the command is set once per control period (2 ms, held over four
    steps); the walk still logs one sample per 1/LogRate with the command of the period holding its last step (the
    law on the pose at most one period before: 2e-3 rad/s), and ends at the first sample after every robot finished."""
    m, _ = quad
    paths = [np.asarray([[-1.0, 1.0]]), np.asarray([[1.0, 1.0]])]
    r = mf.walk(m, _steering_controller(m, 2), paths, time=0.2, gain=0.5, limit=10.0, timestep=m.dt / 4)
    assert r["t"].shape == (5,) and r["command"].shape == r["waypoint"].shape == (2, 5) and r["xy"].shape == (2, 5, 2)
    for b, p in enumerate(paths):
        d = p[0] - r["xy"][b]
        head = np.arctan2(-d[:, 0], d[:, 1]) - r["psi"][b]
        np.testing.assert_allclose(r["command"][b], 0.5 * np.arctan2(np.sin(head), np.cos(head)), atol=2e-3)
    done = mf.walk(m, _steering_controller(m, 1), [np.asarray([[0.0, 0.1]])], time=1.0, timestep=m.dt / 4)
    assert done["t"].tolist() == pytest.approx([0.0, 1.0 / m.episode.log_rate]) and done["xy"].shape == (1, 2, 2)
