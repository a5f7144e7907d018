"""Handles that ask f for two values at one source point are refused, naming both: a point
handle on a source segment, segments sharing a point, points the GPU's float32 cannot tell
apart; handles that agree there pass."""

from __future__ import annotations

import numpy as np
import pytest

import glmls
from glmls.core.handleset import HandleSet
from glmls.core.segments import _first_on_segment

NONE = np.zeros((0, 2))
SEGMENT = np.array([[[10.0, 40.0], [10.0, 10.0]]])
TARGET = np.array([[[10.0, 40.0], [14.0, 11.0]]])


@pytest.mark.parametrize(
    ("point", "target", "match"),
    [
        ([10.0, 25.0], [30.0, 25.0], r"src\[0\] \[10.0, 25.0\] lies on src_segments\[0\]"),
        ([10.0, 40.0], [0.0, 0.0], r"src\[0\] \[10.0, 40.0\] lies on src_segments\[0\]"),
        ([10.0, 10.0], [10.0, 10.0], r"whose target there is \[14.0, 11.0\]"),
        ([10.0 + 1e-7, 25.0], [30.0, 25.0], r"at t = 0.5\), whose target there is \[12.0, 25.5\]"),
    ],
)
def test_a_point_handle_on_a_segment_with_another_target_is_refused(point, target, match):
    with pytest.raises(ValueError, match=match):
        HandleSet.validate([point], [target], SEGMENT, TARGET)


@pytest.mark.parametrize(
    ("point", "target"),
    [
        ([10.0, 40.0], [10.0, 40.0]),  # a segment's end, its target
        ([10.0, 10.0], [14.0, 11.0]),
        ([10.0, 25.0], [12.0, 25.5]),  # the middle, the target's middle
        ([10.001, 25.0], [30.0, 25.0]),  # near, not on it: a steep f, but one value
        ([10.0, 41.0], [0.0, 0.0]),  # on the line, past the end
    ],
)
def test_a_point_handle_agreeing_with_a_segment_passes(point, target):
    handles = HandleSet.validate([point], [target], SEGMENT, TARGET)
    assert len(handles) == 2


def test_segments_sharing_a_vertex_with_different_targets_are_refused():
    src = np.array([[[10.0, 40.0], [10.0, 10.0]], [[10.0, 10.0], [40.0, 10.0]]])
    dst = np.array([[[10.0, 40.0], [14.0, 11.0]], [[30.0, 30.0], [40.0, 10.0]]])
    match = (
        r"src_segments\[0\]\[1\] \[10.0, 10.0\] lies on src_segments\[1\] .* whose target "
        r"there is \[30.0, 30.0\], but that end's target is \[14.0, 11.0\]"
    )
    with pytest.raises(ValueError, match=match):
        glmls.MLS(NONE, NONE, src_segments=src, dst_segments=dst)


def test_a_segment_end_inside_another_segment_must_agree_with_it():
    src = np.array([[[0.0, 0.0], [20.0, 0.0]], [[10.0, 0.0], [10.0, 10.0]]])
    dst = np.array([[[0.0, 0.0], [20.0, 0.0]], [[10.0, 5.0], [10.0, 10.0]]])
    with pytest.raises(ValueError, match=r"src_segments\[1\]\[0\] \[10.0, 0.0\] lies on"):
        HandleSet.validate(NONE, NONE, src, dst)
    dst[1, 0] = [10.0, 0.0]
    assert HandleSet.validate(NONE, NONE, src, dst).segments == 2


def test_polylines_and_points_on_them_with_their_targets_pass():
    rng = np.random.default_rng(1)
    vertices = rng.random((40, 2)) * 500
    moved = vertices + rng.normal(size=vertices.shape) * 5
    closed, closed_moved = np.vstack([vertices, vertices[:1]]), np.vstack([moved, moved[:1]])
    t = rng.random((20, 1))
    points = np.vstack([(1 - t) * vertices[3] + t * vertices[4], vertices[:5]])
    targets = np.vstack([(1 - t) * moved[3] + t * moved[4], moved[:5]])
    handles = HandleSet.validate(
        points,
        targets,
        glmls.polyline_segments(closed),
        glmls.polyline_segments(closed_moved),
    )
    assert handles.segments == 40


def test_a_reversed_duplicate_segment_shows_its_targets_in_one_direction():
    a = np.array([[10.0, 40.0], [10.0, 10.0]])
    b = np.array([[10.0, 40.0], [14.0, 11.0]])
    match = (
        r"with different targets \[\[10.0, 40.0\], \[14.0, 11.0\]\] and \[\[14.0, 11.0\], "
        r"\[10.0, 40.0\]\] \(src_segments\[1\] reversed, its target too\)"
    )
    with pytest.raises(ValueError, match=match):
        HandleSet.validate(NONE, NONE, np.stack([a, a[::-1]]), np.stack([b, b]))
    assert HandleSet.validate(NONE, NONE, np.stack([a, a[::-1]]), np.stack([b, b[::-1]]))


