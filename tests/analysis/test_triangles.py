"""Reference-triangle errors (paper eqs. 10, 11) against the formulas, and degenerate input."""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import random_handles
from numpy.testing import assert_allclose

import glmls
from glmls import reference

SHAPE = (512, 512)


def formula_errors(r, fr, simplices, eps):
    """Eqs. (10) and (11) triangle by triangle, corner by corner, with math.* in float64."""
    distance, angle = [], []
    for tri in simplices:
        d_sum = a_sum = 0.0
        for k in range(3):
            i, j, h = tri[k], tri[(k + 1) % 3], tri[(k + 2) % 3]
            before = math.dist(r[i], r[j])
            after = math.dist(fr[i], fr[j])
            d_sum += abs(before - after) / before

            def cos_at(pts, c, a, b):
                u, v = pts[a] - pts[c], pts[b] - pts[c]
                return float(u @ v) / (math.hypot(*u) * math.hypot(*v))

            cos_a, cos_b = cos_at(r, i, j, h), cos_at(fr, i, j, h)
            a_sum += (abs(cos_a - cos_b) + eps) / (abs(cos_a) + eps)
        distance.append(d_sum / 3)
        angle.append(a_sum / 3)
    return np.array(distance), np.array(angle)


@pytest.mark.parametrize("transform", glmls.TRANSFORMS)
def test_matches_formulas_with_a_float64_deformation(gl, rng, transform):
    p, q = random_handles(rng, 10, size=512.0, displacement=40.0)
    r = rng.uniform(0, 512, (40, 2))
    config = glmls.MLSConfig(transform=transform)

    def f(points):
        return reference.mls(p, q, points, config, shape=SHAPE)[0]

    errors = glmls.analysis.triangle_errors(f, r, eps=1e-6, angle="paper")
    assert errors.angle_measure == "paper"
    assert_allclose(errors.deformed_points, f(r), rtol=0, atol=0)
    distance, angle = formula_errors(r, f(r), errors.simplices, 1e-6)
    assert_allclose(errors.distance, distance, rtol=1e-12)
    assert_allclose(errors.angle, angle, rtol=1e-12)
    assert errors.simplices.shape == (len(errors.distance), 3)


@pytest.mark.parametrize("transform", glmls.TRANSFORMS)
def test_gpu_deformation_matches_float64(gl, rng, transform):
    p, q = random_handles(rng, 10, size=512.0, displacement=40.0)
    r = rng.uniform(0, 512, (40, 2))
    with glmls.MLS(p, q, transform=transform, shape=SHAPE, ctx=gl) as m:
        errors = glmls.analysis.triangle_errors(m, r, angle="paper")
    f_r = reference.mls(p, q, r, m.config, shape=SHAPE)[0]
    assert_allclose(errors.deformed_points, f_r, rtol=0, atol=0.01)
    distance, angle = formula_errors(r, f_r, errors.simplices, 1e-6)
    # f(r) within 0.01 px moves relative lengths and cosines of ~50 px edges by < 1e-3
    assert_allclose(errors.distance, distance, rtol=0, atol=1e-3)
    assert_allclose(errors.angle, angle, rtol=1e-3, atol=1e-3)


@pytest.mark.parametrize("transform", ["similarity", "affine"])
@pytest.mark.parametrize("factor", [0.5, 1.5])
def test_uniform_scale_has_no_angular_error(gl, rng, transform, factor):
    """The paper's argument: scaling changes lengths only."""
    p = rng.uniform(0, 512, (8, 2))
    r = rng.uniform(0, 512, (30, 2))
    eps = 1e-6
    with glmls.MLS(p, factor * p + 3.0, transform=transform, ctx=gl) as m:
        errors = glmls.analysis.triangle_errors(m, r, eps=eps, angle="paper")
        degrees = glmls.analysis.triangle_errors(m, r)
    assert degrees.angle_measure == "degrees"
    assert degrees.angle.max() < 1e-3  # float32 noise only
    assert_allclose(errors.distance, abs(factor - 1), rtol=0, atol=1e-5)
    # unchanged cosines leave eps / (|cos a| + eps) per corner, plus float32 noise
    assert errors.angle.max() < 1e-3
    assert np.median(errors.angle) < 1e-4
    assert not errors.flipped.any()


