"""A batch whose cells are magnified past what one shader invocation may walk on a driver
that caps an invocation's loop iterations (Mesa's llvmpipe: 65,535 over all its loops): every
output pixel is drawn, the pixel the exact map gives (glmls/shaders/common/pieces.glsl)."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import coordinate_image
from numpy.testing import assert_allclose, assert_array_equal

import glmls

SCALE = 100.0  # a 4 px cell covers 400 x 400 output pixels
OUT = (380, 380)
ORIGIN = (SCALE * 4 + 10.3, SCALE * 4 + 10.3)  # pixel centres off the source's boundaries


def handles():
    """f(v) = 100 v, and the same mirrored in x (every cell reversed, the same box)."""
    p = np.array([[0, 0], [15, 0], [0, 15], [15, 15.0]])
    mirrored = p * SCALE
    mirrored[:, 0] = 15 * SCALE - mirrored[:, 0]
    return np.stack([p, p]), np.stack([p * SCALE, mirrored])


def source_points():
    """The exact source point (x, y) of every output pixel under both maps, (2, H, W, 2)."""
    yy, xx = np.mgrid[0 : OUT[0], 0 : OUT[1]].astype(float)
    x, y = (xx + ORIGIN[0]) / SCALE, (yy + ORIGIN[1]) / SCALE
    return np.stack([np.dstack([x, y]), np.dstack([15 - x, y])])


@pytest.mark.parametrize(
    ("dtype", "interpolation"),
    [(np.uint8, "nearest"), (np.uint16, "nearest"), (np.float32, "linear")],
)
def test_a_batch_with_cells_larger_than_the_loop_limit_is_drawn_whole(gl, dtype, interpolation):
    src, dst = handles()
    images = np.stack([coordinate_image(16, 16).astype(dtype)] * 2)
    out = glmls.warp_batch(
        images,
        src,
        dst,
        transform="affine",
        grid=4,
        output_shape=OUT,
        origin=ORIGIN,
        background=255,
        interpolation=interpolation,
        ctx=gl,
    )
    s = source_points()
    if interpolation == "nearest":
        assert_array_equal(out[..., :2], np.rint(s).astype(dtype))
    else:
        assert_allclose(out[..., :2], s, atol=2e-3)


def test_a_batch_with_cells_larger_than_the_loop_limit_maps_every_pixel(gl):
    """The batch's maps (return_maps) come from the scan of the mesh too."""
    src, dst = handles()
    images = np.stack([coordinate_image(16, 16).astype(np.uint8)] * 2)
    result = glmls.warp_batch(
        images,
        src,
        dst,
        transform="affine",
        grid=4,
        output_shape=OUT,
        origin=ORIGIN,
        return_maps=True,
        ctx=gl,
    )
    assert_allclose(np.stack(result.maps), source_points(), atol=2e-3)
