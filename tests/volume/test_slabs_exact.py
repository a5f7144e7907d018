"""Slabs are invisible to the last bit: trilinear float32 volumes cut into slabs (and the
lattice into bands, the source into ranges of slices) equal the one-piece result exactly,
for both methods, every border, on a canvas whose origin float32 does not hold exactly (each
slab computes its voxels' places from the canvas's origin, not from its own)."""

from __future__ import annotations

import numpy as np
import pytest

import glmls
from glmls.volume import SlabOptions

SHAPE = (11, 9, 13)
SMALL = SlabOptions(slab_bytes=3000, band_bytes=40000)
# the source 7 slices at a time (of 11; 9 x 13 x 3 float32 voxels a slice)
SLICED = SlabOptions(slab_bytes=2000, band_bytes=40000, texture_bytes=7 * 9 * 13 * 3 * 4)
# a band of one cell layer where the backward method holds f's inverse Jacobians (grid 2)
NARROW = SlabOptions(slab_bytes=3000, band_bytes=12000)


@pytest.mark.parametrize("method", ["quads", "backward"])
@pytest.mark.parametrize("grid", [1, 2, 5])
@pytest.mark.parametrize(
    "canvas", [{}, {"output_shape": (7, 12, 10), "origin": (-2.5, 1.1, 3.3)}], ids=["", "canvas"]
)
def test_slabbed_linear_warps_equal_the_whole(gl, rng, method, grid, canvas):
    src = rng.uniform(0, 12, (7, 3))
    dst = src + rng.normal(0, 1.5, src.shape)
    volume = rng.normal(0, 1, (*SHAPE, 3)).astype(np.float32)
    with glmls.MLS(src, dst, transform="rigid", shape=SHAPE) as m:
        for border in glmls.BORDERS:
            options = dict(method=method, interpolation="linear", border=border, grid=grid)
            whole = m.warp(volume, **options, **canvas)
            cuts = (SMALL, SLICED)
            for slabs in (*cuts, NARROW) if grid == 2 else cuts:
                cut = m.warp(volume, **options, **canvas, slabs=slabs)
                np.testing.assert_array_equal(cut, whole, err_msg=f"{border} {slabs}")
