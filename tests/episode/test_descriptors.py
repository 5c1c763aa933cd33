"""Behaviour descriptors (cpgjax.episode.descriptors) against hand-computed episodes and the simulator."""

from __future__ import annotations

import math

import jax.numpy as jnp
import numpy as np
import pytest
from runcases import TINY_TIME

from cpgjax.episode import descriptors as bd
from cpgjax.io.wl import load_model


class _Track:
    """The two fields of a model the heading needs: the tracked body is body 0."""

    track = 0


def _rot_z(psi):
    """[3, 3, 1, B] rotations about z by psi [B]."""
    c, s = np.cos(psi), np.sin(psi)
    z, o = np.zeros_like(psi), np.ones_like(psi)
    return jnp.asarray(np.stack([np.stack([c, -s, z]), np.stack([s, c, z]), np.stack([z, z, o])])[:, :, None])


@pytest.mark.parametrize("direction", [1.0, -1.0])
def test_turning_rate_and_speed_on_a_circle_of_known_radius(direction):
    """A body walking a circle of radius r at speed v, its forward axis on the tangent: turning rate v/r
    (the heading turns by 2 pi per lap), forward speed v to O(dpsi^2/24) (here 1e-4 relative)."""
    r, v, T, samples = np.float64([0.5, 2.0]), 0.2, 10.0, 200
    w = direction * v / r                                 # rad/s, + = counter-clockwise (left)
    t = np.linspace(0.0, T, samples + 1)
    psi = w[None] * t[:, None]                            # heading from +y, counter-clockwise
    # the centre at (-r, 0) for a left turn: position = centre + r (cos psi, sin psi), velocity along (-sin, cos)
    x = -direction * r * (1 - np.cos(psi))
    y = direction * r * np.sin(psi)
    m = _Track()
    acc = bd.init(m, jnp.asarray(np.stack([x[0], y[0], 0 * x[0]])[:, None]), _rot_z(psi[0]), 0)
    for i in range(1, samples + 1):
        acc = bd.update(acc, np.zeros((0, 1), bool), jnp.zeros((1, 2), bool), bd.heading(m, _rot_z(psi[i])),
                        jnp.asarray(np.stack([x[i], y[i]])))
    out = bd.finish(acc, lambda a: a / samples, lambda a: a / T)
    np.testing.assert_allclose(np.asarray(out["turn"]), w, rtol=1e-5)
    dpsi = np.abs(w) * T / samples
    np.testing.assert_allclose(np.asarray(out["speed"]), v, rtol=dpsi.max() ** 2 / 24 * 1.01 + 1e-6)


def test_duty_factor_is_the_share_of_samples_with_any_foot_vertex_down():
    """Leg 0's foot has vertices 0 and 1 (down when either is), leg 1's vertex 2; 4 samples."""
    feet = np.asarray([[True, True, False], [False, False, True]])
    pattern = np.asarray([[1, 0, 0], [0, 1, 0], [0, 0, 1], [0, 0, 0]], bool)   # per sample: vertex down?
    m = _Track()
    acc = bd.init(m, jnp.zeros((3, 1, 1)), _rot_z(np.zeros(1)), 2)
    for p in pattern:
        acc = bd.update(acc, feet, jnp.asarray(p[:, None]), jnp.zeros(1), jnp.zeros((2, 1)))
    np.testing.assert_allclose(np.asarray(bd.finish(acc, lambda a: a / 4, lambda a: a)["duty"])[:, 0], [0.5, 0.25])


def test_a_robot_standing_still_has_every_foot_always_down_and_does_not_turn():
    """The quadruped with every servo holding angle 0 stands on its four feet: duty factor 1 for each leg
    (exactly: every sample), turning rate and forward speed ~0 (measured: below 1e-6)."""
    model = load_model("models/quadruped.wl")
    names, feet, bodies = bd.legs(model)
    assert names == ("AR", "AL", "PR", "PL") and feet.sum(1).tolist() == [1, 1, 1, 1]
    assert [[model.body_names[b] for b in leg] for leg in bodies][0] == ["LegUAR", "LegLAR"]
    from cpgjax.episode.probes import Descriptors
    from cpgjax.episode.rollout import rollout

    coeffs = jnp.zeros((model.n_ctrl, model.n_coeff, 16))
    r = rollout(model, coeffs, time=TINY_TIME, probes=(Descriptors(),))     # the program of the test below
    np.testing.assert_array_equal(np.asarray(r["duty"]), 1.0)
    assert np.abs(np.asarray(r["turn"])).max() < 1e-4 and np.abs(np.asarray(r["heading_speed"])).max() < 1e-4


def test_the_hexapods_six_legs():
    model = load_model("models/hexapod.wl")
    names, feet, _ = bd.legs(model)
    assert len(names) == 6 and set(names) == {"AR", "CR", "PR", "AL", "CL", "PL"}
    assert feet.sum(1).tolist() == [1] * 6


def test_descriptors_do_not_change_the_episode():
    """Switching the descriptors on adds sums to the scan, nothing else: the scores are those of the episode
    without them (two programs, so a tolerance: measured, fitness 3e-8 apart, distance and tilt equal, natively
    and under XLA_FLAGS=--xla_cpu_max_isa=AVX2 and SSE4_2; 1e-6 allows another compiler's fusion).  Without: the
    suite's tiny episode of 16 robots (episode/test_rollout.py's program)."""
    from cpgjax.episode.batch import simulate
    from cpgjax.episode.probes import Descriptors
    from cpgjax.episode.rollout import rollout

    model = load_model("models/quadruped.wl")
    g = np.random.default_rng(1).uniform(-0.3, 0.3, (16, model.n_ctrl, model.n_coeff)).astype(np.float32)
    c = jnp.moveaxis(jnp.asarray(g), 0, -1)
    a = simulate(model, g, time=TINY_TIME)
    b = rollout(model, c, time=TINY_TIME, probes=(Descriptors(),))
    for k in ("fitness", "distance", "tilt"):
        np.testing.assert_allclose(np.asarray(a[k]), np.asarray(b[k]), rtol=1e-6, atol=1e-6)
    assert math.isfinite(float(np.asarray(b["turn"]).sum()))
