"""Slices wider or taller than a texture's side are built in boxes of columns and rows, from a
source held a box at a time, and give the one-piece result exactly: ``texture_side`` cuts
small volumes as ``GL_MAX_3D_TEXTURE_SIZE`` cuts large ones, and a volume 2100 voxels wide
(past llvmpipe's 2048) is warped as numpy shifts it."""

from __future__ import annotations

import numpy as np
import pytest

import glmls
from glmls.volume import SlabOptions

SHAPE = (6, 40, 50)  # D, H, W


def _handles(rng, shape):
    """A quarter turn about z through the volume's centre, bent by a few voxels: each output
    row samples a column of the source, and no two voxels sample alike."""
    d, h, w = shape
    src = rng.uniform(0, 1, (10, 3)) * [w - 1, h - 1, d - 1]
    cx, cy = (w - 1) / 2, (h - 1) / 2
    dst = np.column_stack([cx - (src[:, 1] - cy), cy + (src[:, 0] - cx), src[:, 2]])
    return src, dst + rng.normal(0, 1.5, dst.shape)


def _cuts(volume):
    """A box of 6 columns and rows (a cell of grid 2 and its neighbours), and boxes of 17
    with the source held 4 slices at a time and slabs of a few slices (on the canvas, whose
    wide margins make boxes of 6 slow)."""
    voxel = volume.dtype.itemsize * (volume.shape[3] if volume.ndim == 4 else 1)
    yield SlabOptions(texture_side=6)
    yield SlabOptions(texture_side=17, slab_bytes=4096, texture_bytes=4 * 17 * 17 * voxel)


def _volumes(rng):
    yield rng.integers(0, 256, SHAPE, dtype=np.uint8)
    yield rng.normal(0, 1, (*SHAPE, 3)).astype(np.float32)


@pytest.mark.parametrize("method", ["quads", "backward"])
@pytest.mark.parametrize("border", ["constant", "wrap", "symmetric"])
def test_tiled_warps_equal_the_whole(gl, rng, method, border):
    src, dst = _handles(rng, SHAPE)
    canvas = {"output_shape": (7, 45, 47), "origin": (-3.0, -2.5, -0.5)}  # past every side
    with glmls.MLS(src, dst, transform="rigid", shape=SHAPE) as m:
        for volume in _volumes(rng):
            for interpolation in ("nearest", "linear"):
                options = dict(method=method, border=border, interpolation=interpolation)
                for extra in ({}, canvas):
                    whole = m.warp(volume, **options, **extra)
                    for slabs in list(_cuts(volume))[1 if extra else 0 :]:
                        cut = m.warp(volume, **options, **extra, slabs=slabs)
                        message = f"{volume.dtype} {interpolation} {extra} {slabs}"
                        np.testing.assert_array_equal(cut, whole, err_msg=message)


def test_a_texture_side_too_small_for_a_cell_is_named(gl, rng):
    volume = rng.integers(0, 256, SHAPE, dtype=np.uint8)
    src, dst = _handles(rng, SHAPE)
    with glmls.MLS(src, dst, transform="rigid", shape=SHAPE) as m:
        slabs = SlabOptions(texture_side=4)  # a cell of grid 3 samples 5 columns
        with pytest.raises(ValueError, match=r"samples 5 source columns.*texture_side"):
            m.warp(volume, method="quads", grid=3, slabs=slabs)
        out = m.warp(volume, method="backward", slabs=slabs)  # 4: a voxel's 4 at most
        np.testing.assert_array_equal(out, m.warp(volume, method="backward"))


def test_texture_side_is_an_integer_of_at_least_4():
    assert SlabOptions(texture_side=np.int64(4)).texture_side == 4
    with pytest.raises(ValueError, match="texture_side must be an integer >= 4, got 3"):
        SlabOptions(texture_side=3)
    with pytest.raises(TypeError, match="texture_side"):
        SlabOptions(texture_side=8.0)


@pytest.mark.parametrize("method", ["quads", "backward"])
def test_a_volume_wider_than_the_gl_limit_is_shifted_exactly(gl, rng, method):
    """Past ``GL_MAX_3D_TEXTURE_SIZE`` (2048 on llvmpipe) along x: a shift by whole voxels
    copies them (numpy's reference), and a warp that moves every voxel differently is the
    same in boxes of any side."""
    shape = (2, 3, 2100)
    volume = rng.integers(1, 256, shape, dtype=np.uint8)
    d, h, w = shape
    src = np.array([[x, y, z] for z in (0, d - 1) for y in (0, h - 1) for x in (0, w - 1)], float)
    with glmls.MLS(src, src + [3.0, 0, 0], transform="rigid", shape=shape) as m:
        for interpolation in ("nearest", "linear"):
            out = m.warp(volume, method=method, interpolation=interpolation)
            expected = np.zeros_like(volume)
            expected[..., 3:] = volume[..., :-3]
            np.testing.assert_array_equal(out, expected, err_msg=interpolation)
            out = m.warp(volume, method=method, interpolation=interpolation, border="wrap")
            np.testing.assert_array_equal(out, np.roll(volume, 3, axis=2), err_msg=interpolation)
    bent = src + rng.normal(0, 2.0, src.shape)
    with glmls.MLS(src, bent, transform="affine", shape=shape) as m:
        out = m.warp(volume, method=method, interpolation="linear", border="reflect")
        cut = m.warp(
            volume,
            method=method,
            interpolation="linear",
            border="reflect",
            slabs=SlabOptions(texture_side=700),
        )
        np.testing.assert_array_equal(cut, out)
