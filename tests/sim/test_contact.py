"""Ground contact (cpgjax/sim/contact.py): eq. 3.7 and stick-slip friction."""

import numpy as np
from simcases import box, model_from

from cpgjax.episode.batch import simulate


def test_resting_penetration_is_m_g_over_A_contacts():
    m = box(z=0.05, mass=10.0)
    r = simulate(m, np.zeros((0, 5)), time=2.0, record=True)
    depth = 0.05 - r["traj"]["x"][-1, 2, 0]
    expected = 10.0 * 9.81 / (1e5 * 4)  # four bottom corners
    assert abs(depth - expected) / expected < 0.02, (depth, expected)


def _block_on_slope(slope, mu):
    text = f"""
TimeMax 2
LogRate 50
Friction {mu}
Terrain ramp {slope}
Object Box {{
    Type Cube
    Mass 2
    Dimensions .1 .1 .1
    Position 0 1.0 {-np.tan(slope) * 1.0 + 0.05 / np.cos(slope) + 0.001}
    Orientation {-slope} 0 0
}}
"""
    return model_from(text)


def test_static_friction_holds_a_block_on_a_slope_below_the_friction_angle():
    slope = 0.3  # tan = 0.31
    m = _block_on_slope(slope, mu=0.6)
    r = simulate(m, np.zeros((0, 5)), time=2.0, record=True)
    y = r["traj"]["x"][:, 1, 0]
    assert abs(y[-1] - y[10]) < 2e-3  # stuck (creeps less than 2 mm in 1.6 s)


def test_dynamic_friction_lets_it_slide_with_the_coulomb_acceleration():
    slope = 0.3
    mu = 0.1
    m = _block_on_slope(slope, mu=mu)
    r = simulate(m, np.zeros((0, 5)), time=2.0, record=True)
    t = r["traj"]["t"]
    v = r["traj"]["v"][:, :, 0]
    speed = np.linalg.norm(v, axis=1)
    sel = (t > 0.5) & (t < 1.8)
    acc = np.polyfit(t[sel], speed[sel], 1)[0]
    expected = 9.81 * (np.sin(slope) - mu * np.cos(slope))
    assert abs(acc - expected) / expected < 0.05, (acc, expected)


def test_a_body_sinks_no_deeper_than_a_few_millimetres_when_dropped():
    m = box(z=0.5, mass=10.0)
    r = simulate(m, np.zeros((0, 5)), time=1.5)
    assert not r["diverged"]
    assert r["depth"] < 0.01
