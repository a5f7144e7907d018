"""glmls.warp_batch refuses what one glmls.warp refuses, for every method and path, naming
the image: a source point with two different targets, affine handles on one line."""

from __future__ import annotations

import numpy as np
import pytest

import glmls


def batch():
    images = np.zeros((3, 10, 12), np.uint8)
    src = np.tile([[1.0, 1.0], [8.0, 2.0], [3.0, 7.0]], (3, 1, 1))
    return images, src, src + 0.5


@pytest.mark.parametrize("method", glmls.METHODS)
@pytest.mark.parametrize("given", ["array", "ragged"])
def test_a_source_point_with_two_targets_names_its_image(gl, method, given):
    images, src, dst = batch()
    src[2, 1] = src[2, 0]
    if given == "ragged":
        src, dst = list(src), list(dst)
        src[0], dst[0] = src[0][:2], dst[0][:2]
    with pytest.raises(ValueError, match=r"^images\[2\]: src\[0\] and src\[1\] are the same point"):
        glmls.warp_batch(images, src, dst, method=method)
    with pytest.raises(ValueError, match=r"src\[0\] and src\[1\] are the same point"):
        glmls.warp(images[2], src[2], dst[2], method=method)


@pytest.mark.parametrize("method", glmls.METHODS)
def test_exact_duplicate_handles_warp_as_one_warp_does(gl, method):
    images, src, dst = batch()
    src[1, 1], dst[1, 1] = src[1, 0], dst[1, 0]  # the same pair twice: accepted
    out = glmls.warp_batch(images, src, dst, method=method)
    single = [glmls.warp(i, p, q, method=method) for i, p, q in zip(images, src, dst, strict=True)]
    np.testing.assert_array_equal(out, single)


@pytest.mark.parametrize("method", ["quads", "backward", "splat"])
def test_affine_handles_on_a_line_name_their_image(gl, method):
    images, src, dst = batch()
    src[1] = [[1.0, 1.0], [2.0, 2.0], [4.0, 4.0]]
    with pytest.raises(glmls.DegenerateHandlesError, match=r"^images\[1\]: affine MLS needs"):
        glmls.warp_batch(images, src, dst, method=method, transform="affine")


@pytest.mark.parametrize("method", glmls.METHODS)
@pytest.mark.parametrize("border", ["constant", "edge"])
def test_the_canvas_is_half_open_for_keypoints(gl, method, border):
    """Output pixel c covers [c - 0.5, c + 0.5): a keypoint on the canvas's left or top edge
    is on it (albumentations' 0 <= x < W, pixel centres at 0.5), one on its right or bottom
    edge is not."""
    images, src, _ = batch()  # 10 x 12
    # past the right and bottom edges by more than float32's noise of the identity map
    points = np.array([[-0.5, 3.0], [3.0, -0.5], [-0.5, -0.5], [11.501, 3], [3, 9.501], [-0.51, 3]])
    result = glmls.warp_batch(
        images, src, src, keypoints=np.stack([points] * 3), method=method, border=border
    )
    np.testing.assert_allclose(result.keypoints[0], points, atol=1e-5)
    assert result.keypoints_valid.tolist() == [[True, True, True, False, False, False]] * 3


@pytest.mark.parametrize("grid", [1, 4])
@pytest.mark.parametrize("border", ["constant", "edge"])
@pytest.mark.parametrize("chunks", [None, 1])
def test_quads_keypoints_beyond_the_mesh_move_by_f(gl, grid, border, chunks):
    """Where no cell of the mesh lies (outside the image with the constant border, beyond
    the margin with the others) a keypoint moves by f, not by its nearest cell's map drawn
    out (pixels away at a few pixels' distance): a box partly outside the image keeps its
    shape. Inside the mesh, the mesh's own map."""
    rng = np.random.default_rng(4)
    images = rng.integers(0, 255, (3, 20, 28), dtype=np.uint8)
    src = rng.uniform(2, 18, (3, 6, 2))
    dst = src + rng.normal(0, 3, src.shape)
    outside = np.array([[-12.0, -9.0], [-3.0, 5.0], [40.0, 30.0], [-300.0, 8.0]])
    inside = np.array([[3.0, 4.0], [20.0, 15.0]])
    points = np.stack([np.concatenate([outside, inside])] * 3)
    result = glmls.warp_batch(
        images, src, dst, keypoints=points, grid=grid, border=border, max_batch_bytes=chunks
    )
    for k in range(3):
        with glmls.MLS(src[k], dst[k], shape=(20, 28)) as f:
            moved = result.keypoints[k]
            if border == "constant":
                np.testing.assert_allclose(moved[:4], f(outside), atol=1e-4)
            else:
                np.testing.assert_allclose(moved[3:4], f(outside[3:]), atol=1e-4)
            assert np.abs(moved[4:] - f(inside)).max() < 0.5  # the mesh's map, near f
    single = glmls.warp_batch(
        images, src, dst, keypoints=points, grid=grid, border=border, interpolation="linear"
    )
    np.testing.assert_array_equal(single.keypoints, result.keypoints)


