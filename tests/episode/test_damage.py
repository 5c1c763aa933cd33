"""Damage (cpgjax.episode.damage): the syntax, its errors, and what each damage does to an episode."""

from __future__ import annotations

import numpy as np
import pytest

from cpgjax.episode import damage as dmg
from cpgjax.io.wl import load_model, load_wl
from cpgjax.sim.model import build_model

MODEL = "models/quadruped.wl"


def test_parse_and_describe_round_trip():
    m = load_model(MODEL)
    d = dmg.parse("leg=AR, locked=KneePL,weak=HipAL:0.3", m)
    assert [(x.kind, x.target, x.factor) for x in d] == [("leg", "AR", 1.0), ("locked", "KneePL", 1.0),
                                                         ("weak", "HipAL", 0.3)]
    assert dmg.describe(d) == "leg=AR,locked=KneePL,weak=HipAL:0.3"
    assert dmg.parse("none", m) == () and dmg.describe(()) == "none"


@pytest.mark.parametrize("text, message", [
    ("leg=XX", "no leg 'XX'; the model's legs are AR, AL, PR, PL"),
    ("arm=AR", "expected KIND=NAME with KIND one of leg, locked, weak"),
    ("legAR", "expected KIND=NAME"),
    ("locked=Knee", "no controlled joint 'Knee'"),
    ("locked=KneeAR:0.5", "locked takes no factor"),
    ("weak=HipAR", "weak needs the torque factor"),
    ("weak=HipAR:x", "the torque factor 'x' is not a number"),
    ("weak=HipAR:1.5", "must be in \\[0, 1\\)"),
])
def test_bad_damage_is_a_clear_error(text, message):
    with pytest.raises(ValueError, match=message):
        dmg.parse(text, load_model(MODEL))


def test_each_damage_changes_the_model_as_it_says():
    desc = load_wl(MODEL)
    m = build_model(desc)
    d = dmg.parse("leg=AR,weak=HipPL:0.25,locked=KneeAL", m)
    hurt = build_model(dmg.damaged_description(desc, m, d))
    body = np.asarray(hurt.pt_body)[np.asarray(hurt.ct_pt)]
    gone = {m.body_index("LegUAR"), m.body_index("LegLAR")}
    assert len(hurt.ct_pt) == len(m.ct_pt) - 2 and not gone & set(body.tolist())
    j = list(m.joint_names).index("HipPL")
    assert hurt.j_taumax[j] == pytest.approx(0.25 * m.j_taumax[j])
    assert np.array_equal(np.delete(hurt.j_taumax, j), np.delete(m.j_taumax, j))
    mask = dmg.controller_mask(m, d)
    ctrl = [m.joint_names[int(i)] for i in m.ctrl_joint]
    assert mask[ctrl.index("KneeAL")].sum() == 0 and mask.sum() == mask.size - m.n_coeff


@pytest.mark.slow  # 11 s; fast: the damage syntax (this file) and the descriptors (test_descriptors.py)
def test_a_missing_leg_never_touches_the_ground():
    """leg=AR: the behaviour problem's duty factor of AR is 0 (no contact vertex left).  With the servos holding 0
    the robot tips towards the missing leg onto AL and PR, which stay down throughout (duty 1), and lifts PL."""
    from cpgjax.optim.behaviour import behaviour_problem

    p = behaviour_problem(MODEL, time=0.5, damage="leg=AR")
    r = p.evaluate(np.zeros((1, p.n_genes), np.float32))
    assert float(r["duty_AR"][0]) == 0.0
    assert [float(r[f"duty_{n}"][0]) for n in ("AL", "PR")] == [1.0, 1.0]
    assert float(r["duty_PL"][0]) < 1.0
    assert p.meta["damage"] == "leg=AR"
