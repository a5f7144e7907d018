"""The backward volume warp against a construction that shares no code with glmls's: f from
the float64 reference, its inverse by Newton's method in float64 with a central-difference
Jacobian, and scipy.ndimage.map_coordinates sampling, for every border mode, nearest and
trilinear, on a small volume of three channels."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

import glmls
from glmls import reference

SHAPE = (12, 14, 16)
#: numpy.pad's border names as scipy.ndimage spells them; "constant" samples inside the
#: volume's box [-1/2, n - 1/2] as "edge" does (a voxel is a cube), the background beyond.
SCIPY_MODES = {
    "constant": "nearest",
    "edge": "nearest",
    "symmetric": "reflect",
    "reflect": "mirror",
    "wrap": "grid-wrap",
}
BACKGROUND = 7.0


def _handles():
    rng = np.random.default_rng(0)
    depth, height, width = SHAPE
    src = np.array(
        [[0, 0, 0], [width - 1, 0, 0], [0, height - 1, 0], [0, 0, depth - 1]]
        + [[width - 1, height - 1, depth - 1], [7, 6, 5], [3, 10, 8]],
        float,
    )
    return src, src + rng.normal(0, 0.8, src.shape)


@pytest.fixture(scope="module")
def preimages():
    """The handles, and s with f(s) = u at every voxel centre u ((x, y, z) rows in scan
    order), in float64."""
    src, dst = _handles()
    depth, height, width = SHAPE
    k, j, i = np.meshgrid(np.arange(depth), np.arange(height), np.arange(width), indexing="ij")
    u = np.stack([i, j, k], axis=-1).reshape(-1, 3).astype(np.float64)

    def f(v):
        return reference.mls(src, dst, v, shape=SHAPE, transform="rigid")[0]

    s = u.copy()
    for _ in range(20):
        residual = f(s) - u
        if np.abs(residual).max() < 1e-10:
            break
        jac = np.empty((len(s), 3, 3))
        for axis in range(3):
            step = np.zeros(3)
            step[axis] = 1e-5
            jac[:, axis] = (f(s + step) - f(s - step)) / 2e-5  # row vectors: df = ds J
        s -= np.linalg.solve(np.swapaxes(jac, 1, 2), residual[..., None])[..., 0]
    assert np.abs(f(s) - u).max() < 1e-9
    return src, dst, s


def _expected(volume, s, border, linear):
    coords = s[:, ::-1].T  # (z, y, x)
    if not linear:
        coords = np.floor(coords + 0.5)
    out = np.stack(
        [
            ndimage.map_coordinates(
                volume[..., c].astype(np.float64),
                coords,
                order=int(linear),
                mode=SCIPY_MODES[border],
            )
            for c in range(volume.shape[-1])
        ],
        axis=-1,
    )
    if border == "constant":
        top = np.array(SHAPE[::-1]) - 0.5
        out[((s < -0.5) | (s > top)).any(axis=1)] = BACKGROUND
    return out


@pytest.mark.parametrize("interpolation", ["nearest", "linear"])
def test_backward_warp_matches_an_independent_construction(gl, preimages, interpolation):
    src, dst, s = preimages
    rng = np.random.default_rng(1)
    volume = rng.integers(0, 200, (*SHAPE, 3)).astype(np.uint8)
    linear = interpolation == "linear"
    # voxels whose preimage lies within 0.01 of the volume's box or (nearest) of a rounding
    # tie: Newton's 1e-3 voxel may put them on either side
    top = np.array(SHAPE[::-1]) - 0.5
    ambiguous = (np.abs(s + 0.5) < 0.01).any(axis=1) | (np.abs(s - top) < 0.01).any(axis=1)
    if not linear:
        ambiguous |= (np.abs(s - np.floor(s) - 0.5) < 0.01).any(axis=1)
    assert ambiguous.mean() < 0.1
    with glmls.MLS(src, dst, shape=SHAPE, transform="rigid") as m:
        for border in glmls.BORDERS:
            out = m.warp(
                volume,
                method="backward",
                interpolation=interpolation,
                border=border,
                background=BACKGROUND,
            ).reshape(-1, 3)
            expected = np.round(_expected(volume, s, border, linear))
            error = np.abs(out - expected).max(axis=1)[~ambiguous]
            # one grey level: Newton's 1e-3 voxel and float32's trilinear weights
            assert error.max() <= (1.0 if linear else 0.0), border
