"""Handles binned into a spatial grid give the plain evaluation's f."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

import glmls
from glmls import reference
from glmls.core.weights import GAUSSIAN_CAP, GAUSSIAN_TOLERANCE, gaussian_cut
from glmls.engine.bins import HandleBins, worth_binning

SHAPE = (512, 512)


def dense_handles(rng, n, size=512.0, displacement=4.0):
    p = rng.uniform(0, size, (n, 2))
    return p, p + rng.uniform(-displacement, displacement, p.shape)


def plain_and_binned(p, q, v, **options):
    """f at ``v`` evaluated over all handles and through bins, and the bins used."""
    with glmls.MLS(p, q, bins=False, **options) as plain:
        f_plain = plain(v)
    with glmls.MLS(p, q, bins=True, **options) as binned:
        assert binned.kernel.bins is not None
        return f_plain, binned(v), binned.kernel.bins


@pytest.mark.parametrize(
    "options",
    [
        {"weight": "cressman"},
        {"weight": "shepard"},
        {"weight": "linear", "transform": "affine"},
        {"weight": "gaussian", "radius": 6.0},
        {"weight": "cressman", "interpolating": True, "transform": "similarity"},
    ],
)
def test_binned_equals_plain_and_reference(gl, rng, options):
    options = {"radius": 20.0} | options
    p, q = dense_handles(rng, 1500)
    # points everywhere, on handles, and outside every handle's reach
    v = np.concatenate([rng.uniform(-0.5, 511.5, (1500, 2)), p[:50], [[-300.0, 900.0]]])
    f_plain, f_bins, _ = plain_and_binned(p, q, v, shape=SHAPE, ctx=gl, **options)
    # The sums run in another order: float32 rounding, which the ill-conditioned affine fits
    # of a few handles in reach amplify (measured 3e-5 px; affine 3e-3 px at worst).
    tolerance = 5e-3 if options.get("transform") == "affine" else 2e-4
    assert_allclose(f_bins, f_plain, rtol=0, atol=tolerance)
    f_ref, _, _ = reference.mls(p, q, v[:300], shape=SHAPE, **options)
    assert_allclose(f_bins[:300], f_ref, rtol=0, atol=0.01)


def test_dense_gaussian_cut_equals_plain(gl, rng):
    """Where many handles are near a point, W1 >> 1 moves the gaussian cut nearer."""
    p, q = dense_handles(rng, 4000, size=256.0, displacement=2.0)  # ~30 within R of a point
    v = rng.uniform(0, 255, (1000, 2))
    options = {"weight": "gaussian", "radius": 8.0, "shape": (256, 256), "ctx": gl}
    f_plain, f_bins, _ = plain_and_binned(p, q, v, **options)
    assert_allclose(f_bins, f_plain, rtol=0, atol=2e-4)


def test_gaussian_far_from_every_handle_equals_plain(gl, rng):
    """Points with no handle within reach widen their search (no pass over every handle)."""
    p, q = dense_handles(rng, 600, size=64.0, displacement=1.0)  # a cluster in one corner
    v = np.concatenate([rng.uniform(0, 511, (1000, 2)), [[-900.0, 2000.0], [511.0, 511.0]]])
    options = {"weight": "gaussian", "radius": 2.0, "shape": SHAPE, "ctx": gl}
    f_plain, f_bins, _ = plain_and_binned(p, q, v, **options)
    assert_allclose(f_bins, f_plain, rtol=0, atol=2e-4)


def test_gaussian_cut_keeps_the_handles_apart_from_the_nearest(gl, rng):
    """Handles 25 px apart with R = 4 px: next to a handle the others weigh exp(-30) of it
    and less, below the cut measured against the nearest (ln(N / tau) ~ 22.6), yet their
    moments about it decide M. The cut is measured against the nearest handles apart from
    the nearest one's place, so the bins keep them."""
    y, x = np.mgrid[0:20, 0:20] * 25.0 + 10.0
    p = np.stack([x.ravel(), y.ravel()], 1)
    q = p + rng.uniform(-3, 3, p.shape)
    v = p[rng.choice(len(p), 200)] + rng.uniform(-3, 3, (200, 2))
    d2 = np.sort(((p[None] - v[:, None]) ** 2).sum(-1), axis=1)
    assert np.median((d2[:, 1] - d2[:, 0]) / 16.0) > 25.0
    options = {"weight": "gaussian", "radius": 4.0, "shape": SHAPE, "ctx": gl}
    f_plain, f_bins, _ = plain_and_binned(p, q, v, **options)
    assert_allclose(f_bins, f_plain, rtol=0, atol=2e-4)
    f_ref, m_ref, _ = reference.mls(p, q, v, weight="gaussian", radius=4.0)
    assert (np.abs(m_ref - np.eye(2)).max(axis=(1, 2)) > 1e-6).all()
    assert_allclose(f_bins, f_ref, rtol=0, atol=2e-3)


