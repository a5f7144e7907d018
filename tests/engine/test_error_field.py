"""The MLS error field (paper eq. 7) on the GPU against float64 formulas."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import random_handles
from numpy.testing import assert_allclose

import glmls
from glmls import reference
from glmls.core.mesh import MeshLattice

SHAPE = (96, 128)


def formula_field(p, q, points, config, shape):
    """E_MLS(v) = sum_i |p_i M_v + T_v - q_i|^2 with M, T from the float64 reference."""
    _, big_m, t = reference.mls(p, q, points, config, shape=shape)
    mapped = np.einsum("ni,kij->knj", p, big_m) + t[:, None, :]  # l_v(p_i), (K, N, 2)
    return ((mapped - q[None]) ** 2).sum(axis=(1, 2))


def sample_pixels(rng, shape, p, k=400):
    """Random pixel centres plus the handles' own pixels (snapped there for some weights)."""
    rows = rng.integers(0, shape[0], k)
    cols = rng.integers(0, shape[1], k)
    inside = (p[:, 0] >= 0) & (p[:, 0] < shape[1]) & (p[:, 1] >= 0) & (p[:, 1] < shape[0])
    rows = np.concatenate([rows, p[inside, 1].astype(int)])
    cols = np.concatenate([cols, p[inside, 0].astype(int)])
    return rows, cols


CASES = [
    ("affine", "idw", {}),
    ("similarity", "idw", {}),
    ("rigid", "idw", {}),
    ("rigid", "idw", {"alpha": 2.0}),
    ("similarity", "shepard", {}),
    ("affine", "cressman", {"radius": 60.0}),
    ("rigid", "gaussian", {"radius": 40.0}),
    ("similarity", "linear", {"interpolating": True}),
]


@pytest.mark.parametrize(("transform", "weight", "options"), CASES)
@pytest.mark.parametrize("n", [4, 40])
def test_matches_formula_at_sampled_pixels(gl, rng, transform, weight, options, n):
    p, q = random_handles(rng, n, size=128.0, displacement=15.0)
    p[:2] = np.round(p[:2])  # two handles exactly on pixel centres
    with glmls.MLS(p, q, transform=transform, weight=weight, shape=SHAPE, ctx=gl, **options) as m:
        field = m.error_field(SHAPE)
    assert field.shape == SHAPE
    assert field.dtype == np.float64
    rows, cols = sample_pixels(rng, SHAPE, p)
    expected = formula_field(p, q, np.stack([cols, rows], 1).astype(float), m.config, SHAPE)
    # Relative difference at most 1e-4; below 1 px² the floor is an absolute 1e-4 px²
    # (float32 resolves residuals to ~4e-6 of the scaled coordinates only).
    assert_allclose(field[rows, cols], expected, rtol=1e-4, atol=1e-4)


@pytest.mark.parametrize("grid", [4, 7, 50])
def test_grid_interpolates_the_vertex_values_bilinearly(gl, rng, grid):
    shape = (45, 61)  # not a multiple of any grid: the last cells are shorter
    p, q = random_handles(rng, 6, size=60.0, displacement=8.0)
    with glmls.MLS(p, q, transform="similarity", shape=shape, ctx=gl) as m:
        field = m.error_field(shape, grid=grid)
    xs, ys = MeshLattice.corners(shape, grid).axes
    vertices = np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2)
    at_vertices = formula_field(p, q, vertices, m.config, shape).reshape(len(ys), len(xs))
    # bilinear on a rectilinear grid is separable: along x, then along y
    along_x = np.array([np.interp(np.arange(shape[1]), xs, row) for row in at_vertices])
    expected = np.array([np.interp(np.arange(shape[0]), ys, col) for col in along_x.T]).T
    assert_allclose(field, expected, rtol=1e-4, atol=1e-4)


@pytest.mark.parametrize("transform", glmls.TRANSFORMS)
@pytest.mark.parametrize(
    "options", [{"weight": "idw"}, {"weight": "shepard"}, {"weight": "gaussian", "radius": 30.0}]
)
@pytest.mark.parametrize("grid", [1, 8])
def test_identity_gives_exactly_zero(gl, rng, transform, options, grid):
    p = rng.uniform(0, 128, (30, 2))
    with glmls.MLS(p, p, transform=transform, shape=SHAPE, ctx=gl, **options) as m:
        field = m.error_field(SHAPE, grid=grid)
    assert not field.any()


