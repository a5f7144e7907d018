"""Cells magnified past what one shader invocation may walk on a driver that caps an
invocation's loop iterations (Mesa's llvmpipe: 65,535 over all its loops): each is walked in
pieces (glmls/shaders/common/pieces.glsl) and every output pixel it covers is drawn, the pixel
the exact map gives. On GPU drivers the same tests run the scans as they are."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import coordinate_image, folded_case
from numpy.testing import assert_allclose, assert_array_equal

import glmls

SCALE = 100.0  # a 4 px cell covers 400 x 400 output pixels, a 1 px one 100 x 100
SHAPE = (16, 16)
OUT = (380, 380)  # all inside one 4 px cell (and past 65,535 pixels)


def magnified(mirror=False, scale=SCALE):
    """Handles of f(v) = scale v (x mirrored with ``mirror``: every cell reversed, the same
    box), and the origin of an output canvas inside one cell of 4 px (pixel centres off the
    source's pixel boundaries, so that nearest sampling has no ties)."""
    p = np.array([[0, 0], [15, 0], [0, 15], [15, 15.0]])
    q = p * scale
    if mirror:
        q[:, 0] = 15 * scale - q[:, 0]
    return p, q, (scale * 4 + 10.3, scale * 4 + 10.3)


def source_points(origin, mirror=False, scale=SCALE, shape=OUT):
    """The exact source point (x, y) of every output pixel, (H, W, 2)."""
    yy, xx = np.mgrid[0 : shape[0], 0 : shape[1]].astype(float)
    x = (xx + origin[0]) / scale
    return np.dstack([15 - x if mirror else x, (yy + origin[1]) / scale])


@pytest.mark.parametrize(
    ("path", "options", "dtype", "interpolation", "mirror"),
    [
        ("fused fast", {}, np.uint8, "nearest", False),
        ("fused fast", {}, np.uint8, "nearest", True),  # the keyed pass redraws every cell
        ("fused", {"fast_embedded": False}, np.uint8, "nearest", False),
        ("nearest", {}, np.uint16, "nearest", False),
        ("interpolated", {}, np.float32, "linear", False),
    ],
)
def test_a_cell_larger_than_the_loop_limit_is_drawn_whole(
    gl, pipeline, path, options, dtype, interpolation, mirror
):
    p, q, origin = magnified(mirror)
    img = coordinate_image(*SHAPE).astype(dtype)
    pipe = pipeline(**options)
    with glmls.MLS(p, q, transform="affine", ctx=gl) as m:
        out = pipe.warp(
            m,
            img,
            grid=4,
            output_shape=OUT,
            origin=origin,
            background=255,
            interpolation=interpolation,
        )
    assert pipe.cells.last_path == path
    s = source_points(origin, mirror)
    if interpolation == "nearest":
        assert_array_equal(out[..., :2], np.rint(s).astype(dtype))
    else:
        assert_allclose(out[..., :2], s, atol=2e-3)


@pytest.mark.parametrize(
    ("dtype", "interpolation"),
    [(np.uint8, "nearest"), (np.uint16, "nearest"), (np.float32, "linear")],
)
def test_adaptive_triangles_larger_than_the_loop_limit_are_drawn_whole(gl, dtype, interpolation):
    """The adaptive mesh's leaves (16 px at most) magnified 100x."""
    p = np.array([[0, 0], [63, 0], [0, 63], [63, 63.0]])
    origin = (SCALE * 20 + 10.3, SCALE * 20 + 10.3)
    img = coordinate_image(64, 64).astype(dtype)
    with glmls.MLS(p, p * SCALE, transform="affine", ctx=gl) as m:
        out = m.warp(
            img,
            tolerance=0.05,
            output_shape=OUT,
            origin=origin,
            background=255,
            interpolation=interpolation,
        )
    s = source_points(origin)
    if interpolation == "nearest":
        assert_array_equal(out[..., :2], np.rint(s).astype(dtype))
    else:
        assert_allclose(out[..., :2], s, atol=2e-3)


@pytest.mark.parametrize("interpolation", ["nearest", "linear"])
def test_paper_squares_larger_than_the_loop_limit_are_drawn_whole(gl, interpolation):
    """paper-quads' 1 px squares magnified 400x: each output pixel shows the square's
    nearest vertex (linear: its source point)."""
    scale = 400.0
    p, q, _ = magnified(scale=scale)
    origin = (scale * 4 + 10.3, scale * 4 + 10.3)
    dtype = np.uint16 if interpolation == "nearest" else np.float32
    img = coordinate_image(*SHAPE).astype(dtype)
    with glmls.MLS(p, q, transform="affine", ctx=gl) as m:
        out = m.warp(
            img,
            method="paper-quads",
            output_shape=OUT,
            origin=origin,
            background=255,
            interpolation=interpolation,
        )
    s = source_points(origin, scale=scale)
    if interpolation == "nearest":
        assert_array_equal(out[..., :2], np.rint(s).astype(dtype))
    else:  # float32's inversion of the square's bilinear map: 0.034 px at 50x as well
        assert_allclose(out[..., :2], s, atol=0.05)


def test_fast_quads_redraw_large_folded_cells_as_the_keyed_pass(gl, pipeline):
    """A fold magnified 100x (4 px cells of 400 x 400 output pixels): the fast pass's keyed
    redraw of the cells near it (warp/cells_hot.glsl), walked in pieces, shows what the
    keyed pass shows."""
    shape, p, q = folded_case()
    img = coordinate_image(*shape).astype(np.uint8)
    options = {"grid": 4, "output_shape": (500, 500), "origin": (3900.0, 1700.0), "background": 255}
    fast_pipe, keyed_pipe = pipeline(), pipeline(fast_embedded=False)
    with glmls.MLS(p, q * 100, transform="similarity", ctx=gl) as m:
        fast = fast_pipe.warp(m, img, **options)
        keyed = keyed_pipe.warp(m, img, **options)
    assert fast_pipe.cells.last_path == "fused fast"
    assert keyed_pipe.cells.last_path == "fused"
    bad, crossings = fast_pipe.cells.embedding_counts()
    assert bad > 0 and crossings == 1  # folds inside a simple boundary: only cells near them
    assert fast_pipe.cells.redrawn_cells() > 0
    assert_array_equal(fast, keyed)
    # the pixels that 1 px cells (100 x 100 output pixels, one piece each) cover, but for
    # the boundary's chords and the fold, which differ at grid 4
    with glmls.MLS(p, q * 100, transform="similarity", ctx=gl) as m:
        fine = keyed_pipe.warp(m, img, **(options | {"grid": 1}))
    missed = (keyed[..., 0] == 255) & (fine[..., 0] != 255)
    assert missed.mean() < 0.01, missed.mean()
