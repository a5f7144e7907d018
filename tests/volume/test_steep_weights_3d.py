"""3D MLS next to a handle whose weight is steep: 1 / d^(2 alpha) with alpha > 1 (idw with
alpha 1.5 made interpolating, a radius weight made interpolating with alpha 2).

There the handle's own w d^2 grows without bound while the others' spread about p* stays
finite: that is no sign of coincident sources, and M is the other handles' fit, continuous
from 0.1 voxel down to the handle, where it is the limit (the fit of the others about p_h).
Checked in float64 against that limit computed here from its definition (Kabsch, Umeyama,
A^-1 B: the 8 handles are well spread, so no ridge applies), for ``glmls.reference`` and for
the GPU (f, M, and the Jacobian), whose float32 keeps the others' moments (~1e-27 next to
the handle) from underflowing.

Tolerances: M within 0.05 |v - p_h| of the limit (M moves by O(d) as the others' weights do),
plus 1e-9 for the reference; the GPU, in float32 on coordinates scaled to the handles' box,
within 3e-5 of the reference in M and 2e-5 voxel in f (it is within 5e-6 and 1e-6 with Mesa
llvmpipe), and its Jacobian within 2e-2 of the limit (central differences of 0.05 voxel,
across the handle within 0.055 voxel of it). A coincidence yardstick that counted the
handle's own w d^2 would take M to the identity there, 0.06 to 0.6 away from the limit.
"""

from __future__ import annotations

import numpy as np
import pytest

import glmls
from glmls import reference
from glmls.core.config import MLSConfig
from glmls.engine.passes3 import jacobian_steps

rng = np.random.default_rng(1)
P = rng.uniform(0, 50, (8, 3))
Q = P + rng.normal(0, 2, (8, 3))
HANDLES = [2, 5, 6]
DISTANCES = np.array([1e-1, 3e-2, 1e-2, 3e-3, 1.5e-3, 1e-3, 3e-4, 1e-4, 1e-5, 1e-6])
DIRECTIONS = np.array([[1.0, 0.5, 0.3], [-0.2, 1.0, -0.7], [0.4, -0.6, -1.0]])
DIRECTIONS /= np.linalg.norm(DIRECTIONS, axis=1, keepdims=True)

STEEP = [
    {"weight": "idw", "alpha": 1.5, "interpolating": True},
    {"weight": "gaussian", "radius": 30.0, "alpha": 2.0, "interpolating": True},
    {"weight": "shepard", "radius": 60.0, "alpha": 2.0, "interpolating": True},
    {"weight": "linear", "radius": 60.0, "alpha": 2.0, "interpolating": True},
]


def _points(h):
    """(len(DISTANCES) * len(DIRECTIONS), 3) points at those distances from handle h."""
    return (P[h] + DISTANCES[:, None, None] * DIRECTIONS[None]).reshape(-1, 3)


def _limit(config, h):
    """M at handle h by definition: the weighted fit of the other handles about p_h, q_h."""
    others = np.arange(len(P)) != h
    ph, qh = P[others] - P[h], Q[others] - Q[h]
    w = reference.weights((ph**2).sum(1)[None], config, config.radius)[0]
    a = np.einsum("n,ni,nj->ij", w, ph, ph)
    b = np.einsum("n,ni,nj->ij", w, ph, qh)
    e = np.linalg.eigvalsh(a)
    assert e.min() > 2e-3 * e.sum()  # well spread: the closed forms, no ridge (1e-3)
    if config.transform == "affine":
        return np.linalg.solve(a, b)
    u, _, vt = np.linalg.svd(b)
    u[:, 2] *= np.sign(np.linalg.det(u @ vt))
    r = u @ vt
    return r if config.transform == "rigid" else r * np.trace(r.T @ b) / np.trace(a)


def _cases():
    return [
        MLSConfig(transform=transform, **params)
        for transform in glmls.TRANSFORMS
        for params in STEEP
    ]


def _id(config):
    return f"{config.transform}-{config.weight}"


@pytest.mark.parametrize("config", _cases(), ids=_id)
def test_reference_m_is_continuous_up_to_the_handle(config):
    for h in HANDLES:
        limit = _limit(config, h)
        _, m_on, _ = reference.mls(P, Q, P[h : h + 1], config)
        assert np.abs(m_on[0] - limit).max() < 1e-9
        v = _points(h)
        _, big_m, _ = reference.mls(P, Q, v, config)
        off = np.abs(big_m - limit).max(axis=(1, 2))
        d = np.linalg.norm(v - P[h], axis=1)
        assert (off < 0.05 * d + 1e-9).all(), (h, d[off >= 0.05 * d + 1e-9])


