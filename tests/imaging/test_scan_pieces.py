"""Walking primitives in pieces changes no pixel: a context whose scan conversions walk at
most 40 pixels an invocation (``GLContext.piece_pixels``; on llvmpipe the bound is what
keeps each invocation within the driver's loop limit, glmls/shaders/common/pieces.glsl)
draws every path bit for bit as the shared context does, folds included: the fast quads
and their keyed redraw, the keyed and resolve paths, the adaptive mesh's passes (its
fold-listing pass lists a triangle of several pieces whole), paper-quads, batches and the
volume cells method. It runs on every driver (GPU drivers otherwise never walk pieces)."""

from __future__ import annotations

import moderngl
import numpy as np
import pytest
from helpers import coordinate_image, folded_case
from numpy.testing import assert_array_equal

import glmls
from glmls.gl.context import GLContext

PIECE = 40  # pixels an invocation walks at most: a 4 px cell scaled 2x is in pieces


@pytest.fixture(scope="module")
def pieced():
    """A context of its own whose scans walk pieces of at most PIECE pixels."""
    mgl = moderngl.create_context(standalone=True, backend="egl", require=430)
    ctx = GLContext(mgl, owned=True)
    ctx.piece_pixels = PIECE
    yield ctx
    ctx.release()


def both(gl, pieced, run):
    """``run(ctx)`` on the shared context and on the pieced one."""
    return run(gl), run(pieced)


def folded_scaled(scale=3.0):
    """folded_case's handles, its map scaled (similarity MLS scales with q)."""
    shape, p, q = folded_case()
    return shape, p, q * scale


@pytest.mark.parametrize(
    ("dtype", "options"),
    [
        (np.uint8, {"grid": 4}),  # fused fast, the keyed redraw near the folds
        (np.uint8, {"grid": 1}),
        (np.uint16, {"grid": 4}),  # nearest, the resolve draw
        (np.float32, {"grid": 4, "interpolation": "linear"}),
        (np.uint8, {"tolerance": 0.05}),  # the adaptive mesh
        (np.float32, {"tolerance": 0.05, "interpolation": "linear"}),
        (np.uint16, {"method": "paper-quads"}),
        (np.float32, {"method": "paper-quads", "interpolation": "linear"}),
    ],
)
def test_pieces_change_no_pixel(gl, pieced, dtype, options):
    shape, p, q = folded_scaled()
    img = coordinate_image(*shape).astype(dtype)

    def run(ctx):
        with glmls.MLS(p, q, transform="similarity", ctx=ctx) as m:
            b = m.bounds(shape)
            return m.warp(
                img, output_shape=b.output_shape, origin=b.origin, background=255, **options
            )

    whole, pieces = both(gl, pieced, run)
    assert (whole[..., 0] != 255).mean() > 0.5
    assert_array_equal(pieces, whole)


def test_pieces_change_no_pixel_of_a_mirrored_mesh(gl, pieced):
    """Every cell reversed: the fast quads' keyed pass redraws every cell."""
    shape, p, q = folded_scaled()
    q[:, 0] = -q[:, 0]
    img = coordinate_image(*shape).astype(np.uint8)

    def run(ctx):
        with glmls.MLS(p, q, transform="similarity", ctx=ctx) as m:
            b = m.bounds(shape)
            return m.warp(img, grid=4, output_shape=b.output_shape, origin=b.origin)

    whole, pieces = both(gl, pieced, run)
    assert_array_equal(pieces, whole)


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
def test_pieces_change_no_pixel_of_a_batch(gl, pieced, dtype):
    shape, p, q = folded_scaled(2.0)
    smooth = p + np.array([1.0, -1.0]) * 2.0
    images = np.stack([coordinate_image(*shape).astype(dtype)] * 2)
    src, dst = np.stack([p, p]), np.stack([q, smooth * 2.0])

    def run(ctx):
        return glmls.warp_batch(
            images, src, dst, transform="similarity", grid=4, output_shape=(100, 110), ctx=ctx
        )

    whole, pieces = both(gl, pieced, run)
    assert_array_equal(pieces, whole)


@pytest.mark.parametrize("interpolation", ["nearest", "linear"])
def test_pieces_change_no_voxel(gl, pieced, rng, interpolation):
    shape = (6, 7, 8)
    volume = rng.random(shape).astype(np.float32)
    corners = np.array([[x, y, z] for x in (0, 7) for y in (0, 6) for z in (0, 5)], float)
    moved = corners * 3.0 + rng.uniform(-1.0, 1.0, corners.shape)

    def run(ctx):
        with glmls.MLS(corners, moved, ctx=ctx) as m:
            return m.warp(volume, output_shape=(18, 21, 24), interpolation=interpolation)

    whole, pieces = both(gl, pieced, run)
    assert np.isfinite(whole).all()
    assert_array_equal(pieces, whole)