def test_mirror_flips_every_triangle(rng):
    r = rng.uniform(0, 100, (12, 2))
    errors = glmls.analysis.triangle_errors(lambda v: v * [-1.0, 1.0], r)
    assert errors.flipped.all()
    assert_allclose(errors.distance, 0.0, atol=1e-15)
    assert errors.stats()["flipped"] == len(errors.simplices)


def test_collapsed_edge_gives_nan_angle(rng):
    r = np.array([[0.0, 0.0], [10.0, 0.0], [0.0, 10.0]])
    errors = glmls.analysis.triangle_errors(lambda v: np.where(v[:, :1] > 5, 0.0, v), r)
    assert np.isnan(errors.angle).all()
    assert errors.stats()["angle"]["nan_count"] == 1


@pytest.mark.parametrize(
    ("points", "match"),
    [
        ([[0.0, 0.0], [1.0, 1.0]], "at least 3"),
        ([[0.0, 0.0], [1.0, 1.0], [2.0, 2.0], [5.0, 5.0]], "one line"),
        # not on one line, but within float64's reach of one: the message says how close
        ([[1.0, 1.0], [3.0, 7.0], [9.0, 2.0], [1e300, 2.0]], r"one line, to within 1e-10 .* 4\.55"),
        ([[0.0, 0.0], [1.0, 0.0], [np.nan, 1.0]], "finite"),
        ([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 0.0]], r"\[1\] and reference_points\[3\]"),
        ([[100.0, 100.0], [200.0, 100.0], [100.0, 200.0], [100.0 + 1e-12, 100.0]], "coincide"),
        ([[0.0, 0.0, 0.0]], "shape"),
    ],
)
def test_degenerate_points_raise(points, match):
    with pytest.raises(ValueError, match=match):
        glmls.analysis.triangle_errors(lambda v: v, points)


def test_bad_eps_and_bad_mapping():
    r = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]
    for eps in (0.0, -1.0, True, "1", math.inf, math.nan):
        error = TypeError if isinstance(eps, (bool, str)) else ValueError
        for angle in glmls.analysis.ANGLE_MEASURES:
            with pytest.raises(error, match="eps"):
                glmls.analysis.triangle_errors(lambda v: v, r, eps=eps, angle=angle)
    with pytest.raises(ValueError, match="returned shape"):
        glmls.analysis.triangle_errors(lambda v: v[:2], r)


def test_a_mapping_of_other_than_real_numbers_is_named():
    # complex points were cast to their real part and scored as exact, bool ones as 0 and 1
    r = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]
    for wrong in (lambda v: v + 0j, lambda v: v > 0, lambda v: v.astype(str)):
        with pytest.raises(TypeError, match=r"m\(points\) returned .* expected real numbers"):
            glmls.analysis.triangle_errors(wrong, r)
    with pytest.raises(TypeError, match=r"m must be a glmls\.MLS or a function of points, got int"):
        glmls.analysis.triangle_errors(3, r)
    # plain numbers in a list or an object array stay welcome
    assert glmls.analysis.triangle_errors(lambda v: v.tolist(), r).angle.tolist() == [0.0]
    assert glmls.analysis.triangle_errors(lambda v: v.astype(object), r).angle.tolist() == [0.0]


def test_results_are_read_only(rng):
    errors = glmls.analysis.triangle_errors(lambda v: 2 * v, rng.uniform(0, 9, (6, 2)))
    with pytest.raises(ValueError, match="read-only"):
        errors.angle[0] = 1.0


def corner_degrees(points, tri, k):
    i, j, h = tri[k], tri[(k + 1) % 3], tri[(k + 2) % 3]
    u, v = points[j] - points[i], points[h] - points[i]
    return math.degrees(math.acos(float(u @ v) / (math.hypot(*u) * math.hypot(*v))))


def test_degrees_measure_against_the_formula(rng):
    r = rng.uniform(0, 300, (30, 2))
    p, q = random_handles(rng, 8, size=300.0, displacement=30.0)

    def f(points):
        return reference.mls(p, q, points, glmls.MLSConfig(transform="affine"))[0]

    errors = glmls.analysis.triangle_errors(f, r)
    fr = f(r)
    expected = [
        np.mean([abs(corner_degrees(r, t, k) - corner_degrees(fr, t, k)) for k in range(3)])
        for t in errors.simplices
    ]
    assert_allclose(errors.angle, expected, rtol=1e-9, atol=1e-9)
    assert errors.angle.max() <= 180.0


