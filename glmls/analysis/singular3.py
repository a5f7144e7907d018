"""The largest and the smallest singular value of many 3 x 3 matrices at once, in closed form.

``numpy.linalg.svd`` of a stack of 3 x 3 matrices costs about 2 microseconds a matrix (a
LAPACK call each); the per-cell Jacobians of a 256^3 lattice are 16.7 million of them. Here
every step is an elementwise numpy operation over arrays of matrix entries, in float64:

1. J is scaled by a power of 2 (exact) so that its largest entry lies in [0.5, 1): no
   overflow or underflow from 1e-150 to 1e150, and every tolerance below is relative.
2. The eigenvalue of A = J^T J farthest from the other two (the largest where the two
   smaller ones are the closer pair, else the smallest) by the trigonometric formula for a
   symmetric 3 x 3 matrix; at that end of its range the formula is well conditioned.
3. Its eigenvector v, the longest cross product of two rows of A - lambda I, and an
   orthonormal frame (v, u, w): a, b, c = J v, J u, J w. |a|^2 is v's Rayleigh quotient
   and the 2 x 2 Gram matrix of (b, c) holds the other two eigenvalues, whose difference
   comes from a sum of squares (``hypot``), never from a cancelling discriminant: a
   rotation's three equal singular values stay equal to rounding, not to its square root.
4. The smallest singular value as |det [a b c]| / (s1 s2): a product of the frame's
   columns, so that a nearly singular J keeps its relative accuracy (the difference of two
   nearly equal eigenvalues would keep only its absolute one).

Accuracy (tests/analysis/test_singular3.py, against ``numpy.linalg.svd``): s1 within
1e-14 relative; s3 within 1e-13 x s1 / s3 relative where s2 and s1 are of one magnitude
(rotations, reflections, shears, scales from 1e-30 to 1e30, rank 2 up to rounding), and
within 1e-13 x (s1 / s2)(s1 / s3) where J is close to rank 1 (the frame's
determinant there rounds at the scale of the two larger singular values).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

__all__ = ["cross3", "det_and_extremes", "determinant", "dot3", "singular_extremes"]

Matrix = Sequence[Sequence[np.ndarray]]


def dot3(p: Sequence[np.ndarray], q: Sequence[np.ndarray]) -> np.ndarray:
    """p . q of vectors given as their three components (arrays), summed in order x, y, z
    (as ``(p * q).sum(-1)`` of (..., 3) arrays)."""
    return p[0] * q[0] + p[1] * q[1] + p[2] * q[2]


def cross3(p: Sequence[np.ndarray], q: Sequence[np.ndarray]) -> list[np.ndarray]:
    """p x q of vectors given as their three components (as ``numpy.cross`` rounds it)."""
    return [p[1] * q[2] - p[2] * q[1], p[2] * q[0] - p[0] * q[2], p[0] * q[1] - p[1] * q[0]]


def _apply(k: Matrix, v: Sequence[np.ndarray]) -> list[np.ndarray]:
    return [k[i][0] * v[0] + k[i][1] * v[1] + k[i][2] * v[2] for i in range(3)]


def determinant(j: Matrix) -> np.ndarray:
    """det J of the 3 x 3 matrices ``j[row][column]`` (same-shape arrays), by cofactors of
    the first column: column x . (column y x column z)."""
    columns = [[j[row][col] for row in range(3)] for col in range(3)]
    return dot3(columns[0], cross3(columns[1], columns[2]))


def _isolated_eigenvalue(a: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """(lambda, whether it is the largest) of the symmetric A (entries ``a``), the
    eigenvalue farthest from the other two (Smith's trigonometric formula)."""
    q = (a["00"] + a["11"] + a["22"]) / 3
    b00, b11, b22 = a["00"] - q, a["11"] - q, a["22"] - q
    off = a["01"] * a["01"] + a["02"] * a["02"] + a["12"] * a["12"]
    p = np.sqrt((b00 * b00 + b11 * b11 + b22 * b22 + 2 * off) / 6)
    # det((A - q I) / p) / 2 from the divided entries: p^3 underflows where A is the
    # identity but for an entry of 1e-120
    with np.errstate(divide="ignore"):
        inverse = np.where(p > 0, 1 / p, 0.0)
    b00, b11, b22 = b00 * inverse, b11 * inverse, b22 * inverse
    b01, b02, b12 = a["01"] * inverse, a["02"] * inverse, a["12"] * inverse
    r = b00 * (b11 * b22 - b12 * b12) - b01 * (b01 * b22 - b12 * b02)
    r = (r + b02 * (b01 * b12 - b11 * b02)) / 2
    np.clip(r, -1.0, 1.0, out=r)
    largest = r >= 0  # the two smaller eigenvalues are the closer pair
    phi = np.arccos(r) / 3
    phi[~largest] += 2 * np.pi / 3  # the smallest: cos is flat there as r nears -1
    return q + 2 * p * np.cos(phi), largest


def _eigenvector(a: dict[str, np.ndarray], lam: np.ndarray) -> list[np.ndarray]:
    """A unit eigenvector of A for its isolated eigenvalue ``lam``: the longest cross
    product of two rows of A - lam I ((1, 0, 0) where all vanish: A = lam I)."""
    rows = [
        [a["00"] - lam, a["01"], a["02"]],
        [a["01"], a["11"] - lam, a["12"]],
        [a["02"], a["12"], a["22"] - lam],
    ]
    best = cross3(rows[0], rows[1])
    length = dot3(best, best)
    for i, k in ((0, 2), (1, 2)):
        other = cross3(rows[i], rows[k])
        norm = dot3(other, other)
        longer = norm > length
        best = [np.where(longer, o, b) for o, b in zip(other, best, strict=True)]
        length = np.where(longer, norm, length)
    with np.errstate(divide="ignore", invalid="ignore"):
        scale = np.where(length > 0, 1 / np.sqrt(length), 0.0)
    v = [best[0] * scale, best[1] * scale, best[2] * scale]
    v[0] = np.where(length > 0, v[0], 1.0)
    return v


def _complement(v: Sequence[np.ndarray]) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Unit u, w with (v, u, w) a right-handed orthonormal frame (Eberly's choice of u,
    by v's larger component of x and y: never a division by a small norm)."""
    zero = np.zeros_like(v[0])
    x_larger = np.abs(v[0]) > np.abs(v[1])
    u = [
        np.where(x_larger, -v[2], zero),
        np.where(x_larger, zero, v[2]),
        np.where(x_larger, v[0], -v[1]),
    ]
    scale = 1 / np.sqrt(dot3(u, u))
    u = [c * scale for c in u]
    return u, cross3(v, u)


def singular_extremes(j: Matrix) -> tuple[np.ndarray, np.ndarray]:
    """The largest and the smallest singular value of the 3 x 3 matrices ``j[row][column]``.

    Parameters
    ----------
    j : 3 x 3 nested sequence of numpy.ndarray
        Same-shape float64 arrays of finite entries, one matrix per element.

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)
        s1 >= s3 >= 0, each of the entries' shape (see the module for the accuracy).

    Examples
    --------
    >>> from glmls.analysis.singular3 import singular_extremes
    >>> j = np.diag([3.0, -2.0, 0.5])
    >>> s1, s3 = singular_extremes([[np.array([e]) for e in row] for row in j])
    >>> s1.tolist(), s3.tolist()
    ([3.0], [0.5])
    """
    k, exponent = _scaled(j)
    s1, s3 = _extremes(k)
    return np.ldexp(s1, exponent), np.ldexp(s3, exponent)


def det_and_extremes(j: Matrix) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """det J and the largest and the smallest singular value of the 3 x 3 matrices
    ``j[row][column]``, from one scaling of J.

    Parameters
    ----------
    j : 3 x 3 nested sequence of numpy.ndarray
        Same-shape float64 arrays of finite entries, one matrix per element.

    Returns
    -------
    (numpy.ndarray, numpy.ndarray, numpy.ndarray)
        det J (:func:`determinant`'s bits, but ±inf where it overflows float64 and 0
        where it underflows, never NaN), s1 and s3 (:func:`singular_extremes`).

    Examples
    --------
    >>> from glmls.analysis.singular3 import det_and_extremes
    >>> j = np.diag([3.0, -2.0, 0.5]) * 2.0**700  # det J = -3 x 2^2100 overflows
    >>> det, s1, s3 = det_and_extremes([[np.array([e]) for e in row] for row in j])
    >>> det.tolist(), (s1 / 2.0**700).tolist(), (s3 / 2.0**700).tolist()
    ([-inf], [3.0], [0.5])
    """
    k, exponent = _scaled(j)
    s1, s3 = _extremes(k)
    with np.errstate(over="ignore", invalid="ignore"):
        det = determinant(j)
        wide = ~np.isfinite(det)  # a cofactor overflowed: inf - inf, or inf for -inf
        if wide.any():  # the same cofactors of the scaled J, which cannot overflow
            scaled = determinant([[entry[wide] for entry in row] for row in k])
            det[wide] = np.ldexp(scaled, 3 * exponent[wide])
    return det, np.ldexp(s1, exponent), np.ldexp(s3, exponent)


def _scaled(j: Matrix) -> tuple[list[list[np.ndarray]], np.ndarray]:
    """(J / 2^e, e) with J / 2^e's largest entry in [0.5, 1) (0 for J = 0): exact."""
    big = np.abs(j[0][0])
    for row, col in np.ndindex(3, 3):
        np.maximum(big, np.abs(j[row][col]), out=big)
    exponent = np.frexp(big)[1]
    return [[np.ldexp(j[row][col], -exponent) for col in range(3)] for row in range(3)], exponent


def _extremes(k: Matrix) -> tuple[np.ndarray, np.ndarray]:
    """s1 and s3 of the scaled K (:func:`_scaled`)."""
    columns = [[k[row][col] for row in range(3)] for col in range(3)]
    a = {f"{p}{q}": dot3(columns[p], columns[q]) for p in range(3) for q in range(p, 3)}
    lam, largest = _isolated_eigenvalue(a)
    v = _eigenvector(a, lam)
    u, w = _complement(v)
    jv, ju, jw = _apply(k, v), _apply(k, u), _apply(k, w)
    m00, m11, m01 = dot3(ju, ju), dot3(jw, jw), dot3(ju, jw)
    mid = (m00 + m11) / 2
    rad = np.hypot((m00 - m11) / 2, m01)
    rayleigh = dot3(jv, jv)
    # the isolated one is the largest: the pair (mid +- rad) the two smaller, else the
    # pair holds the two larger and the isolated one is the smallest
    first = np.where(largest, rayleigh, mid + rad)
    second = np.where(largest, mid + rad, mid - rad)
    l1, l2 = np.maximum(first, second), np.minimum(first, second)
    s1, s2 = np.sqrt(l1), np.sqrt(np.maximum(l2, 0.0))
    volume = np.abs(dot3(jv, cross3(ju, jw)))
    with np.errstate(divide="ignore", invalid="ignore"):
        s3 = np.where(s2 > 0, volume / (s1 * s2), 0.0)
    np.minimum(s3, s2, out=s3)
    return s1, s3
