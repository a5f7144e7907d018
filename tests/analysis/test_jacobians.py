"""det J, the singular value ratio and the folds per cell of a volume's lattice, against
hand-computed maps and a cell-by-cell computation from the float64 reference."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

import glmls
from glmls.analysis import ReferenceDeformation, cell_jacobians, tetrahedron_errors


def folded_in_x(v):
    """x mirrored beyond the plane x = 3.5: the cells past it fold, the others do not."""
    out = np.array(v, dtype=float)
    out[:, 0] = np.where(out[:, 0] < 3.5, out[:, 0], 7.0 - out[:, 0])
    return out


def test_the_identity_and_a_translation_fold_nothing():
    cells = cell_jacobians(lambda v: v + [1.0, 2.0, 3.0], (5, 6, 7))
    assert cells.det.shape == (5, 6, 7) and cells.mask.shape == (5, 6, 7)
    assert_allclose(cells.det, 1.0, rtol=1e-12)
    assert_allclose(cells.min_det, 1.0, rtol=1e-12)
    assert_allclose(cells.ratio, 1.0, rtol=1e-12)
    assert cells.count == 0 and not cells.mask.any()
    stats = cells.stats()
    assert stats["cells"] == 210 and stats["folds"] == 0 and stats["folded_voxels"] == 0
    assert stats["det"]["median"] == pytest.approx(1.0)


@pytest.mark.parametrize("grid", [1, 2, 3])
def test_an_affine_map_has_its_det_and_singular_values_everywhere(grid):
    a = np.array([[2.0, 0.3, 0.0], [0.1, 1.0, 0.2], [0.0, -0.4, 0.5]])  # f(v) = v A
    cells = cell_jacobians(lambda v: v @ a + 4.0, (5, 7, 8), grid=grid)
    # the last step is shorter where the grid does not divide the side: still exact
    assert cells.det.shape == tuple(-(-n // grid) for n in (5, 7, 8))
    assert_allclose(cells.det, np.linalg.det(a), rtol=1e-10)
    assert_allclose(cells.min_det, np.linalg.det(a), rtol=1e-10)
    singular = np.linalg.svd(a, compute_uv=False)
    assert_allclose(cells.ratio, singular[0] / singular[2], rtol=1e-10)
    assert cells.count == 0


def test_a_mirror_folds_every_cell():
    cells = cell_jacobians(lambda v: v * [1.0, -1.0, 1.0], (4, 4, 4), grid=2)
    assert cells.count == 8 and cells.mask.all()
    assert_allclose(cells.det, -1.0)


def test_a_collapse_folds_every_cell_with_a_singular_ratio():
    cells = cell_jacobians(lambda v: v * [1.0, 1.0, 0.0], (2, 3, 3))
    assert cells.count == 18 and np.isnan(cells.ratio).all()
    assert cells.stats()["ratio"]["nan_count"] == 18


def onto_plane(v, offset=0.0):
    """f projects onto the plane x + y + z = offset: det J is 0, but rounds to +-4e-16."""
    v = np.asarray(v, dtype=float)
    return v - (v.sum(axis=1, keepdims=True) - offset) / 3


@pytest.mark.parametrize(
    "f",
    [
        onto_plane,
        lambda v: onto_plane(v, 3000.0),
        lambda v: np.outer(v @ [1.0, 2.0, 3.0], [0.3, 0.5, 0.7]),  # onto a line
        lambda v: np.zeros_like(v) + 5.0,  # onto a point
    ],
)
@pytest.mark.parametrize("grid", [1, 2])
def test_a_flattening_that_rounds_off_zero_folds_every_cell_with_a_singular_ratio(f, grid):
    cells = cell_jacobians(f, (4, 5, 6), grid=grid)
    assert cells.count == cells.det.size and cells.mask.all()
    assert (cells.det == 0).all() and (cells.min_det == 0).all()
    assert np.isnan(cells.ratio).all() and cells.stats()["ratio"]["count"] == 0


def test_a_thin_squeeze_is_no_flattening():
    cells = cell_jacobians(lambda v: v * [1.0, 1.0, 1e-9] + 100.0, (3, 4, 5))
    assert cells.count == 0 and not np.isnan(cells.ratio).any()
    assert_allclose(cells.det, 1e-9, rtol=1e-4)
    assert_allclose(cells.min_det, 1e-9, rtol=1e-4)
    assert_allclose(cells.ratio, 1e9, rtol=1e-4)


def test_on_the_gpu_a_flattening_mls_folds_every_cell_and_inverts_every_tetrahedron(gl):
    src = np.random.default_rng(0).uniform(0, [13, 11, 9], (8, 3))
    dst = onto_plane(src, 5.0)  # an affine fit of it is f itself, in float32 on the GPU
    shape = (10, 12, 14)
    try:
        m = glmls.MLS(src, dst, transform="affine", shape=shape, ctx=gl)
    except (TypeError, ValueError) as error:
        pytest.skip(f"glmls.MLS takes no (N, 3) handles here: {error}")
    with m:
        cells = cell_jacobians(m, shape)
        tetrahedra = tetrahedron_errors(m, src)
    assert cells.count == cells.det.size and np.isnan(cells.ratio).all()
    assert tetrahedra.inverted.all()


@pytest.mark.parametrize("grid", [1, 2])
def test_folds_are_counted_at_the_right_cells(grid):
    cells = cell_jacobians(folded_in_x, (3, 2, 8), grid=grid)
    # cell corners in x: -0.5, -0.5 + grid, ...: the cells past x = 3.5 fold
    corners = np.append(np.arange(0, 8, grid) - 0.5, 7.5)
    expected_x = corners[:-1] >= 3.5
    assert_array_equal(cells.folded, np.broadcast_to(expected_x, cells.folded.shape))
    voxels = np.arange(8) >= 4
    assert_array_equal(cells.mask, np.broadcast_to(voxels, (3, 2, 8)))
    assert cells.count == expected_x.sum() * cells.folded.shape[0] * cells.folded.shape[1]


def cell_by_cell(f, corners):
    """det J at the centre and the Kuhn tetrahedra's smallest det, one cell at a time."""
    z, y, x = corners
    shape = (len(z) - 1, len(y) - 1, len(x) - 1)
    det, low = np.empty(shape), np.empty(shape)
    for k, j, i in itertools.product(*(range(n) for n in shape)):
        h = np.array([x[i + 1] - x[i], y[j + 1] - y[j], z[k + 1] - z[k]])
        at = {}
        for b in itertools.product((0, 1), repeat=3):  # (bx, by, bz)
            point = [x[i + b[0]], y[j + b[1]], z[k + b[2]]]
            at[b] = f(np.array([point]))[0]
        columns = []
        for axis in range(3):
            edges = [
                at[b] - at[tuple(0 if a == axis else c for a, c in enumerate(b))]
                for b in at
                if b[axis] == 1
            ]
            columns.append(np.mean(edges, axis=0) / h[axis])
        det[k, j, i] = np.linalg.det(np.array(columns).T)
        dets = []
        for order in itertools.permutations(range(3)):
            b = [0, 0, 0]
            path = [tuple(b)]
            for axis in order:
                b[axis] = 1
                path.append(tuple(b))
            jac = np.zeros((3, 3))
            for step, axis in enumerate(order):
                jac[:, axis] = (at[path[step + 1]] - at[path[step]]) / h[axis]
            dets.append(np.linalg.det(jac))
        low[k, j, i] = min(dets)
    return det, low


