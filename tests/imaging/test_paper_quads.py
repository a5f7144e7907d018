"""method="paper-quads": the paper's pseudo-code (squares of adjacent pixel centres, nearest
vertex, first square in scan order wins) on the GPU, against its float64 numpy implementation
(glmls.core.paper_quads); and ``quads`` against it on folded maps."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import SENTINEL, coordinate_image, folding_handles, smooth_handles
from numpy.testing import assert_array_equal

import glmls
from glmls import reference
from glmls.core.mesh import MeshLattice
from glmls.core.paper_quads import EDGE_TOLERANCE, paper_quads
from glmls.imaging.options import PipelineOptions


def shown(out):
    """(H, W, 2) source pixel (x, y) each output pixel of a coordinate image shows, -1 where
    it kept the background."""
    xy = out[..., :2].astype(np.int64)
    return np.where(out[..., :1] == SENTINEL, -1, xy)


def reference_pixels(m, shape, output_shape=None, origin=(0.0, 0.0)):
    """The numpy pseudo-code on f in float64 at the pixel centres: (pixels, counts)."""
    centres = MeshLattice.centres(shape).points()
    f, _, _ = reference.mls(m.src, m.dst, centres.reshape(-1, 2), m.config, shape=shape)
    out_shape = shape if output_shape is None else output_shape
    return paper_quads(f.reshape(centres.shape), out_shape, origin=origin, counts=True)


# -- the numpy pseudo-code -------------------------------------------------------------------


def test_pseudo_code_of_the_identity_and_a_whole_pixel_shift():
    yy, xx = np.mgrid[0:7, 0:9]
    f = np.stack([xx, yy], -1).astype(float)
    assert_array_equal(paper_quads(f, (7, 9)), np.stack([xx, yy], -1))
    # points on the border of the squares are inside: the border rows and columns show
    moved = paper_quads(f + [2.0, -1.0] + 1e-4, (8, 12))
    assert_array_equal(moved[:6, 2:11], np.stack([xx, yy], -1)[1:, :])
    assert (moved[6:] == -1).all() and (moved[:, :2] == -1).all() and (moved[:, 11:] == -1).all()
    # further from the edge than the tolerance: outside
    assert (paper_quads(f + 2 * EDGE_TOLERANCE, (7, 9))[0] == -1).all()


def test_pseudo_code_marks_with_the_first_square_and_the_nearest_vertex():
    """Two squares (one row of three centres) whose second quadrilateral is folded back over
    the first: their common pixels keep the first square, coloured by its nearest vertex."""
    f = np.array(
        [
            [[0.0, 0.0], [4.0, 0.0], [0.2, 0.0]],
            [[0.0, 4.0], [4.0, 4.0], [0.2, 4.0]],
        ]
    )
    out, counts = paper_quads(f, (5, 5), counts=True)
    # pixel (1, 1) is in both (strictly); nearest of square 0's vertices: (0, 0)
    assert counts[1, 1] == 2
    assert_array_equal(out[1, 1], [0, 0])
    assert_array_equal(out[3, 3], [1, 1])  # nearest (4, 4): vertex (1, 1)
    # the second square alone would show its own vertices there: (2, 0) is nearest (0.2, 0)
    alone = paper_quads(f[:, 1:], (5, 5))
    assert_array_equal(alone[1, 1], [1, 0])
    assert (out[:, 4] >= 0).all()  # x = 4: on the edge shared by both, kept by the first


def test_pseudo_code_checks_its_input():
    with pytest.raises(ValueError, match="deformed"):
        paper_quads(np.zeros((3, 3)), (3, 3))
    with pytest.raises(ValueError, match="output_shape"):
        paper_quads(np.zeros((3, 3, 2)), (0, 3))


# -- the GPU against it ----------------------------------------------------------------------


@pytest.mark.parametrize("shape", [(96, 128), (150, 112)])
def test_paper_quads_on_the_gpu_follow_the_pseudo_code_on_folds(gl, shape):
    """Same source pixel in >= 99 % of covered pixels and >= 95 % of the folded ones
    (measured: 100 % of both); ``quads`` within 1 px of it on >= 95 % of the folded pixels
    (measured 97.8 %; every one within 1 px in each axis)."""
    p, q = folding_handles(shape)
    img = coordinate_image(*shape)
    with glmls.MLS(p, q, shape=shape, ctx=gl) as m:
        assert glmls.analysis.foldovers(m, shape).count > 500
        paper = shown(m.warp(img, method="paper-quads", background=SENTINEL))
        quads = shown(m.warp(img, method="quads", background=SENTINEL))
        expected, counts = reference_pixels(m, shape)
    covered = (expected[..., 0] >= 0) | (paper[..., 0] >= 0)
    folded = counts > 1
    assert covered.sum() > 0.5 * covered.size and folded.sum() > 300
    same = (paper == expected).all(axis=-1)
    assert same[covered].mean() >= 0.99
    assert same[folded].mean() >= 0.95
    near = np.linalg.norm(quads - expected, axis=-1) <= 1.0
    assert near[folded].mean() >= 0.95
    assert (np.abs(quads - expected).max(axis=-1)[folded] <= 1).mean() >= 0.99


def test_paper_quads_agree_with_the_pseudo_code_without_folds_and_on_a_canvas(gl, rng):
    shape = (80, 100)
    p, q = smooth_handles(shape, rng)
    img = coordinate_image(*shape)
    canvas, origin = (100, 130), (-12.0, -7.5)
    with glmls.MLS(p, q, shape=shape, ctx=gl) as m:
        assert glmls.analysis.foldovers(m, shape).count == 0
        out = m.warp(img, method="paper-quads", background=SENTINEL)
        framed = m.warp(
            img, method="paper-quads", background=SENTINEL, output_shape=canvas, origin=origin
        )
        expected, counts = reference_pixels(m, shape)
        expected_framed, _ = reference_pixels(m, shape, canvas, origin)
    assert counts.max() == 1
    assert (shown(out) == expected).all(axis=-1).mean() >= 0.99
    assert (shown(framed) == expected_framed).all(axis=-1).mean() >= 0.99
    assert (shown(framed)[..., 0] >= 0).sum() > (shown(out)[..., 0] >= 0).sum()  # nothing cut


def test_paper_quads_in_bands_equal_one_band(gl):
    shape = (64, 72)
    p, q = folding_handles(shape)
    img = coordinate_image(*shape)
    banded = glmls.gl.WarpPipeline(gl, options=PipelineOptions(band_bytes=4096))
    try:
        assert MeshLattice.centres(shape).rows_per_band(4096) < 10
        with glmls.MLS(p, q, shape=shape, ctx=gl) as m:
            for interpolation in glmls.INTERPOLATIONS:
                whole = m.warp(img, method="paper-quads", interpolation=interpolation)
                bands = banded.warp(m, img, method="paper-quads", interpolation=interpolation)
                assert_array_equal(bands, whole)
    finally:
        banded.release()


def test_paper_quads_linear_blends_the_square_of_the_pixel(gl, rng):
    """``linear``: the bilinear blend of the winning square's four vertex colours at the
    pixel's place in it: a linear ramp comes back as the source point, whose map through
    f (float64) lands within rounding of the pixel centre."""
    shape = (60, 80)
    p, q = smooth_handles(shape, rng)
    img = coordinate_image(*shape).astype(np.float32)
    with glmls.MLS(p, q, shape=shape, ctx=gl) as m:
        out = m.warp(img, method="paper-quads", interpolation="linear", background=-1)
        nearest = m.warp(img, method="paper-quads", background=-1)
        f, _, _ = reference.mls(p, q, out[..., :2].reshape(-1, 2), m.config, shape=shape)
    covered = out[..., 0] >= 0
    assert_array_equal(covered, nearest[..., 0] >= 0)
    u = np.stack(np.meshgrid(np.arange(shape[1]), np.arange(shape[0])), -1)
    d = np.linalg.norm(f.reshape(*shape, 2) - u, axis=-1)[covered]
    assert np.median(d) < 0.02 and d.max() < 0.2  # f is nearly bilinear over one square
    assert np.abs(out[covered][:, :2] - nearest[covered][:, :2]).max() <= 1.0


@pytest.mark.parametrize("border", ["constant", "edge"])
def test_paper_quads_linear_inverts_an_affine_map_exactly(gl, border):
    """Where f is affine (every handle moved by one affine map) each deformed square is a
    parallelogram, and ``linear`` gives each pixel its exact source point: the quadratic of
    Q's bilinear inverse degenerates to a linear one, whose root float32 keeps to ~1e-5 px."""
    height, width = 40, 50
    img = coordinate_image(height, width)[..., :2].astype(np.float32)
    p = np.array([[3.0, 4.0], [40.0, 5.0], [25.0, 30.0], [4.0, 34.0], [20.0, 20.0]])
    matrix, shift = np.array([[1.1, 0.2], [-0.15, 0.95]]), np.array([2.3, -1.7])
    with glmls.MLS(p, p @ matrix + shift, transform="affine", ctx=gl) as m:
        out = m.warp(img, method="paper-quads", interpolation="linear", border=border)
    u = img.astype(np.float64)  # the output pixels (x, y)
    s = (u - shift) @ np.linalg.inv(matrix)
    inside = ((s >= 0) & (s <= [width - 1, height - 1])).all(axis=-1)
    assert inside.sum() > 1500
    assert np.abs(out - s)[inside].max() < 1e-3


