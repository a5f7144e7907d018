"""``splat`` runs on the batched GPU path (one lattice pass, one instanced draw of every
image's points, one read-back per chunk): images, masks, maps and keypoints equal to one
:func:`glmls.warp` per image, bit for bit, and the images to a float64 numpy splat."""

from __future__ import annotations

from functools import partial

import numpy as np
import pytest
from helpers import assert_batch_equals_single_path, moved_handles, random_images, single_warps

import glmls
from glmls import reference
from glmls.batch.single import SingleWarper

SHAPE = (21, 26)


handles = partial(moved_handles, shape=SHAPE)
images_of = partial(random_images, shape=SHAPE)
singles = single_warps


@pytest.mark.parametrize("interpolation", ["nearest", "linear"])
@pytest.mark.parametrize(
    ("dtype", "channels"), [(np.uint8, 3), (np.uint8, 1), (np.uint16, 4), (np.float32, 1)]
)
def test_images_equal_single_warps(no_single, interpolation, dtype, channels):
    rng = np.random.default_rng(1)
    images = images_of(rng, 4, dtype, channels)
    src, dst = handles(rng, 4, [3, 7, 5, 12])  # ragged handle counts
    options = {"method": "splat", "interpolation": interpolation}
    out = glmls.warp_batch(images, src, dst, **options)
    expected = singles(images, src, dst, **options)
    assert out.dtype == images.dtype and out.shape == images.shape
    for k, one in enumerate(expected):
        np.testing.assert_array_equal(out[k], one, err_msg=f"image {k}")


@pytest.mark.parametrize("border", ["constant", "edge", "symmetric", "reflect", "wrap"])
def test_canvas_and_borders_equal_single_warps(no_single, border):
    rng = np.random.default_rng(2)
    images = images_of(rng, 3, np.uint8, 3)
    src, dst = handles(rng, 3)
    dst[1] = dst[1] * 0.8 + 3  # shrinks: the border shows on the canvas
    options = {
        "method": "splat",
        "border": border,
        "output_shape": (25, 30),
        "origin": (-2.0, -3.0),
        "background": (10, 200, 30),
    }
    out = glmls.warp_batch(images, src, dst, **options)
    assert out.shape == (3, 25, 30, 3)
    for k, one in enumerate(singles(images, src, dst, **options)):
        np.testing.assert_array_equal(out[k], one, err_msg=f"image {k}")


def test_list_of_shapes_and_segments_equal_single_warps(no_single):
    """Images of two shapes, one with segment handles (its own MLS), one without handles."""
    rng = np.random.default_rng(3)
    images = [images_of(rng, 1, np.uint8, 3, shape=shape)[0] for shape in (SHAPE, (16, 19), SHAPE)]
    src = [rng.uniform(2, 14, (5, 2)), rng.uniform(2, 14, (4, 2)), np.zeros((0, 2))]
    dst = [p + rng.normal(0, 2, p.shape) for p in src]
    segments = [None, None, [[[2.0, 2.0], [12.0, 9.0]]]]
    moved = [None, None, [[[3.0, 2.0], [13.0, 11.0]]]]
    out = glmls.warp_batch(
        images, src, dst, method="splat", src_segments=segments, dst_segments=moved
    )
    for k, image in enumerate(images):
        kw = {"src_segments": segments[k], "dst_segments": moved[k]} if segments[k] else {}
        one = glmls.warp(image, src[k], dst[k], method="splat", **kw)
        np.testing.assert_array_equal(out[k], one, err_msg=f"image {k}")


@pytest.mark.parametrize("border", ["constant", "reflect"])
def test_masks_maps_keypoints_equal_single_path(monkeypatch, border):
    rng = np.random.default_rng(4)
    height, width = SHAPE
    images = images_of(rng, 4, np.uint8, 3)
    src, dst = handles(rng, 4)
    src, dst = np.stack(src), np.stack(dst)
    dst[2, :3] = dst[2, 3:]  # three handles onto three others: f folds
    masks = rng.integers(0, 5, (4, *SHAPE)).astype(np.uint16)
    points = [rng.uniform((-2, -2), (width + 2, height + 2), (k, 2)) for k in (0, 9, 20, 4)]
    options = {"method": "splat", "interpolation": "linear", "border": border}
    got = glmls.warp_batch(
        images, src, dst, masks=masks, keypoints=points, return_maps=True, **options
    )
    assert_batch_equals_single_path(monkeypatch, got, images, src, dst, masks, points, **options)
    assert got.masks.dtype == np.uint16
    assert all(v.any() and not v.all() for v in got.valid)  # holes and pixels shown


