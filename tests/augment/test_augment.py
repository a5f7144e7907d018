"""glmls.augment.Augment: presets, reproducibility by (seed, index), replay through JSON,
labels (keypoints, masks, boxes, polygons) through the map that placed the pixels, and bad
input named by its index."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

import glmls
from glmls.augment import (
    PRESETS,
    Augment,
    AugmentResult,
    GridPreset,
    TextDistortPreset,
    TextPerspectivePreset,
    TextStretchPreset,
)


@pytest.fixture
def images(rng):
    return rng.integers(0, 255, (5, 24, 40, 3), dtype=np.uint8)


@pytest.mark.parametrize("name", ["grid", "text-distort", "text-stretch", "text-perspective"])
def test_any_part_of_a_batch_equals_the_whole(gl, images, name):
    aug = Augment(name, seed=11)
    whole = aug(images)
    part = aug(images[[3, 1]], indices=[3, 1])
    assert isinstance(whole, glmls.BatchResult) and isinstance(whole, AugmentResult)
    np.testing.assert_array_equal(part.images[0], whole.images[3])
    np.testing.assert_array_equal(part.images[1], whole.images[1])
    assert part.params[0] == whole.params[3]
    assert not np.array_equal(whole.images[0], images[0])  # it did deform


def test_another_seed_draws_otherwise(gl, images):
    first = Augment("grid", seed=0).draw([(24, 40)])[0]
    second = Augment("grid", seed=1).draw([(24, 40)])[0]
    assert first["src"] == second["src"] and first["dst"] != second["dst"]


def test_params_are_json_and_replay_exactly(gl, images, rng):
    aug = Augment("text-distort", seed=4, warp_options={"interpolation": "nearest"})
    keypoints = rng.uniform(2, 20, (5, 3, 2))
    masks = rng.integers(0, 4, (5, 24, 40), dtype=np.uint8)
    first = aug(images, keypoints=keypoints, masks=masks)
    params = json.loads(json.dumps(first.params))
    again = aug.replay(images, params, keypoints=keypoints, masks=masks)
    np.testing.assert_array_equal(again.images, first.images)
    np.testing.assert_array_equal(again.keypoints, first.keypoints)
    np.testing.assert_array_equal(again.masks, first.masks)
    # the params alone make the same deformation with warp_batch
    src = [p["src"] for p in params]
    dst = [p["dst"] for p in params]
    np.testing.assert_array_equal(
        glmls.warp_batch(images, src, dst, **params[0]["options"]), first.images
    )
    assert params[0]["options"]["interpolation"] == "nearest"
    assert params[0]["config"] == {"segments": 4, "radius": None}


def test_params_of_numpy_options_are_json_too(gl, images):
    """Options given as numpy values (an int64 grid, an array background) come out in the
    params as JSON's numbers and lists, and replay the same from JSON."""
    aug = Augment(
        "grid",
        seed=np.int64(2),
        rows=np.int64(3),
        displacement=np.float32(0.05),
        warp_options={"grid": np.int64(2), "background": np.array([1, 2, 3])},
    )
    first = aug(images[:2])
    params = json.loads(json.dumps(first.params))
    assert params == first.params
    assert params[0]["options"]["background"] == [1, 2, 3]
    np.testing.assert_array_equal(aug.replay(images[:2], params).images, first.images)


def test_replay_names_the_draw_it_cannot_use(gl, images):
    aug = Augment("grid")
    params = aug(images[:2]).params
    with pytest.raises(TypeError, match="params must be a sequence of draws"):
        aug.replay(images[:2], "params")
    with pytest.raises(TypeError, match=r"params\[1\] must be a dict, got list"):
        aug.replay(images[:2], [params[0], [1, 2]])
    broken = [params[0], {k: v for k, v in params[1].items() if k != "src"}]
    with pytest.raises(ValueError, match=r"params\[1\] has no 'src'"):
        aug.replay(images[:2], broken)
    with pytest.raises(TypeError, match=r"params\[0\]\['shape'\] must be \[H, W\]"):
        aug.replay(images[:2], [params[0] | {"shape": "24x40"}, params[1]])
    short = params[1] | {"dst": params[1]["dst"][:-1]}
    with pytest.raises(ValueError, match=r"params\[1\]\['src'\] and params\[1\]\['dst'\] hold"):
        aug.replay(images[:2], [params[0], short])


def test_masks_keep_their_labels(gl, images, rng):
    masks = np.zeros((5, 24, 40), np.uint8)
    masks[:, 6:18, 10:30] = 7
    masks[:, 8:12, 12:16] = 3
    out = Augment("grid", seed=2, displacement=0.1)(images, masks=masks)
    assert set(np.unique(out.masks)) <= {0, 3, 7}