@pytest.mark.parametrize(
    "similarity",
    [
        lambda v: 0.5 * v,
        lambda v: v @ np.array([[0.6, 0.8], [-0.8, 0.6]]) * 3.0 + [7.0, -2.0],
        lambda v: v * [-2.0, 2.0],  # a mirror: angles kept, flipped reported apart
    ],
)
def test_similarities_have_no_angular_error(similarity):
    # a square grid: right angles everywhere, where eq. (11) as printed scores 1, not 0
    square = np.stack(np.meshgrid(np.arange(5.0), np.arange(5.0)), -1).reshape(-1, 2) * 20
    errors = glmls.analysis.triangle_errors(similarity, square)
    assert_allclose(errors.angle, 0.0, atol=1e-9)
    paper = glmls.analysis.triangle_errors(similarity, square, angle="paper")
    assert paper.angle.max() > 0.3  # the singularity the default avoids


def test_degrees_are_comparable_across_angles():
    # the same 1-degree turn of one edge: eq. (11) differs by orders of magnitude between
    # a right and a sharp corner, the default does not
    def turned(corner_angle):
        a = math.radians(corner_angle)
        b = math.radians(corner_angle + 1.0)
        r = np.array([[0.0, 0.0], [100.0, 0.0], [100 * math.cos(a), 100 * math.sin(a)]])
        out = r.copy()
        out[2] = [100 * math.cos(b), 100 * math.sin(b)]
        return r, out

    degrees, paper = [], []
    for corner in (90.0, 30.0):
        r, out = turned(corner)
        mapping = {tuple(a): b for a, b in zip(r, out, strict=True)}

        def f(v, mapping=mapping):
            return np.array([mapping[tuple(x)] for x in v])

        degrees.append(glmls.analysis.triangle_errors(f, r).angle[0])
        paper.append(glmls.analysis.triangle_errors(f, r, angle="paper").angle[0])
    # corner 0 turns by 1 degree, the other two share -1 degree: mean |change| 2/3 degree
    assert_allclose(degrees, 2 / 3, rtol=1e-9)
    assert paper[0] / paper[1] > 100


def test_bad_angle_measure():
    r = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]
    with pytest.raises(ValueError, match="unknown angle 'cosine'"):
        glmls.analysis.triangle_errors(lambda v: v, r, angle="cosine")
    for angle in (None, 1, b"paper"):
        with pytest.raises(TypeError, match="angle must be a string"):
            glmls.analysis.triangle_errors(lambda v: v, r, angle=angle)


def test_a_triangle_crushed_to_zero_area_is_a_fold(rng):
    """All of f(r) on one point, or on one line: no orientation is left, a fold."""
    r = rng.uniform(0, 100, (12, 2))
    point = glmls.analysis.triangle_errors(lambda v: np.zeros_like(v) + 30.0, r)
    assert point.flipped.all()
    assert point.stats()["flipped"] == len(point.simplices)
    line = glmls.analysis.triangle_errors(lambda v: v * [1.0, 0.0], r)
    assert line.flipped.all()
    assert not glmls.analysis.triangle_errors(lambda v: v * 1e-3, r).flipped.any()


def test_a_triangle_flattened_to_float32_rounding_is_a_fold(gl):
    """Every handle dragged onto one point: the GPU's f(r) lie within float32 rounding of
    it, their tiny triangles' orientation mere rounding, and every one is a fold."""
    src = np.array([[4.0, 4.0], [27.0, 4.0], [4.0, 27.0], [27.0, 27.0]])
    points = [[8, 8], [24, 8], [8, 24], [24, 24], [16, 16]]
    with glmls.MLS(src, np.tile([[16.0, 16.0]], (4, 1)), transform="affine", ctx=gl) as m:
        errors = glmls.analysis.triangle_errors(m, points)
        assert errors.flipped.all()
        with glmls.MLS(src, src * 0.01 + 8.0, transform="affine", ctx=gl) as small:
            assert not glmls.analysis.triangle_errors(small, points).flipped.any()


