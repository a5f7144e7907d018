"""GPU (float32, scaled coordinates) against the float64 reference."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from helpers import random_handles
from numpy.testing import assert_allclose

import glmls
from glmls import reference

SHAPE = (1024, 1024)
COMBOS = list(itertools.product(glmls.TRANSFORMS, glmls.WEIGHTS))


def _far_points(rng, p, k=6000):
    v = rng.uniform(-0.5, 1023.5, (k, 2))
    d = np.sqrt(((v[:, None, :] - p[None, :, :]) ** 2).sum(-1)).min(axis=1)
    return v[d > 0.5]


@pytest.mark.parametrize(("transform", "weight"), COMBOS)
@pytest.mark.parametrize("n", [3, 256])
def test_matches_reference_within_a_hundredth_pixel(gl, rng, transform, weight, n):
    p, q = random_handles(rng, n)
    v = _far_points(rng, p)
    with glmls.MLS(p, q, transform=transform, weight=weight, shape=SHAPE, ctx=gl) as m:
        f = m(v)
        big_m, t = m.matrices(v)
    f_ref, m_ref, t_ref = reference.mls(p, q, v, m.config, shape=SHAPE)
    assert_allclose(f, f_ref, rtol=0, atol=0.01)  # the bound: 0.01 px
    assert_allclose(big_m, m_ref, rtol=0, atol=1e-4)
    assert_allclose(t, t_ref, rtol=0, atol=0.1)  # T = f - v M: M's error times |v| ~ 1000
    assert_allclose(np.einsum("ki,kij->kj", v, big_m) + t, f, rtol=0, atol=1e-6)


@pytest.mark.parametrize("transform", glmls.TRANSFORMS)
@pytest.mark.parametrize(
    "options",
    [
        {"weight": "idw"},
        {"weight": "idw", "s": 0.0},
        {"weight": "idw", "alpha": 2.0},
        {"weight": "shepard"},
        {"weight": "cressman", "interpolating": True},
        {"weight": "gaussian", "interpolating": True, "radius": 200.0},
        {"weight": "linear", "interpolating": True, "alpha": 0.5},
    ],
)
def test_interpolates_handles_within_a_millipixel(gl, rng, transform, options):
    p, q = random_handles(rng, 256)
    with glmls.MLS(p, q, transform=transform, shape=SHAPE, ctx=gl, **options) as m:
        assert_allclose(m(p), q, rtol=0, atol=1e-3)


@pytest.mark.parametrize("weight", ["cressman", "gaussian", "linear"])
def test_finite_weights_do_not_interpolate(gl, rng, weight):
    """The documented caveat: with a wide radius, f(p_i) misses q_i by pixels."""
    p, q = random_handles(rng, 64)
    with glmls.MLS(p, q, weight=weight, shape=SHAPE, ctx=gl) as m:
        miss = np.abs(m(p) - q).max()
    f_ref, _, _ = reference.mls(p, q, p, weight=weight, shape=SHAPE)
    assert miss > 5.0
    assert np.abs(f_ref - q).max() > 5.0


def test_large_alpha_and_far_points_stay_finite(gl, rng):
    p, q = random_handles(rng, 32)
    far = np.array([[-5000.0, 7000.0], [1e5, -1e5]])
    for options in ({"weight": "idw", "alpha": 4.0}, {"weight": "gaussian", "radius": 60.0}):
        with glmls.MLS(p, q, transform="similarity", ctx=gl, **options) as m:
            f = m(np.concatenate([p + 2.0, far]))
        f_ref, _, _ = reference.mls(
            p, q, np.concatenate([p + 2.0, far]), **options, transform="similarity"
        )
        assert np.isfinite(f).all()
        assert_allclose(f, f_ref, rtol=1e-5, atol=0.05)
