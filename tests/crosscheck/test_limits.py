"""Joint limits in MuJoCo C as ours are (cpgjax/crosscheck/limits.py): a penalty beyond the stop."""

import numpy as np
import pytest
from simcases import rig

from cpgjax.crosscheck.engines import joint_angles, mujoco_run
from cpgjax.crosscheck.limits import DAMPING_STEP, LIMITS, check_limit, current_limit, joint_limit, limit_solref
from cpgjax.crosscheck.mjcf import load, to_mjcf
from cpgjax.episode.batch import simulate
from cpgjax.io.wl import load_model


def _mujoco_angle(m, c, form, dt):
    with joint_limit(form):
        mj = load(m, timestep=dt)
    _, qpos, _ = mujoco_run(m, c, time=4.0, mj=mj)
    return joint_angles(m, mj, qpos)[0, :, 0]


def test_a_saturated_servo_holds_the_arm_past_its_stop_as_far_in_both_engines_as_statics_says():
    """The rig's hip (limits +-1.5 rad) driven to 2.5 sin(pi t): its servo saturates at 17.5 N m and holds the arm
    past the stop by 17.5 / 300 = 0.058 rad (the penalty's statics; the arm's weight, nearly horizontal there, takes
    about 0.001 rad).  Measured: 0.0577 rad here, 0.0573 in MuJoCo C at 2 ms and at 0.25 ms; the whole 4 s trace
    within 0.006 rad of ours (mean 0.0006).  MuJoCo's default limit, as exported before, holds it 0.111 rad past
    and parts from ours by up to 0.056 rad (mean 0.028)."""
    m = rig(time=4)
    c = np.array([[[0.0, 2.5, 0.0, 0.0, 0.0]]])
    pen = simulate(m, c[0], time=4.0, record=True)
    t, ours = pen["traj"]["t"], pen["traj"]["angle"][:, 0]
    assert ours.max() - 1.5 == pytest.approx(17.5 / 300, abs=0.002)
    for dt in (0.002, 0.00025):
        mj = _mujoco_angle(m, c, "penalty", dt)
        assert abs(mj.max() - ours.max()) < 0.002 and abs(mj.min() - ours.min()) < 0.002, (dt, mj.max(), ours.max())
        diff = np.abs(mj[np.round(t / dt).astype(int)] - ours)
        assert diff.max() < 0.01 and diff.mean() < 0.001, (dt, diff.max(), diff.mean())
    soft = _mujoco_angle(m, c, "mujoco", 0.002)
    assert soft.max() - ours.max() > 0.03, soft.max()


def test_the_export_gives_every_limited_hinge_the_penalty_and_the_mujoco_form_its_default():
    quad = load_model("models/quadruped.wl")
    mj = load(quad)
    hinges = [j for j in range(mj.njnt) if mj.jnt_type[j] == 3]
    assert len(hinges) == 8
    for j in hinges:
        w = mj.dof_invweight0[mj.jnt_dofadr[j]]
        s0, s1 = limit_solref(quad.limit_k, quad.limit_c, w, mj.opt.timestep)
        assert mj.jnt_solref[j] == pytest.approx([s0, s1], rel=1e-6)
        assert mj.jnt_solimp[j][:2] == pytest.approx([1e-4, 1e-4])
    with joint_limit("mujoco"):
        assert "solreflimit" not in to_mjcf(quad)
        assert load(quad).jnt_solref[hinges[0]] == pytest.approx([0.02, 1.0])


def test_the_limits_damping_is_capped_where_mujocos_explicit_step_would_not_hold_it():
    """MuJoCo's limit damps explicitly: ``c W dt`` above 2 diverges, so the export keeps it at DAMPING_STEP."""
    assert limit_solref(300.0, 3.0, 10.0, 0.002) == (-3000.0, -30.0)             # c W dt = 0.06: as ours
    s0, s1 = limit_solref(300.0, 3.0, 1561.0, 0.002)                              # the quadruped's knee
    assert s0 == -300.0 * 1561.0 and s1 == pytest.approx(-DAMPING_STEP / 0.002)


def test_the_limit_form_is_a_scoped_setting_and_a_wrong_one_is_named():
    assert current_limit() == "penalty" and LIMITS == ("penalty", "mujoco")
    with joint_limit("mujoco"):
        assert current_limit() == "mujoco"
        with joint_limit(None):
            assert current_limit() == "mujoco"
    assert current_limit() == "penalty"
    with pytest.raises(ValueError, match="MuJoCo's joint limit must be one of penalty, mujoco, got 'hard'"):
        check_limit("hard")


def test_export_writes_the_penalty_limit_unless_asked_for_mujocos(tmp_path):
    from cpgjax import cli

    assert cli.main(["export", "models/quadruped.wl", "--out", str(tmp_path / "p.xml")]) == 0
    assert cli.main(["export", "models/quadruped.wl", "--limit", "mujoco", "--out", str(tmp_path / "m.xml")]) == 0
    assert (tmp_path / "p.xml").read_text().count("solreflimit") == 8
    assert "solreflimit" not in (tmp_path / "m.xml").read_text()
