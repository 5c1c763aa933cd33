"""The observation of a closed-loop controller (cpgjax/episode/sensors.py) against hand-computed states."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from cpgjax.episode import sensors
from cpgjax.io.wl import load_model
from cpgjax.sim.state import initial_state, varied_initial_state
from cpgjax.sim.variation import Variation

QUAD = "models/quadruped.wl"


@pytest.fixture(scope="module", params=["springs", "exact"])
def quad(request):
    return load_model(QUAD, pipeline=request.param)


def _obs(model, s, var=None):
    def obs(s, var):
        z = jnp.zeros(s.x.shape[-1:], jnp.float32)
        return sensors.observe(model, sensors.GROUPS, s, var, (z + 0.25, z + 0.5), z - 0.1)

    return np.asarray(jax.jit(obs)(s, var))


def _varied(model, var):
    return jax.jit(lambda v: varied_initial_state(model, v))(var)      # op by op: a compile for each operation


def _split(model, obs):
    out, i = {}, 0
    for g in sensors.GROUPS:
        n = sensors.sizes(model)[g]
        out[g] = obs[i:i + n]
        i += n
    return out


def test_a_robot_standing_on_its_feet_reads_every_foot_down_no_tilt_and_its_joint_angles(quad):
    """The design pose: feet on the ground (depth 0), body level, at rest."""
    o = _split(quad, _obs(quad, initial_state(quad, 2)))
    assert sensors.sizes(quad) == {"angles": 8, "tilt": 2, "rates": 2, "contact": 4, "stance": 4, "phase": 2,
                                   "command": 1, "steer": 2, "turn": 1, "bias": 1}
    np.testing.assert_array_equal(o["contact"], 1.0)
    np.testing.assert_array_equal(o["stance"], 1.0)      # no memory given: the first reading, the touch sensors'
    np.testing.assert_array_equal(o["tilt"], 0.0)
    np.testing.assert_array_equal(o["rates"], 0.0)
    np.testing.assert_allclose(o["angles"] - np.asarray(quad.j_q0)[quad.ctrl_joint][:, None], 0.0, atol=1e-6)
    np.testing.assert_array_equal(o["phase"], [[0.25, 0.25], [0.5, 0.5]])
    np.testing.assert_array_equal(o["command"], np.float32(-0.1))
    np.testing.assert_array_equal(o["steer"], np.float32(-0.1) * np.float32([[0.25, 0.25], [0.5, 0.5]]))
    np.testing.assert_array_equal(o["turn"], np.float32(0.1))                # |c|, whichever way it turns
    np.testing.assert_array_equal(o["bias"], 1.0)


def test_a_lifted_robot_reads_no_foot_down(quad):
    var = Variation.nominal(quad, 1)._replace(lift=jnp.asarray([0.01]))
    o = _split(quad, _obs(quad, _varied(quad, var)))
    np.testing.assert_array_equal(o["contact"], 0.0)


def test_a_touch_sensor_reads_from_the_depth_it_is_given(quad):
    """A robot lifted 1 mm: a sensor reading from 2 mm above the ground sees its foot down, one reading from the
    ground (0, the contact law's test) or from 1 mm in does not; each leg has its own threshold."""
    var = Variation.nominal(quad, 1)._replace(lift=jnp.asarray([0.001]))
    s = _varied(quad, var)
    at = jnp.asarray([[-0.002], [0.0], [0.001], [-0.0005]], jnp.float32)        # [legs, B]
    read = jax.jit(lambda s, at: sensors.touch(quad, s, None, at))
    np.testing.assert_array_equal(np.asarray(read(s, at))[:, 0], [1.0, 0.0, 0.0, 0.0])
    np.testing.assert_array_equal(np.asarray(read(s, jnp.zeros_like(at))), np.asarray(sensors.touch(quad, s)))
    standing = initial_state(quad, 1)
    np.testing.assert_array_equal(np.asarray(read(standing, at))[:, 0], [1.0, 1.0, 0.0, 1.0])
    # the observation a closed loop reads (its ``touch`` None, as ClosedLoop's default): the sensors' own 0
    observe = jax.jit(lambda s, at: sensors.observe(quad, ("contact", "stance"), s, None, None, None, at))
    for state in (s, standing):
        np.testing.assert_array_equal(np.asarray(observe(state, None)), np.asarray(observe(state, jnp.zeros_like(at))))


def test_a_body_turned_by_known_angles_reads_them_as_roll_and_pitch(quad):
    """The robot turned about its body's x axis by a reads pitch a (nose up for a > 0), about y by b roll b; the
    pendulums are decoupled: a turn about one axis alone leaves the other reading 0.  Rates: the angular velocity
    about the body's y (roll) and x (pitch) axes."""
    a = np.array([0.3, 0.0, -0.2], np.float32)
    b = np.array([0.0, 0.4, 0.0], np.float32)
    var = Variation.nominal(quad, 3)._replace(tilt=jnp.asarray(np.stack([a, b])))
    s = _varied(quad, var)                            # the whole robot turned by Ry(b) Rx(a)
    w = np.zeros((3, quad.nb, 3), np.float32)
    w[:, :, 0] = np.array([0.7, -1.1, 0.2])[:, None]  # robot 0 is turned about x only: its body x axis is world x
    s = s._replace(w=jnp.asarray(w))
    o = _split(quad, _obs(quad, s))
    np.testing.assert_allclose(o["tilt"][1], a, atol=1e-6)                   # pitch
    np.testing.assert_allclose(o["tilt"][0], b, atol=1e-6)                   # roll
    c, sn = math.cos(0.3), math.sin(0.3)   # world (0.7, -1.1, 0.2) in the frame of a body turned by 0.3 about x
    np.testing.assert_allclose(o["rates"][:, 0], [-1.1 * c + 0.2 * sn, 0.7], atol=1e-6)
    assert (o["contact"][:, 0] == 1.0).sum() == 2   # pitched nose up about the body's CM: the hind feet go down


def test_the_relief_scale_flattens_a_rough_field_under_the_feet(quad):
    """On a rough field the feet read the field; with the terrain's relief scaled to 0 the ground is flat again."""
    rough = quad.replace(terrain=quad.terrain.__class__("rough", np.full((3, 3), 0.02), -5.0, -5.0, 5.0, 5.0))
    s = initial_state(rough, 1)
    np.testing.assert_array_equal(_split(rough, _obs(rough, s))["contact"], 1.0)      # 2 cm of ground above them
    flat = Variation.nominal(rough, 1)._replace(relief=jnp.zeros((1,), jnp.float32))
    lifted = s._replace(x=s.x + jnp.asarray([0.0, 0.0, 0.001])[:, None, None])
    np.testing.assert_array_equal(_split(rough, _obs(rough, lifted))["contact"], 1.0)
    np.testing.assert_array_equal(_split(rough, _obs(rough, lifted, flat))["contact"], 0.0)


def test_sensor_noise_depends_on_the_robot_key_and_step_only():
    keys = jax.vmap(lambda k: jax.random.key_data(k))(jax.random.split(jax.random.key(3), 5)).T   # [2, 5]
    amp = jnp.asarray([1.0, 0.0, 2.0])
    a = np.asarray(sensors.noise(keys, jnp.int32(7), amp))
    b = np.asarray(sensors.noise(keys[:, 2:4], jnp.int32(7), amp))
    c = np.asarray(sensors.noise(keys, jnp.int32(8), amp))
    np.testing.assert_array_equal(a[:, 2:4], b)                 # another batch, the same draws
    assert not np.array_equal(a, c)                             # another step, other draws
    np.testing.assert_array_equal(a[1], 0.0)
    assert np.abs(a[0]).max() <= 1.0 and np.abs(a[2]).max() <= 2.0 and np.abs(a[2]).max() > 0
