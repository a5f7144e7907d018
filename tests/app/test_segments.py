"""Segment handles in the window's controller, without a window: drawing, dragging ends and
whole segments (targets, and with shift the sources), deleting, undo and redo."""

from __future__ import annotations

import numpy as np
import pytest

from glmls.app.controller import Controller, Key, Move, Press, Release
from glmls.app.editing import MIN_SEGMENT, segment_distance
from glmls.core.handleset import HandleSet

SHIFT = frozenset({"shift"})
SHAPE = (60, 80)  # H, W
POINTS = np.array([[10.0, 50.0]])


def make(**options) -> Controller:
    return Controller(POINTS, POINTS, SHAPE, pick_radius=4.0, **options)


def drag(c: Controller, a, b, *, via=None, **press) -> None:
    c.feed(Press(*a, **press))
    for point in via or []:
        c.feed(Move(*point))
    c.feed(Move(*b))
    c.feed(Release(*b))


def drawn(a=(20.0, 20.0), b=(60.0, 20.0)) -> Controller:
    """A controller in segment mode with one segment drawn from a to b."""
    c = make()
    c.feed(Key("d"))
    drag(c, a, b, via=[((a[0] + b[0]) / 2, (a[1] + b[1]) / 2)])
    return c


def valid(c: Controller) -> HandleSet:
    """What the window sends to MLS: checked as MLS checks it."""
    return HandleSet.validate(c.src, c.dst, c.src_segments, c.dst_segments)


def test_a_drag_in_segment_mode_draws_a_segment_with_source_equal_target():
    c = make()
    c.feed(Key("d"))
    assert c.segment_mode and not c.reference_mode
    revision = c.revision
    c.feed(Press(20, 20))
    c.feed(Move(40, 25))
    np.testing.assert_array_equal(c.drawing, [[20, 20], [40, 25]])  # shown while drawn
    assert len(c.src_segments) == 0 and c.revision == revision  # not a handle yet
    c.feed(Move(60, 20))
    c.feed(Release(60, 20))
    assert c.drawing is None
    np.testing.assert_array_equal(c.src_segments, [[[20, 20], [60, 20]]])
    np.testing.assert_array_equal(c.dst_segments, c.src_segments)
    assert c.revision > revision and c.undo_depth == 1
    assert len(c.src) == 1  # the point handle untouched
    valid(c)


@pytest.mark.parametrize("end", [(20, 20), (21, 20.5), (20, 21.9)])
def test_a_click_or_a_tiny_drag_draws_nothing(end):
    c = make()
    c.feed(Key("d"))
    drag(c, (20, 20), end)  # shorter than half the pick radius (2 px)
    assert len(c.src_segments) == 0 and c.undo_depth == 0 and c.drawing is None


def test_drag_an_end_of_the_target():
    c = drawn()
    drag(c, (60, 20), (70, 40))  # the end b's target
    np.testing.assert_array_equal(c.dst_segments, [[[20, 20], [70, 40]]])
    np.testing.assert_array_equal(c.src_segments, [[[20, 20], [60, 20]]])
    drag(c, (21, 19), (25, 30))  # near the start
    np.testing.assert_array_equal(c.dst_segments, [[[25, 30], [70, 40]]])
    valid(c)


def test_drag_between_the_ends_moves_the_whole_target():
    c = drawn()
    drag(c, (40, 21), (45, 31), via=[(42, 25)])  # 1 px off the line: within the pick radius
    np.testing.assert_array_equal(c.dst_segments, [[[25, 30], [65, 30]]])
    np.testing.assert_array_equal(c.src_segments, [[[20, 20], [60, 20]]])
    assert c.undo_depth == 2  # drawing, one drag


def test_shift_drag_edits_the_source():
    c = drawn()
    drag(c, (40, 20), (40, 30))  # target moved down 10
    drag(c, (60, 20), (60, 10), mods=SHIFT)  # the source's end b, not the target's
    np.testing.assert_array_equal(c.src_segments, [[[20, 20], [60, 10]]])
    np.testing.assert_array_equal(c.dst_segments, [[[20, 30], [60, 30]]])
    drag(c, (30, 17.5), (35, 17.5), mods=SHIFT)  # the source whole, by its middle
    np.testing.assert_array_equal(c.src_segments, [[[25, 20], [65, 10]]])
    np.testing.assert_array_equal(c.dst_segments, [[[20, 30], [60, 30]]])


def test_a_source_segment_never_gets_shorter_than_the_minimum():
    c = drawn()
    drag(c, (60, 20), (20, 20), via=[(40, 20), (20.5, 20)], mods=SHIFT)
    a, b = c.src_segments[0]
    assert np.hypot(*(b - a)) >= MIN_SEGMENT
    np.testing.assert_array_equal(b, [40, 20])  # the last position that kept a length
    valid(c)
    drag(c, (60, 20), (20, 20))  # a target may shrink to a point
    np.testing.assert_array_equal(c.dst_segments[0], [[20, 20], [20, 20]])
    valid(c)


def test_ends_and_whole_segments_stay_on_the_image():
    c = drawn()
    drag(c, (60, 20), (500, -40))
    np.testing.assert_array_equal(c.dst_segments[0, 1], [79.5, -0.5])
    drag(c, (40, 10), (-300, 10))  # the whole target: stops where an end meets the border
    np.testing.assert_allclose(c.dst_segments[0], [[-0.5, 20], [59, -0.5]])
    c.feed(Press(5, 5))  # drawing is clamped too
    c.feed(Move(-50, 90))
    c.feed(Release(-50, 90))
    np.testing.assert_array_equal(c.src_segments[-1], [[5, 5], [-0.5, 59.5]])


