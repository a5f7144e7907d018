"""Volume warps and 3D analyses of an MLS made with ``spacing=(dz, dy, dx)``: they take its
spacing when given none, refuse another naming both, and a radius weight's default radius is
the physical diagonal, bit for bit that radius given explicitly; isotropic voxels change
nothing."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

import glmls
from glmls.analysis import ReferenceDeformation, cell_jacobians, volume_error_field
from glmls.core.handles3 import volume_diagonal
from glmls.volume import VolumeOptions, volume_bounds, volume_coordinate_map

SHAPE = (6, 10, 16)  # D, H, W
SPACING = (2.0, 1.0, 0.5)  # dz, dy, dx: 12 x 10 x 8 units
PHYSICAL = volume_diagonal(SHAPE, SPACING)
SCALE = np.array(SPACING[::-1])  # (dx, dy, dz)


@pytest.fixture(scope="module")
def problem():
    rng = np.random.default_rng(3)
    extent = np.array(SHAPE[::-1]) * SCALE
    src = rng.uniform(0.1, 0.9, (8, 3)) * extent  # (x, y, z) in the handles' units
    dst = src + rng.uniform(-1.0, 1.0, src.shape)
    z, y, x = np.meshgrid(*(np.arange(n, dtype=np.float32) for n in SHAPE), indexing="ij")
    volume = (np.sin(x / 2) + np.cos(y / 3) + z / 4).astype(np.float32)
    return src, dst, volume


def _warps(m, volume, **spacing):
    return [
        m.warp(volume, **spacing),
        m.warp(volume, method="backward", interpolation="linear", **spacing),
        volume_coordinate_map(m, SHAPE, **spacing)[0],
        np.array(volume_bounds(m, SHAPE, **spacing).origin),
    ]


@pytest.mark.parametrize("weight", ["gaussian", "linear"])
def test_a_warp_takes_the_mls_spacing_and_the_physical_diagonal(gl, problem, weight):
    src, dst, volume = problem
    common = {"weight": weight, "shape": SHAPE, "spacing": SPACING, "ctx": gl}
    with glmls.MLS(src, dst, **common) as m, glmls.MLS(src, dst, radius=PHYSICAL, **common) as e:
        found = _warps(m, volume)
        same_spacing = _warps(m, volume, spacing=SPACING)
        explicit = _warps(e, volume)
        assert m.bounds(SHAPE) == volume_bounds(m, SHAPE, spacing=SPACING)
        assert m.bounds(SHAPE).spacing == SPACING
    for a, b, c in zip(found, same_spacing, explicit, strict=True):
        assert_array_equal(a, b)
        assert_array_equal(a, c)
    with glmls.MLS(src, dst, weight=weight, shape=SHAPE, ctx=gl) as voxels:  # no spacing
        assert np.abs(voxels.warp(volume) - found[0]).max() > 1e-3  # the units differ


def test_the_warp_of_the_former_workaround_agrees(gl, problem):
    """radius= the physical diagonal, spacing given to each warp (no spacing on the MLS):
    the same f, up to float32 rounding of other GPU coordinates."""
    src, dst, volume = problem
    with (
        glmls.MLS(src, dst, weight="gaussian", shape=SHAPE, spacing=SPACING, ctx=gl) as m,
        glmls.MLS(src, dst, weight="gaussian", radius=PHYSICAL, ctx=gl) as former,
    ):
        found = m.warp(volume, method="backward", interpolation="linear")
        expected = former.warp(volume, method="backward", interpolation="linear", spacing=SPACING)
        points = volume_coordinate_map(m, SHAPE)[0]
        points_former = volume_coordinate_map(former, SHAPE, spacing=SPACING)[0]
    assert_allclose(found, expected, atol=1e-3)
    assert_allclose(points, points_former, atol=1e-3)


def test_another_spacing_is_refused_naming_both(gl, problem):
    src, dst, volume = problem
    message = r"spacing=\(1.0, 1.0, 1.0\) differs from the MLS's spacing=\(2.0, 1.0, 0.5\)"
    with glmls.MLS(src, dst, shape=SHAPE, spacing=SPACING, ctx=gl) as m:
        for attempt in (
            lambda: m.warp(volume, spacing=(1, 1, 1)),
            lambda: glmls.volume.warp_volume(m, volume, options=VolumeOptions(spacing=(1, 1, 1))),
            lambda: m.coordinate_map(SHAPE, spacing=(1.0, 1.0, 1.0)),
            lambda: m.bounds(SHAPE, spacing=[1, 1, 1]),
            lambda: volume_error_field(m, SHAPE, spacing=(1, 1, 1), grid=4),
            lambda: cell_jacobians(m, SHAPE, spacing=(1, 1, 1), grid=4),
        ):
            with pytest.raises(ValueError, match=message):
                attempt()
        options = VolumeOptions(method="backward", interpolation="linear")  # the MLS's spacing
        assert_array_equal(
            glmls.volume.warp_volume(m, volume, options=options), _warps(m, volume)[1]
        )


def test_isotropic_spacing_warps_as_none(gl, problem):
    src, dst, volume = problem
    with (
        glmls.MLS(src, dst, weight="gaussian", shape=SHAPE, ctx=gl) as plain,
        glmls.MLS(src, dst, weight="gaussian", shape=SHAPE, spacing=(1, 1, 1), ctx=gl) as unit,
    ):
        for a, b in zip(_warps(unit, volume), _warps(plain, volume), strict=True):
            assert_array_equal(a, b)


def test_the_analyses_take_the_mls_spacing(gl, problem):
    """The error field and the cells' J of the GPU MLS with spacing: those with the spacing
    given, and those of the float64 reference made with the same shape and spacing."""
    src, dst, _ = problem
    options = {"weight": "gaussian", "transform": "affine", "shape": SHAPE, "spacing": SPACING}
    reference = ReferenceDeformation(src, dst, **options)
    assert reference.spacing == SPACING
    with glmls.MLS(src, dst, ctx=gl, **options) as m:
        field = volume_error_field(m, SHAPE, grid=2)
        assert_array_equal(field, volume_error_field(m, SHAPE, grid=2, spacing=SPACING))
        cells = cell_jacobians(m, SHAPE, grid=2)
        assert_array_equal(cells.det, cell_jacobians(m, SHAPE, grid=2, spacing=SPACING).det)
    expected = volume_error_field(reference, SHAPE, grid=2)
    assert_array_equal(expected, volume_error_field(reference, SHAPE, grid=2, spacing=SPACING))
    assert_allclose(field, expected, rtol=1e-3, atol=1e-3)
    assert_allclose(cells.det, cell_jacobians(reference, SHAPE, grid=2).det, atol=1e-3)


def test_the_volume_report_takes_the_mls_spacing(gl, problem):
    src, dst, volume = problem
    with glmls.MLS(src, dst, weight="gaussian", shape=SHAPE, spacing=SPACING, ctx=gl) as m:
        report = glmls.analysis.volume_report(volume, m, grid=4)
        assert report.summary["analysis"]["spacing"] == list(SPACING)
        assert_array_equal(report.field, volume_error_field(m, SHAPE, grid=4))
        with pytest.raises(ValueError, match="differs from the MLS's spacing"):
            glmls.analysis.volume_report(volume, m, grid=4, spacing=(1, 1, 1))
