"""``paper-quads`` runs on the batched GPU path (one lattice pass, one scan of every image's
squares, one fill draw, one read-back per chunk): images, masks, maps and keypoints equal to
one :func:`glmls.warp` per image, bit for bit, and the pixels shown to the float64 numpy
pseudo-code (:func:`glmls.core.paper_quads.paper_quads`)."""

from __future__ import annotations

from functools import partial

import moderngl
import numpy as np
import pytest
from helpers import (
    SENTINEL,
    assert_batch_equals_single_path,
    coordinate_image,
    folded_case,
    folding_handles,
    moved_handles,
    random_images,
    single_warps,
)

import glmls
from glmls import reference
from glmls.core.mesh import MeshLattice
from glmls.core.paper_quads import paper_quads
from glmls.gl.context import GLContext

SHAPE = (21, 26)
PAPER = {"method": "paper-quads"}


handles = partial(moved_handles, shape=SHAPE)
images_of = partial(random_images, shape=SHAPE)
singles = single_warps


def assert_singles(out, images, src, dst, **options):
    for k, one in enumerate(singles(images, src, dst, **options)):
        np.testing.assert_array_equal(out[k], one, err_msg=f"image {k}")


@pytest.mark.parametrize("interpolation", ["nearest", "linear"])
@pytest.mark.parametrize(
    ("dtype", "channels"), [(np.uint8, 3), (np.uint8, 1), (np.uint16, 4), (np.float32, 2)]
)
def test_images_equal_single_warps(no_single, interpolation, dtype, channels):
    rng = np.random.default_rng(1)
    images = images_of(rng, 4, dtype, channels)
    src, dst = handles(rng, 4, [3, 7, 5, 12])  # ragged handle counts
    dst[1][:3] = dst[1][3:6]  # three handles onto three others: f folds
    options = {**PAPER, "interpolation": interpolation}
    out = glmls.warp_batch(images, src, dst, **options)
    assert out.dtype == images.dtype and out.shape == images.shape
    assert_singles(out, images, src, dst, **options)


@pytest.mark.parametrize("interpolation", ["nearest", "linear"])
@pytest.mark.parametrize("border", ["constant", "edge", "symmetric", "reflect", "wrap"])
def test_canvas_and_borders_equal_single_warps(no_single, border, interpolation):
    rng = np.random.default_rng(2)
    images = images_of(rng, 3, np.uint8, 3)
    src, dst = handles(rng, 3)
    dst[1] = dst[1] * 0.8 + 3  # shrinks: the border shows on the canvas
    options = {
        **PAPER,
        "interpolation": interpolation,
        "border": border,
        "output_shape": (25, 30),
        "origin": (-2.0, -3.0),
        "background": (10, 200, 30),
    }
    out = glmls.warp_batch(images, src, dst, **options)
    assert out.shape == (3, 25, 30, 3)
    assert_singles(out, images, src, dst, **options)
    background = np.all(out == (10, 200, 30), axis=-1)
    assert background.any() == (border == "constant")  # a border mode covers the canvas


def test_list_of_shapes_and_segments_equal_single_warps(no_single):
    """Images of two shapes, one with segment handles (its own MLS), one without handles."""
    rng = np.random.default_rng(3)
    images = [images_of(rng, 1, np.uint8, 3, shape=shape)[0] for shape in (SHAPE, (16, 19), SHAPE)]
    src = [rng.uniform(2, 14, (5, 2)), rng.uniform(2, 14, (4, 2)), np.zeros((0, 2))]
    dst = [p + rng.normal(0, 2, p.shape) for p in src]
    segments = [None, None, [[[2.0, 2.0], [12.0, 9.0]]]]
    moved = [None, None, [[[3.0, 2.0], [13.0, 11.0]]]]
    out = glmls.warp_batch(images, src, dst, src_segments=segments, dst_segments=moved, **PAPER)
    for k, image in enumerate(images):
        kw = {"src_segments": segments[k], "dst_segments": moved[k]} if segments[k] else {}
        one = glmls.warp(image, src[k], dst[k], **kw, **PAPER)
        np.testing.assert_array_equal(out[k], one, err_msg=f"image {k}")


@pytest.mark.parametrize(
    ("border", "interpolation", "mask_dtype"),
    [
        ("constant", "linear", np.uint16),
        ("reflect", "linear", np.int32),
        ("edge", "nearest", np.uint8),
    ],
)
def test_masks_maps_keypoints_equal_single_path(monkeypatch, border, interpolation, mask_dtype):
    rng = np.random.default_rng(4)
    height, width = SHAPE
    images = images_of(rng, 4, np.uint8, 3)
    src, dst = handles(rng, 4)
    src, dst = np.stack(src), np.stack(dst)
    dst[2, :3] = dst[2, 3:]  # three handles onto three others: f folds
    masks = rng.integers(0, 5, (4, *SHAPE)).astype(mask_dtype)
    points = [rng.uniform((-2, -2), (width + 2, height + 2), (k, 2)) for k in (0, 9, 20, 4)]
    options = {**PAPER, "interpolation": interpolation, "border": border}
    got = glmls.warp_batch(
        images, src, dst, masks=masks, keypoints=points, return_maps=True, **options
    )
    assert_batch_equals_single_path(monkeypatch, got, images, src, dst, masks, points, **options)
    assert got.masks.dtype == mask_dtype
    assert all(v.any() and not v.all() for v in got.valid)  # pixels shown, and not all
    assert any(v.any() and not v.all() for v in got.keypoints_valid)


