"""MuJoCo's friction cone in the export (cpgjax/crosscheck/mjcf.py: ``CONES``, ``friction_cone``; ``--mujoco-cone``).

Ours is Coulomb's circular cone, ``|f_t| <= mu f_r`` whatever the direction (sim/contact.py), and its normal force
does not depend on mu (eq. 3.7).  MuJoCo's default pyramidal cone is neither: it holds less along the diagonals of its
contact frame, and its regularisation mixes mu into the normal direction.  The elliptic cone is both.
"""

import numpy as np
import pytest

from cpgjax.crosscheck.mjcf import CONES, friction_cone, initial_qpos, load, to_mjcf
from cpgjax.io.wl import load_model


def test_the_cone_is_in_the_export_only_when_asked():
    """The default export is the text it always was (MuJoCo's pyramidal cone: no ``cone`` attribute, so every
    figure measured with it stands); ``cone=`` or an enclosing ``friction_cone`` asks for another; a wrong name is
    refused with the choices."""
    m = load_model("models/worm.wl")
    plain = to_mjcf(m)
    assert "cone=" not in plain
    assert to_mjcf(m, cone="pyramidal") == plain
    assert 'cone="elliptic"' in to_mjcf(m, cone="elliptic")
    with friction_cone("elliptic"):
        assert 'cone="elliptic"' in to_mjcf(m)
        assert to_mjcf(m, cone="pyramidal") == plain
    assert to_mjcf(m) == plain
    with pytest.raises(ValueError, match="pyramidal, elliptic"):
        to_mjcf(m, cone="round")
    assert CONES == ("pyramidal", "elliptic")


def _pushed(cone: str, angle_deg: float, share: float) -> float:
    """How far [m] a 10 kg box (mu 0.5) on flat ground slides in 1 s under a horizontal force of ``share`` mu m g at
    ``angle_deg`` from the x axis, in MuJoCo C at 2 ms, after 0.5 s settling."""
    import mujoco
    from simcases import box

    m = box(z=0.05, mass=10.0, friction=0.5)
    mj = load(m, timestep=0.002, cone=cone)
    d = mujoco.MjData(mj)
    d.qpos[:] = initial_qpos(m, mj)
    mujoco.mj_forward(mj, d)
    for _ in range(250):
        mujoco.mj_step(mj, d)
    x0 = d.qpos[:2].copy()
    a, f = np.radians(angle_deg), share * 0.5 * 10.0 * 9.81
    for _ in range(500):
        d.xfrc_applied[1, :3] = [f * np.cos(a), f * np.sin(a), 0.0]
        mujoco.mj_step(mj, d)
    return float(np.linalg.norm(d.qpos[:2] - x0))


def test_the_elliptic_cone_holds_a_pushed_box_in_every_direction_as_coulomb_the_pyramid_not_on_its_diagonal():
    """Coulomb (and ours): a box pushed at 0.9 mu m g stays, at 1.05 mu m g it slides, in any direction.  MuJoCo's
    elliptic cone does so along x and along the diagonal (measured: 0.44 and 0.45 mm of soft creep at 0.9; 128 and
    142 mm slid at 1.05).  The pyramidal cone holds along x (6 mm at 0.9) but lets the box slide along the diagonal
    already at 0.75 mu m g (114 mm; its edges there hold mu / sqrt 2).  Tolerance: 5 mm is held, 50 mm slid."""
    for angle in (0.0, 45.0):
        assert _pushed("elliptic", angle, 0.9) < 0.005, angle
        assert _pushed("elliptic", angle, 1.05) > 0.05, angle
    assert _pushed("pyramidal", 0.0, 0.75) < 0.005
    assert _pushed("pyramidal", 45.0, 0.75) > 0.05


