"""The float64 reference against independent solutions of the least-squares problem (eq. 2)."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import random_handles
from numpy.testing import assert_allclose
from scipy.optimize import minimize

import glmls
from glmls import reference
from glmls.core.config import MLSConfig


def _weighted_lstsq_affine(p, q, w):
    """Minimise sum w |[p 1] X - q|^2 with numpy's lstsq: X = [M; T]."""
    a = np.hstack([p, np.ones((len(p), 1))]) * np.sqrt(w)[:, None]
    x, *_ = np.linalg.lstsq(a, q * np.sqrt(w)[:, None], rcond=None)
    return x[:2], x[2]


def _brute_force(p, q, w, transform):
    """Minimise eq. (2) numerically over the transform's parameters."""

    def unpack(x):
        if transform == "similarity":
            m = np.array([[x[0], x[1]], [-x[1], x[0]]])
        else:
            m = np.array([[np.cos(x[0]), np.sin(x[0])], [-np.sin(x[0]), np.cos(x[0])]])
        return m, x[-2:]

    def cost(x):
        m, t = unpack(x)
        return (w * ((p @ m + t - q) ** 2).sum(1)).sum()

    x0 = [1.0, 0.0, 0.0, 0.0] if transform == "similarity" else [0.0, 0.0, 0.0]
    best = min(
        (
            minimize(cost, np.array(x0) + np.array([a] + [0] * (len(x0) - 1)), method="BFGS")
            for a in (0.0, 2.0, -2.0)
        ),
        key=lambda r: r.fun,
    )
    return unpack(best.x)


@pytest.mark.parametrize("transform", glmls.TRANSFORMS)
@pytest.mark.parametrize("weight", glmls.WEIGHTS)
def test_reference_solves_the_weighted_least_squares(rng, transform, weight):
    p, q = random_handles(rng, 12, size=400, displacement=50)
    config = MLSConfig(transform=transform, weight=weight, radius=500.0)
    v = rng.uniform(0, 400, (5, 2))
    f, big_m, t = reference.mls(p, q, v, config)
    for k in range(len(v)):
        d2 = ((p - v[k]) ** 2).sum(1)
        w = reference.weights(d2[None], config, 500.0)[0]
        if transform == "affine":
            m_expected, t_expected = _weighted_lstsq_affine(p, q, w)
        else:
            m_expected, t_expected = _brute_force(p, q, w / w.max(), transform)
        assert_allclose(big_m[k], m_expected, atol=1e-5)
        assert_allclose(t[k], t_expected, atol=1e-3)
        assert_allclose(f[k], v[k] @ m_expected + t_expected, atol=1e-3)


def test_weights_follow_table_1():
    d = np.array([[0.5, 1.0, 3.0, 12.0]])
    r = 10.0

    def w(**kw):
        return reference.weights(d**2, MLSConfig(**kw), r)[0]

    assert_allclose(w(weight="idw", alpha=2.0, s=0.1), 1 / (0.1 + d[0] ** 4))
    assert_allclose(w(weight="cressman"), np.maximum(0, (r**2 - d[0] ** 2) / (r**2 + d[0] ** 2)))
    assert_allclose(w(weight="shepard"), np.maximum(0, (r - d[0]) / (r * d[0])))
    # the Gaussian is scaled by its value at the nearest handle (MLS ignores common factors)
    g = np.exp(-(d[0] ** 2) / r**2)
    assert_allclose(w(weight="gaussian"), g / g.max())
    # linear is divided by R (a common factor), so that a huge R does not overflow
    assert_allclose(w(weight="linear"), np.maximum(0, r - d[0]) / r)
    assert_allclose(w(weight="linear", interpolating=True), np.maximum(0, r - d[0]) / d[0] ** 2 / r)