def test_right_click_deletes_a_segment_by_its_target_or_source():
    c = drawn()
    drag(c, (40, 20), (40, 40))  # target away from the source
    drag(c, (10, 30), (70, 30), mods=SHIFT)  # a second segment
    assert len(c.src_segments) == 2
    c.feed(Press(55, 40, "right"))  # on the first target
    np.testing.assert_array_equal(c.src_segments, [[[10, 30], [70, 30]]])
    c.feed(Press(40, 30, "right"))  # on the second, its source = target
    assert len(c.src_segments) == 0
    c.feed(Press(70, 5, "right"))  # nothing there
    assert len(c.src) == 1 and c.undo_depth == 5


def test_undo_and_redo_cover_segment_edits():
    c = drawn()
    states = [c.dst_segments.copy()]
    drag(c, (60, 20), (70, 30))
    states.append(c.dst_segments.copy())
    c.feed(Press(40, 24, "right"))
    assert len(c.src_segments) == 0
    c.feed(Key("u"))
    np.testing.assert_array_equal(c.dst_segments, states[1])
    c.feed(Key("Ctrl+Z"))
    np.testing.assert_array_equal(c.dst_segments, states[0])
    c.feed(Key("Backspace"))
    assert len(c.src_segments) == 0  # before the drawing
    assert c.redo_depth == 3
    c.feed(Key("U"))
    np.testing.assert_array_equal(c.dst_segments, states[0])
    c.feed(Key("Ctrl+Y"))
    np.testing.assert_array_equal(c.dst_segments, states[1])
    drag(c, (20, 20), (22, 22))  # a new edit forgets what was undone
    assert c.redo_depth == 0
    c.feed(Key("Ctrl+Shift+Z"))
    assert c.message == "nothing to redo"
    np.testing.assert_array_equal(c.dst_segments, [[[22, 22], [70, 30]]])


def test_reset_restore_and_set_handles_take_segments():
    loaded = np.array([[[5.0, 5.0], [25.0, 5.0]]])
    c = make(src_segments=loaded, dst_segments=loaded + [0.0, 10.0])
    c.feed(Key("r"))
    np.testing.assert_array_equal(c.dst_segments, loaded)
    np.testing.assert_array_equal(c.dst, c.src)
    c.set_handles(np.zeros((0, 2)), np.zeros((0, 2)))
    assert len(c.src) == 0 and len(c.src_segments) == 0
    c.feed(Key("R"))
    np.testing.assert_array_equal(c.dst_segments, loaded + [0.0, 10.0])
    np.testing.assert_array_equal(c.src, POINTS)
    c.feed(Key("u"))
    assert len(c.src_segments) == 0
    with pytest.raises(ValueError, match="zero length"):
        make(src_segments=[[[1, 1], [1, 1]]], dst_segments=[[[1, 1], [2, 2]]])
    with pytest.raises(ValueError, match="same shape"):
        make(src_segments=loaded, dst_segments=np.zeros((0, 2, 2)))
    with pytest.raises(ValueError, match=r"shape \(S, 2, 2\)"):
        c.set_handles(POINTS, POINTS, src_segments=[[1, 2, 3]], dst_segments=[[1, 2, 3]])


def test_points_and_segments_are_edited_in_either_mode():
    c = drawn()
    drag(c, (10, 50), (12, 55))  # the point's target, in segment mode
    np.testing.assert_array_equal(c.dst, [[12, 55]])
    c.feed(Key("d"))  # back to points: a click on empty space adds a point
    assert c.mode == "points"
    drag(c, (60, 20), (60, 25))  # a segment end, in point mode
    np.testing.assert_array_equal(c.dst_segments[0, 1], [60, 25])
    c.feed(Press(70, 50))
    c.feed(Release(70, 50))
    assert len(c.src) == 2 and len(c.src_segments) == 1
    c.feed(Key("d"))
    c.feed(Key("p"))  # reference mode replaces segment mode
    assert c.mode == "reference"
    drag(c, (30, 40), (35, 40))
    assert len(c.reference) == 1 and len(c.src_segments) == 1


def test_a_point_on_a_segment_is_picked_before_the_segment():
    c = drawn()
    drag(c, (10, 50), (40, 20))  # the point's target onto the segment's middle
    drag(c, (40, 20), (40, 30))
    np.testing.assert_array_equal(c.dst, [[40, 30]])
    np.testing.assert_array_equal(c.dst_segments, c.src_segments)


def test_random_edits_never_send_what_mls_refuses():
    rng = np.random.default_rng(7)
    c = drawn()
    c.pick_radius = 6.0
    for _ in range(400):
        kind = rng.integers(5)
        x, y = rng.uniform(-10, 90), rng.uniform(-10, 70)
        if kind == 0:
            mods = frozenset({"shift"}) if rng.integers(2) else frozenset()
            c.feed(Press(x, y, rng.choice(["left", "left", "right"]), mods))
        elif kind in (1, 2):
            c.feed(Move(x, y))
        elif kind == 3:
            c.feed(Release(x, y))
        else:
            c.feed(Key(str(rng.choice(["d", "u", "U", "r"]))))
        handles = valid(c)
        lengths = np.hypot(*(handles.src_segments[:, 1] - handles.src_segments[:, 0]).T)
        assert (lengths >= MIN_SEGMENT).all()
    assert len(c.src_segments) > 0


def test_segment_distance():
    segments = np.array([[[0.0, 0.0], [10.0, 0.0]], [[5.0, 5.0], [5.0, 5.0]]])
    np.testing.assert_allclose(segment_distance(segments, 5, 3), [3, 2])
    np.testing.assert_allclose(segment_distance(segments, -3, 4), [5, np.hypot(8, 1)])