@pytest.mark.parametrize("interpolation", ["nearest", "linear"])
def test_ragged_keypoints_beyond_the_mesh_move_as_image_by_image(gl, monkeypatch, interpolation):
    """Images with no keypoints, with keypoints inside the mesh only, and with some beyond
    it (or their footprints' edges beyond it, bilinear): each image's flags are those of its
    own warp, the keypoints beyond the mesh moved by its f bit for bit, those inside by its
    mesh (f at the vertices in float32: within its rounding)."""
    rng = np.random.default_rng(8)
    count = 12
    images = rng.integers(0, 255, (count, 18, 22, 3), dtype=np.uint8)
    src = rng.uniform(2, 16, (count, 5, 2))
    dst = src + rng.normal(0, 2, src.shape)
    sizes = [0, 3, 7, 1, 0, 12, 2, 5, 9, 4, 6, 1]
    points = [rng.uniform(-4, 25, (k, 2)) for k in sizes]
    points[1] = rng.uniform(2, 15, (3, 2))  # inside only
    options = {"keypoints": points, "interpolation": interpolation, "grid": 2}
    result = glmls.warp_batch(images, src, dst, **options)
    monkeypatch.setattr(glmls.batch.run, "batchable", lambda chosen: False)
    alone = glmls.warp_batch(images, src, dst, **options)
    for k, p in enumerate(points):
        np.testing.assert_array_equal(result.keypoints_valid[k], alone.keypoints_valid[k])
        beyond = (p < -0.5).any(axis=1) | (p[:, 0] > 21.5) | (p[:, 1] > 17.5)
        np.testing.assert_array_equal(result.keypoints[k][beyond], alone.keypoints[k][beyond])
        np.testing.assert_allclose(result.keypoints[k], alone.keypoints[k], rtol=0, atol=1e-6)
    assert 0 < sum(((p < -0.5).any(axis=1) | (p > 17.5).any(axis=1)).sum() for p in points)


@pytest.mark.parametrize("method", glmls.METHODS)
@pytest.mark.parametrize("border", ["constant", "edge"])
def test_valid_pixels_are_the_pixels_the_method_draws(gl, method, border):
    """``valid`` holds where some source pixel covers the output pixel in the method's own
    image (not the border rule's copies past the image): splat's holes (stretched, a
    forward splat leaves gaps) and paper-quads' are not valid, though f's inverse is found
    there."""
    rng = np.random.default_rng(3)
    images = rng.uniform(0.1, 1, (2, 30, 40)).astype(np.float32)
    src = rng.uniform(3, 27, (2, 8, 2))
    dst = src + rng.normal(0, 4, src.shape)
    result = glmls.warp_batch(
        images, src, dst, return_maps=True, method=method, border=border, background=-1.0,
        output_shape=(36, 48), origin=(-4.0, -3.0),
    )  # fmt: skip
    drawn = result.images != -1.0
    if border != "constant":  # the border rule's copies are shown, not covered: not valid
        x, y = result.maps[..., 0], result.maps[..., 1]
        drawn &= (x >= -0.5) & (x < 39.5) & (y >= -0.5) & (y < 29.5)
    assert not (result.valid & ~drawn).any()
    assert (drawn & ~result.valid).sum() <= 0.01 * drawn.sum()
