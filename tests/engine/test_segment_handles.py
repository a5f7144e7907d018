"""Segment handles (Schaefer et al. 2006, section 4) on the GPU against the float64 reference,
and the reference against independent computations."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.integrate import quad

import glmls
from glmls import reference
from glmls.core.config import MLSConfig
from glmls.core.handleset import HandleSet
from glmls.core.segments import polyline_segments, segment_config, segment_feet
from glmls.reference import segment_moments

SIZE = 1024
SHAPE = (SIZE, SIZE)
NONE = np.zeros((0, 2))


def random_segments(rng, count, size=SIZE, move=25.0, length=(20.0, 300.0)):
    """``count`` source segments of random direction and length inside the image, and
    targets moved by up to ``move`` px at each end."""
    a = rng.uniform(0.1 * size, 0.9 * size, (count, 2))
    angle = rng.uniform(0, 2 * np.pi, count)
    span = rng.uniform(*length, count)[:, None] * np.stack([np.cos(angle), np.sin(angle)], 1)
    src = np.stack([a, np.clip(a + span, 0, size - 1)], axis=1)
    return src, src + rng.uniform(-move, move, src.shape)


def away_from(src_segments, points, distance=0.5):
    """The points farther than ``distance`` px from every segment."""
    _, _, dist2 = segment_feet(src_segments, points)
    return points[dist2.min(axis=1) > distance**2]


def along(segments, t):
    """Points at parameters t (S, K) of each segment, (S K, 2)."""
    return (
        segments[:, None, 0] * (1 - t)[..., None] + segments[:, None, 1] * t[..., None]
    ).reshape(-1, 2)


CONFIGS = [
    (transform, weight, options)
    for transform in glmls.TRANSFORMS
    for weight, options in [
        ("idw", {}),
        ("idw", {"alpha": 2.0}),
        ("idw", {"alpha": 0.5}),
        ("cressman", {}),
        ("shepard", {}),
        ("gaussian", {}),
        ("linear", {}),
        ("gaussian", {"interpolating": True}),
        ("linear", {"radius": 400.0, "interpolating": True}),
    ]
]


@pytest.mark.parametrize(("transform", "weight", "options"), CONFIGS)
def test_gpu_matches_the_float64_reference(rng, transform, weight, options):
    """<= 0.01 px at points farther than 0.5 px from every segment: 64 segments and 16
    points on a 1024^2 image."""
    a, b = random_segments(rng, 64)
    p = rng.uniform(50, 970, (16, 2))
    q = p + rng.uniform(-25, 25, p.shape)
    v = away_from(a, rng.uniform(-20, SIZE + 20, (400, 2)))
    config = MLSConfig(transform=transform, weight=weight, **options)
    with glmls.MLS.from_config(p, q, config, src_segments=a, dst_segments=b, shape=SHAPE) as m:
        f = m(v)
        big_m, _ = m.matrices(v)
    f_ref, m_ref, _ = reference.mls(p, q, v, config, shape=SHAPE, src_segments=a, dst_segments=b)
    assert_allclose(f, f_ref, atol=1e-2)
    assert_allclose(big_m, m_ref, atol=2e-4)


@pytest.mark.parametrize("transform", glmls.TRANSFORMS)
@pytest.mark.parametrize(
    ("weight", "options"),
    [
        ("idw", {}),
        ("idw", {"alpha": 2.0}),
        ("idw", {"s": 0.0}),
        ("shepard", {}),
        ("cressman", {"interpolating": True}),
        ("gaussian", {"interpolating": True}),
    ],
)
def test_points_of_a_segment_map_onto_its_target(rng, transform, weight, options):
    """Weights infinite at d = 0 (and idw with its default s, which segments leave out):
    f(p(t)) = q(t) within 1e-2 px."""
    a, b = random_segments(rng, 24)
    t = rng.uniform(0, 1, (24, 20))
    t[:, :2] = [0.0, 1.0]  # the ends too
    with glmls.MLS(
        NONE, NONE, src_segments=a, dst_segments=b, transform=transform, weight=weight,
        shape=SHAPE, **options,
    ) as m:  # fmt: skip
        assert_allclose(m(along(a, t)), along(b, t), atol=1e-2)


@pytest.mark.parametrize("weight", glmls.WEIGHTS)
def test_a_segment_split_in_two_is_the_same_handle(rng, weight):
    a, b = random_segments(rng, 16)
    t = rng.uniform(0.2, 0.8, 16)[:, None]
    cut_a, cut_b = along(a, t), along(b, t)
    a2 = np.concatenate([np.stack([a[:, 0], cut_a], 1), np.stack([cut_a, a[:, 1]], 1)])
    b2 = np.concatenate([np.stack([b[:, 0], cut_b], 1), np.stack([cut_b, b[:, 1]], 1)])
    v = away_from(a, rng.uniform(0, SIZE, (2000, 2)))
    options = {"weight": weight, "shape": SHAPE}
    with (
        glmls.MLS(NONE, NONE, src_segments=a, dst_segments=b, **options) as whole,
        glmls.MLS(NONE, NONE, src_segments=a2, dst_segments=b2, **options) as halves,
    ):
        assert_allclose(halves(v), whole(v), atol=1e-3)


@pytest.mark.parametrize("transform", glmls.TRANSFORMS)
def test_crossing_segments_keep_their_targets_up_to_the_crossing(transform):
    """Interiors that cross are accepted whatever their targets there ([10, 10] and [10, 15]
    at the middle of both): each segment maps onto its target, and the crossing point onto
    the target of the segment given first, on the GPU as in the reference."""
    a = np.array([[[0.0, 0.0], [20.0, 20.0]], [[0.0, 20.0], [20.0, 0.0]]])
    b = a + [[[0.0, 0.0], [0.0, 0.0]], [[0.0, 5.0], [0.0, 5.0]]]
    t = np.array([[0.1, 0.3, 0.49, 0.51, 0.8]] * 2)
    crossing = np.array([[10.0, 10.0]])
    for order in ([0, 1], [1, 0]):
        with glmls.MLS(
            NONE, NONE, src_segments=a[order], dst_segments=b[order], transform=transform
        ) as m:
            assert_allclose(m(along(a, t)), along(b, t), atol=1e-2)
            assert_allclose(m(crossing), [[10.0, 10.0 + 5.0 * order[0]]], atol=1e-3)
            v = crossing + [[0.3, 0.0], [0.0, -0.7], [2.0, 1.0]]
            ref = reference.mls(
                NONE, NONE, v, transform=transform, src_segments=a[order], dst_segments=b[order]
            )[0]
            assert_allclose(m(v), ref, atol=1e-2)


def test_identity_segments_give_the_identity_exactly(rng):
    a, _ = random_segments(rng, 8)
    p = rng.uniform(0, SIZE, (5, 2))
    v = rng.uniform(0, SIZE, (500, 2))
    with glmls.MLS(p, p, src_segments=a, dst_segments=a, shape=SHAPE) as m:
        assert_allclose(m(v), v, atol=1e-3)
        assert m.error_field((64, 64)).max() == 0.0


@pytest.mark.parametrize("storage", ["ssbo", "ubo", "texture"])
@pytest.mark.parametrize("bins", [False, True])
def test_every_storage_and_the_spatial_bins_agree(rng, storage, bins):
    """Bins list each segment in every bin its reach touches; compact weights at a small
    radius, where bins pay, against the reference."""
    a, b = random_segments(rng, 40, length=(10.0, 120.0))
    p = rng.uniform(0, SIZE, (300, 2))
    q = p + rng.uniform(-15, 15, p.shape)
    v = away_from(a, rng.uniform(0, SIZE, (600, 2)))
    for weight in ("cressman", "gaussian"):
        options = {"weight": weight, "radius": 60.0, "transform": "similarity"}
        with glmls.MLS(
            p, q, src_segments=a, dst_segments=b, storage=storage, bins=bins, **options
        ) as m:
            assert (m.kernel.bins is not None) == bins
            f = m(v)
        f_ref = reference.mls(p, q, v, src_segments=a, dst_segments=b, **options)[0]
        assert_allclose(f, f_ref, atol=1e-2)


def test_error_field_integrates_along_the_segments(rng):
    shape = (96, 128)
    a, b = random_segments(rng, 5, size=128, move=8.0, length=(10.0, 60.0))
    p = rng.uniform(0, 128, (4, 2))
    q = p + rng.uniform(-8, 8, p.shape)
    rows, cols = np.mgrid[0:96:5, 0:128:5]
    v = np.stack([cols.ravel(), rows.ravel()], 1).astype(float)
    for transform in glmls.TRANSFORMS:
        with glmls.MLS(p, q, src_segments=a, dst_segments=b, transform=transform, shape=shape) as m:
            field = m.error_field(shape)
        expected = reference.mls_error(
            p, q, v, transform=transform, shape=shape, src_segments=a, dst_segments=b
        )
        assert_allclose(field[rows.ravel(), cols.ravel()], expected, rtol=1e-4)


def test_error_of_a_segment_is_its_integral_per_pixel_of_length():
    """One segment and a global similarity that misses it by a known linear residual."""
    a = np.array([[[0.0, 0.0], [10.0, 0.0]], [[0.0, 5.0], [10.0, 5.0]]])
    b = a.copy()
    b[0, 1, 1] += 3.0  # the first target's end lifted by 3 px: the residual runs 0 -> 3
    v = np.array([[5.0, 2.0]])
    e = reference.mls_error(NONE, NONE, v, src_segments=a, dst_segments=b, transform="affine")
    # a brute-force sum along both segments
    _, big_m, t = reference.mls(NONE, NONE, v, src_segments=a, dst_segments=b, transform="affine")
    s = np.linspace(0, 1, 20001)
    total = 0.0
    for k in range(2):
        pts = a[k, 0] * (1 - s[:, None]) + a[k, 1] * s[:, None]
        tgt = b[k, 0] * (1 - s[:, None]) + b[k, 1] * s[:, None]
        r2 = ((pts @ big_m[0] + t[0] - tgt) ** 2).sum(1)
        total += np.trapezoid(r2, s) * 10.0
    assert_allclose(e, [total], rtol=1e-6)


def test_reference_integrals_against_adaptive_quadrature():
    """The sinh-substituted Gauss-Legendre integrals against scipy's adaptive Gauss-Kronrod
    quadrature (over t with x = h sinh t, which it needs for the peak at the foot), also for a
    point 0.05 px from the segment, for every weight."""
    segment = [[[100.0, 100.0], [400.0, 180.0]]]
    handles = HandleSet.validate(NONE, NONE, segment, [[[0, 0], [1, 1]]])
    v = np.array([[250.0, 140.0 + 0.05], [250.0, 300.0], [50.0, 90.0], [420.0, 185.0]])
    geometry = reference.segment_geometry(handles, v)
    # point handles at distances 0 and 1e-6 px fix the gaussian's common factor (its weights
    # relative to the least distance above the least, glmls.core.weights.gaussian_excess) to
    # exp(1e-12 / R^2) = 1 in float64
    at_zero = np.tile([0.0, 1e-12], (len(v), 1))
    for weight in glmls.WEIGHTS:
        config = MLSConfig(weight=weight, radius=300.0, alpha=1.5 if weight == "idw" else 1.0)
        moments, _ = segment_moments(geometry, config, 300.0, at_zero)
        for k in range(len(v)):
            x0, x1, h2 = (geometry[key][k, 0] for key in ("x0", "x1", "h2"))
            h = np.sqrt(h2)

            def integrand(t, power, h=h, h2=h2, config=config):
                x = h * np.sinh(t)
                d2 = np.array([[0.0, 1e-12, h2 + x * x]])
                w = reference.weights(d2, segment_config(config), 300.0)[0, 2]
                return w * x**power * h * np.cosh(t)

            t0, t1 = np.arcsinh(x0 / h), np.arcsinh(x1 / h)
            edge = np.arcsinh(np.sqrt(max(300.0**2 - h2, 0.0)) / h)  # the radius weights' kinks
            kinks = [k for k in (-edge, edge) if t0 < k < t1]
            for power in range(3):
                # J1 may cancel to ~0: an absolute tolerance on the scale of J0 L^power
                scale = moments[k, 0, 0] * max(abs(x0), abs(x1)) ** power
                exact, _ = quad(
                    integrand, t0, t1, args=(power,), points=kinks or None,
                    limit=500, epsabs=1e-12 * scale, epsrel=1e-10,
                )  # fmt: skip
                assert_allclose(moments[k, 0, power], exact, rtol=1e-8, atol=1e-10 * scale)


def test_reference_against_densely_sampled_points(rng):
    """One segment handle is the limit of many point handles spread evenly along it."""
    a, b = random_segments(rng, 1, size=400, move=30.0)
    t = (np.arange(3000) + 0.5) / 3000
    samples_p, samples_q = along(a, t[None]), along(b, t[None])
    v = away_from(a, rng.uniform(0, 400, (100, 2)), distance=5.0)
    for transform in glmls.TRANSFORMS:
        f = reference.mls(NONE, NONE, v, transform=transform, src_segments=a, dst_segments=b)[0]
        dense = reference.mls(samples_p, samples_q, v, transform=transform)[0]
        assert_allclose(f, dense, atol=1e-3)


def test_points_and_segments_mix(rng):
    """Their moments add: a mixed MLS differs from either alone, and matches the reference."""
    a, b = random_segments(rng, 6)
    p = rng.uniform(0, SIZE, (6, 2))
    q = p + rng.uniform(-30, 30, p.shape)
    v = away_from(a, rng.uniform(0, SIZE, (300, 2)))
    with (
        glmls.MLS(p, q, src_segments=a, dst_segments=b, shape=SHAPE) as both,
        glmls.MLS(p, q, shape=SHAPE) as points,
    ):
        f = both(v)
        assert np.abs(f - points(v)).max() > 1.0
    assert_allclose(f, reference.mls(p, q, v, src_segments=a, dst_segments=b)[0], atol=1e-2)
    assert_allclose(both.handles.source_points()[:6], p)


def test_set_handles_switches_between_points_and_segments(rng):
    a, b = random_segments(rng, 4)
    p = rng.uniform(0, SIZE, (4, 2))
    v = rng.uniform(0, SIZE, (50, 2))
    with glmls.MLS(p, p + 5, shape=SHAPE) as m:
        m.set_handles(NONE, NONE, src_segments=a, dst_segments=b)
        assert m.src_segments.shape == (4, 2, 2)
        assert_allclose(
            m(v), reference.mls(NONE, NONE, v, src_segments=a, dst_segments=b)[0], atol=1e-2
        )
        m.set_handles(p, p + 5)
        assert_allclose(m(v), v + 5, atol=1e-3)
        assert m.src_segments.shape == (0, 2, 2)


def test_warp_with_segments_keeps_a_straight_edge_straight(rng):
    """A vertical bar pushed sideways by a segment along it stays a straight bar (point
    handles at the same ends bend it)."""
    image = np.zeros((128, 128), np.uint8)
    image[16:112, 60:68] = 255
    a = np.array([[[64.0, 16.0], [64.0, 111.0]]])
    b = a + [[[20.0, 0.0], [20.0, 0.0]]]
    b[0, 1, 0] += 10.0  # and tilted
    pins = np.array([[0.0, 0.0], [127.0, 0.0], [0.0, 127.0], [127.0, 127.0]])
    for method in set(glmls.METHODS) - {"splat"}:  # splat moves whole pixels: a staircase
        out = glmls.warp(
            image, pins, pins, src_segments=a, dst_segments=b, method=method, interpolation="linear"
        )
        rows = np.arange(24, 104)
        centre = np.array([np.average(np.arange(128), weights=out[r] + 1e-9) for r in rows])
        line = np.polyval(np.polyfit(rows, centre, 1), rows)
        assert np.abs(centre - line).max() < 0.35, method


@pytest.mark.parametrize(
    ("src_segments", "dst_segments", "message"),
    [
        ([[[0, 0], [5, 5]]], None, "src_segments needs dst_segments"),
        (None, [[[0, 0], [5, 5]]], "dst_segments needs src_segments"),
        ([[0, 0], [5, 5]], [[0, 0], [5, 5]], r"shape \(S, 2, 2\)"),
        ([[[0, 0], [5, 5]]], [[[0, 0], [5, 5]], [[1, 1], [2, 2]]], "same length"),
        ([[[3, 3], [3, 3]]], [[[0, 0], [5, 5]]], "zero length"),
        ([[[0, 0], [np.nan, 5]]], [[[0, 0], [5, 5]]], "finite"),
        ([[[0, 0], [5, 5]]], [[[0, 0], [np.inf, 5]]], "finite"),
        (
            [[[0, 0], [5, 5]], [[5, 5], [0, 0]]],
            [[[0, 0], [5, 5]], [[0, 0], [5, 6]]],
            "same segment",
        ),
        ([[[0, 0], [5e6, 5]]], [[[0, 0], [5, 5]]], "within"),
        ([[[0, 0], [5, 5]], [[1, 1]]], [[[0, 0], [5, 5]], [[1, 1]]], r"src_segments .*lengths"),
        (np.zeros((0, 5)), np.zeros((0, 5)), r"src_segments must have shape \(S, 2, 2\)"),
    ],
)
def test_bad_segments_raise_value_errors_naming_them(src_segments, dst_segments, message):
    with pytest.raises(ValueError, match=message):
        glmls.MLS(NONE, NONE, src_segments=src_segments, dst_segments=dst_segments)


def test_non_numeric_segments_raise_type_error():
    with pytest.raises(TypeError, match="src_segments"):
        glmls.MLS(
            NONE, NONE, src_segments=[[["a", "b"], ["c", "d"]]], dst_segments=[[[0, 0], [1, 1]]]
        )


def test_affine_needs_handles_that_span_the_plane():
    on_a_line = np.array([[[0.0, 0.0], [10.0, 0.0]], [[20.0, 0.0], [30.0, 0.0]]])
    with pytest.raises(glmls.DegenerateHandlesError):
        glmls.MLS(NONE, NONE, src_segments=on_a_line, dst_segments=on_a_line, transform="affine")
    # one segment and a point off its line is enough
    glmls.MLS([[5.0, 5.0]], [[5.0, 6.0]], src_segments=on_a_line[:1], dst_segments=on_a_line[:1],
              transform="affine").release()  # fmt: skip


def test_polyline_segments():
    vertices = [[0, 0], [10, 0], [10, 5]]
    assert polyline_segments(vertices).tolist() == [[[0, 0], [10, 0]], [[10, 0], [10, 5]]]
    assert glmls.polyline_segments(vertices).shape == (2, 2, 2)
    with pytest.raises(ValueError, match="at least 2 vertices"):
        polyline_segments([[0, 0]])


def test_repr_counts_segments(rng):
    a, b = random_segments(rng, 3)
    with glmls.MLS(NONE, NONE, src_segments=a, dst_segments=b) as m:
        assert "3 segments" in repr(m)


@pytest.mark.parametrize("transform", ["similarity", "rigid"])
def test_the_bins_keep_a_gaussian_s_far_tail_beyond_every_segment_s_reach(transform):
    """The bins list a segment where the gaussian's cut is measured from the point itself;
    farther from every handle the cut is relative to the nearest, and there the segments,
    however far, decide f: through the bins as over every handle and in float64."""
    a = np.array([[[100.0, 100.0], [300.0, 120.0]], [[120.0, 400.0], [320.0, 380.0]]])
    b = a + np.array([[[6.0, -4.0]], [[-5.0, 7.0]]])
    options = {"weight": "gaussian", "radius": 8.0, "transform": transform, "shape": (512, 512)}
    far = np.array([[200.0, 250.0], [480.0, 40.0], [20.0, 480.0], [500.0, 500.0]])
    with glmls.MLS(NONE, NONE, src_segments=a, dst_segments=b, bins=True, **options) as m:
        reach = m.kernel.bins.reach * m.kernel.scaling.scale
        assert np.sqrt(segment_feet(a, far)[2].min()) > 2.0 * reach  # beyond every list
        binned = m(far)
    f_ref = reference.mls(NONE, NONE, far, src_segments=a, dst_segments=b, **options)[0]
    assert np.abs(f_ref - far).max() > 3.0  # the tail moves
    assert_allclose(binned, f_ref, atol=1e-2)