def test_paper_quads_options(gl):
    img = np.zeros((10, 12), np.uint8)
    with glmls.MLS([[2.0, 2.0]], [[3.0, 2.0]], ctx=gl) as m:
        with pytest.raises(ValueError, match="grid must be 1"):
            m.warp(img, method="paper-quads", grid=2)
        assert m.warp(img, method="paper-quads", grid=1).shape == img.shape
    with pytest.raises(ValueError, match="grid must be 1"):
        glmls.warp(img, [[2.0, 2.0]], [[3.0, 2.0]], method="paper-quads", grid=4, ctx=gl)


def test_paper_quads_need_a_viewport_of_the_output_size(gl):
    pipe = glmls.gl.WarpPipeline.of(gl)
    img = np.zeros((10, 12, 4), np.uint8)
    with gl, glmls.MLS([[2.0, 2.0]], [[3.0, 2.0]], ctx=gl) as m:
        source = pipe.upload(glmls.imaging.source.prepare_image(img, 64, normalized=True), "t")
        target = gl.mgl.texture((24, 20), 4, dtype="f1")
        bound = gl.mgl.fbo or gl.mgl.detect_framebuffer(0)
        framebuffer = gl.mgl.framebuffer(color_attachments=[target])
        try:
            framebuffer.viewport = (0, 0, 24, 20)
            with pytest.raises(ValueError, match="viewport"):
                pipe.render(m, source, framebuffer, method="paper-quads")
        finally:
            bound.use()
            framebuffer.release()
            target.release()


@pytest.mark.parametrize("shape", [(1, 9), (9, 1), (1, 1)])
def test_an_image_without_squares_is_refused(gl, shape):
    """One row or column holds no square of four pixel centres: with the constant border
    every pixel would keep the background, so it is refused; a border mode's margin adds the
    squares past the image, and the identity comes back."""
    image = np.arange(shape[0] * shape[1], dtype=np.uint8).reshape(shape) + 1
    none = np.zeros((0, 2))
    pixels = "pixel" if shape[1] == 1 else "pixels"
    wide = f"image {shape[1]} {pixels} wide and {shape[0]} high has none"
    with pytest.raises(ValueError, match=wide):
        glmls.warp(image, none, none, method="paper-quads", ctx=gl)
    out = glmls.warp(image, none, none, method="paper-quads", border="edge", ctx=gl)
    np.testing.assert_array_equal(out, image)
