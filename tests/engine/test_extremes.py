"""Extreme but valid values give finite answers (never NaN or inf), and values outside the
documented range are refused with a ValueError naming it."""

from __future__ import annotations

import re

import numpy as np
import pytest
from numpy.testing import assert_allclose

import glmls
from glmls import reference
from glmls.core.handles import COORDINATE_LIMIT
from glmls.gl.context import create_headless

P = np.array([[100.0, 100.0], [300.0, 120.0], [200.0, 300.0], [120.0, 260.0]])
Q = P + np.array([[5.0, 0.0], [0.0, 5.0], [-4.0, 3.0], [2.0, -2.0]])
POINTS = np.concatenate([P, [[150.0, 150.0], [0.0, 0.0], [511.0, 511.0], [-3000.0, 9000.0]]])


@pytest.mark.parametrize("weight", glmls.RADIUS_WEIGHTS)
@pytest.mark.parametrize("radius", [1e-30, 1e-4, 1e-2, 1e30, 1e300])
def test_tiny_and_huge_radii_give_finite_results(gl, weight, radius):
    """A radius far below a pixel: each point follows its nearest handle (gaussian) or none
    reaches it; far beyond the image: the global fit of every handle."""
    for interpolating in (False, True):
        options = {"weight": weight, "radius": radius, "interpolating": interpolating}
        with glmls.MLS(P, Q, ctx=gl, **options) as m:
            f = m(POINTS)
            big_m, t = m.matrices(POINTS)
            field = m.error_field((24, 32), grid=4)
        assert np.isfinite(f).all() and np.isfinite(big_m).all() and np.isfinite(t).all()
        assert np.isfinite(field).all()
        f_ref, _, _ = reference.mls(P, Q, POINTS, **options)
        assert np.isfinite(f_ref).all()
        assert_allclose(f, f_ref, rtol=0, atol=0.01)


def test_a_huge_radius_is_the_global_fit(gl):
    """R = 1e300 (not representable in float32): every weight is flat, so f is the one
    least-squares fit of all handles, for linear and cressman as for gaussian."""
    with glmls.MLS(P, Q, weight="gaussian", radius=1e6, transform="affine", ctx=gl) as m:
        expected = m(POINTS)
    for weight in ("linear", "cressman", "gaussian"):
        with glmls.MLS(P, Q, weight=weight, radius=1e300, transform="affine", ctx=gl) as m:
            assert_allclose(m(POINTS), expected, rtol=0, atol=1e-3)


def test_huge_radii_with_bins_forced(gl, rng):
    p = rng.uniform(0, 512, (300, 2))
    q = p + rng.uniform(-3, 3, p.shape)
    for weight in glmls.RADIUS_WEIGHTS:
        with glmls.MLS(p, q, weight=weight, radius=1e300, bins=True, ctx=gl) as m:
            assert np.isfinite(m(POINTS)).all(), weight


def test_coordinates_beyond_the_limit_are_refused(gl):
    far = COORDINATE_LIMIT * 2
    for src, dst in (
        (np.array([[far, 0.0]]), np.array([[0.0, 0.0]])),
        (P, np.concatenate([Q[:3], [[1e30, 1e30]]])),
        (np.array([[-1.7e308, 0.0], [1.7e308, 1.0]]), np.array([[0.0, 0.0], [1.0, 1.0]])),
    ):
        with pytest.raises(ValueError, match=re.escape(f"within ±{COORDINATE_LIMIT:.0e} px")):
            glmls.MLS(src, dst, ctx=gl)
        with pytest.raises(ValueError, match="within"):
            reference.mls(src, dst, POINTS)
    with glmls.MLS(P, Q, ctx=gl) as m:
        with pytest.raises(ValueError, match="points must lie within"):
            m([[1e300, 1e300]])
        at_limit = m([[COORDINATE_LIMIT, -COORDINATE_LIMIT]])
    assert np.isfinite(at_limit).all()


def test_handles_far_apart_within_the_limit_keep_their_displacements(gl):
    """Handles a million pixels apart: float32 keeps ~0.1 px of such an extent."""
    p = np.array([[0.0, 0.0], [0.9, 0.0], [0.0, 0.9]]) * COORDINATE_LIMIT
    q = p + 10.0
    with glmls.MLS(p, q, ctx=gl) as m:
        f = m(p)
    assert_allclose(f, q, rtol=0, atol=0.2)


