"""A 3D MLS's bounds and coordinate_map are the volume construction's, through the facade."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_array_equal

import glmls
from glmls.volume import volume_bounds, volume_coordinate_map


def handles():
    rng = np.random.default_rng(5)
    src = rng.uniform(0, 15, (6, 3))
    return src, src + rng.uniform(-1.5, 1.5, (6, 3))


def test_bounds_and_coordinate_map_delegate(gl):
    src, dst = handles()
    with glmls.MLS(src, dst, ctx=gl) as m:
        b = m.bounds((10, 12, 14), grid=2, spacing=(1.0, 1.0, 1.5))
        assert b == volume_bounds(m, (10, 12, 14), grid=2, spacing=(1.0, 1.0, 1.5))
        points, residual, covered = m.coordinate_map((6, 7, 8), grid=2)
        expected = volume_coordinate_map(m, (6, 7, 8), grid=2)
    assert_array_equal(points, expected[0])
    assert_array_equal(residual, expected[1])
    assert_array_equal(covered, expected[2])
    assert points.shape == (6, 7, 8, 3)


def test_translation_bounds_hold_the_moved_volume(gl):
    src = np.array([[0.0, 0, 0], [9, 0, 0], [0, 9, 0], [0, 0, 9]])
    with glmls.MLS(src, src + [2, -1, 3], ctx=gl) as m:
        b = m.bounds((5, 6, 7))
    assert b.output_shape == (5, 6, 7)
    assert b.origin == (2.0, -1.0, 3.0)


def test_glmls_warp_takes_a_volume_by_3d_handles(gl):
    """glmls.warp with (N, 3) handles is the 3D MLS of the volume's shape and spacing and its
    warp, bit for bit, for both methods; its errors name what is wrong."""
    src, dst = handles()
    rng = np.random.default_rng(6)
    volume = rng.integers(0, 255, (8, 12, 16), dtype=np.uint8)
    spacing = (1.5, 1.0, 0.75)
    options = {"weight": "gaussian", "transform": "similarity"}
    for method, interpolation in (("quads", "nearest"), ("backward", "linear")):
        got = glmls.warp(
            volume,
            src,
            dst,
            method=method,
            interpolation=interpolation,
            spacing=spacing,
            ctx=gl,
            **options,
        )
        with glmls.MLS(src, dst, shape=volume.shape, spacing=spacing, ctx=gl, **options) as m:
            expected = m.warp(volume, method=method, interpolation=interpolation)
        assert_array_equal(got, expected)
    with pytest.raises(TypeError, match="methd"):
        glmls.warp(volume, src, dst, methd="quads", ctx=gl)
    with pytest.raises(ValueError, match="splat"):
        glmls.warp(volume, src, dst, method="splat", ctx=gl)
    with pytest.raises(ValueError, match="2D image"):
        glmls.warp(volume[0], src, dst, ctx=gl)
    with pytest.raises(TypeError, match="spacing"):  # an image's warp has no spacing
        glmls.warp(volume[0], src[:, :2], dst[:, :2], spacing=spacing, ctx=gl)


@pytest.mark.parametrize("keywords", [{"transfrm": "affine"}, {"methd": "quads", "radus": 3.0}])
def test_glmls_warp_names_an_unknown_keyword_of_a_volume_as_of_an_image(gl, keywords):
    """Neither the MLS's keywords nor the warp's: named as the image warp names them, not as
    an unknown warp option beside a list of the warp's alone (which lacks ``transform``)."""
    src, _ = handles()
    volume = np.zeros((4, 5, 6), np.uint8)
    names = ", ".join(sorted(keywords))
    for image, points in ((volume, src), (volume[0], src[:, :2])):
        with pytest.raises(TypeError) as error:
            glmls.warp(image, points, points, ctx=gl, **keywords)
        assert str(error.value) == (
            f"warp() got {'unknown keywords' if len(keywords) > 1 else 'an unknown keyword'} "
            f"{names}"
        )