def test_masks_keypoints_and_maps_taken_by_the_batch(no_single):
    """Labels of each kind on the batched path (a bool mask, keypoints alone; the maps with
    a float32 image): the masks equal single warps of the masks."""
    rng = np.random.default_rng(5)
    images = images_of(rng, 3, np.float32, 1)
    src, dst = handles(rng, 3)
    masks = rng.random((3, *SHAPE)) < 0.5
    points = rng.uniform(0, 20, (3, 6, 2))
    got = glmls.warp_batch(images, src, dst, masks=masks, keypoints=points, **PAPER)
    assert got.masks.dtype == bool and got.maps is None
    for k in range(3):
        mask = glmls.warp(masks[k].astype(np.uint8), src[k], dst[k], **PAPER)
        np.testing.assert_array_equal(got.masks[k], mask.astype(bool))
        assert got.keypoints[k].shape == (6, 2)
    maps = glmls.warp_batch(images, src, dst, return_maps=True, **PAPER)
    np.testing.assert_array_equal(maps.images, got.images)
    assert maps.maps.shape == (3, *SHAPE, 2) and all(v.any() for v in maps.valid)


def numpy_paper(image, src, dst, output_shape, origin):
    """The float64 pseudo-code: f at the pixel centres (float64), each output pixel the
    source pixel its first square's nearest vertex names (-1: none)."""
    shape = image.shape[:2]
    centres = MeshLattice.centres(shape).points()
    f = reference.mls(src, dst, centres.reshape(-1, 2))[0].reshape(centres.shape)
    return paper_quads(f, output_shape, origin=origin)


def test_images_follow_the_float64_pseudo_code(no_single):
    """Tolerance: f in float32 moves a vertex ~1e-5 px, enough to move a pixel centre within
    that of an edge (or of equal distance to two vertices) to the other side; at least 99%
    of the pixels show the source pixel that the float64 pseudo-code names, folds included
    (the bound of tests/imaging/test_paper_quads.py)."""
    shape = (48, 56)
    p, q = folding_handles(shape)
    src = [p, p, p + 0.3]
    dst = [q, p + (1.37, -2.21), q * 0.9 + 2]
    images = np.stack([coordinate_image(*shape)] * 3)
    canvas, origin = (52, 60), (-2.0, -1.5)
    out = glmls.warp_batch(
        images, src, dst, output_shape=canvas, origin=origin, background=SENTINEL, **PAPER
    )
    for k in range(3):
        shown = np.where(out[k][..., :1] == SENTINEL, -1, out[k][..., :2].astype(np.int64))
        expected = numpy_paper(images[k], src[k], dst[k], canvas, origin)
        assert (expected[..., 0] >= 0).mean() > 0.5
        same = (shown == expected).all(axis=-1).mean()
        assert same >= 0.99, f"image {k}: {same:.2%} of the pixels agree"


def test_chunks_equal_one_chunk(no_single):
    """A budget of one image a chunk gives what one chunk gives."""
    rng = np.random.default_rng(7)
    images = images_of(rng, 5, np.uint8, 4)
    src, dst = handles(rng, 5)
    for interpolation in ("nearest", "linear"):
        options = {**PAPER, "interpolation": interpolation}
        whole = glmls.warp_batch(images, src, dst, **options)
        chunked = glmls.warp_batch(images, src, dst, max_batch_bytes=1, **options)
        np.testing.assert_array_equal(whole, chunked)


def test_an_image_without_squares_is_named():
    """An image one pixel wide has no square of four pixel centres with the constant border:
    refused as by its own warp, the image named; with a border mode its lattice has them."""
    images = [np.zeros((9, 12), np.uint8), np.zeros((9, 1), np.uint8)]
    src = [np.array([[2.0, 2.0], [8.0, 6.0]]), np.array([[0.0, 2.0], [0.0, 6.0]])]
    dst = [s + (0.5, 0.25) for s in src]
    with pytest.raises(ValueError, match=r"images\[1\]: method 'paper-quads' fills squares"):
        glmls.warp_batch(images, src, dst, **PAPER)
    out = glmls.warp_batch(images, src, dst, border="edge", **PAPER)
    for k in range(2):
        one = glmls.warp(images[k], src[k], dst[k], border="edge", **PAPER)
        np.testing.assert_array_equal(out[k], one)


@pytest.fixture(scope="module")
def pieced():
    """A context of its own whose scans walk at most 40 pixels an invocation: the squares of
    a map scaled 3x are walked in pieces (common/pieces.glsl)."""
    mgl = moderngl.create_context(standalone=True, backend="egl", require=430)
    ctx = GLContext(mgl, owned=True)
    ctx.piece_pixels = 40
    yield ctx
    ctx.release()


@pytest.mark.parametrize("interpolation", ["nearest", "linear"])
def test_squares_in_pieces_equal_single_warps(no_single, pieced, interpolation):
    shape, p, q = folded_case()
    images = np.stack([coordinate_image(*shape)] * 2)
    src, dst = [p, p], [q * 3.0, p * 3.0 + 1.5]
    options = {**PAPER, "interpolation": interpolation, "output_shape": (130, 150)}
    out = glmls.warp_batch(images, src, dst, transform="similarity", ctx=pieced, **options)
    for k in range(2):
        one = glmls.warp(images[k], src[k], dst[k], transform="similarity", **options)
        np.testing.assert_array_equal(out[k], one, err_msg=f"image {k}")
