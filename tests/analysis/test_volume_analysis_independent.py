"""The 3D analyses against a float64 computation written here from the paper and the
definitions alone (not glmls.reference): MLS by the weighted moments (affine), the SVD of the
weighted covariance with det R = +1 (rigid) times Umeyama's scale (similarity); E_MLS (eq. 7)
at every voxel of an anisotropic volume and its statistics (eqs. 8, 9, median, trimmed mean);
det J, the singular value ratio and the Kuhn tetrahedra's det J per cell."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy import stats as scipy_stats

import glmls
from glmls.analysis import ReferenceDeformation, cell_jacobians, error_stats, volume_error_field
from glmls.core.weights import REGISTRY

SHAPE = (4, 5, 6)  # D, H, W
SPACING = (1.6, 0.9, 1.2)  # dz, dy, dx
SCALE = np.array(SPACING[::-1])
RADIUS = float(np.sqrt(((np.array(SHAPE) * SPACING) ** 2).sum()))


def handles():
    rng = np.random.default_rng(11)
    src = rng.uniform(0.05, 0.95, (6, 3)) * (np.array(SHAPE[::-1]) - 1) * SCALE + 0.123
    return src, src + rng.normal(0, 1.2, src.shape)


def mls(src, dst, points, transform, weight):
    """f, M, T at ``points`` in float64, one point at a time."""

    class Parameters:
        alpha, s = 1.0, 1e-8

    d2 = ((points[:, None] - src[None]) ** 2).sum(-1)
    weights = REGISTRY[weight].reference(d2, Parameters, RADIUS)
    M, T = np.empty((len(points), 3, 3)), np.empty((len(points), 3))
    for k, w in enumerate(weights):
        p_star, q_star = w @ src / w.sum(), w @ dst / w.sum()
        p_hat, q_hat = src - p_star, dst - q_star
        covariance = (p_hat * w[:, None]).T @ q_hat
        if transform == "affine":
            M[k] = np.linalg.solve((p_hat * w[:, None]).T @ p_hat, covariance)
        else:
            u, sigma, vt = np.linalg.svd(covariance)
            sign = np.diag([1.0, 1.0, np.sign(np.linalg.det(u @ vt))])
            M[k] = u @ sign @ vt
            if transform == "similarity":
                M[k] *= (sigma * np.diag(sign)).sum() / (w * (p_hat**2).sum(1)).sum()
        T[k] = q_star - p_star @ M[k]
    return np.einsum("ki,kij->kj", points, M) + T, M, T


def voxel_points():
    z, y, x = np.meshgrid(*(np.arange(n) for n in SHAPE), indexing="ij")
    return np.stack([x, y, z], -1).reshape(-1, 3) * SCALE


@pytest.mark.parametrize("weight", sorted(REGISTRY))
@pytest.mark.parametrize("transform", glmls.TRANSFORMS)
def test_the_error_field_and_its_statistics(gl, transform, weight):
    src, dst = handles()
    _, M, T = mls(src, dst, voxel_points(), transform, weight)
    fitted = np.einsum("ni,kij->knj", src, M) + T[:, None]
    expected = ((fitted - dst) ** 2).sum((1, 2)).reshape(SHAPE)
    options = {"transform": transform, "weight": weight, "shape": SHAPE, "spacing": SPACING}
    exact = volume_error_field(ReferenceDeformation(src, dst, **options), SHAPE)
    assert_allclose(exact, expected, rtol=1e-10)
    with glmls.MLS(src, dst, ctx=gl, **options) as m:
        assert_allclose(volume_error_field(m, SHAPE), expected, rtol=1e-4)
    found, values = error_stats(exact), expected.ravel()
    mean, std = values.mean(), np.sqrt(((values - values.mean()) ** 2).mean())
    assert found["mean"] == pytest.approx(mean) and found["std"] == pytest.approx(std)
    assert found["median"] == pytest.approx(np.median(values))
    assert found["trimmed_mean"] == pytest.approx(scipy_stats.trim_mean(values, 0.1))
    shares = [np.mean(np.abs(values - mean) <= k * std) for k in (1, 2, 3)]
    assert found["within"] == pytest.approx(shares)


@pytest.mark.parametrize("grid", [1, 2])
@pytest.mark.parametrize("transform", glmls.TRANSFORMS)
def test_det_j_ratio_and_the_kuhn_tetrahedra_per_cell(transform, grid):
    src, dst = handles()
    dst[[2, 4]] = dst[[4, 2]]  # two handles swap: some cells fold
    axes = [np.append(np.arange(-0.5, n - 0.5, grid), n - 0.5) for n in SHAPE[::-1]]
    corners = np.stack(np.meshgrid(*axes[::-1], indexing="ij")[::-1], -1) * SCALE
    f = mls(src, dst, corners.reshape(-1, 3), transform, "idw")[0].reshape(corners.shape)
    cells = cell_jacobians(
        ReferenceDeformation(src, dst, transform=transform, shape=SHAPE, spacing=SPACING),
        SHAPE,
        grid=grid,
    )
    for k, j, i in itertools.product(*(range(n) for n in cells.det.shape)):
        c, p = f[k : k + 2, j : j + 2, i : i + 2], corners[k : k + 2, j : j + 2, i : i + 2]
        side = p[1, 1, 1] - p[0, 0, 0]
        J = np.stack(
            [
                (c[:, :, 1] - c[:, :, 0]).mean((0, 1)) / side[0],
                (c[:, 1] - c[:, 0]).mean((0, 1)) / side[1],
                (c[1] - c[0]).mean((0, 1)) / side[2],
            ],
            axis=1,
        )
        singular = np.linalg.svd(J, compute_uv=False)
        dets = []
        for order in itertools.permutations(range(3)):  # the path 000 -> ... -> 111
            path = [np.zeros(3, int)]
            for axis in order:
                path.append(path[-1] + np.eye(3, dtype=int)[axis])
            image = np.array([c[z, y, x] for x, y, z in path])
            source = np.array([p[z, y, x] for x, y, z in path])
            dets.append(np.linalg.det(image[1:] - image[0]) / np.linalg.det(source[1:] - source[0]))
        assert cells.det[k, j, i] == pytest.approx(np.linalg.det(J), abs=1e-12)
        assert cells.ratio[k, j, i] == pytest.approx(singular[0] / singular[2], rel=1e-9)
        assert cells.min_det[k, j, i] == pytest.approx(min(dets), abs=1e-12)
        assert cells.folded[k, j, i] == (np.linalg.det(J) <= 0 or min(dets) <= 0)
    assert cells.count > 0 or grid > 1
