"""glmls.warp_batch refuses what one glmls.warp refuses, for every method and path, naming
the image: a source point with two different targets, affine handles on one line."""

from __future__ import annotations

import numpy as np
import pytest

import glmls


def batch():
    images = np.zeros((3, 10, 12), np.uint8)
    src = np.tile([[1.0, 1.0], [8.0, 2.0], [3.0, 7.0]], (3, 1, 1))
    return images, src, src + 0.5


@pytest.mark.parametrize("method", glmls.METHODS)
@pytest.mark.parametrize("given", ["array", "ragged"])
def test_a_source_point_with_two_targets_names_its_image(gl, method, given):
    images, src, dst = batch()
    src[2, 1] = src[2, 0]
    if given == "ragged":
        src, dst = list(src), list(dst)
        src[0], dst[0] = src[0][:2], dst[0][:2]
    with pytest.raises(ValueError, match=r"^images\[2\]: src\[0\] and src\[1\] are the same point"):
        glmls.warp_batch(images, src, dst, method=method)
    with pytest.raises(ValueError, match=r"src\[0\] and src\[1\] are the same point"):
        glmls.warp(images[2], src[2], dst[2], method=method)


@pytest.mark.parametrize("method", glmls.METHODS)
def test_exact_duplicate_handles_warp_as_one_warp_does(gl, method):
    images, src, dst = batch()
    src[1, 1], dst[1, 1] = src[1, 0], dst[1, 0]  # the same pair twice: accepted
    out = glmls.warp_batch(images, src, dst, method=method)
    single = [glmls.warp(i, p, q, method=method) for i, p, q in zip(images, src, dst, strict=True)]
    np.testing.assert_array_equal(out, single)


@pytest.mark.parametrize("method", ["quads", "backward", "splat"])
def test_affine_handles_on_a_line_name_their_image(gl, method):
    images, src, dst = batch()
    src[1] = [[1.0, 1.0], [2.0, 2.0], [4.0, 4.0]]
    with pytest.raises(glmls.DegenerateHandlesError, match=r"^images\[1\]: affine MLS needs"):
        glmls.warp_batch(images, src, dst, method=method, transform="affine")
