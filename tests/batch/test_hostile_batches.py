"""Hostile inputs to glmls.warp_batch: what glmls.warp takes, a batch takes too, with the
same result; inputs are never modified."""

from __future__ import annotations

import numpy as np
import pytest

import glmls


@pytest.fixture
def batch():
    rng = np.random.default_rng(0)
    images = (rng.random((3, 12, 14)) * 60000).astype(np.uint16)
    src = np.array([[[2.0, 2], [10, 2], [2, 9], [10, 9]]] * 3)
    return images, src, src + [1.0, 0.5]


@pytest.mark.parametrize("method", ["quads", "backward", "splat"])
def test_big_endian_images_warp_as_glmls_warp_warps_them(gl, batch, method):
    images, src, dst = batch
    swapped = images.astype(">u2")
    kept = swapped.copy()
    expected = np.stack(
        [
            glmls.warp(i, s, d, method=method, ctx=gl)
            for i, s, d in zip(swapped, src, dst, strict=True)
        ]
    )
    stacked = glmls.warp_batch(swapped, src, dst, method=method, ctx=gl)
    listed = glmls.warp_batch(list(swapped), list(src), list(dst), method=method, ctx=gl)
    np.testing.assert_array_equal(stacked, expected)
    np.testing.assert_array_equal(listed, expected)
    assert stacked.dtype == np.uint16
    np.testing.assert_array_equal(swapped, kept)


def test_big_endian_masks_warp_as_native_ones(gl, batch):
    images, src, dst = batch
    masks = (images % 5).astype(np.uint16)
    native = glmls.warp_batch(images, src, dst, masks=masks, ctx=gl)
    swapped = glmls.warp_batch(images, src, dst, masks=masks.astype(">u2"), ctx=gl)
    np.testing.assert_array_equal(swapped.masks, native.masks)


def test_the_same_batch_twice_gives_the_same_result_and_leaves_its_inputs(gl, batch):
    images, src, dst = batch
    keypoints = np.random.default_rng(1).random((3, 5, 2)) * 10
    masks = (images % 3).astype(np.uint8)
    given = [a.copy() for a in (images, src, dst, keypoints, masks)]
    first = glmls.warp_batch(images, src, dst, keypoints=keypoints, masks=masks, ctx=gl)
    second = glmls.warp_batch(
        np.asfortranarray(images), src, dst, keypoints=keypoints, masks=masks, ctx=gl
    )
    np.testing.assert_array_equal(first.images, second.images)
    np.testing.assert_array_equal(first.keypoints, second.keypoints)
    np.testing.assert_array_equal(first.masks, second.masks)
    for now, before in zip((images, src, dst, keypoints, masks), given, strict=True):
        np.testing.assert_array_equal(now, before)


@pytest.mark.parametrize("method", ["quads", "backward"])
@pytest.mark.parametrize("stacked", [True, False])
def test_a_float64_value_beyond_float32_is_warped_and_a_background_named(gl, method, stacked):
    """It was refused; its image reaches the GPU divided by a power of two, the others not."""
    images = np.zeros((3, 8, 8))
    images[:, 3, 3] = 2.0**1000, 1.0, 2.0**-1000  # exact in float32 divided by 2**960
    given = images if stacked else list(images)
    src, dst = np.zeros((3, 1, 2)), np.ones((3, 1, 2))
    out = glmls.warp_batch(given, src, dst, method=method, ctx=gl)
    np.testing.assert_array_equal(np.stack(out)[:, 4, 4], [2.0**1000, 1.0, 2.0**-1000])
    assert np.count_nonzero(np.stack(out)) == 3
    with pytest.raises(ValueError, match=r"^images\[0\]: background 0\.5 is beyond float32's"):
        glmls.warp_batch(given, src, dst, method=method, background=0.5, ctx=gl)


@pytest.mark.parametrize("item", ["images", "src", "dst", "keypoints", "masks"])
def test_a_ragged_item_is_named(item):
    inputs = {
        "images": [np.zeros((8, 8), np.uint8)] * 2,
        "src": [np.array([[2.0, 2.0], [5.0, 5.0]])] * 2,
        "dst": [np.array([[2.0, 2.0], [5.0, 6.0]])] * 2,
        "keypoints": [np.zeros((1, 2))] * 2,
        "masks": [np.zeros((8, 8), np.uint8)] * 2,
    }
    inputs[item] = [inputs[item][0], [[1, 2], [3]]]
    images, src, dst = inputs.pop("images"), inputs.pop("src"), inputs.pop("dst")
    with pytest.raises(ValueError, match=rf"^{item}\[1\] is ragged"):
        glmls.warp_batch(images, src, dst, **inputs)


