"""Segment handles in the analysis: drawn in the pictures, listed in the report, dragged by the
automatic choice's random deformations and counted in its handle miss."""

from __future__ import annotations

import json

import numpy as np
import pytest

import glmls
from glmls.analysis import tuning, tuning_trials
from glmls.core.handleset import HandleSet
from glmls.core.segments import polyline_segments

SRC = np.array([[10.0, 10.0], [50.0, 12.0]])
DST = np.array([[14.0, 8.0], [50.0, 12.0]])
A = np.concatenate(
    [[[[12.0, 44.0], [30.0, 40.0]]], polyline_segments([[40, 30], [50, 40], [56, 30]])]
)
B = A + [[[0.0, 0.0], [2.0, -3.0]], [[1.0, 1.0], [0.0, 2.0]], [[0.0, 2.0], [0.0, 0.0]]]
REFERENCE = [[5.0, 5.0], [55.0, 6.0], [30.0, 25.0], [8.0, 42.0], [52.0, 40.0]]
SOURCE, TARGET = (0, 0, 255), (255, 0, 0)


def test_handles_picture_draws_segments(gl):
    image = np.zeros((40, 80, 3), np.uint8)
    a = [[[10.0, 10.0], [70.0, 10.0]]]
    b = [[[10.0, 30.0], [70.0, 30.0]]]
    picture = glmls.analysis.render_handles(
        image,
        np.zeros((0, 2)),
        np.zeros((0, 2)),
        src_segments=a,
        dst_segments=b,
        source_color=SOURCE,
        color=TARGET,
        ctx=gl,
    )
    assert picture[10, 40].tolist() == list(SOURCE)  # the source segment
    assert picture[30, 40].tolist() == list(TARGET)  # the target segment
    assert picture[10, 10].tolist() == list(SOURCE)  # a disk at each source end
    assert picture[20, 70].tolist() == list(TARGET)  # the arrow from end to end
    assert picture[20, 40].tolist() == [0, 0, 0]  # nothing between the segments
    plain = glmls.analysis.render_handles(image, SRC, DST, ctx=gl)
    both = glmls.analysis.render_handles(
        image, SRC, DST, src_segments=np.zeros((0, 2, 2)), dst_segments=np.zeros((0, 2, 2)), ctx=gl
    )
    np.testing.assert_array_equal(plain, both)
    with pytest.raises(ValueError, match="src_segments needs dst_segments"):
        glmls.analysis.render_handles(image, SRC, DST, src_segments=a, ctx=gl)


def test_report_lists_and_draws_segments(gl, rng, tmp_path):
    shape = (48, 60)
    image = rng.integers(0, 256, (*shape, 3), dtype=np.uint8)
    with glmls.MLS(SRC, DST, src_segments=A, dst_segments=B, transform="similarity", ctx=gl) as m:
        result = glmls.analysis.report(image, m, REFERENCE, out_dir=tmp_path)
        plain = glmls.analysis.render_handles(image, SRC, DST, ctx=gl)
    summary = json.loads((tmp_path / "report.json").read_text())
    config = summary["configuration"]
    assert (config["handles"], config["segments"]) == (2, 3)
    np.testing.assert_array_equal(config["src_segments"], A)
    np.testing.assert_array_equal(config["dst_segments"], B)
    drawn = result.images["input_handles"]
    assert drawn.shape == (*shape, 3)
    assert (drawn != plain).any(axis=-1).sum() > 50  # the segments are in the picture


def test_random_edits_drag_segment_ends():
    handles = HandleSet.validate(SRC, DST, A, B)
    shape = (48, 60)
    trials = tuning_trials.random_edits(handles, 6, seed=4, shape=shape)
    again = tuning_trials.random_edits(handles, 6, seed=4, shape=shape)
    # trial 0: the user's own edit
    np.testing.assert_array_equal(trials[0][0], DST)
    np.testing.assert_array_equal(trials[0][1], B)
    moved_ends = 0
    for (dst, segments), (dst2, segments2) in zip(trials, again, strict=True):
        np.testing.assert_array_equal(dst, dst2)
        np.testing.assert_array_equal(segments, segments2)
        assert dst.shape == (2, 2) and segments.shape == (3, 2, 2)
        np.testing.assert_array_equal(segments[1, 1], segments[2, 0])  # the polyline stays joined
        moved_ends += int((segments != B).any(axis=-1).sum())
    assert moved_ends > 0  # segment ends are dragged too


def test_tune_with_segments_counts_their_ends_in_the_miss(gl):
    shape = (48, 60)
    configs = tuning.parse_config("similarity:gaussian:radius=20", shape)
    result = tuning.tune(
        shape,
        SRC,
        DST,
        REFERENCE,
        src_segments=A,
        dst_segments=B,
        trials=2,
        seed=3,
        configs=configs,
        ctx=gl,
    )
    handles = HandleSet.validate(SRC, DST, A, B)
    misses = []
    for dst, segments in tuning_trials.random_edits(handles, 2, seed=3, shape=shape):
        with glmls.MLS.from_config(
            SRC, dst, configs[0], shape=shape, src_segments=A, dst_segments=segments, ctx=gl
        ) as m:
            f = m(handles.source_points())
        q = np.concatenate([dst, segments.reshape(-1, 2)])
        misses.append(np.hypot(*(f - q).T).mean())
    row = result.rows[0]
    assert row["handle_miss_mean"] == pytest.approx(np.mean(misses), rel=1e-6)
    assert row["handle_miss_mean"] > 0  # a gaussian does not interpolate
    assert not row["admissible"] and "misses its targets" in row["set_apart"][0]
    with pytest.raises(ValueError, match="src_segments needs dst_segments"):
        tuning.tune(shape, SRC, DST, REFERENCE, src_segments=A, configs=configs, ctx=gl)