@pytest.mark.parametrize("transform", ["affine", "similarity"])
def test_transform_that_fits_every_handle_gives_zero(gl, rng, transform):
    p = rng.uniform(0, 128, (25, 2))
    angle = 0.3
    rotation = np.array([[np.cos(angle), np.sin(angle)], [-np.sin(angle), np.cos(angle)]])
    q = 1.3 * p @ rotation + [7.0, -4.0]
    with glmls.MLS(p, q, transform=transform, shape=SHAPE, ctx=gl) as m:
        assert not m.error_field(SHAPE).any()


def test_no_handles_and_one_handle_give_zero(gl):
    for src, dst in (([], []), ([[10.0, 20.0]], [[30.0, 5.0]])):
        with glmls.MLS(src, dst, ctx=gl) as m:
            assert not m.error_field((8, 9)).any()


def test_tiny_images_match_the_formula(gl, rng):
    """1 x 1, 1 x 7 (grid 3: one row of cells) and 5 x 5 (grid 2) images, as the function
    and as the method, against the float64 formula."""
    p, q = random_handles(rng, 5, size=10.0, displacement=3.0)
    with glmls.MLS(p, q, ctx=gl) as m:
        for shape, grid in (((1, 1), 1), ((3, 4), 1), ((1, 7), 3), ((5, 5), 2)):
            field = glmls.analysis.error_field(m, shape, grid=grid)
            assert field.shape == shape
            xs, ys = MeshLattice.corners(shape, grid).axes
            if grid == 1:
                xs, ys = np.arange(shape[1], dtype=float), np.arange(shape[0], dtype=float)
            points = np.stack(np.meshgrid(xs, ys), -1).reshape(-1, 2)
            at = formula_field(p, q, points, m.config, None).reshape(len(ys), len(xs))
            if grid == 1:
                expected = at
            else:
                along_x = np.array([np.interp(np.arange(shape[1]), xs, row) for row in at])
                expected = np.array([np.interp(np.arange(shape[0]), ys, c) for c in along_x.T]).T
            assert_allclose(field, expected, rtol=1e-4, atol=1e-4)
            assert_allclose(m.error_field(shape, grid=grid), field, rtol=0, atol=0)
            assert (field > 0).all()


def test_bad_arguments(gl):
    with glmls.MLS([[0.0, 0.0]], [[1.0, 1.0]], ctx=gl) as m:
        for grid in (0, -2):
            with pytest.raises(ValueError, match="grid"):
                m.error_field((4, 4), grid=grid)
        for grid in (1.5, True):
            with pytest.raises(TypeError, match="grid"):
                m.error_field((4, 4), grid=grid)
        with pytest.raises(ValueError, match="shape"):
            m.error_field((0, 4))
        with pytest.raises(TypeError, match="shape"):
            m.error_field(5)
    with pytest.raises(glmls.ReleasedError):
        m.error_field((4, 4))


def test_error_at_points_matches_the_reference(gl, rng):
    """E_MLS at any points (the adaptive field's vertices), points and segments, against
    the float64 reference."""
    from glmls import reference
    from glmls.engine.error_field import error_at

    shape = (90, 120)
    p = rng.uniform(5, 85, (9, 2))
    q = p + rng.normal(0, 4, p.shape)
    segments = np.array([[[10.0, 70], [60, 80]]])
    moved = segments + [3.0, -2.0]
    points = rng.uniform(-3, 120, (2500, 2))
    with glmls.MLS(p, q, shape=shape, src_segments=segments, dst_segments=moved) as m:
        values = error_at(m.kernel, points, shape)
        assert error_at(m.kernel, np.zeros((0, 2)), shape).shape == (0,)
        config = m.config
    expected = reference.mls_error(
        p, q, points, config, shape=shape, src_segments=segments, dst_segments=moved
    )
    np.testing.assert_allclose(values, expected, rtol=1e-4, atol=1e-6 * expected.max())