@pytest.mark.parametrize("length", [1e-7, 1e-5, 1e-12])
def test_a_segment_shorter_than_float32_tells_apart_is_refused(length):
    # its ends merged in the GPU's float32 coordinates: f was NaN everywhere (1e-7 px at
    # 500 px), or its moments lost (1e-5 px: f 0.2-0.4 px off half a pixel from it)
    p = np.array([[10.0, 10.0], [500.0, 20.0], [200.0, 400.0]])
    segment = np.array([[[500.0, 500.0], [500.0 + length, 500.0]]])
    match = (
        r"src_segments\[0\] .* is .* px long, shorter than float32 on the GPU tells apart "
        r"at this scale \(.* px\): give it as a point handle"
    )
    with pytest.raises(ValueError, match=match):
        glmls.MLS(p, p + 1.0, src_segments=segment, dst_segments=segment + 3.0)
    # a thousandth of a pixel is a segment (tests/engine/test_segment_precision.py)
    segment[0, 1, 0] = 500.001
    assert HandleSet.validate(p, p, segment, segment).segments == 1


def _near_pair(dimension: int) -> tuple[np.ndarray, np.ndarray]:
    """Sources 1e-7 px apart (one point in float32 scaled coordinates), targets 10 px apart."""
    corners = np.eye(dimension) * 25.0 + 5.0
    src = np.vstack([np.full(dimension, 5.0), np.full(dimension, 5.0), corners])
    src[1, -1] += 1e-7
    dst = src.copy()
    dst[1, 0] += 10.0
    return src, dst


@pytest.mark.parametrize("dimension", [2, 3])
def test_sources_float32_merges_with_different_targets_are_refused(gl, dimension):
    src, dst = _near_pair(dimension)
    match = (
        r"src\[0\] .* and src\[1\] .* are 1e-07 px apart, closer than float32 on the GPU "
        r"tells apart at this scale \(it steps by .* px there\), with different targets"
    )
    with pytest.raises(ValueError, match=match):
        glmls.MLS(src, dst, s=0.0)
    dst[1] = dst[0]  # one target: the GPU's one point is right
    with glmls.MLS(src, dst, s=0.0) as m:
        assert np.abs(m(src) - dst).max() < 1e-3


def test_a_batch_refuses_float32_merged_sources_naming_the_image(gl):
    src, dst = _near_pair(2)
    images = np.zeros((2, 40, 40), np.float32)
    with pytest.raises(ValueError, match=r"images\[1\]: src\[0\] .* are 1e-07 px apart"):
        glmls.warp_batch(images, [src, src], [src, dst])


def _brute_conflict(x, y, owner, a, b, tol):
    """The first (point, segment) conflict by a loop over every pair."""
    for k in range(len(x)):
        for s in range(len(a)):
            step = a[s, 1] - a[s, 0]
            t = np.clip(np.dot(x[k] - a[s, 0], step) / np.dot(step, step), 0.0, 1.0)
            if owner[k] == s or np.sum((a[s, 0] + t * step - x[k]) ** 2) > tol**2:
                continue
            there = (1 - t) * b[s, 0] + t * b[s, 1]
            stretch = np.hypot(*(b[s, 1] - b[s, 0])) / np.hypot(*step)
            if np.hypot(*(y[k] - there)) > tol * (1 + stretch):
                return k, s
    return None


def test_points_on_segments_match_brute_force():
    rng = np.random.default_rng(3)
    for _ in range(200):
        count, points = rng.integers(1, 6), rng.integers(0, 8)
        a = rng.integers(0, 6, (count, 2, 2)) * rng.choice([1.0, 0.37, 1e3])
        a[(a[:, 0] == a[:, 1]).all(axis=1), 1, 0] += 1.0
        b = a + rng.integers(0, 2, a.shape)
        p = rng.integers(0, 6, (points, 2)) * rng.choice([1.0, 0.5])
        q = p + rng.integers(0, 2, p.shape)
        x, y = np.concatenate([p, a.reshape(-1, 2)]), np.concatenate([q, b.reshape(-1, 2)])
        owner = np.concatenate([np.full(points, -1), np.repeat(np.arange(count), 2)])
        found = _first_on_segment(x, y, owner, a, b, 1e-3)
        assert (None if found is None else found[:2]) == _brute_conflict(x, y, owner, a, b, 1e-3)
