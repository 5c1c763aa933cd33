"""The servo rig and the tracking rollout, against a linear PD servo on a pure inertia (closed form)."""

from __future__ import annotations

import numpy as np
import pytest

from cpgjax.analysis.cutoff import fit_sigmoid, linear_servo_error
from cpgjax.episode.tracking import RigError, axis_inertia, servo_rig, window_start
from cpgjax.io.wl import load_wl, parse_wl
from cpgjax.sim.model import build_model

# a 1 kg block turning about its own CM (x axis) on a controlled joint: a pure inertia
# I = m (dy^2 + dz^2) / 12 = 1/150 kg m^2; kp = 10, kd = 0.413: natural 6.2 Hz, damping ratio 0.8.
# dt = 1e-4 s keeps backward Euler's error on the damping well under 1 %.
INERTIA = (0.2**2 + 0.2**2) / 12
KP, KD = 10.0, 0.413
WHEEL = f"""
TimeStep 1e-4
Gravity 9.81
Servo {KP} 0 {KD} 17.5
Object Stand {{
    Type Cube
    Mass 5
    Dimensions .1 .1 .1
    NoContact
}}
Object Wheel {{
    Type Cube
    Mass 1
    Dimensions .1 .2 .2
    NoContact
}}
Joint Axle {{
    Stand 0.1 0 0
    Wheel 0 0 0
    ControlX
}}
"""
FREQS = np.array([1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0, 12.0, 16.0, 20.0])


@pytest.fixture(scope="module")
def wheel_path(tmp_path_factory):
    p = tmp_path_factory.mktemp("wheel") / "wheel.wl"
    p.write_text(WHEEL)
    return str(p)


def test_closed_form_reference_values():
    # at the natural frequency |E| = 1 / (2 zeta); far above it, 1; at 0, 0
    wn = np.sqrt(KP / INERTIA)
    zeta = KD / (2 * np.sqrt(KP * INERTIA))
    assert linear_servo_error([wn / (2 * np.pi)], INERTIA, KP, KD)[0] == pytest.approx(1 / (2 * zeta))
    assert linear_servo_error([1e4], INERTIA, KP, KD)[0] == pytest.approx(1.0, abs=1e-3)
    assert linear_servo_error([0.0], INERTIA, KP, KD)[0] == 0.0


def test_servo_experiment_recovers_the_cutoff_of_a_linear_servo(wheel_path):
    """No gravity, no saturation, a pure inertia: both engines' errors and cut-offs are the closed form's."""
    from cpgjax.experiments.servo import ServoConfig, run_servo

    cfg = ServoConfig(joint="Axle", freqs=tuple(FREQS), amps=(0.2,), settle=0.3, periods=2, gravity=0.0,
                      tau_max=1e6)
    out = run_servo(wheel_path, cfg)
    assert out["servo"]["inertia"] == pytest.approx(INERTIA, rel=1e-9)
    exact = linear_servo_error(FREQS, INERTIA, KP, KD)
    b_exact = fit_sigmoid(FREQS, exact)["b"]
    assert 4.0 < b_exact < 12.0                                      # the cut-off lies inside the range
    for name in ("penalty", "mujoco"):
        rel = np.asarray(out["engines"][name]["rel"][0])
        np.testing.assert_allclose(rel, exact, atol=0.02, err_msg=name)
        assert out["engines"][name]["cutoff_hz"][0] == pytest.approx(b_exact, rel=0.03), name


def test_saturation_lowers_the_cutoff(wheel_path):
    """With a torque limit below what a 0.4 rad drive needs near the cut-off, the joint stops following sooner."""
    from cpgjax.experiments.servo import ServoConfig, run_servo

    cfg = ServoConfig(joint="Axle", freqs=tuple(FREQS), amps=(0.4,), settle=0.3, gravity=0.0, tau_max=0.5,
                      mujoco=False)
    out = run_servo(wheel_path, cfg)
    b_exact = fit_sigmoid(FREQS, linear_servo_error(FREQS, INERTIA, KP, KD))["b"]
    assert out["engines"]["penalty"]["cutoff_hz"][0] < 0.8 * b_exact