@pytest.mark.parametrize("method", ["quads", "backward", "splat"])
def test_a_background_that_does_not_fit_an_image_names_it(gl, method):
    """In a list of images of different channels or dtypes, a background that fits some of
    them names the first image it does not fit, on the batched path as on the single one."""
    rgb = np.zeros((8, 9, 3), np.uint8)
    handles = np.array([[[2.0, 2.0], [6.0, 5.0]]] * 3)
    with pytest.raises(ValueError, match=r"^images\[1\]: background must be a scalar or 1 "):
        glmls.warp_batch(
            [rgb, rgb[..., 0], rgb],
            handles,
            handles + 1,
            background=(1, 2, 3),
            method=method,
            ctx=gl,
        )
    wide = [rgb.astype(np.uint16), rgb, rgb]
    with pytest.raises(ValueError, match=r"^images\[1\]: background 300.0 is outside 0..255"):
        glmls.warp_batch(wide, handles, handles + 1, background=300, method=method, ctx=gl)


def _objects(*items: np.ndarray) -> np.ndarray:
    out = np.empty(len(items), object)
    for i, item in enumerate(items):
        out[i] = item
    return out


def test_a_one_dimensional_object_array_is_a_sequence(gl):
    """A 1-D object array of arrays of different shapes (what ``np.array(items,
    dtype=object)`` makes of ragged items) is taken as the sequence of its items, for images,
    handles and keypoints alike, in warp_batch and Augment."""
    images = [np.arange(120, dtype=np.uint8).reshape(10, 12), np.ones((8, 9), np.uint8)]
    src = [np.array([[1.0, 1.0], [5.0, 5.0]]), np.array([[2.0, 2.0]])]
    dst = [s + 0.5 for s in src]
    points = [np.array([[3.0, 4.0]]), np.zeros((0, 2))]
    given = glmls.warp_batch(images, src, dst, keypoints=points)
    objects = glmls.warp_batch(
        _objects(*images), _objects(*src), _objects(*dst), keypoints=_objects(*points)
    )
    for a, b in zip(given.images, objects.images, strict=True):
        np.testing.assert_array_equal(a, b)
    for a, b in zip(given.keypoints, objects.keypoints, strict=True):
        np.testing.assert_array_equal(a, b)
    aug = glmls.augment.Augment("grid", seed=3)
    plain = aug(
        images, keypoints=points, boxes=[np.array([[1.0, 1.0, 6.0, 6.0]]), np.zeros((0, 4))]
    )
    packed = aug(
        _objects(*images),
        keypoints=_objects(*points),
        boxes=_objects(np.array([[1.0, 1.0, 6.0, 6.0]]), np.zeros((0, 4))),
    )
    for a, b in zip(plain.images, packed.images, strict=True):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(plain.boxes[0], packed.boxes[0])


@pytest.mark.parametrize("masks", [np.array(True), np.array(False), np.array(3, np.uint8)])
def test_a_mask_array_without_a_batch_axis_is_named(batch, masks):
    """A 0-d mask array, bool or not, is refused naming ``masks`` and its shape."""
    images, src, dst = batch
    with pytest.raises(ValueError, match=r"^masks must be an array of 3 dimensions .*shape \(\)"):
        glmls.warp_batch(images, src, dst, masks=masks)


@pytest.mark.parametrize("method", glmls.METHODS)
@pytest.mark.parametrize("border", ["constant", "edge"])
def test_keypoints_at_the_coordinate_limit_are_moved_and_not_valid(gl, method, border):
    """Keypoints as far as the inputs take them (±1e6 px): each is moved, off the canvas
    and not valid, by every method and border; the footprint's edge, the probes of f's
    Jacobian and ``backward-swap``'s preimages, which reach further, do not refuse them."""
    rng = np.random.default_rng(2)  # moves whose swapped map's preimages, far off, pass it
    images = np.zeros((2, 20, 24), np.uint8)
    src = rng.uniform(2, 18, (2, 5, 2))
    dst = src + rng.normal(0, 3, src.shape)
    keypoints = np.array([[[1e6, 1e6], [-1e6, 5.0], [999999.8, 3.0]], [[3.0, 3.0]] * 3])
    result = glmls.warp_batch(images, src, dst, keypoints=keypoints, method=method, border=border)
    assert np.isfinite(result.keypoints).all()
    assert result.keypoints_valid.tolist() == [[False] * 3, [True] * 3]
