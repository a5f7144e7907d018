"""Segment handles where float32 used to fail: points on a segment's line beyond its ends,
a short segment seen from far away, and points on a lone segment; f on the GPU against the
float64 reference (glmls.reference)."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

import glmls
from glmls import reference

NONE = np.zeros((0, 2))


def gpu_and_reference(src, dst, ss, ds, points, **options):
    with glmls.MLS(src, dst, src_segments=ss, dst_segments=ds, **options) as m:
        f, (M, _) = m(points), m.matrices(points)
        config, shape = m.config, m.shape
    f_ref, M_ref, _ = reference.mls(
        src, dst, points, config, shape=shape, src_segments=ss, dst_segments=ds
    )
    return f, f_ref, M, M_ref


@pytest.mark.parametrize("transform", ["rigid", "similarity", "affine"])
@pytest.mark.parametrize("weight", ["idw", "gaussian"])
def test_points_on_a_segments_line_beyond_its_ends(gl, transform, weight):
    # idw's closed form took J0 = 0 there (h = 0, s negligible): f missed by up to 20 px
    # along the whole row of pixels through a horizontal segment (and column: vertical)
    src = np.array([[5.0, 5], [35, 5], [20, 35]])
    dst = src + [[1, 1], [0, 2], [-1, 0]]
    ss = np.array([[[10.0, 20], [30, 20]], [[20, 2], [20, 12]]])
    ds = np.array([[[10.0, 22], [30, 21]], [[21, 2], [20, 13]]])
    line = np.arange(40.0)
    points = np.r_[np.c_[line, np.full(40, 20.0)], np.c_[np.full(40, 20.0), line]]
    f, f_ref, _, _ = gpu_and_reference(
        src, dst, ss, ds, points, transform=transform, weight=weight, radius=30
    )
    assert_allclose(f, f_ref, atol=1e-4)


@pytest.mark.parametrize("transform", ["rigid", "similarity"])
@pytest.mark.parametrize("length", [5.0, 0.2])
def test_a_lone_short_segment_far_away(gl, transform, length):
    # J2 about the segment's nearest point came from J2 - 2 xc J1 + xc^2 J0, which cancels
    # to ~L^3 / xc^2: the rotation a lone segment defines was lost (f off by 100-250 px)
    c = 500.0
    ss = np.array([[[c, c], [c + length, c]]])
    ds = ss + np.array([[0, 1], [0.3 * length, 0.2 * length + 1]])
    points = np.random.default_rng(1).uniform(0, 1000, (200, 2))
    f, f_ref, _, _ = gpu_and_reference(
        NONE, NONE, ss, ds, points, transform=transform, shape=(1000, 1000)
    )
    assert_allclose(f, f_ref, atol=1e-3)


@pytest.mark.parametrize("transform", ["rigid", "similarity"])
@pytest.mark.parametrize("length", [1.0, 0.01])
def test_points_on_a_lone_segment(gl, transform, length):
    # every handle within the snapping distance: the weights' normalisation was 3e38 and the
    # segment's J2 overflowed (NaN f and M for rigid)
    ss = np.array([[[0.0, 0], [length, 0]]])
    ds = np.array([[[0.0, 0], [length, length]]])
    points = np.array([[0.0, 0], [length / 2, 0], [length, 0], [3, 0], [1, 1], [20, 20]])
    f, f_ref, M, M_ref = gpu_and_reference(NONE, NONE, ss, ds, points, transform=transform)
    assert np.isfinite(f).all() and np.isfinite(M).all()
    assert_allclose(f, f_ref, atol=1e-4)
    assert_allclose(M, M_ref, atol=1e-4)
