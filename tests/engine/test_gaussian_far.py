"""The gaussian weight far from every handle: f on the GPU against the float64 reference at
points up to a few hundred R from handles packed in a small box.

There the weights that count are those of the nearest handles, and they differ by a few R^2
of squared distance out of D^2 ~ 1e4-1e5 R^2. The shaders take each handle's excess over the
point's offset about the nearest handle (``mls/core.glsl``, ``mls_handle_weight``), rounded
at ~6e-8 D |p - p_o|, not at ~6e-8 D^2 as the squared distances themselves: without that
the weights moved by up to ~1e-3 of themselves, f by up to 8 px (affine, R = 16, 80 R out)
and 0.5 px (rigid). Far out affine MLS is ill-conditioned (the two nearest handles decide
it): moving v by its own float32 rounding moves the reference's f by up to 0.03 px there.

Tolerances, from the worst over the cases below (measured: affine up to 0.2 px, p99 0.012;
similarity and rigid up to 0.033 px, p99 8e-4; the points 1 to 375 R from the handles),
with room: p99 within 5e-3 px (affine 0.05), every point within 0.1 px (affine 1 px).
"""

from __future__ import annotations

import numpy as np
import pytest

import glmls
from glmls import reference

#: (p99, max) of |f - f_ref| in pixels, per transform.
TOLERANCE = {"affine": (0.05, 1.0), "similarity": (5e-3, 0.1), "rigid": (5e-3, 0.1)}


def _case(dim: int, seed: int, extent: float, reach: float, count: int):
    rng = np.random.default_rng(seed)
    src = rng.uniform(0, extent, (12 + 4 * (dim - 2), dim))
    dst = src + rng.normal(0, extent / 20, src.shape)
    return src, dst, rng.uniform(-reach, reach, (count, dim))


def _check(found: np.ndarray, expected: np.ndarray, transform: str) -> None:
    assert np.isfinite(found).all()
    error = np.abs(found - expected).max(axis=1)
    p99, worst = TOLERANCE[transform]
    assert np.percentile(error, 99) <= p99, np.percentile(error, 99)
    assert error.max() <= worst, error.max()


@pytest.mark.parametrize("transform", ["affine", "similarity", "rigid"])
@pytest.mark.parametrize("radius", [4.0, 16.0])
def test_2d_far_tail(transform, radius):
    src, dst, points = _case(2, int(radius), 100.0, 1500.0, 3000)
    options = {"transform": transform, "weight": "gaussian", "radius": radius}
    with glmls.MLS(src, dst, **options) as m:
        found = m(points)
    _check(found, reference.mls(src, dst, points, **options)[0], transform)


@pytest.mark.parametrize("transform", ["affine", "rigid"])
def test_2d_far_tail_interpolating(transform):
    src, dst, points = _case(2, 7, 100.0, 1500.0, 2000)
    options = {"transform": transform, "weight": "gaussian", "radius": 16.0}
    options.update(interpolating=True, alpha=1.0)
    with glmls.MLS(src, dst, **options) as m:
        found = m(points)
    _check(found, reference.mls(src, dst, points, **options)[0], transform)


#: (p99, max) of |f - f_ref| in pixels with segment handles (see the test).
SEGMENT_TOLERANCE = {"affine": (0.3, 1.5), "similarity": (0.03, 0.1), "rigid": (0.03, 0.1)}


@pytest.mark.parametrize("transform", ["affine", "similarity", "rigid"])
@pytest.mark.parametrize("seed", [100, 102])
def test_2d_far_tail_with_segments(transform, seed):
    # a segment's weight is integrated over nodes along it, each node's excess d^2 - g taken
    # about the nearest handle as a point handle's (mls/segments.glsl). Measured over five
    # such sets, 1 to 90 R out: similarity and rigid p99 <= 0.021 px, max <= 0.024 px;
    # affine p99 <= 0.19 px, max 0.88 px (ill-conditioned there: one segment's spread
    # decides its third direction). From the nodes' squared distances the errors were up to
    # 2.9 px (similarity), 1.8 px (rigid) and 5.2 px (affine).
    rng = np.random.default_rng(seed)
    src = rng.uniform(0, 100, (8, 2))
    dst = src + rng.normal(0, 5, src.shape)
    src_segments = rng.uniform(0, 100, (3, 2, 2))
    dst_segments = src_segments + rng.normal(0, 5, src_segments.shape)
    points = rng.uniform(-1500, 1500, (1500, 2))
    options = {"transform": transform, "weight": "gaussian", "radius": 16.0}
    options.update(src_segments=src_segments, dst_segments=dst_segments)
    with glmls.MLS(src, dst, **options) as m:
        found = m(points)
    error = np.abs(found - reference.mls(src, dst, points, **options)[0]).max(axis=1)
    assert np.isfinite(found).all()
    p99, worst = SEGMENT_TOLERANCE[transform]
    assert np.percentile(error, 99) <= p99, np.percentile(error, 99)
    assert error.max() <= worst, error.max()