def test_knee_rig_is_the_lower_leg_on_a_welded_upper_leg():
    desc = load_wl("models/quadruped.wl")
    robot = build_model(desc)
    rig = build_model(servo_rig(desc, "KneeAR", lift=1.0))
    assert rig.body_names == ("LegUAR", "LegLAR") and list(rig.fixed) == [True, False]
    assert rig.n_ctrl == 1 and rig.joint_names == ("KneeAR",)
    i = robot.body_names.index("LegLAR")
    np.testing.assert_allclose(rig.x0[:, 1], robot.x0[:, i] + [0, 0, 1.0], atol=1e-9)
    # the lower leg (0.3 kg, .035 x .162 m) about the knee, 0.071 m above its centre
    assert axis_inertia(rig) == pytest.approx(0.3 * (0.035**2 + 0.162**2) / 12 + 0.3 * 0.071**2, rel=1e-9)


def test_hip_rig_carries_the_whole_leg():
    rig = build_model(servo_rig(load_wl("models/quadruped.wl"), "HipPL"))
    assert set(rig.body_names) == {"Body", "LegUPL", "LegLPL"} and rig.fixed[rig.body_names.index("Body")]
    assert rig.joint_names[rig.ctrl_joint[0]] == "HipPL" and rig.n_ctrl == 2


def test_bad_rigs_and_windows():
    desc = parse_wl(WHEEL.replace("ControlX", "PassiveX"), "<wheel>")
    with pytest.raises(RigError, match="passive"):
        servo_rig(desc, "Axle")
    with pytest.raises(RigError, match="no joint 'Knee'"):
        servo_rig(desc, "Knee")
    with pytest.raises(RigError, match="0.1 Hz"):
        window_start(np.array([0.1, 1.0]), 2.0, 0.5)
    np.testing.assert_allclose(window_start(np.array([1.0, 4.0]), 2.5, 0.5), [0.5, 0.5])


# a bar (I_cm = 1 * (0.2^2 + 0.02^2) / 12) swinging about its end, 0.1 m from its CM: I = I_cm + m d^2,
# on a stiff servo (kp 600, kd 3: 34 Hz, damping ratio 0.53) at the default 0.5 ms step.  The implicit
# damper's conservative I_eff is I_cm (free bodies turn about their CMs): dt kd / I_eff = 0.45, where
# dt kd / I = 0.11 -- the quadruped's knee in small.
BAR_I = (0.2**2 + 0.02**2) / 12 + 0.1**2
BAR_KP, BAR_KD = 600.0, 3.0


def test_servo_damping_is_the_nominal_kd_at_the_default_step(tmp_path):
    """The derivative term is backward Euler over the whole step: the servo delivers kd, not kd / (1 + dt kd / I_eff).

    Fails with the damper applied to the rate at the start of the step: the response then follows
    kd / 1.45 (an error of 1.44 at 35 Hz instead of 0.98)."""
    from cpgjax.experiments.servo import ServoConfig, run_servo

    p = tmp_path / "bar.wl"
    p.write_text(WHEEL.replace("Dimensions .1 .2 .2", "Dimensions .1 .2 .02").replace("Wheel 0 0 0", "Wheel 0 -0.1 0")
                 .replace("TimeStep 1e-4", "TimeStep 5e-4").replace(f"Servo {KP} 0 {KD}", f"Servo {BAR_KP} 0 {BAR_KD}"))
    freqs = np.array([10.0, 20.0, 30.0, 35.0, 40.0, 50.0])
    cfg = ServoConfig(joint="Axle", freqs=tuple(freqs), amps=(0.05,), settle=1.0, periods=2, gravity=0.0,
                      tau_max=1e6, mujoco=False)
    out = run_servo(str(p), cfg)
    assert out["servo"]["inertia"] == pytest.approx(BAR_I, rel=1e-6)
    rel = np.asarray(out["engines"]["penalty"]["rel"][0])
    exact = linear_servo_error(freqs, BAR_I, BAR_KP, BAR_KD)
    weak = linear_servo_error(freqs, BAR_I, BAR_KP, BAR_KD / 1.45)
    assert np.max(np.abs(weak - exact)) > 0.3                        # the two dampers are told apart
    np.testing.assert_allclose(rel, exact, rtol=0.12, atol=0.02)     # first-order in dt: ~10 % at 30-40 Hz
