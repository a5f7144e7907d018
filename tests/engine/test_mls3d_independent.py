"""3D MLS against a float64 implementation written here from the closed forms alone
(Schaefer et al. 2006 in three dimensions: affine A^-1 B from the weighted moments, rigid
Kabsch's SVD with the reflection fix, similarity rigid times Umeyama's scale), independent of
``glmls.reference``; mirrored targets; f and J where a ridge decides what the handles leave
free (docs/mathematics.md, "The 3D solve on the GPU"); the shapes a 3D MLS refuses."""

from __future__ import annotations

import numpy as np
import pytest

import glmls
from glmls import reference

#: Where the handles in reach are well spread (every eigenvalue of A, and the middle one of
#: B B^T, above this share of the trace), no ridge acts and the closed forms are exact.
WELL_SPREAD = 2e-3
RADIUS = 120.0


def _raw_weights(d2, weight, alpha, interpolating):
    """Table 1 of the paper, without any common factor."""
    d = np.sqrt(d2)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        w = {
            "idw": lambda: 1.0 / (1e-8 + d2**alpha),
            "cressman": lambda: np.maximum(0.0, (RADIUS**2 - d2) / (RADIUS**2 + d2)),
            "shepard": lambda: np.where(d < RADIUS, (RADIUS - d) / (RADIUS * d), 0.0),
            "gaussian": lambda: np.exp(-d2 / RADIUS**2),
            "linear": lambda: np.maximum(0.0, RADIUS - d),
        }[weight]()
        return w / d2**alpha if interpolating else w


def _independent(p, q, v, transform, weight, alpha=1.0, interpolating=False):
    """f (K, 3), M (K, 3, 3) and whether each point's handles in reach are well spread."""
    d2 = ((v[:, None] - p[None]) ** 2).sum(-1)
    w = _raw_weights(d2, weight, alpha, interpolating)
    # about each point's nearest handle (a translation: the same fit), so that steep weights
    # keep float64's digits in the centroids
    o = np.argmin(d2, axis=1)
    dp, dq = p[None] - p[o][:, None], q[None] - q[o][:, None]
    total = w.sum(1)
    with np.errstate(divide="ignore", invalid="ignore"):
        ps = np.einsum("kn,kni->ki", w, dp) / total[:, None]
        qs = np.einsum("kn,kni->ki", w, dq) / total[:, None]
    ph, qh = dp - ps[:, None], dq - qs[:, None]
    big_a = np.einsum("kn,kni,knj->kij", w, ph, ph)
    big_b = np.einsum("kn,kni,knj->kij", w, ph, qh)
    well = np.isfinite(big_a).all((1, 2)) & np.isfinite(big_b).all((1, 2)) & (total > 0)
    big_a[~well], big_b[~well] = np.eye(3), np.eye(3)
    trace = np.trace(big_a, axis1=1, axis2=2)
    bbt = np.linalg.eigvalsh(big_b @ np.swapaxes(big_b, 1, 2))
    well &= np.linalg.eigvalsh(big_a)[:, 0] > WELL_SPREAD * trace
    well &= bbt[:, 1] > WELL_SPREAD * bbt.sum(1)
    big_a[~well], big_b[~well], trace[~well] = np.eye(3), np.eye(3), 3.0  # left out below
    if transform == "affine":
        m = np.linalg.solve(big_a, big_b)
    else:
        u, _, vt = np.linalg.svd(big_b)  # p^ R ~ q^: R = U diag(1, 1, d) V^T maximises tr(R^T B)
        u[:, :, 2] *= np.sign(np.linalg.det(u @ vt))[:, None]
        m = u @ vt
        if transform == "similarity":
            m *= (np.einsum("kij,kij->k", m, big_b) / trace)[:, None, None]
    f = np.einsum("ki,kij->kj", v - p[o] - ps, m) + q[o] + qs
    return f, m, well


@pytest.fixture(scope="module")
def handles():
    rng = np.random.default_rng(1)
    src = rng.uniform(0, 256, (64, 3))
    return src, src + rng.normal(0, 8, src.shape), rng.uniform(-20, 276, (300, 3))


@pytest.mark.parametrize("alpha", [1.0, 0.5, 2.0])
@pytest.mark.parametrize("interpolating", [False, True])
@pytest.mark.parametrize("weight", glmls.WEIGHTS)
@pytest.mark.parametrize("transform", glmls.TRANSFORMS)
def test_the_reference_is_the_closed_forms(handles, transform, weight, interpolating, alpha):
    """Wherever no ridge acts, glmls.reference is the textbook solution to float64's
    precision, for every transform, weight (the registry's), alpha and interpolating."""
    src, dst, points = handles
    f, m, well = _independent(src, dst, points, transform, weight, alpha, interpolating)
    radius = RADIUS if weight != "idw" else None
    options = {"weight": weight, "alpha": alpha, "interpolating": interpolating}
    f_ref, m_ref, _ = reference.mls(src, dst, points, transform=transform, radius=radius, **options)
    assert well.sum() > 250  # most points: a 256^3 box with 64 handles
    np.testing.assert_allclose(f_ref[well], f[well], rtol=0, atol=1e-9)
    np.testing.assert_allclose(m_ref[well], m[well], rtol=0, atol=1e-10)