@pytest.mark.parametrize("transform", ["affine", "similarity", "rigid"])
@pytest.mark.parametrize("radius", [4.0, 16.0])
def test_3d_far_tail(transform, radius):
    src, dst, points = _case(3, 10 + int(radius), 60.0, 800.0, 2000)
    options = {"transform": transform, "weight": "gaussian", "radius": radius}
    with glmls.MLS(src, dst, **options) as m:
        found = m(points)
    _check(found, reference.mls(src, dst, points, **options)[0], transform)


@pytest.mark.parametrize("bins", [False, True])
def test_2d_far_from_a_dense_crowd(bins):
    # 1,500 handles in a 400 px box, R = 12 px, points up to 2,000 px out: each handle's
    # rounding grows with |p - p_o| (up to 400 px here). Measured: p99 0.014 px, at most
    # 0.06 px, with the spatial bins or without (the rounding of d^2 put f 0.49 px off); the
    # reference itself moves by up to 0.7 px when the handles move by their float32 rounding.
    rng = np.random.default_rng(4)
    src = rng.uniform(0, 400, (1500, 2))
    dst = src + rng.normal(0, 3, src.shape)
    points = rng.uniform(-2000, 2400, (400, 2))
    options = {"transform": "rigid", "weight": "gaussian", "radius": 12.0}
    with glmls.MLS(src, dst, bins=bins, **options) as m:
        found = m(points)
    error = np.abs(found - reference.mls(src, dst, points, **options)[0]).max(axis=1)
    assert np.percentile(error, 99) <= 0.03, np.percentile(error, 99)
    assert error.max() <= 0.2, error.max()


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("bins", [False, True])
def test_the_nearest_pair_decides_m_to_the_edge_of_the_coordinate_range(dim, bins):
    """Points up to 1e6 px out, R = 10 px: the offset g - |u|^2 taken from the two squares
    (each ~1e12, rounded by ~6e4) lost every weight but the nearest's, and f fell back to a
    translation up to 3.8e5 px off; the nearest apart's own excess keeps it, so f is the fit
    of the nearest handles there, to float32's ~1e-7 of the coordinates."""
    if bins and dim == 3:
        pytest.skip("the spatial bins are 2D's")
    rng = np.random.default_rng(5)
    src = rng.uniform(0, 64, (5 + dim, dim))
    dst = src + rng.normal(0, 3, src.shape)
    directions = rng.normal(size=(60, dim))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    points = directions * rng.uniform(1e5, 1e6, (60, 1))
    options = {"transform": "similarity", "weight": "gaussian", "radius": 10.0}
    extra = {"bins": bins} if dim == 2 else {}
    with glmls.MLS(src, dst, **options, **extra) as m:
        found = m(points)
        matrices, _ = m.matrices(points)
    expected, expected_m, _ = reference.mls(src, dst, points, **options)
    error = np.abs(found - expected).max(axis=1)
    assert (error <= 4e-7 * np.abs(points).max(axis=1)).all(), error.max()
    assert np.abs(matrices - expected_m).max() < 1e-4


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("radius", [1e-4, 1.1e-3])
def test_a_tiny_radius_keeps_the_nearest_pairs_fit(dim, radius):
    """R of 1e-4 px among handles tens of pixels apart: the nearest apart's excess (0 by
    definition) came out as float32's rounding of its dot products, some 1e-5 px², which
    divided by R^2 took its weight to e^-2000 at one point in three: M = I there, f up to
    7 px off; an excess within its terms' rounding is 0 now."""
    rng = np.random.default_rng(6)
    src = rng.uniform(0, 64, (5 + dim, dim))
    dst = src + rng.normal(0, 3, src.shape)
    points = rng.uniform(0, 64, (3000, dim))
    options = {"transform": "similarity", "weight": "gaussian", "radius": radius}
    with glmls.MLS(src, dst, **options) as m:
        found = m(points)
    expected = reference.mls(src, dst, points, **options)[0]
    assert np.abs(found - expected).max() < 1e-3


