"""Joints (cpgjax/sim/joints.py and servo.py): pivot springs, pendulum, servo, limits."""

import numpy as np
from simcases import pendulum, period, rig

from cpgjax.episode.batch import simulate


def test_pendulum_has_the_small_angle_period_of_its_inertia():
    L, mass = 0.5, 1.0
    m = pendulum(angle=0.05, length=L, mass=mass)
    r = simulate(m, np.zeros((0, 5)), time=3.0, record=True)
    angle = r["traj"]["angle"][:, 0]
    d = L / 2
    I_pivot = mass * (L**2 + 0.02**2) / 12 + mass * d**2
    expected = 2 * np.pi * np.sqrt(I_pivot / (mass * 9.81 * d))
    measured = period(r["traj"]["t"], angle)
    assert abs(measured - expected) / expected < 0.01, (measured, expected)
    # the pivot held: the springs stretch by a fraction of a millimetre
    assert r["pivot_err"] < 1e-3


def test_servo_follows_a_slow_target_on_a_fixed_rig():
    m = rig(limits=(-1.5, 1.5), time=4)
    c = np.array([[0.0, 0.3, 0.0, 0.0, 0.0]])
    r = simulate(m, c, time=4.0, record=True)
    err = np.abs(r["traj"]["angle"][:, 0] - r["traj"]["target"][:, 0])
    assert err[r["traj"]["t"] > 1].mean() < 0.05  # rad
    assert np.abs(r["traj"]["angle"][:, 0]).max() > 0.25


def test_joint_limits_stop_the_joint_near_the_limit():
    m = rig(limits=(-0.5, 0.5), time=2)
    c = np.array([[1.4, 0.0, 0.0, 0.0, 0.0]])  # target beyond the limit
    r = simulate(m, c, time=2.0, record=True)
    final = r["traj"]["angle"][-1, 0]
    assert 0.5 < final < 0.6  # the limit's penalty balances the saturated servo
