"""Terrain (cpgjax/sim/terrain.py): bilinear heightfields, bumps, ramps, seeded roughness."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from cpgjax.sim.description import TerrainDef
from cpgjax.sim.terrain import check_terrain, height_and_normal, make_terrain, parse_terrain


def test_matrix_is_bilinearly_interpolated_with_its_normal():
    h = ((0.0, 1.0), (2.0, 3.0))  # rows are y
    t = make_terrain(TerrainDef("matrix", (2, 2, 0.0, 1.0, 0.0, 1.0), h))
    z, n = height_and_normal(t, jnp.array([0.25, 0.5, 1.0]), jnp.array([0.5, 0.5, 1.0]))
    np.testing.assert_allclose(np.asarray(z), [0.25 + 1.0, 0.5 + 1.0, 3.0], atol=1e-5)
    n = np.stack([np.asarray(c) for c in n])
    expected = np.array([-1.0, -2.0, 1.0]) / np.sqrt(6.0)  # plane z = x + 2y
    np.testing.assert_allclose(n[:, 0], expected, atol=1e-6)


def test_ramp_descends_with_its_slope():
    t = make_terrain("ramp:0.2")
    z, _ = height_and_normal(t, jnp.array([0.0, 0.0]), jnp.array([1.0, 2.0]))
    np.testing.assert_allclose(np.diff(np.asarray(z)), -np.tan(0.2), rtol=1e-5)


def test_bump_has_its_height_across_the_path():
    t = make_terrain("bump:0.02@1.5")
    z, _ = height_and_normal(t, jnp.array([-1.0, 0.0, 2.0, 0.0]), jnp.array([1.6, 1.7, 1.6, 0.5]))
    np.testing.assert_allclose(np.asarray(z), [0.02, 0.02, 0.02, 0.0], atol=1e-6)


def test_rough_terrain_is_uniform_in_its_range_and_seeded():
    a, b, c = make_terrain("rough:0.03:0.1:7"), make_terrain("rough:0.03:0.1:7"), make_terrain("rough:0.03:0.1:8")
    assert np.array_equal(a.heights, b.heights) and not np.array_equal(a.heights, c.heights)
    assert a.heights.min() >= 0 and a.heights.max() <= 0.03
    assert abs(a.heights.mean() - 0.015) < 0.001


def test_wl_terrain_statements_match_the_cli_syntax():
    assert make_terrain(TerrainDef("bump", (0.02, 1.5, 0.3))).spec == "bump:0.02@1.5:0.3"
    assert np.array_equal(make_terrain(TerrainDef("rough", (0.03, 0.1, 7.0))).heights,
                          make_terrain("rough:0.03:0.1:7").heights)


@pytest.mark.parametrize("bad", ["hill:1", "bump:x", "rough:", "ramp:2", "bump:0.1:0", "bump:0.1:-0.2",
                                 "rough:0.01:0"])
def test_bad_terrain_text_is_a_clear_error(bad):
    with pytest.raises(ValueError, match="terrain"):
        make_terrain(bad)


def test_cli_spec_gives_the_checked_terrain_def_with_its_defaults():
    assert parse_terrain("bump:0.02") == check_terrain("bump", (0.02, 1.0, 0.3))
    assert parse_terrain("ramp:-0.1:x") == check_terrain("ramp", (-0.1,), "X")
    assert parse_terrain("rough:0.02::3") == check_terrain("rough", (0.02, 0.1, 3.0))


def test_cli_errors_name_the_spec_and_give_an_example():
    with pytest.raises(ValueError) as e:
        make_terrain("bump:0.1:0")
    assert str(e.value) == ("terrain 'bump:0.1:0': bump WIDTH must be positive (metres along y), got 0 "
                            "(e.g. bump:0.02@1.0:0.3)")


@pytest.mark.parametrize(("tdef", "message"), [
    (TerrainDef("ramp", (2.0,)), "|SLOPE| < pi/2"),
    (TerrainDef("bump", (0.1, 1.0, -0.2)), "bump WIDTH must be positive"),
    (TerrainDef("rough", (0.01, 0.0)), "rough CELL must be positive"),
    (TerrainDef("rough", (0.01, 0.1, 1.5)), "rough SEED must be a non-negative integer, got 1.5"),
    (TerrainDef("matrix", (2, 2, 0.0, 1.0, 0.0, 1.0), ((0.0, 1.0),)), "matrix heights must be NY = 2 rows"),
    (TerrainDef("matrix", (2, 2, 1.0, 0.0, 0.0, 1.0), ((0.0, 1.0), (0.0, 1.0))), "X0 < X1"),
    (TerrainDef("flat", (1.0,)), "flat terrain takes 0 to 0 parameters"),
    (TerrainDef("hill"), "unknown terrain kind 'hill'"),
])
def test_a_terrain_def_made_in_code_is_checked_too(tdef, message):
    with pytest.raises(ValueError, match=message.replace("|", r"\|").replace("(", r"\(")):
        make_terrain(tdef)


def test_a_robot_starts_on_its_terrain_never_in_it():
    """On a rough field the quadruped's `.wl` pose (feet on z = 0) would stand up to RANGE inside the ground: it is
    raised as a whole until its contact vertex with the most ground above it touches; elsewhere it is where it was."""
    from cpgjax.io.wl import load_model
    from cpgjax.sim.model import _contact_points
    from cpgjax.sim.terrain import start_lift

    flat = load_model("models/quadruped.wl")
    for spec in ("ramp:0.1", "bump:0.02", "rough:0"):
        assert np.array_equal(load_model("models/quadruped.wl", terrain=spec).x0, flat.x0), spec
    m = load_model("models/quadruped.wl", terrain="rough:0.04:0.1:3")
    feet = _contact_points(m.x0, m.q0, m.pt_body[m.ct_pt], m.pt_local[:, m.ct_pt])
    clearance = feet[2] - m.terrain.height_np(feet[0], feet[1])
    assert clearance.min() == pytest.approx(0.0, abs=1e-9) and start_lift(m.terrain, feet) == 0.0
    lift = m.x0[2] - flat.x0[2]
    assert np.ptp(lift) < 1e-12 and 0.01 < lift[0] <= 0.04 and np.array_equal(m.x0[:2], flat.x0[:2])
    assert start_lift(make_terrain("flat"), feet - 1.0) == 0.0          # flat ground: never moved


@pytest.mark.parametrize("spec", ["rough:0.02:0.07:4",
                                  "course:flat:0.5,rough:0.02:1,stairs:0.04:0.3:3,bar:0.03,flat:1"])
def test_heights_in_numpy_are_the_heights_jax_computes_op_by_op(spec):
    """``Terrain.height_np`` (exports, plots, the perturbed grounds) is numpy, operation by operation as JAX runs the
    height of :func:`height_and_normal` op by op: the same bits on any host (each operation one IEEE rounding; checked
    natively and under ``--xla_cpu_max_isa`` AVX2 and SSE4_2), at random points, on every grid point (where an
    index may reach past the last row: both clamp it), and off the field; and within 1e-6 m of the simulator's
    jitted height, which may fuse a product and a sum into one rounding (measured: at most 7.5e-9 m)."""
    t = make_terrain(spec)
    rng = np.random.default_rng(5)
    ny, nx = t.heights.shape
    gx, gy = np.meshgrid(t.x0 + t.dx * np.arange(nx), t.y0 + t.dy * np.arange(ny))
    x = np.concatenate([rng.uniform(-6, 14, 500), gx.reshape(-1)])
    y = np.concatenate([rng.uniform(-6, 14, 500), gy.reshape(-1)])
    z = t.height_np(x, y)
    op_by_op = np.asarray(height_and_normal(t, jnp.asarray(x), jnp.asarray(y))[0])
    assert z.dtype == np.float32 and np.array_equal(z.view(np.uint32), op_by_op.view(np.uint32))
    jitted = np.asarray(jax.jit(lambda a, b: height_and_normal(t, a, b)[0])(x, y))
    np.testing.assert_allclose(z, jitted, rtol=0, atol=1e-6)
