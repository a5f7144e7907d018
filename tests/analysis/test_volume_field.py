"""The MLS error field over a volume (eq. 7) and its statistics (eqs. 8, 9), against the
float64 reference."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy import stats as scipy_stats

import glmls
from glmls import reference
from glmls.analysis import ReferenceDeformation, error_stats, volume_error_field
from glmls.analysis.volume_field import fit_residuals

SRC = np.array([[2.0, 2, 1], [12, 3, 2], [3, 10, 1], [2, 2, 8], [11, 10, 7], [7, 6, 4]])
DST = SRC + np.array([[0.0, 0, 0], [1, 0, 0], [0, -1, 0], [0, 0, 1], [-1, 1, 0], [2, 1, -1]])


def voxel_centres(shape):
    z, y, x = np.mgrid[0 : shape[0], 0 : shape[1], 0 : shape[2]]
    return np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1).astype(np.float64)


@pytest.mark.parametrize("transform", ["rigid", "similarity", "affine"])
def test_the_field_is_the_reference_error_at_every_voxel(transform):
    shape = (9, 12, 14)
    m = ReferenceDeformation(SRC, DST, transform=transform, shape=shape)
    field = volume_error_field(m, shape)
    expected = reference.mls_error(SRC, DST, voxel_centres(shape), transform=transform, shape=shape)
    assert field.shape == shape and field.dtype == np.float64
    assert_allclose(field.ravel(), expected, rtol=1e-12, atol=1e-9)
    assert field.max() > 1.0  # the handles do not fit one rigid/similar/affine map


def test_a_grid_evaluates_every_grid_voxels_and_interpolates_trilinearly():
    shape = (9, 12, 14)
    m = ReferenceDeformation(SRC, DST, shape=shape)
    exact = volume_error_field(m, shape)
    field = volume_error_field(m, shape, grid=4)
    # on the lattice (0, 4, 8 and the last voxel along each axis) it is exact
    for z in (0, 4, 8):
        for y in (0, 4, 8, 11):
            for x in (0, 4, 8, 12, 13):
                assert field[z, y, x] == pytest.approx(exact[z, y, x], rel=1e-12)
    # between: linear along each axis, e.g. half-way in x and a quarter in z
    corner = lambda z, x: exact[z, 4, x]  # noqa: E731
    expected = 0.75 * (corner(4, 4) + corner(4, 8)) / 2 + 0.25 * (corner(8, 4) + corner(8, 8)) / 2
    assert field[5, 4, 6] == pytest.approx(expected, rel=1e-12)
    # the last, shorter step: x = 12 -> 13 holds no voxel between, y = 8 -> 11 does
    t = 1 / 3
    assert field[0, 9, 0] == pytest.approx((1 - t) * exact[0, 8, 0] + t * exact[0, 11, 0])


def test_the_identity_and_a_global_similarity_have_no_error():
    shape = (6, 7, 8)
    assert volume_error_field(ReferenceDeformation(SRC, SRC), shape).max() < 1e-20
    turn = np.array([[0.0, 1, 0], [-1, 0, 0], [0, 0, 1]])
    moved = ReferenceDeformation(SRC, 1.5 * SRC @ turn + 3.0, transform="similarity")
    assert volume_error_field(moved, shape, grid=2).max() < 1e-9


def test_the_statistics_are_eqs_8_and_9_with_the_median_and_trimmed_mean():
    shape = (8, 9, 10)
    field = volume_error_field(ReferenceDeformation(SRC, DST), shape)
    found = error_stats(field)
    values = field.ravel()
    assert found["count"] == values.size and found["nan_count"] == 0
    assert found["mean"] == pytest.approx(values.sum() / values.size, rel=1e-12)  # eq. 8
    assert found["std"] == pytest.approx(
        np.sqrt(((values - values.mean()) ** 2).sum() / values.size), rel=1e-10
    )  # eq. 9
    assert found["median"] == pytest.approx(np.median(values))
    assert found["trimmed_mean"] == pytest.approx(scipy_stats.trim_mean(values, 0.1), rel=1e-12)
    assert found["min"] == values.min() and found["max"] == values.max()
    within = np.abs(values - values.mean()) <= found["std"]
    assert found["within"][0] == pytest.approx(within.mean())


def test_the_reference_deformation_is_the_reference():
    points = np.random.default_rng(5).uniform(0, 12, (50, 3))
    m = ReferenceDeformation(SRC, DST, transform="affine", shape=(9, 12, 14))
    f, matrix, translation = reference.mls(SRC, DST, points, transform="affine", shape=(9, 12, 14))
    assert_allclose(m(points), f, rtol=0, atol=0)
    found = m.matrices(points)
    assert_allclose(found[0], matrix, rtol=0, atol=0)
    assert_allclose(found[1], translation, rtol=0, atol=0)
    assert m.config.transform == "affine" and m.shape == (9, 12, 14)
    assert not m.src.flags.writeable
    with m as same:
        assert same is m


def test_the_reference_deformation_takes_points_as_an_mls_does(gl):
    """One (3,) point is a (1, 3) row, no points a (0, 3) array, as a 3D MLS takes them."""
    m = ReferenceDeformation(SRC, DST, transform="affine")
    with glmls.MLS(SRC, DST, transform="affine", ctx=gl) as ours:
        for points in ([4, 5, 6], np.array([4.0, 5.0, 6.0], np.float32), np.zeros((0, 3)), []):
            assert m(points).shape == ours(points).shape
            assert_allclose(m(points), ours(points), atol=1e-4)
            M, T = m.matrices(points)
            assert M.shape == ours.matrices(points)[0].shape and T.shape == m(points).shape
    with pytest.raises(ValueError, match=r"\(N, 3\)"):
        m([4, 5])


@pytest.mark.parametrize(
    ("src", "dst", "message"),
    [
        ([[0, 0], [1, 1]], [[0, 0], [1, 1]], r"\(N, 3\)"),
        ([[0, 0, 0]], [[0, 0, 0], [1, 1, 1]], "alike"),
        ([[0, 0, np.nan]], [[0, 0, 0]], "finite"),
    ],
)
def test_the_reference_deformation_checks_its_handles(src, dst, message):
    with pytest.raises(ValueError, match=message):
        ReferenceDeformation(src, dst)


def test_the_field_checks_its_arguments():
    m = ReferenceDeformation(SRC, DST)
    with pytest.raises(ValueError, match="D, H, W"):
        volume_error_field(m, (4, 4))
    with pytest.raises(ValueError, match="grid"):
        volume_error_field(m, (4, 4, 4), grid=0)
    with pytest.raises(TypeError, match="integers"):
        volume_error_field(m, "abc")
    # (D, H, W, C): the channels are left out
    assert volume_error_field(m, (3, 4, 5, 2)).shape == (3, 4, 5)


class UndefinedAtHalf:
    """A deformation whose affine fit is NaN at every other point."""

    src = dst = SRC

    def __call__(self, points):
        return np.full(np.shape(points), np.nan)

    def matrices(self, points):
        matrix = np.tile(np.eye(3), (len(points), 1, 1))
        matrix[::2] = np.nan
        return matrix, np.zeros((len(points), 3))


def test_nan_from_the_deformation_raises():
    with pytest.raises(ValueError, match=r"m.matrices\(points\) returned NaN"):
        volume_error_field(UndefinedAtHalf(), (6, 6, 6))


def test_the_gpu_deformation_matches_the_reference(gl):
    shape = (9, 12, 14)
    try:
        m = glmls.MLS(SRC, DST, shape=shape, ctx=gl)
    except (TypeError, ValueError) as error:
        pytest.skip(f"glmls.MLS takes no (N, 3) handles here: {error}")
    with m:
        field = volume_error_field(m, shape, grid=2)
    expected = volume_error_field(ReferenceDeformation(SRC, DST, shape=shape), shape, grid=2)
    # float32 on the GPU: relative to the largest error
    assert np.abs(field - expected).max() <= 1e-3 * expected.max()


def test_blocks_of_planes_give_the_same_field(monkeypatch):
    m = ReferenceDeformation(SRC, DST)
    whole = volume_error_field(m, (7, 9, 10), grid=2)
    from glmls.analysis import volume_field

    monkeypatch.setattr(volume_field, "CHUNK", 1)  # one plane of points per call of m
    assert_allclose(volume_error_field(m, (7, 9, 10), grid=2), whole, rtol=1e-12)


def test_spacing_puts_the_voxels_at_physical_points():
    """With ``spacing`` (dz, dy, dx) voxel (k, j, i) is the point (i dx, j dy, k dz), as
    MLS.warp places it: the error field and J are those of f there."""
    spacing, shape = (1.5, 1.0, 2.0), (3, 4, 5)
    bend = lambda v: v + [[0.01, 0.0, 0.0]] * v[:, :1] ** 2  # noqa: E731  (x + x^2 / 100, y, z)
    cells = glmls.analysis.cell_jacobians(bend, shape, spacing=spacing)
    # cell i spans x = (i -+ 1/2) 2: dx'/dx = 1 + (x0 + x1) / 100 = 1 + 0.04 i
    assert_allclose(cells.det[1, 2], 1 + 0.04 * np.arange(5), atol=1e-12)
    src = np.array([[2.0, 2, 2], [13, 2, 2], [2, 13, 2], [2, 2, 13], [13, 13, 13]])
    dst = src.copy()
    dst[4] = [10.0, 10, 10]
    m = glmls.analysis.ReferenceDeformation(src, dst)
    field = glmls.analysis.volume_error_field(m, shape, spacing=spacing)
    z, y, x = np.mgrid[0:3, 0:4, 0:5]
    points = np.stack([x.ravel() * 2.0, y.ravel() * 1.0, z.ravel() * 1.5], axis=1)
    exact = glmls.reference.mls_error(src, dst, points).reshape(shape)
    assert_allclose(field, exact, rtol=1e-9)
    with pytest.raises(ValueError, match="spacing"):
        glmls.analysis.volume_error_field(m, shape, spacing=(1.0, 0.0, 1.0))


def test_a_2d_deformation_is_named_by_every_volume_analysis(gl):
    from glmls.analysis import cell_jacobians, tetrahedron_errors

    cube = [[x, y, z] for z in (0, 4) for y in (0, 4) for x in (0, 4)]
    with glmls.MLS([[0, 0], [10, 0], [0, 10]], [[0, 0], [10, 1], [0, 10]], ctx=gl) as m:
        for analyse in (
            lambda: cell_jacobians(m, (6, 6, 6)),
            lambda: volume_error_field(m, (6, 6, 6)),
            lambda: tetrahedron_errors(m, cube),
        ):
            with pytest.raises(ValueError, match=r"m is a 2D deformation \(src of shape \(3, 2\)"):
                analyse()


def _summed_by_handle(src, dst, matrix, translation):
    """eq. (7) as written: the fit at each point applied to every handle, float64."""
    fitted = np.einsum("nd,kde->kne", src, matrix) + translation[:, None, :]
    return ((fitted - dst) ** 2).sum(axis=(1, 2))


@pytest.mark.parametrize("count", [1, 6, 7, 64])
def test_fit_residuals_from_moments_equal_the_sum_over_handles(count):
    """E_MLS from the handles' moments (O(1) a point) equals the sum handle by handle to
    float64's rounding, far from the origin too; exact fits (E = 0, a rigid map that meets
    every handle) stay exactly 0, not the rounding of terms that cancel."""
    rng = np.random.default_rng(count)
    for offset in (0.0, 1e5):
        src = rng.uniform(0, 256, (count, 3)) + offset
        dst = src + rng.normal(0, 5, src.shape)
        matrix = np.eye(3) + rng.normal(0, 0.05, (500, 3, 3))
        translation = rng.normal(0, 5, (500, 3))
        expected = _summed_by_handle(src, dst, matrix, translation)
        assert_allclose(fit_residuals(src, dst, matrix, translation), expected, rtol=1e-9, atol=0)
    rotation = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    src = rng.uniform(0, 256, (count, 3)) + 1e4
    dst = src @ rotation + [3.0, -4.0, 5.0]
    matrix = np.repeat(rotation[None], 4, axis=0)
    translation = np.repeat([[3.0, -4.0, 5.0]], 4, axis=0)
    exact = fit_residuals(src, dst, matrix, translation)
    np.testing.assert_array_equal(exact, _summed_by_handle(src, dst, matrix, translation))
    identity = fit_residuals(src, src, np.repeat(np.eye(3)[None], 3, axis=0), np.zeros((3, 3)))
    assert (identity == 0).all()


def test_a_plain_function_is_a_type_error_saying_what_the_field_needs():
    """eq. 7 measures the fits m.matrices against the handles m.src, m.dst."""
    needs = r"m must be a glmls.MLS of \(N, 3\) handles or a glmls.analysis.ReferenceDeformation"
    with pytest.raises(TypeError, match=needs + r".*got function, without src, dst, matrices"):
        volume_error_field(lambda p: p, (3, 3, 3))

    class Handles:
        src = dst = SRC

        def __call__(self, points):
            return points

    with pytest.raises(TypeError, match=r"got Handles, without matrices \("):
        volume_error_field(Handles(), (3, 3, 3))