@pytest.mark.parametrize("config", _cases(), ids=_id)
def test_gpu_m_is_continuous_up_to_the_handle(gl, config):
    v = np.concatenate([_points(h) for h in HANDLES])
    d = np.concatenate([np.linalg.norm(_points(h) - P[h], axis=1) for h in HANDLES])
    limits = np.repeat([_limit(config, h) for h in HANDLES], len(v) // len(HANDLES), axis=0)
    f_ref, m_ref, _ = reference.mls(P, Q, v, config)
    with glmls.MLS.from_config(P, Q, config) as m:
        f = m(v)
        big_m, _ = m.matrices(v)
        f_j, jac = m.jacobian(v)
    assert np.abs(f - f_ref).max() < 2e-5
    assert np.abs(f_j - f_ref).max() < 2e-5
    assert np.abs(big_m - m_ref).max() < 3e-5
    off = np.abs(big_m - limits).max(axis=(1, 2))
    assert (off < 0.05 * d + 3e-5).all(), d[off >= 0.05 * d + 3e-5]
    assert np.abs(jac - limits).max() < 2e-2


@pytest.mark.parametrize("transform", glmls.TRANSFORMS)
def test_m_is_the_fit_of_the_handles_apart_in_a_gaussians_far_tail(gl, transform):
    """As 2D (tests/test_float64_2d.py): tens of voxels from every handle with R = 4 voxels,
    where the others weigh exp(-30) to exp(-45) of the nearest, in the gaussian's tail:
    their spread about p* decides M however small their weights (the moments are taken
    about the nearest handle), in the reference and on the GPU, where M is no translation.
    (The nearest handle apart outweighs the rest there, so the fit is that of about two
    handles, whose turn about their axis the degenerate-set rule decides.) Float32 on the
    GPU: M within 4e-5 of the reference, f within 5e-3 voxel ~100 voxels from the handles
    (measured)."""
    config = MLSConfig(transform=transform, weight="gaussian", radius=4.0)
    v = np.random.default_rng(5).uniform(80, 120, (300, 3))
    d2 = np.sort(((P[None] - v[:, None]) ** 2).sum(-1), axis=1)
    excess = (d2[:, 1] - d2[:, 0]) / 16.0
    v = v[(excess > 30) & (excess < 45)]
    assert len(v) > 50
    f_ref, m_ref, _ = reference.mls(P, Q, v, config)
    assert (np.abs(m_ref - np.eye(3)).max(axis=(1, 2)) > 0.05).all()
    with glmls.MLS.from_config(P, Q, config) as m:
        assert np.abs(m(v) - f_ref).max() < 1e-2
        assert np.abs(m.matrices(v)[0] - m_ref).max() < 1e-4


STEEPER = [
    {"weight": "idw", "alpha": 8.0, "interpolating": True},
    {"weight": "cressman", "radius": 60.0, "alpha": 8.0, "interpolating": True},
    {"weight": "gaussian", "radius": 30.0, "alpha": 8.0, "interpolating": True},
]


@pytest.mark.parametrize(
    "config",
    [MLSConfig(transform=t, **params) for t in glmls.TRANSFORMS for params in STEEPER],
    ids=_id,
)
def test_gpu_m_next_to_a_handle_of_alpha_8(gl, config):
    """alpha = 8 made interpolating: next to a handle the others weigh (d / D)^16 of it, below
    float32's range from ~1e-2 voxel; relative to the nearest of them they are in range
    (as 2D, tests/test_float64_2d.py), and M is their fit, not the nearest's alone (I)."""
    v = np.concatenate([_points(h) for h in HANDLES])
    f_ref, m_ref, _ = reference.mls(P, Q, v, config)
    assert (np.abs(m_ref - np.eye(3)).max(axis=(1, 2)) > 0.02).all()  # I would fail below
    with glmls.MLS.from_config(P, Q, config) as m:
        f = m(v)
        big_m, _ = m.matrices(v)
        f_j, jac = m.jacobian(v)
        steps = jacobian_steps(m.kernel, v)
    assert np.abs(f - f_ref).max() < 2e-5
    assert np.abs(f_j - f_ref).max() < 2e-5
    assert np.abs(big_m - m_ref).max() < 1e-4
    # J: the float64 central differences of the GPU's step (1e-4 in measurements)
    expected = np.empty_like(jac)
    for axis in range(3):
        step = np.zeros_like(v)
        step[:, axis] = steps
        ahead, behind = (
            reference.mls(P, Q, v + step, config)[0],
            reference.mls(P, Q, v - step, config)[0],
        )
        expected[:, axis] = (ahead - behind) / (2 * steps[:, None])
    assert np.abs(jac - expected).max() < 5e-4
