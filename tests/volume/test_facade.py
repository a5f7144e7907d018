"""A 3D MLS's bounds and coordinate_map are the volume construction's, through the facade."""

from __future__ import annotations

import numpy as np
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
