"""Ledges (``sim/ledges.py``): stairs, a bar and a gap as vertical faces across the path; their specs, their
profile, and eq. 3.7's depth and normal at a tread and at a riser (analytic cases)."""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np
import pytest
from simcases import model_from

from cpgjax.errors import DescriptionError
from cpgjax.io.wl import parse_wl
from cpgjax.sim.contact import contact_frame
from cpgjax.sim.ledges import GAP_DEPTH, STAIRS_AT
from cpgjax.sim.terrain import make_terrain, parse_terrain, terrain_spec


def test_each_kind_builds_its_profile():
    t = make_terrain("stairs:0.04:0.3:5")
    assert not t.flat and t.heights is None
    np.testing.assert_allclose(t.ledges.edges, STAIRS_AT + 0.3 * np.arange(5))
    ys = np.array([0.0, 0.999, 1.0, 1.29, 1.31, 2.21, 9.0])
    np.testing.assert_allclose(t.height_np(np.zeros_like(ys), ys), [0, 0, 0.04, 0.04, 0.08, 0.2, 0.2], atol=1e-7)
    down = make_terrain("stairs:-0.04:0.3:2")
    np.testing.assert_allclose(down.height_np(np.zeros(3), np.array([0.5, 1.1, 1.5])), [0, -0.04, -0.08], atol=1e-7)
    bar = make_terrain("bar:0.03@2.0:0.1")
    np.testing.assert_allclose(bar.height_np(np.zeros(4), np.array([1.99, 2.0, 2.09, 2.1])), [0, 0.03, 0.03, 0])
    gap = make_terrain("gap:0.2@1.5")
    np.testing.assert_allclose(gap.height_np(np.zeros(3), np.array([1.49, 1.6, 1.7])), [0, -GAP_DEPTH, 0])
    for spec in ("stairs:0.04:0.3:5", "bar:0.03@2.0:0.1", "gap:0.2@1.5", "bar:0.03@1.0"):
        assert make_terrain(terrain_spec(parse_terrain(spec))).ledges.levels.tolist() == \
            make_terrain(spec).ledges.levels.tolist()


@pytest.mark.parametrize("spec,message", [
    ("stairs:0.04", "stairs takes RISE:TREAD[:N]"),
    ("stairs:0:0.3", "stairs RISE must be non-zero"),
    ("stairs:0.5:0.3", "the quadruped's leg is 0.32 m"),
    ("stairs:0.04:-0.3", "stairs TREAD must be between 0.05 and 3 m, got -0.3"),
    ("stairs:0.04:0.3:2.5", "stairs N must be a whole number of steps, 1 to 50, got 2.5"),
    ("bar:0.03", "bar takes HEIGHT@Y[:DEPTH]"),
    ("bar:-0.03@1", "bar HEIGHT must be positive"),
    ("bar:0.03@1:0", "bar DEPTH must be positive"),
    ("gap:0.1@1:2", "gap takes WIDTH@Y, got more parameters"),
    ("gap:0@1", "gap WIDTH must be positive"),
])
def test_a_bad_spec_says_what_is_wrong_with_an_example(spec, message):
    with pytest.raises(ValueError, match="e.g. ") as e:
        parse_terrain(spec)
    assert message in str(e.value) and "\n" not in str(e.value)


BOX = "\nObject Box {\n Type Cube\n Mass 1\n Dimensions .1 .1 .1\n Position 0 0 0.05\n}\n"


def test_wl_files_write_the_same_kinds():
    d = parse_wl("Terrain stairs 0.04 0.3 3\n" + BOX, "<t>")
    assert d.terrain.kind == "stairs" and d.terrain.params == (0.04, 0.3, 3.0)
    assert parse_wl("Terrain bar 0.03 1.0\n" + BOX, "<t>").terrain.params == (0.03, 1.0)
    with pytest.raises(DescriptionError, match=r"<t>:2: stairs TREAD must be between 0.05 and 3 m, got 0"):
        parse_wl("TimeMax 1\nTerrain stairs 0.04 0\n" + BOX, "<t>")
    with pytest.raises(DescriptionError, match=r"<t>:1: Terrain gap expects 2 numbers"):
        parse_wl("Terrain gap 0.1\n" + BOX, "<t>")


def test_a_vertex_leaves_by_the_nearest_face():
    """Under a tread a vertex is pushed up by its depth; just past a riser, below the tread beyond it and above the
    level before it, it is pushed back along -y by how far it went in (not up by the riser's height); on a
    step down, forward along +y.  Exact to float32's rounding."""
    m = model_from("Terrain stairs 0.04 0.3 5\n" + BOX)
    # (y, z) -> (depth, normal)
    cases = [((0.5, -0.002), (0.002, (0, 0, 1))),          # flat before the stairs
             ((1.15, 0.035), (0.005, (0, 0, 1))),          # mid-tread, 5 mm under it
             ((1.003, 0.02), (0.003, (0, -1, 0))),         # 3 mm into the first riser, 2 cm above the floor
             ((1.003, 0.039), (0.001, (0, 0, 1))),         # the same, 1 mm under the tread: up is nearer
             ((1.003, -0.001), (0.041, (0, 0, 1))),        # under the floor too: the riser is no way out
             ((1.15, 0.045), (-0.005, None))]              # above the tread: no contact
    y = jnp.asarray([[c[0][0]] for c in cases], jnp.float32)
    z = jnp.asarray([[c[0][1]] for c in cases], jnp.float32)
    cp = jnp.stack([jnp.zeros_like(y), y, z])
    depth, fr = contact_frame(m, cp, None)
    for k, (_, (d, n)) in enumerate(cases):
        assert float(depth[k, 0]) == pytest.approx(d, abs=2e-7)
        if n is not None:
            np.testing.assert_allclose(np.asarray(fr.n[:, k, 0]), n, atol=1e-7)
            t1, t2 = np.asarray(fr.t1[:, k, 0]), np.asarray(fr.t2[:, k, 0])
            np.testing.assert_allclose([t1 @ t1, t2 @ t2, t1 @ n, t2 @ n, t1 @ t2], [1, 1, 0, 0, 0], atol=1e-6)
    down = model_from(m.description.text.replace("stairs 0.04", "stairs -0.04"))
    depth, fr = contact_frame(down, jnp.asarray([[[0.0]], [[0.997]], [[-0.02]]], jnp.float32), None)
    assert float(depth[0, 0]) == pytest.approx(0.003, abs=2e-7)
    np.testing.assert_allclose(np.asarray(fr.n[:, 0, 0]), (0, 1, 0), atol=1e-7)
