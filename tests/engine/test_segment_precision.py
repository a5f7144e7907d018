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


@pytest.mark.parametrize("transform", ["rigid", "similarity", "affine"])
def test_a_gaussian_seen_from_beyond_a_segments_end(gl, transform):
    """Gaussian R = 3 px, points 10 R and more past the segments' ends: along a segment the
    weight falls from its near end within R^2 / (2 |end|) ~ 0.15 px, which quadrature nodes
    spread about the foot of the perpendicular missed (p* 0.1 px off a lone segment)."""
    ss = np.array([[[20.0, 20], [40, 22]], [[60, 70], [62, 90]], [[20, 80], [30, 70]]])
    ds = ss + np.random.default_rng(3).uniform(-3, 3, ss.shape)
    v = np.array([[50.0, 50], [5, 95], [90, 10], [45, 45], [25, 50], [70, 40]])
    f, f_ref, M, M_ref = gpu_and_reference(
        NONE, NONE, ss, ds, v, transform=transform, weight="gaussian", radius=3.0, shape=(100, 100)
    )
    assert_allclose(f, f_ref, atol=1e-3)
    assert_allclose(M, M_ref, atol=1e-3)


@pytest.mark.parametrize(
    ("h", "x0", "length", "radius"),
    [(5.0, 20.0, 20.0, 3.0), (0.5, 60.0, 10.0, 3.0), (0.5, 200.0, 10.0, 1.0), (2, -50, 46.5, 3)],
)
def test_the_references_gaussian_moments_past_a_segments_end(h, x0, length, radius):
    """The float64 reference's moments J_k = integral of w x^k along a segment (x from the foot
    of the perpendicular) against scipy's adaptive quadrature, where the weight is a sliver
    at the segment's near end."""
    from scipy.integrate import quad

    handles = glmls.HandleSet.validate(
        NONE, NONE, [[[x0, 0.0], [x0 + length, 0.0]]], [[[x0, 1.0], [x0 + length, 1.0]]]
    )
    v = np.array([[0.0, h]])
    geometry = reference.segment_geometry(handles, v)
    config = glmls.MLSConfig(weight="gaussian")
    moments, _ = reference.segment_moments(geometry, config, radius, np.zeros((1, 0)))
    near = min(abs(x0), abs(x0 + length))

    def w(x):  # relative to the nearest point's weight, as the reference's common factor
        return np.exp(-(x * x - near * near) / radius**2)

    sliver = radius**2 / (2 * near)
    end = x0 if x0 > 0 else x0 + length
    step = sliver if x0 > 0 else -sliver
    breaks = sorted(end + step * k for k in (1, 4, 16, 64))
    expected = [
        quad(lambda x, k=k: w(x) * x**k, x0, x0 + length, points=breaks, limit=400, epsrel=1e-12)[0]
        for k in range(3)
    ]
    assert_allclose(moments[0, 0] / moments[0, 0, 0], np.array(expected) / expected[0], rtol=1e-9)


RNG = np.random.default_rng(2)
POINTS_P = RNG.uniform(10, 90, (6, 2))
POINTS_Q = POINTS_P + RNG.uniform(-3, 3, (6, 2))
SEGMENTS_SRC = np.array([[[20.0, 20], [40, 22]], [[60, 70], [62, 90]]])
SEGMENTS_DST = SEGMENTS_SRC + RNG.uniform(-2, 2, SEGMENTS_SRC.shape)


@pytest.mark.parametrize("alpha", [2.0, 6.0])
@pytest.mark.parametrize("transform", ["rigid", "affine"])
def test_segments_keep_their_share_next_to_a_point_handle(gl, transform, alpha):
    """idw with the default s (below the floor under which segments leave it out): a point
    handle's weight carries the factor (s + m^alpha) of its normalisation, and so must a
    segment's. Within 0.01 px of a point handle that factor is s-dominated, and segments
    without it lost their share (M 0.15 off at alpha 2)."""
    v = np.concatenate([POINTS_P + [0.05, 0], POINTS_P + [0.003, 0.002], POINTS_P - [0.0, 1e-4]])
    f, f_ref, M, M_ref = gpu_and_reference(
        POINTS_P, POINTS_Q, SEGMENTS_SRC, SEGMENTS_DST, v, transform=transform, alpha=alpha,
        shape=(100, 100),
    )  # fmt: skip
    assert_allclose(f, f_ref, atol=1e-4)
    assert_allclose(M, M_ref, atol=1e-4)


@pytest.mark.parametrize("s", [1e-8, 1e-12, 0.0])
@pytest.mark.parametrize("transform", ["rigid", "similarity", "affine"])
def test_alpha_10_next_to_a_segment_is_finite(gl, transform, s):
    """0.002 px from a segment with alpha = 10: without s (left out of segments' weights
    below the floor) a segment's weight relative to idw's s-normalisation overflowed
    float32 (NaN f); it is bounded where the point handles no longer count."""
    v = np.array([[61.0, 80.02], [61.0, 80.0], [60.9999, 80.0], [30.0, 21.0001], [50, 50]])
    f, f_ref, M, _ = gpu_and_reference(
        POINTS_P, POINTS_Q, SEGMENTS_SRC, SEGMENTS_DST, v, transform=transform, alpha=10.0, s=s,
        shape=(100, 100),
    )  # fmt: skip
    assert np.isfinite(f).all() and np.isfinite(M).all()
    assert_allclose(f, f_ref, atol=1e-3)


