"""Hostile inputs to glmls.augment.Augment: keypoints, recorded params and shapes that are
not what they should be are refused, the error naming the item, before any warp."""

from __future__ import annotations

import copy
import json

import numpy as np
import pytest

from glmls.augment import Augment

IMAGES = np.random.default_rng(0).integers(0, 255, (2, 16, 20), dtype=np.uint8)


@pytest.mark.parametrize(
    "points",
    [
        np.ones((2, 2, 2), np.complex128),  # the imaginary part may not be dropped
        [np.array([[1, None]])] * 2,
        [np.array([["a", "b"]])] * 2,
    ],
)
def test_keypoints_that_are_not_real_numbers_are_refused(points):
    with pytest.raises(TypeError, match=r"keypoints\[0\] has dtype .*; expected real numbers"):
        Augment("grid")(IMAGES, keypoints=points)


@pytest.fixture
def recorded(gl):
    aug = Augment("grid", seed=3)
    return aug, json.loads(json.dumps(aug(IMAGES).params))


def _edited(params, edit):
    params = copy.deepcopy(params)
    edit(params)
    return params


@pytest.mark.parametrize(
    ("edit", "error", "message"),
    [
        (lambda p: p[1].__setitem__("src", "abc"), TypeError, r"params\[1\]\['src'\] has dtype"),
        (
            lambda p: p[0]["dst"].__setitem__(0, [1.0]),
            ValueError,
            r"params\[0\]\['dst'\] must be \(K, 2\) rows of numbers",
        ),
        (
            lambda p: p[0].__setitem__("src", [[1.0, 2.0, 3.0]]),
            ValueError,
            r"params\[0\]\['src'\] has shape \(1, 3\); expected \(K, 2\)",
        ),
        (
            lambda p: [d["options"].__setitem__("keypoints", 1) for d in p],
            TypeError,
            r"params\[0\]\['options'\] cannot hold keypoints",
        ),
        (
            lambda p: [d["options"].__setitem__("method", "swirl") for d in p],
            ValueError,
            r"params\[0\]\['options'\]: unknown method 'swirl'",
        ),
    ],
)
def test_replay_of_edited_params_names_the_bad_entry(recorded, edit, error, message):
    aug, params = recorded
    with pytest.raises(error, match=message):
        aug.replay(IMAGES, _edited(params, edit))


def test_replay_of_the_params_through_json_gives_the_same_images(recorded):
    aug, params = recorded
    first = aug.replay(IMAGES, params)
    np.testing.assert_array_equal(first.images, aug(IMAGES).images)
    np.testing.assert_array_equal(aug.replay(IMAGES, params).images, first.images)


@pytest.mark.parametrize(
    ("shapes", "error", "message"),
    [
        ([(0, 5)], ValueError, r"shapes\[0\]: shape must be \(H, W\) with H, W >= 1"),
        ([(8, 8), (-3, 5)], ValueError, r"shapes\[1\]: shape must be \(H, W\) with H, W >= 1"),
        ([(3.5, 5)], ValueError, r"shapes\[0\]: shape must be \(H, W\) integers"),
        ("ab", TypeError, "shapes must be a sequence of"),
    ],
)
def test_draw_refuses_shapes_that_are_no_image_sizes(shapes, error, message):
    with pytest.raises(error, match=message):
        Augment("grid").draw(shapes)


def test_draw_takes_an_image_s_shape_with_its_channels():
    aug = Augment("grid", rows=2, cols=2)
    assert aug.draw([(8, 9, 3)]) == aug.draw([(8, 9)])