@pytest.mark.parametrize("radius", [1e-4, 1e-2])
def test_a_tie_for_the_nearest_handle_keeps_both(radius):
    """Points on the bisector of two handles (far out), and at the middle of two of three
    (2D and 3D): float32 may round either of the pair nearer, and the offset about it, a
    rounding of zero, came out negative as often as not, weighing the nearest e^-(|g_o| /
    R^2) = 0: M = I, f up to 1.4e4 px off. g >= |u|^2 holds now, and an excess within the
    rounding of its operands (Q = P - 2u cancels at the middle) is 0."""
    src = np.array([[174.0, 51.0], [199.0, 9.0]])
    dst = np.array([[169.653, 46.349], [202.635, 8.793]])
    along = np.array([-8e4, -3e3, -300.0, 3.0, 100.0, 3e3, 1e4, 3e4, 8e4])
    bisector = src.mean(axis=0) + along[:, None] * np.array([42.0, 25.0]) / np.hypot(42, 25)
    options = {"transform": "similarity", "weight": "gaussian", "radius": radius}
    with glmls.MLS(src, dst, **options) as m:
        found = m(bisector)
    error = np.abs(found - reference.mls(src, dst, bisector, **options)[0]).max(axis=1)
    assert (error <= 1e-6 * np.maximum(np.abs(bisector).max(axis=1), 100.0)).all(), error
    rng = np.random.default_rng(7)
    for dim in (2, 3):
        for _ in range(12):
            src = rng.uniform(0, 48, (3, dim))
            dst = src + rng.normal(0, 3, src.shape)
            middle = (src[:1] + src[1:2]) / 2
            if np.linalg.norm(src[2] - middle) < 1.5 * np.linalg.norm(src[0] - middle):
                continue
            with glmls.MLS(src, dst, **options) as m:
                found = m(middle)
            expected = reference.mls(src, dst, middle, **options)[0]
            assert np.abs(found - expected).max() < 1e-3


def test_past_a_segments_end_the_reference_integrates_the_sliver_there():
    """Points 40-160 px past a segment's end, R = 0.3: the gaussian falls from the end
    within R^2 / (2 d), ~0.001 px, narrower than the reference's nodes about the foot,
    which left the segment out (M = I, f 0.6-2.5 px off); nodes about the end take it,
    as the GPU's do. Checked against the segment as 2,001 point handles over that end."""
    src = np.array([[20.0, 30.0], [150.0, 160.0], [60.0, 170.0]])
    dst = src + [[1.0, -2.0], [-3.0, 1.5], [0.5, 2.0]]
    ss = np.array([[[40.0, 40.0], [120.0, 60.0]], [[100.0, 100.0], [100.0, 180.0]]])
    ds = ss + [[[2.0, 1.0], [-1.0, 2.0]], [[-2.0, -1.0], [1.0, -3.0]]]
    direction = np.array([-0.24, 0.97]) / np.hypot(-0.24, 0.97)
    points = np.array([100.0, 180.0]) + np.array([[40.0], [100.0], [160.0]]) * direction
    options = {"transform": "similarity", "weight": "gaussian", "radius": 0.3}
    expected = reference.mls(src, dst, points, src_segments=ss, dst_segments=ds, **options)[0]
    with glmls.MLS(src, dst, src_segments=ss, dst_segments=ds, **options) as m:
        assert np.abs(m(points) - expected).max() < 2e-3
    (a, b), (c, d) = ss[1], ds[1]
    for point, f in zip(points, expected, strict=True):
        end = 0.09 / (2 * np.hypot(*(point - b)))  # the sliver's width
        t = np.linspace(1 - 30 * end / 80.0, 1.0, 2001)[:, None]
        dense_src = np.concatenate([src, a + t * (b - a)])
        dense_dst = np.concatenate([dst, c + t * (d - c)])
        dense = reference.mls(dense_src, dense_dst, point[None], **options)[0][0]
        assert np.abs(dense - f).max() < 2e-3
