"""The 3D analyses of a volume measure the f that warps it: a radius weight given no radius
takes the analysed volume's diagonal in the handles' units, as the volume's warp does, also
where the MLS was made without ``spacing`` (each warp's own) or with another ``shape``; and
``volume_report``'s ``radius_used`` is the radius its numbers were computed with."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

import glmls
from glmls.analysis import (
    ReferenceDeformation,
    cell_jacobians,
    tetrahedron_errors,
    volume_error_field,
    volume_report,
)
from glmls.core.handles3 import volume_diagonal
from glmls.volume import volume_coordinate_map

SHAPE = (6, 10, 16)  # D, H, W
SPACING = (2.0, 1.0, 0.5)  # dz, dy, dx: 12 x 10 x 8 units
SCALE = np.array(SPACING[::-1])  # (dx, dy, dz)
OPTIONS = {"weight": "gaussian", "transform": "affine"}


@pytest.fixture(scope="module")
def problem():
    rng = np.random.default_rng(5)
    extent = np.array(SHAPE[::-1]) * SCALE
    src = rng.uniform(0.1, 0.9, (8, 3)) * extent  # (x, y, z) in the handles' units
    dst = src + rng.uniform(-1.5, 1.5, src.shape)
    z, y, x = np.meshgrid(*(np.arange(n, dtype=np.float32) for n in SHAPE), indexing="ij")
    volume = (np.sin(x / 2) + np.cos(y / 3) + z / 4).astype(np.float32)
    return src, dst, volume


def _exact(src, dst):
    """The float64 f of the volume of SHAPE and SPACING: its diagonal is the radius."""
    return ReferenceDeformation(src, dst, shape=SHAPE, spacing=SPACING, **OPTIONS)


@pytest.mark.parametrize(
    "made", [{"shape": SHAPE}, {}, {"shape": (12, 12, 12), "spacing": None}], ids=str
)
def test_the_reference_analyses_take_the_analysed_volume_radius(problem, made):
    src, dst, _ = problem
    m = ReferenceDeformation(src, dst, **made, **OPTIONS)
    exact = _exact(src, dst)
    assert_allclose(
        volume_error_field(m, SHAPE, grid=3, spacing=SPACING),
        volume_error_field(exact, SHAPE, grid=3),
        rtol=1e-12,
        atol=1e-12,
    )
    cells, expected = (cell_jacobians(d, SHAPE, grid=4, spacing=SPACING) for d in (m, exact))
    assert_allclose(cells.det, expected.det, rtol=1e-12, atol=1e-12)


def test_an_explicit_radius_and_a_weight_without_one_are_kept(problem):
    src, dst, _ = problem
    for options in ({"weight": "gaussian", "radius": 7.0}, {"weight": "idw"}):
        m = ReferenceDeformation(src, dst, shape=SHAPE, **options)
        points = np.array([[3.0, 4.0, 5.0]])
        field = volume_error_field(m, (1, 1, 1), spacing=SPACING)  # the voxel at the origin
        assert_allclose(field.ravel(), glmls.reference.mls_error(src, dst, [[0.0, 0, 0]], m.config))
        assert_allclose(m(points), glmls.reference.mls(src, dst, points, m.config, shape=SHAPE)[0])


def test_the_gpu_analyses_of_an_mls_without_spacing_take_the_warp_radius(gl, problem):
    src, dst, volume = problem
    exact = _exact(src, dst)
    with glmls.MLS(src, dst, shape=SHAPE, ctx=gl, **OPTIONS) as m:  # no spacing: each warp's
        field = volume_error_field(m, SHAPE, grid=3, spacing=SPACING)
        cells = cell_jacobians(m, SHAPE, grid=4, spacing=SPACING)
        report = volume_report(volume, m, grid=3, jacobian_grid=4, spacing=SPACING)
        # the warp's f: its preimages map onto the output voxels under the exact f
        points, _, covered = volume_coordinate_map(m, SHAPE, method="backward", spacing=SPACING)
    assert_allclose(field, volume_error_field(exact, SHAPE, grid=3), rtol=1e-4, atol=1e-4)
    assert_allclose(cells.det, cell_jacobians(exact, SHAPE, grid=4).det, atol=1e-4)
    assert_array_equal(report.field, field)
    assert report.summary["jacobians"] == cells.stats()
    tetrahedra = tetrahedron_errors(exact, src)  # the handles as reference points
    assert_array_equal(report.tetrahedra.simplices, tetrahedra.simplices)
    assert_allclose(report.tetrahedra.angle, tetrahedra.angle, atol=1e-3)
    radius = report.summary["configuration"]["radius_used"]
    assert radius == pytest.approx(volume_diagonal(SHAPE, SPACING))
    z, y, x = np.meshgrid(*(np.arange(n) for n in SHAPE), indexing="ij")
    outputs = np.stack([x, y, z], -1)[covered] * SCALE
    assert_allclose(exact(points[covered]), outputs, atol=2e-3)
