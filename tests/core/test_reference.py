"""The float64 reference against independent solutions of the least-squares problem (eq. 2)."""

from __future__ import annotations

import re

import numpy as np
import pytest
from helpers import random_handles
from numpy.testing import assert_allclose
from scipy.optimize import minimize

import glmls
from glmls import reference
from glmls.analysis import ReferenceDeformation
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
    # the Gaussian is scaled by its value at the second nearest distance, that of the
    # nearest handles apart from the nearest one's place (MLS ignores common factors)
    g = np.exp(-(d[0] ** 2) / r**2)
    assert_allclose(w(weight="gaussian"), g / g[1])
    # linear is divided by R (a common factor), so that a huge R does not overflow
    assert_allclose(w(weight="linear"), np.maximum(0, r - d[0]) / r)
    assert_allclose(w(weight="linear", interpolating=True), np.maximum(0, r - d[0]) / d[0] ** 2 / r)


def _perp(a):
    return np.array([-a[1], a[0]])  # the paper's (x, y)^⊥ = (-y, x)


def _paper_closed_form(p, q, v, transform):
    """f(v) written out from Schaefer et al.'s closed forms, w_i = 1 / |p_i - v|^2."""
    w = 1.0 / np.sum((p - v) ** 2, axis=1)
    p_star, q_star = w @ p / w.sum(), w @ q / w.sum()  # eq. 4
    p_hat, q_hat = p - p_star, q - q_star
    if transform == "affine":  # eq. 5
        a = sum(wi * np.outer(pi, pi) for wi, pi in zip(w, p_hat, strict=True))
        b = sum(wi * np.outer(pi, qi) for wi, pi, qi in zip(w, p_hat, q_hat, strict=True))
        return (v - p_star) @ np.linalg.inv(a) @ b + q_star
    d = v - p_star
    a_i = [
        wi * np.array([pi, -_perp(pi)]) @ np.array([d, -_perp(d)]).T
        for wi, pi in zip(w, p_hat, strict=True)
    ]
    f_r = sum(qi @ ai for qi, ai in zip(q_hat, a_i, strict=True))
    if transform == "similarity":  # eq. 6: mu_s = sum w_i p̂_i p̂_i^T
        return f_r / sum(wi * pi @ pi for wi, pi in zip(w, p_hat, strict=True)) + q_star
    return np.linalg.norm(d) * f_r / np.linalg.norm(f_r) + q_star  # rigid


@pytest.mark.parametrize("transform", ["affine", "similarity", "rigid"])
def test_gpu_and_reference_follow_the_papers_closed_forms(gl, transform):
    """A hand case: four handles, one point, the paper's equations written out anew."""
    p = np.array([[0.0, 0.0], [4.0, 0.0], [0.0, 3.0], [5.0, 4.0]])
    q = np.array([[0.0, 1.0], [4.5, 0.0], [-1.0, 3.0], [5.0, 5.0]])
    v = np.array([1.0, 2.0])
    expected = _paper_closed_form(p, q, v, transform)
    f, _, _ = reference.mls(p, q, [v], MLSConfig(transform=transform, s=0.0))
    assert_allclose(f[0], expected, atol=1e-12)
    with glmls.MLS(p, q, transform=transform, s=0.0, ctx=gl) as m:
        assert_allclose(m([v])[0], expected, atol=1e-5)


@pytest.mark.parametrize("s", [1e30, 1e300])
def test_idw_of_a_huge_s_is_the_global_least_squares_fit(s):
    """s dwarfing every d^2 makes the weights equal: f is the unweighted fit everywhere.
    The weights 1 / s (1e-300) made the affine moments' determinant underflow to 0."""
    rng = np.random.default_rng(3)
    p = rng.uniform(0, 100, (6, 2))
    q = p + rng.normal(0, 5, (6, 2))
    v = rng.uniform(0, 100, (5, 2))
    big_m, t = _weighted_lstsq_affine(p, q, np.ones(len(p)))
    f, _, _ = reference.mls(p, q, v, MLSConfig(transform="affine", s=s))
    assert_allclose(f, v @ big_m + t, atol=1e-9)


P2 = np.array([[0.0, 0.0], [10.0, 0.0], [0.0, 10.0], [7.0, 7.0]])
P3 = np.array([[0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [0.0, 10.0, 0.0], [0.0, 0.0, 10.0]])


def _invalid_inputs(p):
    """(name, src, dst, points, keywords) that glmls.MLS refuses (or, for one point, takes)."""
    d = p.shape[1]
    point = p[:1] + 0.5
    duplicate = p.copy()
    duplicate[1] = duplicate[0]
    far = np.full((1, d), 2e6)
    image = (0, 5) if d == 2 else (0, 5, 4)
    return [
        ("points beyond the limit", p, p + 1, far, {}),
        ("src beyond the limit", np.concatenate([p[:-1], far]), p + 1, point, {}),
        ("dst beyond the limit", p, np.concatenate([p[:-1] + 1, far]), point, {}),
        ("one source, two targets", duplicate, p + 1, point, {}),
        ("an empty shape", p, p + 1, point, {"weight": "gaussian", "shape": image}),
        ("a shape of 4", p, p + 1, point, {"weight": "gaussian", "shape": (3, 5, 6, 7)}),
        ("one point as a (D,) array", p, p + 1, point[0], {}),
    ]


@pytest.mark.parametrize("p", [P2, P3], ids=["2D", "3D"])
def test_invalid_input_is_refused_as_the_gpu_refuses_it(gl, p):
    """The reference validates as glmls.MLS does: coordinates beyond ±1e6, one source point with
    two targets in 3D, a malformed shape (it accepted all of these), and one (D,) point, which
    MLS takes as a (1, D) row (the reference refused it)."""
    for name, src, dst, points, options in _invalid_inputs(p):
        try:
            with glmls.MLS(src, dst, ctx=gl, **options) as m:
                expected = m(points)
        except (ValueError, TypeError) as error:
            with pytest.raises(type(error), match=re.escape(str(error))):
                reference.mls(src, dst, points, **options)
        else:
            assert_allclose(reference.mls(src, dst, points, **options)[0], expected, atol=1e-4)
            assert name == "one point as a (D,) array"


@pytest.mark.parametrize(
    "call",
    [
        lambda config, **options: reference.mls(P2, P2 + 1.0, P2[:1], config, **options),
        lambda config, **options: reference.mls_error(P2, P2 + 1.0, P2[:1], config, **options),
        lambda config, **options: ReferenceDeformation(P3, P3 + 1.0, config, **options),
    ],
    ids=["mls", "mls_error", "ReferenceDeformation"],
)
def test_config_and_options_together_are_refused(call):
    """A configuration and keyword options at once would leave the options unused: an error
    naming them, rather than f of another weight than the one asked for."""
    with pytest.raises(TypeError, match="weight"):
        call(MLSConfig(), weight="gaussian", radius=5.0)
    call(MLSConfig(weight="gaussian", radius=5.0))
    call(None, weight="gaussian", radius=5.0)