def _resting_depth(cone: str, mu: float) -> float:
    """The quadruped's feet's depth [m] in MuJoCo C after 1 s standing (its servos holding 0), mu set on every geom."""
    import mujoco

    from cpgjax.crosscheck.engines import foot_geoms

    model = load_model("models/quadruped.wl")
    mj = load(model, timestep=0.002, cone=cone)
    mj.geom_friction[:, 0] = mu
    d = mujoco.MjData(mj)
    d.qpos[:] = initial_qpos(model, mj)
    mujoco.mj_forward(mj, d)
    for _ in range(500):
        mujoco.mj_step(mj, d)
    feet = set(np.flatnonzero(foot_geoms(model, mj) >= 0).tolist())
    depths = [-d.contact[i].dist for i in range(d.ncon) if {d.contact[i].geom1, d.contact[i].geom2} & feet]
    assert len(depths) == 4, depths
    return float(np.mean(depths))


def test_with_the_pyramidal_cone_mujocos_ground_softens_as_mu_grows_with_the_elliptic_it_does_not():
    """Eq. 3.7 (ours): a resting foot's depth is its load over A, whatever mu.  MuJoCo's elliptic cone: 0.135 mm at
    mu 1 and at the model's 2.5 alike (measured, equal to 1e-6).  The pyramidal cone (the export's default): 0.135 mm
    at mu 1 and 1.40 mm at 2.5, ten times deeper (0.72 mm at 2, 2.8 mm at 3; docs/crosscheck.md).  Tolerances:
    1 % between the elliptic depths, a ratio above 5 for the pyramidal ones."""
    e1, e25 = _resting_depth("elliptic", 1.0), _resting_depth("elliptic", 2.5)
    p1, p25 = _resting_depth("pyramidal", 1.0), _resting_depth("pyramidal", 2.5)
    assert abs(e25 - e1) < 0.01 * e1, (e1, e25)
    assert p25 > 5 * p1, (p1, p25)


def test_a_box_landing_at_the_quadrupeds_mu_sinks_as_eq_3_7_says_with_the_elliptic_cone_only():
    """The export's ``solref`` makes a body landing on its contacts sink as eq. 3.7's closed form says
    (tests/crosscheck/test_mjcf.py, at mu 1).  At the quadruped's mu = 2.5, a 1 kg box dropped 1 cm onto its four
    corners sinks 0.100 mm in MuJoCo with the elliptic cone, as at mu 1 (eq. 3.7: 0.104 mm), and 0.156 mm with the
    pyramidal one (measured; 13.8 kg: 1.04 and 1.37 mm against eq. 3.7's 1.18).  Tolerances: 15 % of eq. 3.7's
    depth (test_mjcf.py's), and the pyramidal cone's at least 1.3 times the elliptic's."""
    import mujoco
    from simcases import box
    from test_mjcf import _max_penetration_closed_form

    m = box(z=0.06, mass=1.0, friction=2.5, log_rate=2000)
    expect = _max_penetration_closed_form(1.0, 4, m.ground_A, m.ground_B, np.sqrt(2 * 9.81 * 0.01))
    deepest = {}
    for cone in CONES:
        mj = load(m, timestep=2e-5, cone=cone)
        d = mujoco.MjData(mj)
        deepest[cone] = 0.0
        for _ in range(2500):                        # 50 ms: the landing's deepest point comes within 10 ms
            mujoco.mj_step(mj, d)
            if d.ncon:
                deepest[cone] = max(deepest[cone], -float(d.contact.dist[: d.ncon].min()))
    assert abs(deepest["elliptic"] - expect) < 0.15 * expect, (deepest, expect)
    assert deepest["pyramidal"] > 1.3 * deepest["elliptic"], deepest