def test_error_stats_do_not_overflow():
    stats = glmls.analysis.error_stats([1e308, 1e308, -1e308])
    assert stats["mean"] == pytest.approx(1e308 / 3)
    assert np.isfinite(stats["std"]) and stats["std"] == pytest.approx(np.sqrt(8 / 9) * 1e308)
    assert stats["within"] == pytest.approx([2 / 3, 1.0, 1.0])  # deviations 2/3, 2/3, 4/3
    assert glmls.analysis.error_stats([1e-320, 0.0])["mean"] == pytest.approx(5e-321)


def test_grids_of_numpy_integers_and_out_of_range(gl):
    image = np.zeros((20, 30, 3), np.uint8)
    out = glmls.warp(image, P / 20, Q / 20, grid=np.int64(4), ctx=gl)
    assert out.shape == image.shape
    with glmls.MLS(P, Q, ctx=gl) as m:
        assert m.error_field((8, 8), grid=np.int32(2)).shape == (8, 8)
        for bad in (2**31, 10**7):
            with pytest.raises(ValueError, match="grid must be an integer from 1 to"):
                m.warp(image, grid=bad)


# -- the fuzz ----------------------------------------------------------------------------------

KINDS = ("random", "clustered", "tiny radius", "huge radius", "huge displacement", "collinear")


def fuzz_case(rng, kind):
    n = int(rng.integers(1, 40))
    p = rng.uniform(-50, 560, (n, 2))
    q = p + rng.normal(0, 8, p.shape)
    options = {
        "transform": str(rng.choice(glmls.TRANSFORMS)),
        "weight": str(rng.choice(glmls.WEIGHTS)),
        "alpha": float(rng.choice([0.1, 0.5, 1.0, 2.0, 5.0])),
        "s": float(rng.choice([0.0, 1e-8, 1.0])),
        "radius": float(10 ** rng.uniform(0.5, 3)),
        "interpolating": bool(rng.integers(2)),
    }
    if kind == "clustered":
        p = p[:1] + rng.normal(0, 10 ** rng.uniform(-3, 0), p.shape)
        q = p + rng.normal(0, 5, p.shape)
    elif kind == "tiny radius":
        options["radius"] = float(10 ** rng.uniform(-30, -1))
    elif kind == "huge radius":
        options["radius"] = float(10 ** rng.uniform(4, 300))
    elif kind == "huge displacement":
        q = p + rng.normal(0, 10 ** rng.uniform(3, 5), p.shape)
    elif kind == "collinear":
        t = rng.uniform(0, 500, n)
        p = np.stack([t, 0.5 * t + 20], -1) + rng.normal(0, 1e-6, (n, 2))
        q = p + rng.normal(0, 6, p.shape)
    _, first = np.unique(p, axis=0, return_index=True)  # one target per source point
    return p[np.sort(first)], q[np.sort(first)], options


@pytest.fixture(scope="module")
def roomy():
    """A context keeping every program the fuzz compiles (its configurations number ~200)."""
    ctx = create_headless(max_programs=1024)
    yield ctx
    ctx.release()


def test_fuzz_every_transform_and_weight_stays_finite(roomy):
    """2,400 handle sets mixing the hard cases: f, M, T and the error field are finite."""
    gl = roomy
    rng = np.random.default_rng(2026)
    points = np.concatenate([rng.uniform(-100, 600, (40, 2)), [[0.0, 0.0], [255.5, 255.5]]])
    tried = 0
    for i in range(2400):
        kind = KINDS[i % len(KINDS)]
        p, q, options = fuzz_case(rng, kind)
        try:
            m = glmls.MLS(p, q, shape=(512, 512), ctx=gl, **options)
        except glmls.DegenerateHandlesError:
            continue  # affine on (near) collinear handles: refused, as documented
        with m:
            v = np.concatenate([points, p[:5]])
            f = m(v)
            big_m, t = m.matrices(v)
            assert np.isfinite(f).all(), (kind, options, p, q)
            assert np.isfinite(big_m).all() and np.isfinite(t).all(), (kind, options)
            if i % 12 == 0:
                assert np.isfinite(m.error_field((16, 16), grid=4)).all(), (kind, options)
        tried += 1
    assert tried > 2000