@pytest.mark.parametrize("transform", glmls.TRANSFORMS)
def test_mirrored_targets(gl, transform):
    """dst a mirror image of src (x -> 256 - x, and a little noise): rigid is a proper
    rotation (det M = +1, Kabsch's reflection fix), similarity a positive multiple of one,
    affine the mirror; the GPU within 2e-3 voxel of the closed forms (the fix's rotation
    is ill-conditioned where B's two smaller singular values nearly tie: 1e-3 voxel there)."""
    rng = np.random.default_rng(4)
    src = rng.uniform(0, 256, (64, 3))
    dst = src * [-1.0, 1.0, 1.0] + [256.0, 0.0, 0.0] + rng.normal(0, 1, src.shape)
    points = rng.uniform(0, 256, (400, 3))
    with glmls.MLS(src, dst, transform=transform) as m:
        f = m(points)
        big_m, t = m.matrices(points)
    f_ind, m_ind, well = _independent(src, dst, points, transform, "idw")
    f_ref, _, _ = reference.mls(src, dst, points, transform=transform)
    assert np.isfinite(f).all() and np.isfinite(big_m).all()
    assert well.sum() > 350
    det = np.linalg.det(big_m)
    if transform == "rigid":
        np.testing.assert_allclose(det, 1.0, rtol=0, atol=1e-5)
    elif transform == "similarity":
        assert (det > 0).all()
    else:
        assert (det < 0).all()
    np.testing.assert_allclose(f[well], f_ind[well], rtol=0, atol=2e-3)
    np.testing.assert_allclose(big_m[well], m_ind[well], rtol=0, atol=1e-4)
    np.testing.assert_allclose(f, f_ref, rtol=0, atol=2e-3)
    np.testing.assert_allclose(np.einsum("ki,kij->kj", points, big_m) + t, f, rtol=0, atol=1e-9)


@pytest.mark.parametrize("transform", glmls.TRANSFORMS)
def test_smooth_where_a_ridge_decides(gl, transform):
    """Two handles trading places: the rotation about their line is free and the ridge
    decides it, dividing the moments' rounding by 1e-3 (float32 moments would move f by
    ~0.02 voxel here, differently from point to point, and J by ~0.3). Those points are solved
    from float64 moments: f, 160 voxels from the handles, within 1e-4 voxel of the reference
    at points 0.001 voxel apart, steps between them no larger than the map's own (|J| ~ 1:
    1e-3), J within 1e-3 of the reference's central differences, and every preimage found
    within 1e-4."""
    rng = np.random.default_rng(8)
    src = rng.uniform(0, 256, (2, 3))
    dst = src[::-1].copy()
    x0, step = rng.uniform(0, 256, 3), np.array([0.3, -0.7, 0.64]) / np.sqrt(1.0396)
    line = x0 + np.linspace(-0.2, 0.2, 401)[:, None] * step  # 0.001 voxel apart
    with glmls.MLS(src, dst, transform=transform) as m:
        f = m(line)
        back, valid = m.inverse(f[::20], return_valid=True)
        _, jacobian = m.jacobian(line[::20])
    f_ref, _, _ = reference.mls(src, dst, line, transform=transform)
    h = 1e-4
    j_ref = np.stack(
        [
            reference.mls(src, dst, line[::20] + e, transform=transform)[0]
            - reference.mls(src, dst, line[::20] - e, transform=transform)[0]
            for e in np.eye(3) * h
        ],
        axis=1,
    ) / (2 * h)
    assert np.isfinite(f).all() and valid.all()
    assert np.abs(np.diff(f, axis=0)).max() < 1e-3
    np.testing.assert_allclose(f, f_ref, rtol=0, atol=1e-4)
    np.testing.assert_allclose(back, line[::20], rtol=0, atol=1e-4)
    np.testing.assert_allclose(jacobian, j_ref, rtol=0, atol=1e-3)


@pytest.mark.parametrize(
    ("src", "dst", "message"),
    [
        ([1.0, 2.0, 3.0], [1.0, 2.0, 4.0], r"\(N, 3\) as \(x, y, z\) rows, got \(3,\)"),
        (np.ones((4, 3)), np.ones((4, 2)), r"dst must have shape \(N, 3\)"),
        (np.ones((4, 2)), np.ones((4, 3)), r"dst must have shape \(N, 2\)"),
        (np.ones((4, 4)), np.ones((4, 4)), r"\(N, 2\) as \(x, y\) rows or \(N, 3\)"),
        ([[0.0, 0, 0], [1, np.nan, 0]], [[0.0, 0, 0], [1, 1, 0]], "src must be finite; row 1"),
        ([[0.0, 0, 0], [1, 1, 0]], [[0.0, 0, 0], [np.inf, 1, 0]], "dst must be finite; row 1"),
    ],
)
def test_malformed_handles_are_named(src, dst, message):
    with pytest.raises(ValueError, match=message):
        glmls.MLS(src, dst)


def test_points_of_another_dimension_are_named(gl, handles):
    """A 3D MLS refuses (K, 2) points, a (2,) point and non-finite points by name; one (3,)
    point is the row (1, 3), as scikit-image's transforms take it."""
    src, dst, _ = handles
    with glmls.MLS(src, dst) as m:
        for call in (m, m.matrices, m.jacobian, m.inverse):
            with pytest.raises(ValueError, match=r"\(N, 3\) as \(x, y, z\) rows, got \(4, 2\)"):
                call(np.ones((4, 2)))
            with pytest.raises(ValueError, match=r"got \(2,\)"):
                call(np.ones(2))
            with pytest.raises(ValueError, match="points must be finite; row 0"):
                call([[np.nan, 1.0, 1.0]])
            with pytest.raises(TypeError, match="real numbers"):
                call(np.ones((2, 3), complex))
        assert m(src[0]).shape == (1, 3)
