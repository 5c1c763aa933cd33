"""The exact pipeline's tree (cpgjax/sim/exact/tree.py): generalized coordinates from a `.wl` file's joints, by depth;
what exact joints cannot express is a ``path:line`` error."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from simcases import model_from

from cpgjax.errors import DescriptionError
from cpgjax.sim import initial_state
from cpgjax.sim.exact.tree import build_levels, build_tree


def test_a_robot_rooted_at_a_middle_body_walks_its_joints_the_files_way():
    """The worm is tracked at its middle segment: the tree walks two joints from child to parent; the bodies the
    kinematics (MuJoCo's stage, `smooth.kinematics`) places from the state's angles measure those angles as the
    file's (body_b relative to body_a).  Its bodies against MuJoCo C's: tests/sim/exact/test_stages.py."""
    from cpgjax.io.wl import load_model
    from cpgjax.sim.exact.levels import to_levels
    from cpgjax.sim.exact.smooth import kinematics
    from cpgjax.sim.joints import joint_angles
    from cpgjax.sim.rotation import quat_to_mat

    m = load_model("models/worm.wl", pipeline="exact")
    t = m.exact.tree
    assert t.roots[0] == m.track and (t.sign < 0).sum() >= 1
    s = initial_state(m, 1)
    roots = np.asarray(m.exact.levels.bodies[0])
    angle = s.exact.angle + jnp.linspace(-0.3, 0.3, m.nj)[:, None]

    @jax.jit      # the kinematics alone: a small program (the whole exact step compiles for seconds)
    def measured(angle):
        root = (s.x[:, roots], s.q[:, roots], s.v[:, roots], s.w[:, roots])
        _, q, _, w = kinematics(m, root, to_levels(m, angle), to_levels(m, jnp.zeros_like(angle)))
        return joint_angles(m, quat_to_mat(q), w)[0]

    np.testing.assert_allclose(np.asarray(measured(angle)), np.asarray(angle), atol=1e-5)


def _cube(name: str, extra: str = "") -> str:
    """A `.wl` body: a 10 cm cube of 1 kg (``extra``: more lines of its block)."""
    return f"Object {name} {{\n    Type Cube\n    Mass 1\n    Dimensions .1 .1 .1\n{extra}}}\n"


@pytest.mark.parametrize("text, match", [
    ("""
Track A
""" + _cube("A") + _cube("B", "    Fixed\n") + """Joint J {
    A 0 0 -.05
    B 0 0 .05
    ControlX
}
""", r"Joint 'J': body 'B' is Fixed"),
])
def test_what_exact_joints_cannot_express_is_a_path_line_error(text, match):
    line = next(i for i, t in enumerate(text.split("\n"), 1) if t.startswith("Joint J"))
    with pytest.raises(DescriptionError, match=f"^<test>:{line}: {match}"):
        model_from(text, pipeline="exact")
    model_from(text, pipeline="springs")      # the thesis's pipeline takes it


def test_a_loop_of_joints_is_a_path_line_error():
    text = "\n" + _cube("A") + _cube("B") + _cube("C") + """Joint J1 {
    A 0 0 -.05
    B 0 0 .05
    ControlX
}
Joint J2 {
    B 0 0 -.05
    C 0 0 .05
    ControlX
}
Joint J3 {
    C 0 0 -.05
    A 0 0 .05
    ControlX
}
"""
    with pytest.raises(DescriptionError, match=r"<test>:\d+: .*loop"):
        model_from(text, pipeline="exact")


def test_the_tree_of_the_quadruped_has_its_legs_by_depth():
    from cpgjax.io.wl import load_model

    m = load_model("models/quadruped.wl", pipeline="exact")
    t = build_tree(m, m.description)
    lv = build_levels(t)
    names = m.body_names
    assert [names[b] for b in lv.bodies[0]] == ["Body"] and list(lv.free) == [True]
    # every upper leg hangs from the body, every lower leg from its own upper leg, each by its own joint
    for i, b in enumerate(lv.bodies[2]):
        upper = lv.bodies[1][lv.parent[2][i]]
        assert names[b].replace("LegL", "") == names[upper].replace("LegU", "")
        assert m.joint_names[lv.joint[2][i]] == "Knee" + names[b][4:]
    assert sorted(m.joint_names[k] for k in lv.joint[1]) == sorted(n for n in m.joint_names if n.startswith("Hip"))
    assert (t.sign > 0).all()
