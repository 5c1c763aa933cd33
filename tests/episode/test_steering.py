"""Steering by a commanded turning rate (cpgjax/episode/steering.py): the command law, the schedule, the tracking
sums and fitness against hand-computed values, the command in the observation, and a schedule of zeros against
the unsteered closed loop."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from runcases import TINY_TIME

from cpgjax.episode import policy as pol
from cpgjax.episode import sensors, steering
from cpgjax.episode.batch import simulate
from cpgjax.io.ctl import read_ctl
from cpgjax.io.wl import load_model
from cpgjax.sim.rotation import euler_to_mat, mat_to_quat
from cpgjax.sim.state import initial_state

QUAD = "models/quadruped.wl"


def _posed(model, xy, psi):
    """The robot's initial state with every body moved so that the tracked body's CM is at ``xy`` [2, B] and its
    heading is ``psi`` [B] (the tracked body turned about the vertical; the other bodies are not used)."""
    B = len(psi)
    s = initial_state(model, B)
    q = jnp.stack([jnp.asarray(mat_to_quat(euler_to_mat(0.0, 0.0, float(p)))) for p in psi], -1)   # [4, B]
    x = s.x.at[:2, model.track].set(jnp.asarray(xy, s.x.dtype))
    return s._replace(x=x, q=s.q.at[:, model.track].set(q.astype(s.q.dtype)))


def test_the_follower_commands_its_gain_times_the_heading_error_to_the_next_waypoint_clipped():
    """Robot at (1, 2) facing psi; the waypoint (0, 3) is at bearing atan2(1, 1) = pi/4 (counter-clockwise from +y)."""
    m = load_model(QUAD)
    psi = np.asarray([0.6, -0.5, math.pi / 4, 3.0])
    s = _posed(m, np.asarray([[1.0] * 4, [2.0] * 4]), psi)
    got_psi, xy = steering.heading_of(m, s)
    np.testing.assert_allclose(got_psi, psi, atol=1e-6)
    err = math.pi / 4 - psi
    err = np.arctan2(np.sin(err), np.cos(err))                 # 3.0 rad: the error wraps to pi/4 - 3 + 2 pi
    course = steering.Course(jnp.broadcast_to(jnp.asarray([0.0, 3.0], jnp.float32)[None, :, None], (1, 2, 4)),
                             jnp.full((4,), 1, jnp.int32), gain=1.5, limit=0.4)
    np.testing.assert_allclose(steering.heading_error(xy, got_psi, course.points[0]), err, atol=1e-6)
    c, mem = course.command(m, s, course.init(m, s))
    np.testing.assert_allclose(c, np.clip(1.5 * err, -0.4, 0.4), atol=1e-6)
    assert abs(1.5 * err[0]) < 0.4 and abs(1.5 * err[1]) > 0.4       # one inside the limit, one clipped
    np.testing.assert_array_equal(mem["waypoint"], 0)


def test_a_waypoint_within_reach_is_passed_and_after_the_last_the_command_is_zero():
    m = load_model(QUAD)
    s = _posed(m, np.asarray([[0.0, 0.0], [0.9, 0.9]]), np.asarray([0.0, 0.0]))
    # robot 0: waypoints (0, 1) then (-1, 1); robot 1: only (0, 1), padded by repeating it
    pts = steering.course([np.asarray([[0.0, 1.0], [-1.0, 1.0]]), np.asarray([[0.0, 1.0]])], gain=1.0, limit=2.0)
    pts = jax.tree.map(lambda a: jnp.moveaxis(jnp.asarray(a), 0, -1), pts)        # batch-last, as in the rollout
    c, mem = pts.command(m, s, pts.init(m, s))
    np.testing.assert_array_equal(mem["waypoint"], [1, 1])
    # robot 0 now heads for (-1, 1), seen from (0, 0.9): bearing atan2(1, 0.1); robot 1 has finished
    np.testing.assert_allclose(c, [math.atan2(1.0, 0.1), 0.0], atol=1e-6)


def test_a_schedule_commands_the_first_rate_until_the_switch_then_the_second():
    m = load_model(QUAD)
    s = initial_state(m, 2)
    sch = steering.Schedule(jnp.asarray([0.1, -0.2]), jnp.asarray([0.3, 0.0]), switch=1.0, limit=0.4)
    for n, want in ((0, [0.1, -0.2]), (int(round(1.0 / m.dt)) - 1, [0.1, -0.2]), (int(round(1.0 / m.dt)), [0.3, 0.0])):
        c, _ = sch.command(m, s._replace(n=jnp.asarray(n, s.n.dtype)), {})
        np.testing.assert_array_equal(c, np.float32(want))


def test_the_command_reaches_the_observation_as_command_and_times_the_phase():
    m = load_model(QUAD)
    s = initial_state(m, 3)
    c = jnp.asarray([0.4, -0.25, 0.0], jnp.float32)
    sin, cos = jnp.asarray([0.6, 0.0, 1.0]), jnp.asarray([0.8, -1.0, 0.0])
    obs = np.asarray(sensors.observe(m, ("command", "steer", "bias"), s, None, (sin, cos), c))
    np.testing.assert_array_equal(obs[0], c)
    np.testing.assert_array_equal(obs[1], np.float32(c * sin))
    np.testing.assert_array_equal(obs[2], np.float32(c * cos))
    np.testing.assert_array_equal(obs[3], 1.0)
    assert pol.parse_controller("pmtg").inputs == sensors.DEFAULT_GROUPS and "steer" not in sensors.DEFAULT_GROUPS \
        and "turn" not in sensors.DEFAULT_GROUPS
    fam = pol.parse_controller("pmtg:tilt+contact+command+steer+bias")
    assert fam.n_in(m) == 2 + 4 + 1 + 2 + 1 and fam.spec == "pmtg:tilt+contact+command+steer+bias"


def _walk(v, rates, T, n):
    """A hand-made episode: the CM on arcs at speed v, turning at rates[0] for the first half and rates[1] for the
    second, sampled n times; the tracking sums over it (S = 1, always up)."""
    dt = T / n
    psi, xy = 0.0, np.zeros(2)
    acc = steering.track_init(jnp.asarray([psi]), jnp.asarray(xy[:, None]))
    for k in range(1, n + 1):
        w = rates[0] if k <= n // 2 else rates[1]
        new = psi + w * dt
        # exact arc: the chord from the old to the new point, along the mid-angle, of length 2 v/w sin(w dt / 2)
        chord = v * dt if w == 0 else 2 * v / w * math.sin(w * dt / 2)
        mid = 0.5 * (psi + new)
        xy = xy + chord * np.asarray([-math.sin(mid), math.cos(mid)])
        psi = new
        acc = steering.track_update(acc, jnp.asarray([psi], jnp.float32), jnp.asarray(xy[:, None], jnp.float32),
                                    jnp.ones(1), k > n // 2, jnp.asarray([True]))
    return acc


def test_the_tracking_sums_of_a_hand_made_walk_give_its_speed_and_its_turn_error():
    """A walk of 8 s at 0.2 m/s turning 0.3 rad/s left then 0.1 right, told 0.25 then -0.1: heading fitness 0.2 m/s
    (to the chord's O(w^2 dt^2 / 24) = 4e-6 relative), turn error 0.5 (0.05 + 0) rad/s (float32 sums: 1e-6)."""
    T, n = 8.0, 160
    acc = _walk(0.2, (0.3, -0.1), T, n)
    hf, err = steering.track_finish(acc, T, T / 2, jnp.asarray([0.25]), jnp.asarray([-0.1]))
    np.testing.assert_allclose(hf, 0.2, rtol=1e-5)
    np.testing.assert_allclose(err, 0.5 * (0.05 + 0.0), atol=2e-6)
    # the tracking fitness: the speed times 1 - error / (half the range)
    np.testing.assert_allclose(steering.tracking_fitness(hf, err, 0.4), 0.2 * (1 - 0.025 / 0.2), rtol=1e-5)
    assert float(steering.tracking_fitness(hf, jnp.asarray([0.25]), 0.4)[0]) == 0.0     # an error past half the range
    # capped at 0.15 m/s the 0.2 m/s walk is credited 0.15; a cap above its speed leaves its score
    np.testing.assert_allclose(steering.tracking_fitness(hf, err, 0.4, 0.15), 0.15 * (1 - 0.025 / 0.2), rtol=1e-5)
    np.testing.assert_allclose(steering.tracking_fitness(hf, err, 0.4, 0.3), 0.2 * (1 - 0.025 / 0.2), rtol=1e-5)
    # a robot standing still turning on the spot scores 0 whatever it turns
    acc = _walk(0.0, (0.25, -0.1), T, n)
    hf, err = steering.track_finish(acc, T, T / 2, jnp.asarray([0.25]), jnp.asarray([-0.1]))
    assert abs(float(hf[0])) < 1e-9 and float(err[0]) < 1e-5


def test_a_fallen_robot_stops_scoring_and_turning():
    acc = steering.track_init(jnp.zeros(1), jnp.zeros((2, 1)))
    acc = steering.track_update(acc, jnp.asarray([0.5]), jnp.asarray([[0.0], [1.0]]), jnp.ones(1), False,
                                jnp.asarray([False]))
    assert float(acc["advance"][0]) == 0.0 and float(acc["turn0"][0]) == 0.0 and float(acc["psi"][0]) == 0.5


@pytest.mark.slow   # 15 s of CPU: the steered closed loop is its own program
def test_a_schedule_of_zero_commands_is_the_unsteered_closed_loop_bit_for_bit():
    """The command computed in the scan (a Schedule) reads 0 for every robot: the episode is the closed loop's with
    its constant command 0, bit for bit (the policy reads command and steer: every weight of them multiplies 0)."""
    m = load_model(QUAD)
    fam = pol.parse_controller("pmtg:tilt+contact+phase+command+steer+bias")
    c = read_ctl("models/quadruped-trot.ctl", n_dof=8, harmonics=2).coeffs.reshape(-1)
    rng = np.random.default_rng(3)
    g = np.concatenate([np.repeat(c[None], 16, 0), rng.uniform(-0.8, 0.8, (16, fam.n_weights(m)))], 1)
    closed = pol.from_genomes(fam, m, g.astype(np.float32))
    z = np.zeros(16, np.float32)
    steered = closed.replace(steer=steering.Schedule(z, z, TINY_TIME / 2, 0.4))
    a, b = simulate(m, closed, time=TINY_TIME), simulate(m, steered, time=TINY_TIME)
    for k in a:
        np.testing.assert_array_equal(a[k], b[k], err_msg=k)
    assert np.ptp(a["distance"]) > 0 and np.abs(b["turn_error"]).max() > 0       # episodes that differ, and turn
