"""The backward method's Newton runs in two passes (``volume/newton.comp.glsl``): the first
evaluates f once per voxel and lists those not yet within the tolerance; the second, sized by
the first, finishes them, walking its list with a stride where the list holds more work
groups than a dispatch takes."""

from __future__ import annotations

import numpy as np
import pytest

import glmls
from glmls.gl.context import GLContext
from glmls.volume import volume_coordinate_map


def _folding_handles(shape):
    rng = np.random.default_rng(4)
    extent = np.array(shape[::-1], np.float64)
    src = rng.uniform(0, 1, (12, 3)) * (extent - 1)
    dst = src + rng.normal(0, 0.12 * extent.min(), src.shape)
    return src, dst


@pytest.mark.parametrize("grid", [1, 2])
def test_the_second_pass_walks_every_listed_voxel_with_few_work_groups(gl, monkeypatch, grid):
    shape = (14, 18, 22)
    src, dst = _folding_handles(shape)
    with glmls.MLS(src, dst, transform="rigid", shape=shape) as m:
        points, residual, covered = volume_coordinate_map(m, shape, grid=grid)
        limits = GLContext.limits.fget(gl)
        few = dict(limits, max_work_groups_x=2)  # 128 invocations walk the whole list
        monkeypatch.setattr(GLContext, "limits", property(lambda self: few))
        capped = volume_coordinate_map(m, shape, grid=grid)
    # most voxels need more than the first pass's evaluation: the list is far longer
    # than the 128 invocations of a dispatch of two work groups
    assert covered.sum() > 1000
    np.testing.assert_array_equal(capped[0], points)
    np.testing.assert_array_equal(capped[1], residual)
    np.testing.assert_array_equal(capped[2], covered)
