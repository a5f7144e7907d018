"""An independent float64 MLS in 2D, written from the paper for the checks against glmls.

Schaefer, McPhail and Warren (2006) with the weights of Table 1 of "Extensions to the MLS
method for image deformation". Nothing here comes from :mod:`glmls`: the weights are the
table's formulas, the affine fit is a weighted least squares solved by
:func:`numpy.linalg.lstsq` (near one line, with glmls's documented ridge toward the
similarity fit), the similarity and rigid fits are complex numbers (with row
vectors, v M for M = [[a, b], [-b, a]] is the complex product (x + iy)(a + ib)), and segment
handles are densely sampled point handles weighted per unit of length (the limit the
segment integrals of the paper's section 4 are).
"""

from __future__ import annotations

import numpy as np


def table1(d: np.ndarray, weight: str, *, alpha=1.0, s=1e-8, radius=None, interpolating=False):
    """Table 1's weight w(d) at distances ``d`` (any shape), +inf where infinite."""
    d = np.asarray(d, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        if weight == "idw":
            w = 1.0 / (s + d ** (2.0 * alpha))
        elif weight == "cressman":
            w = np.maximum(0.0, (radius**2 - d**2) / (radius**2 + d**2))
        elif weight == "shepard":
            w = np.where(d == 0, np.inf, np.maximum(0.0, (radius - d) / (radius * d)))
        elif weight == "gaussian":
            w = np.exp(-(d**2) / radius**2)
        elif weight == "linear":
            w = np.maximum(0.0, radius - d)
        else:
            raise ValueError(weight)
        if interpolating:
            w = np.where(d == 0, np.where(w > 0, np.inf, 0.0), w / d ** (2.0 * alpha))
    return w


#: glmls's share of trace(A) below which A's small eigenvalue gets the ridge (affine)
RIDGE = 1e-3


def fit(ph: np.ndarray, qh: np.ndarray, w: np.ndarray, transform: str) -> np.ndarray:
    """The M minimising sum w |p^ M - q^|^2 over the transform's family, one point."""
    z = (ph[:, 0] + 1j * ph[:, 1]), (qh[:, 0] + 1j * qh[:, 1])
    if transform == "affine":
        r = np.sqrt(w)[:, None]
        m, _, rank, _ = np.linalg.lstsq(r * ph, r * qh, rcond=1e-9)
        a = (r * ph).T @ (r * ph)
        e, u = np.linalg.eigh(a)  # ascending: e[0] the small eigenvalue
        x = e[0] / e.sum()
        if rank == 2 and x >= RIDGE:
            return m
        if rank == 0:
            transform = "similarity"  # no spread: a translation's M, as similarity's
        else:
            # glmls's documented definition near one line (docs/mathematics.md): a ridge
            # RIDGE (1 - x / RIDGE)^2 trace(A) toward the similarity fit in the direction of
            # A's small eigenvalue, solved as a least squares with that one extra row
            sim = fit(ph, qh, w, "similarity")
            g = RIDGE * (1.0 - max(x, 0.0) / RIDGE) ** 2 * e.sum()
            n = u[:, 0]
            return np.linalg.solve(
                a + g * np.outer(n, n), (r * ph).T @ (r * qh) + g * np.outer(n, n @ sim)
            )
    c = (w * np.conj(z[0]) * z[1]).sum()
    if transform == "similarity":
        c = c / (w * np.abs(z[0]) ** 2).sum()
    else:
        c = c / abs(c)
    return np.array([[c.real, c.imag], [-c.imag, c.real]])


def mls64(p, q, v, transform="rigid", weight="idw", *, density=None, **params):
    """f, M, T at points ``v`` (K, 2) for handles p -> q (N, 2), all float64.

    ``density`` (N,) multiplies each handle's weight (the sample spacing of a segment).
    On a handle whose weight is infinite: f = q_i, M the limit (the other handles about p_i).
    """
    p, q, v = (np.asarray(a, dtype=np.float64).reshape(-1, 2) for a in (p, q, v))
    density = np.ones(len(p)) if density is None else np.asarray(density, dtype=np.float64)
    fs, ms = [], []
    for point in v:
        d = np.hypot(*(p - point).T)
        w = table1(d, weight, **params) * density
        dp, dq = p - point, q - point  # about v: no cancellation next to a handle
        inf = np.isinf(w)
        if inf.any():
            i = np.flatnonzero(inf)[0]
            pst, qst = dp[i], dq[i]
            w = np.where(inf, 0.0, w)
        elif w.sum() == 0:  # no handle in reach: the point stays
            fs.append(point.copy())
            ms.append(np.eye(2))
            continue
        else:
            # about the heaviest handle: next to a handle whose weight is steep (1e40 against
            # 1e-15) the others' spread about p* would be lost to the rounding of p* about v
            o = np.argmax(w)
            pst = dp[o] + (w @ (dp - dp[o])) / w.sum()
            qst = dq[o] + (w @ (dq - dq[o])) / w.sum()
        keep = w > 0
        if len(np.unique(p[keep | inf], axis=0)) < 2:  # a translation (one handle, coincident)
            m = np.eye(2)
        else:
            m = fit(dp[keep] - pst, dq[keep] - qst, w[keep], transform)
        fs.append(point + qst - pst @ m)
        ms.append(m)
    f, big_m = np.array(fs), np.array(ms)
    return f, big_m, f - np.einsum("ki,kij->kj", v, big_m)


def sampled_segments(src_segments, dst_segments, samples: int):
    """Midpoints p(t_k), q(t_k) of ``samples`` equal pieces of each segment, and each piece's
    source length (the weight per unit of length)."""
    a, b = np.asarray(src_segments, float)[:, 0], np.asarray(src_segments, float)[:, 1]
    c, d = np.asarray(dst_segments, float)[:, 0], np.asarray(dst_segments, float)[:, 1]
    t = ((np.arange(samples) + 0.5) / samples)[None, :, None]
    p = (1 - t) * a[:, None] + t * b[:, None]
    q = (1 - t) * c[:, None] + t * d[:, None]
    length = np.hypot(*(b - a).T) / samples
    return p.reshape(-1, 2), q.reshape(-1, 2), np.repeat(length, samples)
