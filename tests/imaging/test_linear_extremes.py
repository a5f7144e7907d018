"""Linear interpolation of float images whose neighbouring values differ by more than
float32's range (+-2e38 side by side): every blend lies between its inputs, none is NaN."""

from __future__ import annotations

import numpy as np
import pytest

import glmls

BIG = np.float32(2e38)


def _columns(shape: tuple[int, ...]) -> np.ndarray:
    """+2e38 and -2e38 in alternate columns (the last axis)."""
    image = np.full(shape, BIG, np.float32)
    image[..., 1::2] = -BIG
    return image


@pytest.mark.parametrize("method", ["quads", "backward"])
def test_a_half_pixel_shift_of_opposite_extremes_blends_to_zero(gl, method):
    image = _columns((8, 8))
    with glmls.MLS([[0.0, 0.0]], [[0.5, 0.0]], shape=image.shape) as m:
        out = m.warp(image, method=method, interpolation="linear", border="edge")
    assert np.isfinite(out).all()
    assert np.abs(out).max() <= BIG
    # halfway between +2e38 and -2e38, away from the clamped first column
    assert np.abs(out[:, 1:]).max() <= 1e33


def test_a_half_voxel_shift_of_opposite_extremes_blends_to_zero(gl):
    volume = _columns((4, 5, 6))
    corners = np.array([[x, y, z] for x in (0, 5) for y in (0, 4) for z in (0, 3)], float)
    out = glmls.warp(
        volume,
        corners,
        corners + [0.5, 0.0, 0.0],
        transform="affine",
        method="backward",
        interpolation="linear",
        border="edge",
    )
    assert np.isfinite(out).all()
    assert np.abs(out[..., 1:]).max() <= 1e33
