"""Float64 numpy reference of the MLS mathematics, written straight from the formulas.

Used by the tests to check the GPU; it is not a fallback path (it is slow: O(K N) memory).
Conventions as in :class:`glmls.MLS`: points are (x, y) rows, f(v) = v M + T with row vectors.

Degenerate cases follow the same rules as the shader (``glmls/shaders/mls/core.glsl``):
- a point exactly on a handle whose weight is infinite there: f = q_i, and M is the limit,
  the solution over the other handles about p_i;
- no handle in reach (compact-support weights): identity;
- coincident source handles in reach (spread about p* below 1e-13 of that about v): M = I;
- rigid with all targets in reach collapsed to one point: M = I;
- affine with a singular moment matrix: the similarity solution.
"""

from __future__ import annotations

import numpy as np

from .config import MLSConfig
from .handles import as_points, validate_handles


def weights(d2: np.ndarray, config: MLSConfig, radius: float | None) -> np.ndarray:
    """Table 1 weights for squared distances ``d2`` (K, N); +inf where infinite at d = 0.

    Each weight's formula is its registry entry's (``glmls.core.weights``); a common factor
    per point is allowed (the Gaussian is divided by its value at the nearest handle, so that
    it does not underflow far from every handle).
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        w = config.weight_entry.reference(d2, config, radius)
        if config.interpolating:
            w = w / d2**config.alpha
    return w


def _solve(a11, a12, a22, b, transform):
    """M (K, 2, 2) from moments; b has shape (K, 2, 2) with b[:, i, j] = sum w p^_i q^_j."""
    mu = a11 + a22
    big_a = b[:, 0, 0] + b[:, 1, 1]
    big_b = b[:, 0, 1] - b[:, 1, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        if transform == "rigid":
            norm = np.hypot(big_a, big_b)
            ok = norm > 1e-6 * mu
            norm = np.where(ok, norm, 1.0)
        else:
            norm = np.where(mu > 0, mu, 1.0)
            ok = np.ones_like(mu, dtype=bool)
        rot = (
            np.stack([np.stack([big_a, big_b], -1), np.stack([-big_b, big_a], -1)], -2)
            / norm[:, None, None]
        )
    rot[~ok] = np.eye(2)
    if transform != "affine":
        return rot
    det = a11 * a22 - a12**2
    regular = det > 1e-5 * mu**2
    safe = np.where(regular, det, 1.0)
    inv = np.stack([np.stack([a22, -a12], -1), np.stack([-a12, a11], -1)], -2) / safe[:, None, None]
    return np.where(regular[:, None, None], inv @ b, rot)


def mls(
    src: object,
    dst: object,
    points: object,
    config: MLSConfig | None = None,
    *,
    shape: tuple[int, int] | None = None,
    **options: object,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """f(points), M and T in float64: ``f = points @ M + T`` row by row.

    ``config`` or keyword options as for :class:`glmls.MLS`; ``shape`` gives the default
    radius (the image diagonal).
    """
    config = config if config is not None else MLSConfig(**options)  # type: ignore[arg-type]
    p, q = validate_handles(src, dst)
    v = as_points(points)
    k = len(v)
    f = v.copy()
    big_m = np.broadcast_to(np.eye(2), (k, 2, 2)).copy()
    if len(p) == 0 or k == 0:
        return f, big_m, f - np.einsum("ki,kij->kj", v, big_m)
    radius = config.resolve_radius(shape)

    dp = p[None, :, :] - v[:, None, :]  # p_i - v, (K, N, 2)
    dq = q[None, :, :] - v[:, None, :]
    d2 = (dp**2).sum(-1)
    w = weights(d2, config, radius)
    hit = np.isinf(w).any(axis=1)
    hit_index = np.argmax(np.isinf(w), axis=1)
    w = np.where(np.isinf(w), 0.0, w)  # the hit handle's p^ is 0: it drops out of the moments

    wsum = w.sum(axis=1)
    reached = hit | (wsum > 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        pst = np.where(
            hit[:, None], dp[np.arange(k), hit_index], (w[..., None] * dp).sum(1) / wsum[:, None]
        )
        qst = np.where(
            hit[:, None], dq[np.arange(k), hit_index], (w[..., None] * dq).sum(1) / wsum[:, None]
        )
    pst[~reached] = 0.0
    qst[~reached] = 0.0
    ph = dp - pst[:, None, :]
    qh = dq - qst[:, None, :]
    a11 = (w * ph[..., 0] ** 2).sum(1)
    a12 = (w * ph[..., 0] * ph[..., 1]).sum(1)
    a22 = (w * ph[..., 1] ** 2).sum(1)
    b = np.einsum("kn,kni,knj->kij", w, ph, qh)

    big_m = _solve(a11, a12, a22, b, config.transform)
    # coincident source handles: their spread about p* is negligible against that about v
    coincident = ~(a11 + a22 > 1e-13 * (w * d2).sum(1))
    big_m[coincident | ~reached] = np.eye(2)
    f = v + qst - np.einsum("ki,kij->kj", pst, big_m)
    f[~reached] = v[~reached]
    t = f - np.einsum("ki,kij->kj", v, big_m)
    return f, big_m, t