@pytest.mark.parametrize("alpha", [2.0, 5.0])
@pytest.mark.parametrize("transform", ["rigid", "similarity", "affine"])
def test_m_on_a_segment_of_a_steep_interpolating_idw(gl, transform, alpha):
    """On a segment and within the snapping distance of it, idw made interpolating weighs
    1 / d^(4 alpha): the segment's weight is bounded at 2^100 of the normalisation, so that
    its second moment stays finite and decides M, the segment's own turn and stretch, as in
    the reference (not the identity of an overflowed sum)."""
    a, b = SEGMENTS_SRC[:, 0], SEGMENTS_SRC[:, 1]
    normal = (b - a)[:, ::-1] * [-1, 1] / np.linalg.norm(b - a, axis=1)[:, None]
    v = np.concatenate([0.5 * (a + b), 0.8 * a + 0.2 * b + 3e-4 * normal, a + 1e-4 * normal])
    turned = SEGMENTS_DST + np.stack([np.zeros_like(a), 3.0 * normal], axis=1)
    f, f_ref, M, M_ref = gpu_and_reference(
        POINTS_P, POINTS_Q, SEGMENTS_SRC, turned, v, transform=transform, alpha=alpha,
        interpolating=True, shape=(100, 100),
    )  # fmt: skip
    assert np.abs(M_ref - np.eye(2)).max(axis=(1, 2)).min() > 0.01  # I would fail below
    assert_allclose(f, f_ref, atol=1e-4)
    assert_allclose(M, M_ref, atol=1e-3)


@pytest.mark.parametrize(
    "options",
    [
        {"weight": "idw", "alpha": 0.1, "s": 0.0},
        {"weight": "idw", "alpha": 0.2, "s": 0.0},
        {"weight": "cressman", "alpha": 0.2, "radius": 80.0, "interpolating": True},
    ],
    ids=lambda options: f"{options['weight']}-{options['alpha']}",
)
def test_a_weight_integrable_along_a_segment_does_not_snap_to_it(gl, options):
    """Infinite at d = 0 but slower than 1 / d, the weight's integral along a segment is
    finite on it: f is continuous across the segment and passes beside its target (px away
    here), on it as next to it, in the reference and on the GPU alike."""
    a, b = SEGMENTS_SRC[:, 0], SEGMENTS_SRC[:, 1]
    normal = (b - a)[:, ::-1] * [-1, 1] / np.linalg.norm(b - a, axis=1)[:, None]
    on = np.concatenate([0.5 * (a + b), 0.7 * a + 0.3 * b])
    turned = SEGMENTS_DST + np.stack(
        [np.zeros_like(a), 4.0 * np.c_[normal[:, 1], -normal[:, 0]]], 1
    )
    f, f_ref, M, M_ref = gpu_and_reference(
        POINTS_P, POINTS_Q, SEGMENTS_SRC, turned, on, shape=(100, 100), **options
    )
    beside, _, _ = reference.mls(
        POINTS_P, POINTS_Q, on + 1e-6 * np.tile(normal, (2, 1)), shape=(100, 100),
        src_segments=SEGMENTS_SRC, dst_segments=turned, **options,
    )  # fmt: skip
    targets = np.concatenate(
        [0.5 * (turned[:, 0] + turned[:, 1]), 0.7 * turned[:, 0] + 0.3 * turned[:, 1]]
    )
    assert np.linalg.norm(f_ref - targets, axis=1).min() > 0.1  # not snapped
    assert_allclose(f_ref, beside, atol=1e-3)  # continuous
    assert_allclose(f, f_ref, atol=1e-3)
    assert_allclose(M, M_ref, atol=1e-3)


FAR = np.array([[5.0, 95.0], [95, 5], [50, 50], [95, 95], [3, 3], [50, 60]])


def test_the_references_gaussian_keeps_a_segment_that_decides_m_in_the_far_tail():
    """At (5, 95) the nearest point handle outweighs a segment by e^40 (R ~ 6.1 px) and the
    next point handle by more: in the tail the handles apart from the nearest decide M, and
    the segment leads them. f is continuous in R; a cut of the segments at e^-40 of the
    nearest's weight made it jump by 2.7 px at R = 6.11."""
    f = [
        reference.mls(
            POINTS_P, POINTS_Q, FAR[:1], transform="affine", weight="gaussian", radius=radius,
            src_segments=SEGMENTS_SRC, dst_segments=SEGMENTS_DST,
        )[0][0]
        for radius in (6.08, 6.10, 6.12, 6.14)
    ]  # fmt: skip
    assert np.abs(np.diff(f, axis=0)).max() < 0.01


@pytest.mark.parametrize("radius", [3.0, 2.0])
@pytest.mark.parametrize("transform", ["rigid", "similarity", "affine"])
def test_a_gaussian_with_segments_in_its_far_tail(gl, transform, radius):
    """Point handles and segments with a gaussian of R = 2-3 px, points 30-60 px from every
    handle: relative to the nearest point handle the others weigh e^-100 and less (below
    float32); relative to the nearest handles apart from it they are in range, as without
    segments (f was up to 6.5 px off)."""
    f, f_ref, M, M_ref = gpu_and_reference(
        POINTS_P, POINTS_Q, SEGMENTS_SRC, SEGMENTS_DST, FAR, transform=transform,
        weight="gaussian", radius=radius, shape=(100, 100),
    )  # fmt: skip
    assert_allclose(f, f_ref, atol=1e-3)
    assert_allclose(M, M_ref, atol=1e-3)