@pytest.mark.parametrize("apart", [1e-4, 1e-7, 1e-10])
def test_a_reference_sliver_folds_only_where_f_clearly_turns_it_over(gl, apart):
    """Two reference points a fraction of a pixel apart make triangles already within f's
    float32 rounding of zero area: the identity (f(r) = r bit for bit) folds none of them,
    where a flatness test on f(r) alone called every such sliver a fold (and tune set every
    configuration apart); a mirror still turns every other triangle over."""
    src = np.array([[20.0, 20], [100, 20], [20, 80], [100, 80], [60, 50]])
    points = np.array([[10, 10], [110, 15], [15, 85], [105, 80], [40, 30], [60, 45]])
    points = np.vstack([points, [60.0, 45.0 + apart]])
    with glmls.MLS(src, src.copy(), ctx=gl) as m:
        errors = glmls.analysis.triangle_errors(m, points)
    assert np.array_equal(errors.deformed_points, errors.points)
    assert len(errors.simplices) >= 7 and not errors.flipped.any()
    mirror = src * [-1.0, 1.0] + [120.0, 0.0]
    with glmls.MLS(src, mirror, transform="affine", ctx=gl) as m:
        mirrored = glmls.analysis.triangle_errors(m, points)
    slivers = np.isin(mirrored.simplices, [5, 6]).sum(axis=1) == 2
    assert slivers.sum() == 2 and mirrored.flipped[~slivers].all()


@pytest.mark.parametrize("offset", [0.0, 1e5, 5e5, 9e5])
def test_far_from_the_origin_the_gpus_folds_are_the_float64_ones(gl, offset):
    """Handles and points 5e5 px out: the GPU holds them about its frame's centre, where
    f(r)'s float32 rounding is that of a map at the origin; taken about the origin the
    flatness tolerance flagged a third of the healthy triangles."""
    rng = np.random.default_rng(3)
    src = offset + rng.uniform(0, 100, (10, 2))
    dst = src + rng.normal(0, 3, src.shape)
    points = offset + rng.uniform(0, 100, (40, 2))
    with glmls.MLS(src, dst, transform="similarity", ctx=gl) as m:
        found = glmls.analysis.triangle_errors(m, points)
    expected = glmls.analysis.triangle_errors(
        lambda v: reference.mls(src, dst, v, transform="similarity")[0], points
    )
    assert_allclose(found.deformed_points, expected.deformed_points, atol=1e-7 * (offset + 100))
    assert (found.flipped == expected.flipped).all()


def test_a_thin_triangle_kept_whole_is_no_fold(gl):
    """A thin reference triangle (0.2 px high, 60 px long, at x ~ 500) that f leaves as it is:
    its orientation is thousands of float32 steps clear of rounding, and f does not stretch
    it, so it is no fold (its own aspect ratio is no stretch of f)."""
    points = [[505.57, 323.97], [444.77, 323.21], [444.86, 323.01], [388.85, 276.41]]
    src = np.array([[0.0, 0.0], [511.0, 0.0], [0.0, 511.0], [511.0, 511.0]])
    with glmls.MLS(src, src, transform="affine", ctx=gl) as m:
        errors = glmls.analysis.triangle_errors(m, points)
    assert len(errors.simplices) == 3  # two of them thin
    assert not errors.flipped.any()


def test_points_beyond_the_coordinate_range_are_refused_before_qhull():
    points = np.random.default_rng(0).random((8, 2)) * 100
    for scale in (1e150, 1e7):
        with pytest.raises(ValueError, match=r"reference_points must lie within ±1e\+06 px"):
            glmls.analysis.triangle_errors(lambda v: v * 2.0, points * scale)


@pytest.mark.parametrize("scale", [1e-160, 1e-200])
def test_tiny_points_are_measured_as_their_copy_at_unit_scale(scale):
    """Their squares underflow float64: Qhull's lifted points and the corner angles."""
    points = np.random.default_rng(0).random((8, 2)) * 100
    unit = glmls.analysis.triangle_errors(lambda v: v * 2.0, points)
    tiny = glmls.analysis.triangle_errors(lambda v: v * 2.0, points * scale)
    np.testing.assert_array_equal(tiny.simplices, unit.simplices)
    assert_allclose(tiny.distance, 1.0, rtol=1e-12)
    assert not tiny.angle.any() and not tiny.flipped.any()