@pytest.mark.parametrize("dimension", [2, 3])
@pytest.mark.parametrize("transform", glmls.TRANSFORMS)
def test_an_interpolating_gaussian_of_a_small_radius_stays_finite(gl, transform, dimension):
    """The gaussian made interpolating, alpha 5, R well below the handles' spacing: the
    nearest handle's weight is the gaussian's cap (e^60) times its bounded power, within
    float32 (it overflowed to inf: NaN f next to a handle and far from every one)."""
    rng = np.random.default_rng(0)
    p = rng.uniform(0, 500, (4, dimension))
    q = p + rng.normal(0, 5, p.shape)
    v = np.concatenate([rng.uniform(-100, 600, (30, dimension)), p + 1e-3, p + 0.3])
    options = {"weight": "gaussian", "radius": 0.05, "alpha": 5.0, "s": 1.0, "interpolating": True}
    with glmls.MLS(p, q, transform=transform, shape=(512,) * dimension, ctx=gl, **options) as m:
        f = m(v)
        big_m, t = m.matrices(v)
    assert np.isfinite(f).all() and np.isfinite(big_m).all() and np.isfinite(t).all()


@pytest.mark.parametrize("transform", ["affine", "similarity", "rigid"])
@pytest.mark.parametrize("size", [1e-2, 1e-4, 1e-6])
def test_handles_a_few_thousandths_apart_with_s_0(gl, transform, size):
    """Handles in a box of ``size`` units (points in metres, s=0): a point near a handle snaps
    to it only where the other handles' share of the weights is below float32's rounding, so
    f follows the float64 f as it does for handles in pixels (f is scale-invariant with s=0),
    for the alphas below 1 too."""
    rng = np.random.default_rng(5)
    src = rng.uniform(0, size, (8, 2))
    dst = src + rng.normal(0, 0.05 * size, src.shape)
    points = rng.uniform(0, size, (500, 2))
    for alpha in (1.0, 0.5):
        options = {"transform": transform, "s": 0, "alpha": alpha}
        expected = reference.mls(src, dst, points, **options)[0]
        with glmls.MLS(src, dst, ctx=gl, **options) as m:
            f = m(points)
        assert np.abs(f - expected).max() < 2e-6 * size, (alpha, np.abs(f - expected).max())


def test_segments_a_few_thousandths_apart_with_s_0(gl):
    """The same for segment handles: their end points set the extent too."""
    rng = np.random.default_rng(6)
    size = 1e-5
    src_segments = rng.uniform(0, size, (3, 2, 2))
    dst_segments = src_segments + rng.normal(0, 0.05 * size, src_segments.shape)
    points = rng.uniform(0, size, (300, 2))
    empty = np.zeros((0, 2))
    handles = {"src_segments": src_segments, "dst_segments": dst_segments}
    expected = reference.mls(empty, empty, points, s=0, **handles)[0]
    with glmls.MLS(empty, empty, ctx=gl, s=0, **handles) as m:
        f = m(points)
    assert np.abs(f - expected).max() < 2e-5 * size


@pytest.mark.parametrize("dimension", [2, 3])
def test_handles_spread_below_what_float32_resolves_are_refused(gl, dimension):
    """Source handles spread over 1e-14 or 1e-20 units (their box and the scale, at least 1
    unit): float32's squared distances fell under the weights' smallest normal numbers and f
    came out wrong by 1-40 % of the spread (NaN for affine idw in 3D); now a ValueError. At
    1e-12 units f is still the float64 reference's, and one source point (spread 0) passes."""
    rng = np.random.default_rng(3)
    src = rng.uniform(0, 10, (6, dimension))
    dst = src + rng.normal(0, 0.5, src.shape)
    for k in (1e-14, 1e-20):
        with pytest.raises(ValueError, match=r"the source handles span .* float32 on the GPU"):
            glmls.MLS(src * k, dst * k, s=0, ctx=gl)
    points = rng.uniform(0, 10, (20, dimension))
    for transform in ("affine", "rigid"):
        with glmls.MLS(src * 1e-12, dst * 1e-12, transform=transform, s=0, ctx=gl) as m:
            found = m(points * 1e-12)
        expected = reference.mls(
            src * 1e-12, dst * 1e-12, points * 1e-12, transform=transform, s=0
        )[0]
        assert np.abs(found - expected).max() < 1e-5 * 10e-12
    with glmls.MLS(src[:1] * 1e-20, dst[:1] * 1e-20, ctx=gl) as m:  # a translation
        assert np.allclose(m(points * 1e-20), points * 1e-20 + (dst[0] - src[0]) * 1e-20)


def test_a_batch_names_the_image_whose_handles_float32_cannot_resolve(gl):
    rng = np.random.default_rng(4)
    src = rng.uniform(0, 6, (3, 5, 2))
    src[1] *= 1e-15
    with pytest.raises(ValueError, match=r"images\[1\]: the source handles span"):
        glmls.warp_batch(np.zeros((3, 1, 1), np.uint8), src, src, ctx=gl)