@pytest.mark.parametrize("weight, radius, n", [("gaussian", 3.0, 8), ("cressman", 40.0, 4)])
def test_few_handles_far_apart_equal_plain(gl, rng, weight, radius, n):
    """More bin rows than handles: the points visit every handle instead of the rows."""
    p = rng.uniform(0, 512, (n, 2))
    q = p + rng.uniform(-5, 5, p.shape)
    v = rng.uniform(0, 511, (2000, 2))
    options = {"weight": weight, "radius": radius, "shape": SHAPE, "ctx": gl}
    f_plain, f_bins, bins = plain_and_binned(p, q, v, **options)
    assert bins.dims[1] > n
    assert_allclose(f_bins, f_plain, rtol=0, atol=2e-4)


def test_gaussian_cut_constants_reach_the_shader(gl, rng):
    """The tolerance is compiled in from the registry (a float define), not copied by hand."""
    p, q = dense_handles(rng, 300)
    with glmls.MLS(p, q, weight="gaussian", radius=8.0, ctx=gl, bins=True) as m:
        defines = m.kernel.defines()
    assert defines["MLS_GAUSSIAN_TOLERANCE"] == GAUSSIAN_TOLERANCE == 2.0**-24
    assert defines["MLS_GAUSSIAN_CAP"] == GAUSSIAN_CAP == 60.0
    assert defines["MLS_REACH_GAUSSIAN"] and defines["MLS_BINS"]
    assert gaussian_cut(65536) == pytest.approx(math.log(65536) + 24 * math.log(2))


def test_binned_warp_equals_plain(gl, rng):
    p, q = dense_handles(rng, 600, size=128.0, displacement=2.0)
    img = rng.integers(0, 255, (128, 128), dtype=np.uint8)
    with glmls.MLS(p, q, weight="cressman", radius=10.0, ctx=gl, bins=False) as plain:
        expected = plain.warp(img, grid=2)
    with glmls.MLS(p, q, weight="cressman", radius=10.0, ctx=gl, bins=True) as binned:
        out = binned.warp(img, grid=2)
    assert (out == expected).mean() > 0.999  # nearest ties at float32 noise only


def test_bins_follow_the_image_radius(gl, rng):
    """Without a radius the image diagonal is used: another image size rebuilds the bins."""
    p, q = dense_handles(rng, 400, size=64.0, displacement=1.0)
    with glmls.MLS(p, q, weight="linear", shape=(64, 64), ctx=gl, bins=True) as m:
        first = m.kernel.bins.reach
        m.warp(np.zeros((32, 32), np.uint8))
        assert m.kernel.bins.reach == pytest.approx(first / 2)  # the diagonal halved


def test_bins_sort_every_handle_once(rng):
    points = rng.uniform(-1, 1, (1000, 2))
    bins = HandleBins.build(points, 0.1, 0.1)
    assert sorted(bins.order) == list(range(1000))
    assert bins.starts[0] == 0 and bins.starts[-1] == 1000
    assert (np.diff(bins.starts) >= 0).all()
    assert len(bins.starts) == bins.dims[0] * bins.dims[1] + 1


def test_automatic_choice_and_bad_options(gl, rng):
    p, q = dense_handles(rng, 300)
    assert worth_binning("cressman", 0.02, p / 256)
    assert not worth_binning("idw", 0.02, p / 256)
    assert not worth_binning("cressman", 0.02, p[:100] / 256)  # too few
    with glmls.MLS(p, q, weight="cressman", radius=10.0, ctx=gl) as m:
        assert m.kernel.bins is not None
    with glmls.MLS(p, q, weight="cressman", shape=SHAPE, ctx=gl) as m:
        assert m.kernel.bins is None  # the diagonal reaches everything
    with pytest.raises(ValueError, match="bins need a weight with a radius"):
        glmls.MLS(p, q, ctx=gl, bins=True)
    with pytest.raises(ValueError, match="bins need a radius"):
        glmls.MLS(p, q, weight="linear", ctx=gl, bins=True)
    with pytest.raises(TypeError, match="bins must be True, False or None"):
        glmls.MLS(p, q, weight="linear", radius=5.0, ctx=gl, bins="yes")


def test_a_gaussian_with_many_segments_takes_its_bins(gl):
    """The fallback that visits every segment walks each segment once (u_segment_count in
    mls/visit.glsl), not once per bin that lists it: 300 short segments and 400 points of a
    gaussian of R = 3 on 256^2 crowd no bin (at most 14 segments and 2 points a bin) and take
    bins where asked, or by themselves, with f as without them."""
    rng = np.random.default_rng(0)
    p = rng.uniform(0, 256, (400, 2))
    q = p + rng.uniform(-2, 2, p.shape)
    a = rng.uniform(0, 256, (300, 2, 2))
    a[:, 1] = a[:, 0] + rng.uniform(-8, 8, (300, 2))
    b = a + rng.uniform(-2, 2, (300, 1, 2))
    options = {"src_segments": a, "dst_segments": b, "weight": "gaussian", "radius": 3.0}
    v = rng.uniform(0, 256, (400, 2))
    with glmls.MLS(p, q, bins=False, ctx=gl, **options) as m:
        plain = m(v)
    with glmls.MLS(p, q, bins=None, ctx=gl, **options) as m:
        assert m.kernel.bins is not None
    with glmls.MLS(p, q, bins=True, ctx=gl, **options) as m:
        np.testing.assert_allclose(m(v), plain, atol=2e-4)
