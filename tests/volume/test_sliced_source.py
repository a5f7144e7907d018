"""A source volume held a few slices at a time (larger than ``texture_bytes``) gives the
one-piece result exactly, whatever range of source slices an output slab samples: a
rotation by 90 degrees about x makes every output slice read every source slice, and
``wrap`` joins the last slice to the first."""

from __future__ import annotations

import numpy as np
import pytest

import glmls
from glmls.volume import SlabOptions
from glmls.volume.texture import border_runs

SHAPE = (12, 10, 9)  # D, H, W: cubes of y and z swapped by the rotation below


def _rotation_about_x(rng, shape):
    """Handles whose rigid MLS is the rotation by 90 degrees about the x axis through the
    volume's centre: (x, y, z) -> (x, c - (z - c), c + (y - c)) with c the centre of y
    and z (their voxel centres go to voxel centres)."""
    d, h, w = shape
    src = rng.uniform(0, 1, (8, 3)) * [w - 1, h - 1, d - 1]
    cy, cz = (h - 1) / 2, (d - 1) / 2
    dst = np.column_stack([src[:, 0], cy - (src[:, 2] - cz), cz + (src[:, 1] - cy)])
    return src, dst


def _slice_bytes(volume: np.ndarray) -> int:
    _, h, w = volume.shape[:3]
    channels = volume.shape[3] if volume.ndim == 4 else 1
    return h * w * channels * volume.dtype.itemsize


@pytest.mark.parametrize("method", ["quads", "backward"])
@pytest.mark.parametrize("border", glmls.BORDERS)
def test_rotated_volume_from_a_sliced_source_equals_the_whole(gl, rng, method, border):
    volume = rng.normal(0, 1, (*SHAPE, 2)).astype(np.float32)
    volume8 = rng.integers(0, 256, SHAPE, dtype=np.uint8)
    src, dst = _rotation_about_x(rng, SHAPE)
    canvas = {"output_shape": (14, 12, 9), "origin": (0.0, -1.0, -1.0)}  # past every side
    with glmls.MLS(src, dst, transform="rigid", shape=SHAPE) as m:
        for grid in (1, 2):
            options = dict(method=method, border=border, grid=grid, **canvas)
            whole = m.warp(volume, interpolation="linear", **options)
            whole8 = m.warp(volume8, **options)
            for held in (4, 7):  # slices one texture holds (4: the fewest it takes)
                slabs = SlabOptions(slab_bytes=4096, texture_bytes=held * _slice_bytes(volume))
                cut = m.warp(volume, interpolation="linear", slabs=slabs, **options)
                np.testing.assert_array_equal(cut, whole, err_msg=f"grid {grid}, {held}")
                slabs = SlabOptions(slab_bytes=4096, texture_bytes=held * _slice_bytes(volume8))
                cut8 = m.warp(volume8, slabs=slabs, **options)
                np.testing.assert_array_equal(cut8, whole8, err_msg=f"grid {grid}, {held}")


def test_rotation_from_a_sliced_source_is_the_rotation(gl, rng):
    """Nearest sampling of the rotation by 90 degrees: the voxels permuted exactly (the
    float64 reference: output voxel (k, j, i) shows source voxel (z, y) = rotated back)."""
    volume = rng.integers(0, 65536, SHAPE, dtype=np.uint16)
    src, dst = _rotation_about_x(rng, SHAPE)
    d, h, _ = SHAPE
    cy, cz = (h - 1) / 2, (d - 1) / 2
    k, j, i = np.meshgrid(*(np.arange(n) for n in SHAPE), indexing="ij")
    y = np.rint(cy + (k - cz)).astype(int)
    z = np.rint(cz - (j - cy)).astype(int)
    inside = (y >= 0) & (y < h) & (z >= 0) & (z < d)
    expected = np.where(inside, volume[np.clip(z, 0, d - 1), np.clip(y, 0, h - 1), i], 0)
    slabs = SlabOptions(slab_bytes=4096, texture_bytes=4 * _slice_bytes(volume))
    with glmls.MLS(src, dst, transform="rigid", shape=SHAPE) as m:
        for method in ("quads", "backward"):
            out = m.warp(volume, method=method, slabs=slabs)
            np.testing.assert_array_equal(out, expected, err_msg=method)


def test_too_small_a_texture_is_named(gl, rng):
    volume = rng.integers(0, 256, SHAPE, dtype=np.uint8)
    src, dst = _rotation_about_x(rng, SHAPE)
    slabs = SlabOptions(texture_bytes=2 * _slice_bytes(volume))
    with glmls.MLS(src, dst, shape=SHAPE) as m:
        for method in ("quads", "backward"):
            with pytest.raises(ValueError, match="texture_bytes"):
                m.warp(volume, method=method, slabs=slabs)


@pytest.mark.parametrize(
    ("low", "high", "border", "runs"),
    [
        (-1, 3, "edge", [(0, 3)]),
        (-(10**9), 10**9, "edge", [(0, 9)]),  # clamped without listing the indices
        (-2, 1, "symmetric", [(0, 1)]),
        (-2, 1, "reflect", [(0, 2)]),
        (-1, 1, "wrap", [(0, 1), (9, 9)]),
        (8, 11, "wrap", [(0, 1), (8, 9)]),
        (3, 5, "wrap", [(3, 5)]),
        (-5, 5, "wrap", [(0, 9)]),
    ],
)
def test_border_runs(low, high, border, runs):
    assert border_runs(low, high, 10, border) == runs