def test_bool_masks_and_keypoints_alone(no_single):
    rng = np.random.default_rng(5)
    images = images_of(rng, 3, np.float32, 1)
    src, dst = handles(rng, 3)
    masks = rng.random((3, *SHAPE)) < 0.5
    points = rng.uniform(0, 20, (3, 6, 2))
    got = glmls.warp_batch(images, src, dst, masks=masks, keypoints=points, method="splat")
    assert got.masks.dtype == bool and got.maps is None
    for k in range(3):
        mask = glmls.warp(masks[k].astype(np.uint8), src[k], dst[k], method="splat")
        np.testing.assert_array_equal(got.masks[k], mask.astype(bool))
        assert got.keypoints[k].shape == (6, 2)


def numpy_splat(image, src, dst):
    """A float64 splat: each pixel centre moved by f, rounded to its pixel, the first pixel
    in scan order shown where several land on one."""
    height, width = image.shape[:2]
    rows, columns = np.mgrid[:height, :width]
    centres = np.stack([columns.ravel(), rows.ravel()], axis=1).astype(np.float64)
    moved = reference.mls(src, dst, centres)[0]
    target = np.floor(moved + 0.5).astype(np.int64)
    inside = np.all((target >= 0) & (target < (width, height)), axis=1)
    out = np.zeros_like(image)
    shown = np.zeros((height, width), bool)
    for n in np.flatnonzero(inside)[::-1]:  # the first in scan order written last
        x, y = target[n]
        out[y, x] = image.reshape(-1, *image.shape[2:])[n]
        shown[y, x] = True
    return out, shown


def test_images_near_a_float64_splat(no_single):
    """Tolerance: f in float32 moves a point within ~1e-4 px of a pixel edge to the other
    pixel; at most 1% of the pixels may differ from the float64 splat."""
    rng = np.random.default_rng(6)
    images = images_of(rng, 3, np.uint8, 3)
    src, dst = handles(rng, 3)
    out = glmls.warp_batch(images, src, dst, method="splat")
    for k in range(3):
        expected, _ = numpy_splat(images[k], src[k], dst[k])
        differ = np.any(out[k] != expected, axis=-1).mean()
        assert differ <= 0.01, f"image {k}: {differ:.2%} of the pixels differ"


def test_chunks_equal_one_chunk(no_single):
    """A budget of one image a chunk gives what one chunk gives."""
    rng = np.random.default_rng(7)
    images = images_of(rng, 5, np.uint8, 4)
    src, dst = handles(rng, 5)
    whole = glmls.warp_batch(images, src, dst, method="splat")
    chunked = glmls.warp_batch(images, src, dst, method="splat", max_batch_bytes=1)
    np.testing.assert_array_equal(whole, chunked)


@pytest.mark.parametrize("method", ["splat", "paper-quads"])
def test_keypoints_without_maps_in_one_pass_equal_single_path(monkeypatch, method):
    """Keypoints without the maps, on the constant border: every image's moved by f at its
    probes in one pass of the chunk and tested against the pixels the batch drew (no f's
    inverse per image), equal to the single path's, where f folds too."""
    rng = np.random.default_rng(7)
    height, width = SHAPE
    images = images_of(rng, 4, np.uint8, 3)
    src, dst = handles(rng, 4, [6, 9, 6, 4])
    dst[1][:3] = dst[1][3:6]  # three handles onto three others: f folds
    points = [rng.uniform((-2, -2), (width + 2, height + 2), (k, 2)) for k in (5, 30, 0, 12)]
    inverses = []
    source_points = SingleWarper.source_points
    monkeypatch.setattr(
        SingleWarper,
        "source_points",
        lambda self, *a, **k: inverses.append(1) or source_points(self, *a, **k),
    )
    got = glmls.warp_batch(images, src, dst, keypoints=points, method=method)
    assert not inverses  # no Newton over every pixel for the keypoints
    monkeypatch.setattr("glmls.batch.run.forward_batchable", lambda options: False)
    for k in range(4):
        one = glmls.warp_batch(
            images[k : k + 1], [src[k]], [dst[k]], keypoints=[points[k]], method=method
        )
        np.testing.assert_array_equal(got.keypoints[k], one.keypoints[0], err_msg=f"{k}")
        np.testing.assert_array_equal(got.keypoints_valid[k], one.keypoints_valid[0])
    valid = np.concatenate(got.keypoints_valid)
    assert valid.any() and not valid.all()


@pytest.mark.parametrize("method", ["quads", "backward", "splat", "paper-quads"])
def test_keypoints_valid_is_a_bool_mask_for_every_method(method):
    """``keypoints_valid`` selects the valid keypoints as a mask: the methods that push pixels
    forward gave 0/1 integers, which as an index pick keypoints 0 and 1 instead."""
    rng = np.random.default_rng(6)
    images = images_of(rng, 2, np.uint8, 1)
    src, dst = handles(rng, 2)
    points = rng.uniform(0, 20, (2, 5, 2))
    got = glmls.warp_batch(images, src, dst, keypoints=points, method=method)
    for k in range(2):
        valid = got.keypoints_valid[k]
        assert valid.dtype == bool and valid.shape == (5,)
        assert got.keypoints[k][valid].shape == (int(valid.sum()), 2)