def test_keypoints_and_boxes_follow_the_pixels(gl):
    """A bright square: the moved keypoint sits on it and the moved box holds it."""
    image = np.zeros((48, 64), np.float32)
    image[18:26, 28:36] = 1.0
    images = np.stack([image] * 3)
    box = [27.5, 17.5, 35.5, 25.5]
    out = Augment("grid", seed=5, displacement=0.06, warp_options={"interpolation": "nearest"})(
        images, keypoints=np.full((3, 1, 2), [31.5, 21.5]), boxes=np.array([[box]] * 3)
    )
    assert out.boxes.shape == (3, 1, 4) and out.boxes_valid.all()
    for i in range(3):
        rows, cols = np.nonzero(out.images[i] > 0.5)
        x, y = out.keypoints[i, 0]
        assert out.images[i][round(y), round(x)] == 1.0
        x0, y0, x1, y1 = out.boxes[i, 0]
        assert x0 <= cols.min() and cols.max() <= x1 and y0 <= rows.min() and rows.max() <= y1
        assert x1 - x0 < (cols.max() - cols.min()) + 3 and y1 - y0 < (rows.max() - rows.min()) + 3


def test_boxes_leaving_the_canvas_are_clipped_and_flagged(gl):
    images = np.zeros((2, 20, 20), np.uint8)
    boxes = [np.array([[2.0, 2.0, 8.0, 8.0], [-30.0, -30.0, -20.0, -20.0]]), np.zeros((0, 4))]
    out = Augment("grid", seed=0, displacement=0.0)(images, boxes=boxes)
    assert isinstance(out.boxes, list) and out.boxes[1].shape == (0, 4)
    assert out.boxes_valid[0].tolist() == [True, False]
    np.testing.assert_allclose(out.boxes[0][0], [2, 2, 8, 8], atol=1e-6)
    assert (out.boxes[0][1] == [-0.5, -0.5, -0.5, -0.5]).all()


def test_polygons_move_densified_and_clipped(gl):
    images = np.zeros((1, 30, 30), np.uint8)
    square = np.array([[5.0, 5.0], [25.0, 5.0], [25.0, 25.0], [5.0, 25.0]])
    plain = Augment("grid", seed=1, displacement=0.0)(images, polygons=[[square]])
    np.testing.assert_allclose(plain.polygons[0][0], square, atol=1e-6)
    dense = Augment("grid", seed=1, displacement=0.0, densify=5.0)(images, polygons=[[square]])
    assert len(dense.polygons[0][0]) == 16
    outside = square + [-20.0, 0.0]
    clipped = Augment("grid", seed=1, displacement=0.0)(images, polygons=[[outside]])
    assert clipped.polygons[0][0][:, 0].min() == -0.5


def test_landmarks_preset_moves_the_given_landmarks(gl, rng):
    images = rng.integers(0, 255, (2, 32, 32), dtype=np.uint8)
    marks = np.array([[[10.0, 10.0], [20.0, 22.0]]] * 2)
    out = Augment("landmarks", seed=3, displacement=2, units="pixels")(images, keypoints=marks)
    for i in range(2):
        dst = np.asarray(out.params[i]["dst"])[:2]
        np.testing.assert_allclose(out.keypoints[i], dst, atol=0.05)
    with pytest.raises(ValueError, match="landmarks"):
        Augment("landmarks")(images)


def test_ragged_batches_give_lists(gl, rng):
    images = [rng.integers(0, 255, (20, 30), dtype=np.uint8), np.zeros((16, 16), np.uint8)]
    out = Augment("grid")(images, keypoints=[np.array([[3.0, 4.0]]), np.zeros((0, 2))])
    assert isinstance(out.images, list) and out.images[1].shape == (16, 16)
    assert out.keypoints[1].shape == (0, 2)


def test_preset_objects_and_their_options():
    aug = Augment(TextStretchPreset(segments=6), seed=1)
    assert aug.preset.segments == 6
    assert Augment("text-perspective", radius=3.0).preset == TextPerspectivePreset(radius=3.0)
    assert set(PRESETS) == {"grid", "text-distort", "text-stretch", "text-perspective", "landmarks"}
    with pytest.raises(TypeError, match="rows"):
        Augment("text-distort", rows=3)
    with pytest.raises(TypeError, match="preset object"):
        Augment(GridPreset(), rows=3)


