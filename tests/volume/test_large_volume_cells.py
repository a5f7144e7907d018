"""A volume cell magnified past what one shader invocation may walk on a driver that caps an
invocation's loop iterations (Mesa's llvmpipe: 65,535 over all its loops): the cells method
walks it in pieces (glmls/shaders/common/pieces.glsl) and every output voxel it covers shows
the exact map's source point."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

import glmls

SCALE = 40.0  # a 1-voxel cell covers 40^3 output voxels
OUT = (40, 40, 40)  # (D, H, W), inside one cell
ORIGIN = (SCALE * 2.5 + 0.3,) * 3  # x, y, z


@pytest.mark.parametrize("interpolation", ["nearest", "linear"])
def test_a_cell_larger_than_the_loop_limit_is_drawn_whole(gl, interpolation):
    corners = np.array([[x, y, z] for x in (0, 7) for y in (0, 7) for z in (0, 7)], float)
    zz, yy, xx = np.mgrid[0:8, 0:8, 0:8]
    volume = np.stack([xx, yy, zz], axis=-1).astype(np.float32)  # each voxel's (x, y, z)
    with glmls.MLS(corners, corners * SCALE, transform="affine", ctx=gl) as m:
        out = m.warp(
            volume,
            output_shape=OUT,
            origin=ORIGIN,
            background=-1.0,
            interpolation=interpolation,
        )
    zz, yy, xx = np.mgrid[0 : OUT[0], 0 : OUT[1], 0 : OUT[2]].astype(float)
    s = np.stack([xx + ORIGIN[0], yy + ORIGIN[1], zz + ORIGIN[2]], axis=-1) / SCALE
    expected = np.rint(s) if interpolation == "nearest" else s
    assert_allclose(out, expected, atol=2e-3)
