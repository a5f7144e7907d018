"""The ridges and rotations of the 3D MLS's degenerate handle sets, in float64 (the rules of
:mod:`glmls.reference`, whose module docstring states them; ``glmls/shaders/mls3/solve_full.glsl``
follows them on the GPU): the ridge g(A) of a moment matrix's near-degenerate eigenvalues, and
the proper rotation of a 3D fit with the rotations a near-degenerate set leaves free."""

from __future__ import annotations

import numpy as np

__all__ = ["DEGENERATE_SHARE", "least_rotation", "ridge3", "ridge_matrix", "rotation3"]

#: Below this share of trace(A) an eigenvalue of the moment matrix A is near-degenerate, and
#: the 3D solutions add a ridge in its direction (see :mod:`glmls.reference`).
DEGENERATE_SHARE = 1e-3


def ridge_matrix(big_a: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """g(A) (K, n, n) for A (K, n, n), n = 2 or 3: the spectral function of A that is 0
    unless an eigenvalue e of A is below DEGENERATE_SHARE of trace(A), where it grows
    smoothly to DEGENERATE_SHARE trace(A) at e = 0; with each eigenvalue's share (K, n) and
    A's eigenvectors (K, n, n), columns in ascending order of their eigenvalues."""
    e, vectors = np.linalg.eigh(big_a)
    trace = np.maximum(e.sum(-1), 0.0)[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        x = np.where(trace > 0, np.maximum(e, 0.0) / trace, 1.0)
    share = DEGENERATE_SHARE * np.maximum(0.0, 1.0 - x / DEGENERATE_SHARE) ** 2
    ridge = np.einsum("kin,kn,kjn->kij", vectors, share * trace, vectors)
    return ridge, share, vectors


def ridge3(big_a: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The near-degenerate directions of A (K, 3, 3), per point: g(A) (ridge_matrix), the
    ridge's share for A's middle eigenvalue (K,), above 0 only where the sources are near
    one line, and A's unit principal axis (K, 3)."""
    ridge, share, vectors = ridge_matrix(big_a)
    return ridge, share[:, 1], vectors[:, :, 2]


def least_rotation(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(K, 3, 3): the rotation of least angle with a R parallel to b (row vectors), for unit
    ``a`` and any ``b``; I where b is 0. Antiparallel a and b: a half turn about an axis
    perpendicular to a (any such axis is as good: the one choice that cannot be continuous),
    a x e_i for the i of the smallest |a_i| + (0, 1e-3, 2e-3)_i: the first of tied |a_i|
    (a along a coordinate axis or a diagonal), whatever rounding does to a (float32's on the
    GPU)."""
    norm = np.linalg.norm(b, axis=-1, keepdims=True)
    bh = np.where(norm > 0, b / np.where(norm > 0, norm, 1.0), a)
    n = np.cross(a, bh)  # sin(angle) times the unit axis
    c = (a * bh).sum(-1)
    anti = c < -1.0 + 1e-12
    cross = np.zeros(a.shape + (3,))  # [n]x, so that [n]x u = n x u (column vectors)
    cross[:, 0, 1], cross[:, 0, 2], cross[:, 1, 2] = -n[:, 2], n[:, 1], -n[:, 0]
    cross[:, 1, 0], cross[:, 2, 0], cross[:, 2, 1] = n[:, 2], -n[:, 1], n[:, 0]
    factor = 1.0 / np.where(anti, 1.0, 1.0 + c)
    # Rodrigues for column vectors, R_c a = b^; row vectors take its transpose
    rc = np.eye(3) + cross + (cross @ cross) * factor[:, None, None]
    helper = np.eye(3)[np.argmin(np.abs(a) + [0.0, 1e-3, 2e-3], axis=-1)]
    perp = np.cross(a, helper)
    perp /= np.linalg.norm(perp, axis=-1, keepdims=True)
    half = 2.0 * np.einsum("ki,kj->kij", perp, perp) - np.eye(3)  # a half turn about perp
    return np.where(anti[:, None, None], half, np.swapaxes(rc, -1, -2))


def rotation3(big_a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The proper rotation R maximising trace(R^T B') (Kabsch with row vectors,
    sum w |p^ R - q^|^2 least), B' = B + c |B| R0 + c' |B| R0' with R0 the least rotation
    taking A's principal axis to its image under B, and c the ridge's share for A's middle
    eigenvalue: 0 unless the sources are near one line (where the rotation about it is
    free); R0' and c' likewise of B B^T, whose middle eigenvalue (B's middle singular value
    squared) is small where the targets are near one line, the sources spread or not (B of
    rank 1 leaves the rotation about the targets' line free)."""
    _, share, axis = ridge3(big_a)
    r0 = least_rotation(axis, np.einsum("ki,kij->kj", axis, b))
    _, shares_b, vectors_b = ridge_matrix(b @ np.swapaxes(b, -1, -2))
    axis_b = vectors_b[:, :, 2]
    r0_b = least_rotation(axis_b, np.einsum("ki,kij->kj", axis_b, b))
    norm = np.linalg.norm(b, axis=(-2, -1))
    shifted = b + (share * norm)[:, None, None] * r0 + (shares_b[:, 1] * norm)[:, None, None] * r0_b
    u, _, vt = np.linalg.svd(shifted)
    d = np.sign(np.linalg.det(u @ vt))
    d = np.where(d == 0, 1.0, d)
    u[:, :, 2] *= d[:, None]
    return u @ vt
