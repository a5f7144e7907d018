"""Fold-overs: the cells f turns over, against the float64 reference mesh."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import cross, reference_mesh
from numpy.testing import assert_array_equal

import glmls
from glmls.analysis.folding import folded_cells


def test_foldovers_match_the_reference_mesh(gl):
    shape = (30, 40)
    p = np.array([[8, 8], [32, 8], [20, 15], [8, 24], [32, 24.0]])
    q = p.copy()
    q[2] = [30, 16]
    with glmls.MLS(p, q, ctx=gl) as m:
        for grid in (1, 3):
            folds = glmls.analysis.foldovers(m, shape, grid=grid)
            f = reference_mesh(m, shape, grid)
            a, b, c, d = f[:-1, :-1], f[:-1, 1:], f[1:, 1:], f[1:, :-1]
            ref = (cross(b - a, c - a) < 0) | (cross(c - a, d - a) < 0)
            assert folds.count == ref.sum() > 0
            # the mask is exactly the source pixels of the folded cells
            rows, cols = np.nonzero(ref)
            expected = np.zeros(shape, bool)
            for r, c_ in zip(rows, cols, strict=True):
                expected[r * grid : (r + 1) * grid, c_ * grid : (c_ + 1) * grid] = True
            assert_array_equal(folds.mask, expected)
    with glmls.MLS(p, p, ctx=gl) as identity:
        assert glmls.analysis.foldovers(identity, shape).count == 0


def test_the_grid_is_keyword_only(gl):
    """As ``m.mesh``, ``m.bounds`` and ``glmls.analysis.error_field`` take it."""
    src = np.array([[2.0, 2.0], [13.0, 2.0], [2.0, 13.0]])
    with glmls.MLS(src, src + 1.0, ctx=gl) as m:
        assert glmls.analysis.foldovers(m, (16, 16), grid=4).count == 0
        with pytest.raises(TypeError, match="positional"):
            glmls.analysis.foldovers(m, (16, 16), 4)  # type: ignore[misc]


def test_folded_cells_of_a_turned_quad():
    """A mesh of one cell: mirrored in x it folds; corner 11 pulled across the diagonal's
    far side turns one triangle over, which is enough."""
    square = np.array([[[0.0, 0.0], [1.0, 0.0]], [[0.0, 1.0], [1.0, 1.0]]])
    assert not folded_cells(square).any()
    assert folded_cells(square[:, ::-1]).all()
    dented = square.copy()
    dented[1, 1] = [-0.5, 0.5]  # triangle (00, 11, 01) turns over, (00, 10, 11) does not
    assert folded_cells(dented).all()


def test_a_cell_crushed_flat_folds():
    """A cell whose corners all land on one point, or one line, has no orientation left."""
    square = np.array([[[0.0, 0.0], [1.0, 0.0]], [[0.0, 1.0], [1.0, 1.0]]])
    assert folded_cells(np.zeros_like(square) + 5.0).all()
    assert folded_cells(square * [1.0, 0.0]).all()
    assert not folded_cells(square * 1e-3).any()


def test_a_mesh_crushed_to_float32_rounding_folds_everywhere(gl):
    """Every handle sent to one point: the GPU's mesh lands within float32's rounding of it,
    and the cells' signs are rounding, not orientation: all of them fold, as the reference
    triangles of the same map are flipped (glmls.analysis.triangle_errors)."""
    src = np.array([[4, 4], [28, 4], [28, 28], [4, 28.0]])
    dst = np.tile([[16.0, 16.0]], (4, 1))
    with glmls.MLS(src, dst, transform="affine", ctx=gl) as m:
        folds = glmls.analysis.foldovers(m, (32, 32))
        _, deformed = m.mesh((32, 32), grid=1)
    assert np.abs(deformed - 16.0).max() < 1e-5  # crushed, up to rounding
    assert folds.count == 32 * 32
    # an exact float64 mesh a thousandth of the size keeps its orientation
    square = np.stack(np.meshgrid(np.arange(33.0), np.arange(33.0)), -1)
    assert not folded_cells(16.0 + 1e-3 * square, rounding=float(np.finfo(np.float64).eps)).any()


def test_tune_sets_apart_a_configuration_that_crushes_the_image(gl):
    """Every handle dragged onto one point: an affine fit crushes every triangle to a point,
    which folds."""
    src = np.array([[10, 10], [50, 10], [50, 50], [10, 50], [30, 30.0]])
    dst = np.tile([[30.0, 30.0]], (5, 1))
    reference = np.array([[15, 15], [45, 15], [45, 45], [15, 45], [30, 20.0]])
    configs = [glmls.MLSConfig(transform="affine")]
    found = glmls.analysis.tune((64, 64), src, dst, reference, trials=1, configs=configs, ctx=gl)
    assert found.rows[0]["folds_mean"] > 0
    assert not found.rows[0]["admissible"]
