"""Each draw records what shaped its labels (``label_options``: ``box_step``, ``densify``,
``clip_polygons``), and replay moves boxes and polygons with the recorded values, whatever
the replaying Augment's; a record without them takes the Augment's."""

from __future__ import annotations

import json

import numpy as np
import pytest

from glmls.augment import Augment
from glmls.augment.replay import replay_boxes

IMAGES = np.random.default_rng(0).integers(0, 255, (2, 32, 40), dtype=np.uint8)
#: f itself moves the outline's samples (no mesh crossings): the box depends on box_step.
BACKWARD = {"method": "backward"}
BOXES = np.array([[[3.0, 4.0, 30.0, 25.0]]] * 2)
#: A square reaching past the canvas: clipping and densifying both change it.
POLYGONS = [[np.array([[5.0, 5.0], [45.0, 5.0], [45.0, 28.0], [5.0, 28.0]])]] * 2


def _made(**labels):
    return Augment("grid", seed=1, displacement=0.1, warp_options=BACKWARD, **labels)


@pytest.fixture(scope="module")
def recorded(gl):
    aug = _made(box_step=11.0, densify=3.0, clip_polygons=False)
    first = aug(IMAGES, boxes=BOXES, polygons=POLYGONS)
    return first, json.loads(json.dumps(first.params))


def _same_labels(result, expected):
    np.testing.assert_array_equal(result.boxes, expected.boxes)
    for ours, theirs in zip(result.polygons, expected.polygons, strict=True):
        for a, b in zip(ours, theirs, strict=True):
            np.testing.assert_array_equal(a, b)


def test_the_params_record_the_label_options(recorded):
    _, params = recorded
    assert params[0]["label_options"] == {"box_step": 11.0, "densify": 3.0, "clip_polygons": False}


def test_replay_moves_the_labels_with_the_recorded_options(recorded):
    first, params = recorded
    again = _made().replay(IMAGES, params, boxes=BOXES, polygons=POLYGONS)
    _same_labels(again, first)
    assert len(again.polygons[0][0]) > 4  # densified every 3 px, not clipped
    assert again.polygons[0][0][:, 0].max() > IMAGES.shape[2]


def test_a_record_without_label_options_takes_the_augments(recorded):
    first, params = recorded
    old = [{k: v for k, v in p.items() if k != "label_options"} for p in params]
    same = _made(box_step=11.0, densify=3.0, clip_polygons=False)
    _same_labels(same.replay(IMAGES, old, boxes=BOXES, polygons=POLYGONS), first)
    plain = _made().replay(IMAGES, old, boxes=BOXES, polygons=POLYGONS)
    assert len(plain.polygons[0][0]) < len(first.polygons[0][0])
    assert not np.array_equal(plain.boxes, first.boxes)


def test_a_partial_record_takes_the_rest_from_the_augment(recorded):
    first, params = recorded
    partial = [p | {"label_options": {"box_step": 11.0}} for p in params]
    aug = _made(densify=3.0, clip_polygons=False)
    _same_labels(aug.replay(IMAGES, partial, boxes=BOXES, polygons=POLYGONS), first)


def test_the_adapters_boxes_follow_the_recorded_box_step(recorded):
    """replay_boxes, the adapters' path (A.ReplayCompose replays a recorded draw)."""
    _, params = recorded
    boxes = [BOXES[0, :, :4]] * 2
    expected = replay_boxes(_made(box_step=11.0), params, boxes)
    for ours, theirs in zip(replay_boxes(_made(), params, boxes), expected, strict=True):
        np.testing.assert_array_equal(ours, theirs)


@pytest.mark.parametrize(
    ("entry", "error", "message"),
    [
        ([2.0], TypeError, r"params\[0\]\['label_options'\] must be a dict, got \[2.0\]"),
        (
            {"boxstep": 2.0},
            TypeError,
            r"params\[0\]\['label_options'\] has no keyword boxstep; it holds box_step, densify",
        ),
        (
            {"box_step": -1},
            ValueError,
            r"params\[0\]\['label_options'\]: box_step must be a finite number > 0, got -1",
        ),
        (
            {"box_step": "2"},
            TypeError,
            r"params\[0\]\['label_options'\]: box_step must be a finite number > 0, got '2'",
        ),
        (
            {"densify": float("nan")},
            ValueError,
            r"params\[0\]\['label_options'\]: densify must be a finite number > 0, got nan",
        ),
        (
            {"clip_polygons": "no"},
            TypeError,
            r"params\[0\]\['label_options'\]: clip_polygons must be True or False, got 'no'",
        ),
    ],
)
def test_a_bad_label_options_record_is_named(entry, error, message):
    aug = Augment("grid")
    params = aug.draw([(32, 40)] * 2)
    params[0]["label_options"] = entry
    with pytest.raises(error, match=message):
        aug.replay(IMAGES, params, boxes=BOXES)