@pytest.mark.parametrize(
    "keywords",
    [
        {},
        {"seed": 5, "box_step": 3.0, "warp_options": {"border": "reflect"}},
        {"densify": 2.0, "clip_polygons": False, "warp_options": {"method": "backward"}},
        {"warp_options": {"grid": 1, "transform": "rigid"}},
        {"warp_options": {"tolerance": 0.2}},
    ],
)
def test_the_repr_makes_the_same_augment_again(keywords):
    """Every keyword that differs from its default is in the repr (a log of the run shows
    the border, the method and the label options that shaped the samples), and the repr
    evaluates to an Augment of the same options."""
    aug = Augment("grid", rows=3, **keywords)
    again = eval(repr(aug), {"Augment": Augment, "GridPreset": GridPreset})
    assert again.preset == aug.preset and again.seed == aug.seed
    assert again.warp_options == aug.warp_options
    assert again.label_options == aug.label_options
    for name, value in keywords.get("warp_options", {}).items():
        assert f"{name!r}: {value!r}" in repr(aug)


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda: Augment("wave"), "unknown preset 'wave'; expected one of grid, text-distort"),
        (lambda: GridPreset(rows=1), "rows must be an integer >= 2, got 1"),
        (lambda: GridPreset(displacement=float("nan")), "displacement must be a finite"),
        (lambda: GridPreset(units="cm"), "unknown units 'cm'; choose one of fraction, pixels"),
        (lambda: TextDistortPreset(segments=0), "segments must be an integer >= 1, got 0"),
        (lambda: TextDistortPreset(radius=-1), "radius must be a finite number >= 0, got -1"),
        (lambda: Augment("grid", seed=-1), "seed must be an integer >= 0, got -1"),
        (lambda: Augment("grid", box_step=0), "box_step must be a finite number > 0, got 0"),
    ],
)
def test_bad_configuration_names_the_value(make, message):
    with pytest.raises(ValueError, match=message.replace("(", r"\(")):
        make()


def test_bad_input_names_the_item(gl, images):
    aug = Augment("grid")
    with pytest.raises(ValueError, match="empty batch"):
        aug(images[:0])
    with pytest.raises(ValueError, match="empty batch"):
        aug([])
    floats = images.astype(np.float32)
    floats[2, 3, 4, 0] = np.nan
    with pytest.raises(ValueError, match=r"images\[2\] holds values that are not finite"):
        aug(floats)
    with pytest.raises(ValueError, match=r"images\[1\] has shape \(0, 5\)"):
        aug([images[0], np.zeros((0, 5), np.uint8)])
    points = np.ones((5, 2, 2))
    points[3, 1, 0] = np.nan
    with pytest.raises(
        ValueError, match=r"keypoints\[3\] holds values that are not finite .*: row 1$"
    ):
        aug(images, keypoints=points)
    with pytest.raises(ValueError, match=r"keypoints\[0\] has shape \(3,\)"):
        aug(images[:1], keypoints=[np.ones(3)])
    with pytest.raises(ValueError, match=r"boxes\[1\] has shape \(1, 3\)"):
        aug(images[:2], boxes=[np.ones((1, 4)), np.ones((1, 3))])
    with pytest.raises(ValueError, match=r"boxes\[0\] holds values that are not finite"):
        aug(images[:1], boxes=[[[0, 0, np.inf, 1]]])
    with pytest.raises(ValueError, match=r"indices\[1\] must be an integer >= 0, got -2"):
        aug(images[:2], indices=[0, -2])
    with pytest.raises(ValueError, match="indices holds 1 value for 2 images"):
        aug(images[:2], indices=[0])
    with pytest.raises(ValueError, match=r"params\[0\] was drawn for shape \(8, 8\)"):
        aug.replay(images[:1], aug.draw([(8, 8)]))
    with pytest.raises(
        ValueError, match=r"polygons\[0\]\[0\] has shape \(3, 3\); expected \(V, 2\)"
    ):
        aug(images[:1], polygons=[[np.ones((3, 3))]])


def test_importing_glmls_imports_no_adapter_library():
    code = (
        "import sys, glmls, glmls.augment\n"
        "print(sorted(m for m in ('torch', 'torchvision', 'albumentations') if m in sys.modules))"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]"


def test_every_seed_and_index_draws_its_own():
    """numpy reads (seed, index) as the words of both numbers, zero-padded: a seed of 2**32
    or more draws otherwise, so that it shares no draw with a smaller seed (2**32 + s at
    index 0 is not s at index 1), while a seed below 2**32 draws from (seed, index)."""
    seeds = [0, 1, 7, 2**32, 2**32 + 1, 2**32 + 7, 3 * 2**32 + 7, 2**64, 2**64 + 1, 2**65]
    seen = {}
    for seed in seeds:
        for draw in Augment("grid", seed=seed).draw([(8, 8)] * 4):
            key = tuple(np.ravel(draw["dst"]))
            assert key not in seen, (seed, draw["index"], seen.get(key))
            seen[key] = (seed, draw["index"])
    draw = Augment("grid", seed=5).draw([(8, 8)], indices=[3])[0]
    src = np.array(draw["src"])
    offsets = np.random.default_rng((5, 3)).uniform(-1.0, 1.0, src.shape) * 0.03 * 8
    np.testing.assert_array_equal(draw["dst"], src + offsets)