def test_the_mls_of_crossing_handles_folds_where_the_cell_by_cell_computation_does():
    shape = (6, 8, 10)
    src = np.array(
        [[3.0, 4, 3], [6, 4, 3], [0, 0, 0], [9, 0, 0], [0, 7, 0], [9, 7, 5], [0, 0, 5], [5, 7, 5]]
    )
    dst = src.copy()
    dst[0], dst[1] = src[1], src[0]  # two handles swap places: the map folds between them
    m = ReferenceDeformation(src, dst, transform="affine", shape=shape)
    cells = cell_jacobians(m, shape, grid=2)
    corners = [np.append(np.arange(0, n, 2) - 0.5, n - 0.5) for n in shape]
    det, low = cell_by_cell(m, corners)
    assert_allclose(cells.det, det, rtol=1e-9, atol=1e-12)
    assert_allclose(cells.min_det, low, rtol=1e-9, atol=1e-12)
    expected = (det <= 0) | (low <= 0)
    assert_array_equal(cells.folded, expected)
    assert 0 < cells.count < cells.folded.size
    index = np.ix_(*(np.arange(n) // 2 for n in shape))
    assert_array_equal(cells.mask, expected[index])
    # the handles' midpoint (4.5, 4, 3) lies in a folded cell
    assert cells.mask[3, 4, 4]


def test_bad_arguments_raise():
    with pytest.raises(ValueError, match="D, H, W"):
        cell_jacobians(lambda v: v, (4, 4))
    with pytest.raises(TypeError, match="grid"):
        cell_jacobians(lambda v: v, (4, 4, 4), grid=1.5)
    with pytest.raises(ValueError, match="values per point"):
        cell_jacobians(lambda v: v[:, :2], (2, 2, 2))
    with pytest.raises(ValueError, match="NaN"):
        cell_jacobians(lambda v: v * np.nan, (2, 2, 2))
    with pytest.raises(TypeError, match="complex128 values, expected real numbers"):
        cell_jacobians(lambda v: v + 0j, (2, 2, 2))


def test_slabs_of_cells_give_the_same_cells(monkeypatch):
    m = ReferenceDeformation(
        [[1.0, 1, 1], [8, 1, 1], [1, 8, 1], [1, 1, 6], [5, 4, 3]],
        [[1.0, 1, 1], [8, 1, 1], [1, 8, 1], [1, 1, 6], [7, 5, 3]],
        transform="affine",
    )
    whole = cell_jacobians(m, (7, 9, 10), grid=2)
    from glmls.analysis import jacobians

    monkeypatch.setattr(jacobians, "SLAB_POINTS", 1)  # one plane of cells at a time
    sliced = cell_jacobians(m, (7, 9, 10), grid=2)
    for name in ("det", "ratio", "min_det", "folded", "mask"):
        assert_array_equal(getattr(sliced, name), getattr(whole, name), err_msg=name)


def svd_cells(f, shape):
    """det and the singular value ratio per cell by numpy's det and SVD of each J (the
    flat rule left out: a map far from flat)."""
    corners = [np.arange(n + 1) - 0.5 for n in shape]
    z, y, x = corners
    zz, yy, xx = np.meshgrid(z, y, x, indexing="ij")
    values = f(np.stack([xx.ravel(), yy.ravel(), zz.ravel()], axis=1))
    values = values.reshape(*zz.shape, 3)
    columns = []
    for axis in (2, 1, 0):  # x, y, z: the mean of the four edges along the axis
        edges = np.diff(values, axis=axis)
        for other in {0, 1, 2} - {axis}:
            edges = (
                edges.take(range(edges.shape[other] - 1), other)
                + edges.take(range(1, edges.shape[other]), other)
            ) / 2
        columns.append(edges)
    jacobian = np.stack(columns, axis=-1)
    singular = np.linalg.svd(jacobian, compute_uv=False)
    return np.linalg.det(jacobian), singular[..., 0] / singular[..., 2]


def test_det_and_ratio_agree_with_numpys_det_and_svd_per_cell():
    src = np.random.default_rng(3).uniform(0, [11, 9, 7], (12, 3))
    dst = src + np.random.default_rng(4).normal(0, 1.5, src.shape)
    shape = (7, 9, 11)
    m = ReferenceDeformation(src, dst, transform="rigid", shape=shape)
    cells = cell_jacobians(m, shape)
    det, ratio = svd_cells(m, shape)
    # J is well conditioned here (ratio < 1e3): both within 1e-12 of numpy's
    assert ratio.max() < 1e3 and 0 < cells.count < cells.det.size
    assert_allclose(cells.det, det, rtol=1e-12, atol=1e-12 * np.abs(det).max())
    assert_allclose(cells.ratio, ratio, rtol=1e-12)


@pytest.mark.parametrize(("block", "slab"), [(1, 1), (7, 50), (40, 10**9), (10**9, 10**9)])
def test_blocks_of_cells_give_the_same_bits(monkeypatch, block, slab):
    # blocks of one cell row, of rows that do not divide a layer, of layers, and one block
    from glmls.analysis import jacobians

    src = np.random.default_rng(5).uniform(0, [10, 9, 8], (9, 3))
    dst = src + np.random.default_rng(6).normal(0, 2.0, src.shape)
    m = ReferenceDeformation(src, dst, transform="similarity", shape=(8, 9, 10))
    whole = cell_jacobians(m, (8, 9, 10))
    monkeypatch.setattr(jacobians, "BLOCK_CELLS", block)
    monkeypatch.setattr(jacobians, "SLAB_POINTS", slab)
    parts = cell_jacobians(m, (8, 9, 10))
    assert 0 < whole.count < whole.det.size
    for name in ("det", "ratio", "min_det", "folded", "mask"):
        assert_array_equal(getattr(parts, name), getattr(whole, name), err_msg=name)


def test_memory_stays_near_the_size_of_the_results():
    import tracemalloc

    def f(v):
        return v * [1.0, 1.1, 0.9] + 0.01 * v[:, [1, 2, 0]] ** 2

    cell_jacobians(f, (4, 4, 4))  # imports and caches before the count
    tracemalloc.start()
    try:
        cells = cell_jacobians(f, (64, 64, 64))
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    results = sum(a.nbytes for a in (cells.det, cells.ratio, cells.min_det, cells.mask))
    # the results take 6.5 MB; J, its singular values and the Kuhn tetrahedra of all
    # 262144 cells at once would take some 130 MB more
    assert peak - results < 48 * 2**20


@pytest.mark.parametrize("scale", [1e-30, 1e30])
def test_scaled_maps_keep_their_cells_and_flattenings(scale):
    rotation = np.array([[0.6, 0.8, 0.0], [-0.8, 0.6, 0.0], [0.0, 0.0, 1.0]])
    for f in (lambda v: v @ rotation * scale, lambda v: v * scale):
        cells = cell_jacobians(f, (4, 5, 6))
        assert cells.count == 0
        assert_allclose(cells.det, scale**3, rtol=1e-14)
        assert_allclose(cells.ratio, 1.0, rtol=4e-15)
    for f in (
        lambda v: onto_plane(v) * scale,
        lambda v: np.outer(v @ [1.0, 2.0, 3.0], [0.3, 0.5, 0.7]) * scale,
    ):
        cells = cell_jacobians(f, (4, 5, 6))
        assert cells.folded.all() and (cells.det == 0).all() and np.isnan(cells.ratio).all()
