"""What the simulator does for XLA's compiler (cpgjax/sim/tricks.py) changes where values are computed, never the
values."""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from simcases import model_from, pendulum

from cpgjax.sim import initial_state, step
from cpgjax.sim.tricks import add_at, column, gather_sum, keep, mul, rot_const, sum0, take

X = jnp.asarray(np.random.default_rng(0).normal(size=(3, 7, 4)), jnp.float32)


@pytest.mark.parametrize("idx", [[0, 1, 2, 3, 4, 5, 6], [2], [3, 3, 3], [1, 2, 3], [0, 2, 4, 6], [5, 1, 1, 2, 3, 0],
                                 [6, 6, 0, 1, 4, 4, 4]])
def test_take_is_indexing_by_slices(idx):
    np.testing.assert_array_equal(np.asarray(take(X, idx)), np.asarray(X)[:, idx])
    jaxpr = str(jax.make_jaxpr(lambda x: take(x, idx))(X))
    assert "gather" not in jaxpr


def test_gather_sum_and_the_short_sums_add_in_a_fixed_order():
    slots = np.array([[0, 3, -1], [1, -1, -1], [2, 4, 5]])        # item 0: 0, 1, 2; item 1: 3, 4; item 2: 5
    want = np.stack([X[:, [0, 1, 2]].sum(1), X[:, [3, 4]].sum(1), X[:, [5]].sum(1)], 1)
    np.testing.assert_allclose(np.asarray(gather_sum(X, slots)), want, rtol=1e-6)
    np.testing.assert_allclose(np.asarray(sum0(X)), np.asarray(X).sum(0), rtol=1e-6)


def test_products_with_constants_leave_out_their_zero_terms():
    R = jnp.asarray(np.random.default_rng(1).normal(size=(3, 3, 2, 4)), jnp.float32)
    r = np.array([[0.0, 1.0], [0.0, 0.0], [2.0, 3.0]])              # no item has a y component
    np.testing.assert_allclose(np.asarray(rot_const(R, r)), np.einsum("ijnB,jn->inB", np.asarray(R), r), rtol=1e-6)
    np.testing.assert_array_equal(np.asarray(column(R, [1, 1])), np.asarray(R)[:, 1])
    np.testing.assert_array_equal(np.asarray(column(R, [0, 2])), np.stack([R[:, 0, 0], R[:, 2, 1]], 1))
    assert mul(None, X) is None and mul(1.0, X) is X and mul(X, 1.0) is X


def test_keep_is_a_loop_that_never_runs():
    tree = (X, {"a": X[0] * 2.0, "n": jnp.arange(3)})
    out = jax.jit(lambda t: keep(t))(tree)
    jax.tree.map(lambda a, b: np.testing.assert_array_equal(np.asarray(a), np.asarray(b)), out, tree)
    assert str(jax.make_jaxpr(lambda t: keep(t))(tree)).count("while") == 1
    assert keep(tree, on=False) is tree


def test_add_at_adds_to_the_rows_named_without_a_scatter():
    x, y = X[0], X[1, :3] * 2.0                                     # [7, 4], [3, 4]
    np.testing.assert_array_equal(np.asarray(add_at(x, [4, 0, 2], y)), np.asarray(x.at[np.array([4, 0, 2])].add(y)))
    assert "scatter" not in str(jax.make_jaxpr(lambda x: add_at(x, [4, 0, 2], y))(x))


BOX = """
Object Box {
    Type Cube
    Mass 2
    Dimensions .2 .1 .05
    Position 0 0 .04
    Orientation .1 .2 0
}"""


def _box_with_and_without_materialized_stages():
    m = model_from(BOX, pipeline="exact")
    return m, m.replace(exact=dataclasses.replace(m.exact, materialize=False))


def test_without_materialized_stages_the_step_leaves_every_stage_to_xla():
    """``exact.materialize = False``: no loop in the step but the contact solve's (traced, not compiled)."""
    s0 = initial_state(_box_with_and_without_materialized_stages()[0], 2)
    z = jnp.zeros((0, 2))
    whiles = [str(jax.make_jaxpr(lambda s, model=model: step(model, s, (z, z)))(s0)).count("while[")
              for model in _box_with_and_without_materialized_stages()]
    assert whiles[0] > 10 and whiles[1] == 1, whiles


@pytest.mark.slow  # 9 s at load 8: two programs compiled; fast: the loops counted above, and test_stages.py
def test_the_step_without_materialized_stages_computes_the_same_robot():
    """The step moves the robot the same with the stages materialized or not, to float32's rounding (a box
    dropped on the ground, 20 steps)."""
    m, plain = _box_with_and_without_materialized_stages()
    s0 = initial_state(m, 2)
    z = jnp.zeros((0, 2))

    def run(model):
        return jax.jit(lambda s: jax.lax.fori_loop(0, 20, lambda i, s: step(model, s, (z, z)), s))(s0)

    a, b = run(m), run(plain)
    assert float(jnp.abs(a.x - s0.x).max()) > 1e-3                  # it fell and hit the ground
    np.testing.assert_allclose(np.asarray(a.x), np.asarray(b.x), atol=1e-6)
    np.testing.assert_allclose(np.asarray(a.v), np.asarray(b.v), atol=1e-4)


def test_the_polynomial_atan2_is_within_its_stated_error_and_a_model_setting_not_a_flag():
    """Within 1e-5 rad of the library's over every quadrant (measured: 1.0e-5 at most on this grid), exact on the
    axes; the joint angles use it only on a model whose ``poly_atan2`` is set."""
    from cpgjax.sim.joints import joint_angles
    from cpgjax.sim.rotation import quat_to_mat
    from cpgjax.sim.tricks import poly_atan2

    a = np.linspace(-np.pi, np.pi, 2001, dtype=np.float32)
    y, x = 2.0 * np.sin(a), 2.0 * np.cos(a)
    np.testing.assert_allclose(np.asarray(poly_atan2(jnp.asarray(y), jnp.asarray(x))), np.arctan2(y, x), atol=1.2e-5)
    np.testing.assert_array_equal(np.asarray(poly_atan2(jnp.float32(0.0), jnp.float32(1.0))), 0.0)
    m = pendulum(angle=0.7)
    s = initial_state(m, 1)
    R = quat_to_mat(s.q)
    plain, _, _ = joint_angles(m, R, s.w)
    poly, _, _ = joint_angles(m.replace(poly_atan2=True), R, s.w)
    assert not m.poly_atan2 and m != m.replace(poly_atan2=True) and abs(float(plain[0, 0])) > 0.5
    np.testing.assert_allclose(np.asarray(poly), np.asarray(plain), atol=1.2e-5)
