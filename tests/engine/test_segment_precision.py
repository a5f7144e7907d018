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


@pytest.mark.parametrize("transform", ["similarity", "rigid"])
def test_a_segment_that_decides_m_in_a_gaussians_tail_counts(gl, transform):
    """Three point handles and a segment, gaussian R = 50 px: at (300, 300) the nearest
    handle outweighs the segment by e^24 and the other points by e^44 and more, so the
    segment decides M. The segments' quadrature cut it where it weighed below e^-24 of the
    nearest (f 1.5 px off, the segment ignored); it counts down to float32's range now."""
    p = np.array([[10.0, 10], [500, 20], [200, 400]])
    q = p + [[1.0, 1], [-2, 1], [0, 3]]
    src_segments = np.array([[[500.0, 500], [510, 500]]])
    dst_segments = src_segments + [3.0, 4.0]
    v = np.array([[300.0, 300], [250, 350]])
    options = {"transform": transform, "weight": "gaussian", "radius": 50.0}
    segments = {"src_segments": src_segments, "dst_segments": dst_segments}
    expected, _, _ = reference.mls(p, q, v, **options, **segments)
    without, _, _ = reference.mls(p, q, v, **options)
    assert np.abs(expected - without).max() > 0.5  # the segment matters there
    with glmls.MLS(p, q, **options, **segments) as m:
        assert_allclose(m(v), expected, atol=1e-3)