def test_a_model_whose_friction_the_pyramidal_cone_cannot_hold_gets_a_note():
    """Above mu 3 the pyramidal cone's ground gives way (the standing quadruped rests 21.9 mm deep at mu 5,
    docs/results/friction-cone.md): ``crosscheck``, ``transfer``, ``agreement`` and ``follow --engine mujoco`` print
    this note, naming the fix;
    none at the quadruped's 2.5, nor with the elliptic cone."""
    from cpgjax.crosscheck.mjcf import PYRAMID_MU_MAX, cone_note

    assert PYRAMID_MU_MAX == 3.0
    assert cone_note(2.5) is None and cone_note(5.0, "elliptic") is None
    note = cone_note(5.0, "pyramidal")
    assert note is not None and "--mujoco-cone elliptic" in note and "\n" not in note
    with friction_cone("elliptic"):
        assert cone_note(5.0) is None
    assert _resting_depth("pyramidal", 5.0) > 0.01      # measured 21.9 mm: the ground gives way


def test_transfer_notes_a_run_whose_models_friction_the_pyramidal_cone_cannot_hold(tmp_path):
    """``transfer`` and ``agreement`` read the model from each run file's attributes: the note names the highest
    friction of them (cli/crosscheck.py: ``runs_cone_note``)."""
    import json

    import h5py

    from cpgjax.cli.crosscheck import runs_cone_note
    from cpgjax.io.results import FORMAT

    text = open("models/worm.wl").read()
    paths = []
    for k, mu in enumerate((2.5, 5.0)):
        p = tmp_path / f"r{k}.h5"
        with h5py.File(p, "w") as f:
            f.attrs.update(format=FORMAT, kind="ga", config="{}", completed=0, population=2, n_genes=1,
                           meta=json.dumps({"model_text": text.replace("Friction      2.5", f"Friction {mu}"),
                                             "model_path": "worm.wl"}))
        paths.append(str(p))
    assert runs_cone_note(paths[:1], None) is None
    assert "friction 5 is above 3" in runs_cone_note(paths, None)
    assert runs_cone_note(paths, "elliptic") is None


def test_export_writes_the_cone_asked_for(tmp_path, capsys):
    """``cpgjax export --cone elliptic`` writes MuJoCo's elliptic cone; the default file is as before; a model of
    mu 5 exported with the pyramidal cone gets the note (naming ``--cone``), with the elliptic one none."""
    from cpgjax import cli

    text = open("models/worm.wl").read()
    (tmp_path / "worm.wl").write_text(text.replace("Friction      2.5", "Friction 5"))
    assert cli.main(["export", "models/worm.wl", "--out", str(tmp_path / "p.xml")]) == 0
    assert cli.main(["export", "models/worm.wl", "--cone", "elliptic", "--out", str(tmp_path / "e.xml")]) == 0
    assert "cone=" not in (tmp_path / "p.xml").read_text()
    assert 'cone="elliptic"' in (tmp_path / "e.xml").read_text()
    capsys.readouterr()
    assert cli.main(["export", str(tmp_path / "worm.wl"), "--out", str(tmp_path / "w5.xml")]) == 0
    assert "add --cone elliptic" in capsys.readouterr().err
    assert cli.main(["export", str(tmp_path / "worm.wl"), "--cone", "elliptic",
                     "--out", str(tmp_path / "w5e.xml")]) == 0
    assert "note" not in capsys.readouterr().err


def test_the_commands_cone_and_stiffness_options_reach_the_export():
    """``--mujoco-cone`` and ``--mujoco-stiffness`` (``crosscheck``; the cone also ``transfer``, ``agreement`` and
    ``follow``) are in force for every model the command exports, and only within it."""
    import argparse

    from cpgjax.cli.crosscheck import mujoco_ground
    from cpgjax.crosscheck.mjcf import contact_solref

    m = load_model("models/worm.wl")
    k, b = (float(v) for v in contact_solref(m).split())
    with mujoco_ground(argparse.Namespace(mujoco_cone="elliptic", mujoco_stiffness=0.5)):
        text = to_mjcf(m)
        assert [float(v) for v in contact_solref(m).split()] == pytest.approx([0.5 * k, 0.5 * b])
    assert 'cone="elliptic"' in text and to_mjcf(m) == to_mjcf(m, cone="pyramidal")
