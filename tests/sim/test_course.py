"""A course (``sim/course.py``): grounds chained along the path, its items' text, its profile and heightfield, and
bad items named with their place in the course."""

from __future__ import annotations

import numpy as np
import pytest

from cpgjax.io.wl import parse_wl
from cpgjax.io.wl.writer import format_wl
from cpgjax.sim import course
from cpgjax.sim.ledges import BAR_DEPTH, GAP_DEPTH
from cpgjax.sim.terrain import make_terrain, parse_terrain, terrain_spec

ISSUE_COURSE = "course:flat:1,rough:0.02:2,stairs:0.04:0.3:3,bar:0.03,flat:1"


def test_each_item_starts_where_the_last_ended_and_at_its_height():
    t = make_terrain(ISSUE_COURSE)
    a = course.COURSE_AT
    stairs_at = a + 1 + 2
    bar_at = stairs_at + 0.9
    np.testing.assert_allclose(t.ledges.edges, [stairs_at, stairs_at + 0.3, stairs_at + 0.6, bar_at,
                                                bar_at + BAR_DEPTH])
    np.testing.assert_allclose(t.ledges.levels, [0, 0.04, 0.08, 0.12, 0.15, 0.12])
    # the rough item: heights in [0, 0.02] one cell in from its ends, none elsewhere
    ys = t.y0 + t.dy * np.arange(t.heights.shape[0])
    rows = t.heights.max(1) > 0
    assert ys[rows].min() >= a + 1 + course.ROUGH_CELL - 1e-9 and ys[rows].max() <= a + 3 - course.ROUGH_CELL + 1e-9
    assert 0.015 < t.heights.max() <= 0.02 and t.heights.min() == 0.0
    assert course.rough_spans(ISSUE_COURSE) == [(a + 1, a + 3)]
    # flat at the last height after the last item, and before the first
    np.testing.assert_allclose(t.height_np(np.zeros(3), np.array([-1.0, 0.4, 11.0])), [0, 0, 0.12], atol=1e-7)
    back_to_back = make_terrain("course:gap:0.1,bar:0.03,flat:1")          # one face where the gap meets the bar
    np.testing.assert_allclose(back_to_back.ledges.edges, [a, a + 0.1, a + 0.1 + BAR_DEPTH])
    np.testing.assert_allclose(back_to_back.ledges.levels, [0, -GAP_DEPTH, 0.03, 0])
    down = make_terrain("course:stairs:0.04:0.3:2,gap:0.1,stairs:-0.04:0.3:2")
    np.testing.assert_allclose(down.ledges.levels, [0, 0.04, 0.08, 0.08 - GAP_DEPTH, 0.04, 0.0])   # no 0-wide tread
    assert down.heights is None


def test_the_text_survives_the_run_file_and_the_wl_file():
    for spec in (ISSUE_COURSE, "course:rough:0.03:1.5:7,gap:0.1,flat:0.5"):
        assert terrain_spec(parse_terrain(spec)) == spec
        d = parse_wl(f"Terrain {spec.replace(':', ' ', 1)}\n" + BOX, "<t>")
        assert terrain_spec(parse_wl(format_wl(d), "<t>").terrain) == spec


BOX = "Object Box {\n Type Cube\n Mass 1\n Dimensions .1 .1 .1\n Position 0 0 0.05\n}\n"


@pytest.mark.parametrize("spec,message", [
    ("course:", "a course needs at least one item"),
    ("course:flat:1,stair:0.04", "course item 2 'stair:0.04': unknown kind 'stair'"),
    ("course:flat:1,stairs:0.04:0.3", "course item 2 'stairs:0.04:0.3': stairs takes RISE:TREAD:N"),
    ("course:stairs:0.04:-0.3:3", "course item 1: stairs TREAD must be between 0.05 and 3 m, got -0.3"),
    ("course:stairs:0.5:0.3:3", "course item 1: stairs RISE must be non-zero and at most 0.3 m"),
    ("course:flat:1,bar:x", "course item 2 'bar:x': bar:HEIGHT[:DEPTH] expects numbers"),
    ("course:flat:6,rough:0.02:7", "the course is 13 m long; at most 12 m"),
    ("course:gap:0", "course item 1: gap WIDTH must be positive"),
])
def test_a_bad_course_names_the_item(spec, message):
    with pytest.raises(ValueError) as e:
        parse_terrain(spec)
    assert message in str(e.value) and "\n" not in str(e.value)


def test_a_bad_course_in_a_wl_file_names_the_line():
    from cpgjax.errors import DescriptionError

    with pytest.raises(DescriptionError, match=r"<t>:2: course item 1 'flat': flat takes LENGTH"):
        parse_wl("TimeMax 1\nTerrain course flat\n" + BOX, "<t>")
