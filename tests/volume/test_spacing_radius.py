"""A radius weight's default radius in a volume warp with ``spacing``: the diagonal of the
volume in the handles' units, sqrt((D dz)^2 + (H dy)^2 + (W dx)^2), as ``glmls warp`` takes
it; the same as that radius given explicitly, and as the float64 reference's."""

from __future__ import annotations

import math

import numpy as np
from numpy.testing import assert_allclose, assert_array_equal

import glmls
from glmls.core.config import MLSConfig
from glmls.core.handles3 import volume_extent
from glmls.volume import volume_bounds, volume_coordinate_map
from glmls.volume.fields import ReferenceField

SHAPE = (5, 9, 8)  # D, H, W
SPACING = (2.0, 1.0, 1.0)  # dz, dy, dx
PHYSICAL = math.sqrt(sum((n * d) ** 2 for n, d in zip(SHAPE, SPACING, strict=True)))
VOXELS = math.sqrt(sum(n**2 for n in SHAPE))


def _problem():
    rng = np.random.default_rng(11)
    extent = np.array([SHAPE[2] * SPACING[2], SHAPE[1] * SPACING[1], SHAPE[0] * SPACING[0]])
    src = rng.uniform(0.5, 1.0, (7, 3)) * (extent - 1)  # handles in physical units (x, y, z)
    dst = src + rng.uniform(-1.5, 1.5, (7, 3))
    z, y, x = np.meshgrid(*(np.arange(n, dtype=np.float32) for n in SHAPE), indexing="ij")
    volume = (np.sin(x / 2) + np.cos(y / 3) + z / 4).astype(np.float32)
    return src, dst, volume


def test_the_physical_extent():
    assert volume_extent(SHAPE, SPACING) == (10.0, 9.0, 8.0)


def test_gaussian_volume_warp_with_spacing_takes_the_physical_diagonal(gl):
    src, dst, volume = _problem()
    options = {"spacing": SPACING, "method": "backward", "interpolation": "linear"}
    with glmls.MLS(src, dst, weight="gaussian", shape=SHAPE, ctx=gl) as m:
        default = m.warp(volume, **options)
        default_map = volume_coordinate_map(m, SHAPE, spacing=SPACING)[0]
        default_bounds = volume_bounds(m, SHAPE, spacing=SPACING)
    with glmls.MLS(src, dst, weight="gaussian", radius=PHYSICAL, shape=SHAPE, ctx=gl) as m:
        physical = m.warp(volume, **options)
        physical_map = volume_coordinate_map(m, SHAPE, spacing=SPACING)[0]
        physical_bounds = volume_bounds(m, SHAPE, spacing=SPACING)
    with glmls.MLS(src, dst, weight="gaussian", radius=VOXELS, shape=SHAPE, ctx=gl) as m:
        voxels = m.warp(volume, **options)
    assert_array_equal(default, physical)
    assert_array_equal(default_map, physical_map)
    assert default_bounds == physical_bounds
    assert np.abs(default - voxels).max() > 1e-3  # the radius matters here


def test_the_reference_field_takes_the_physical_diagonal_too():
    src, dst, _ = _problem()
    points = np.array([[1.0, 2.0, 1.5], [4.0, 6.0, 3.0]])  # voxels (x, y, z)
    config = MLSConfig(weight="gaussian")
    default = ReferenceField(src, dst, config, spacing=SPACING, shape=SHAPE).evaluate(points)
    explicit = ReferenceField(
        src, dst, MLSConfig(weight="gaussian", radius=PHYSICAL), spacing=SPACING
    ).evaluate(points)
    assert_allclose(default, explicit, rtol=0, atol=1e-12)
    scale = np.array(SPACING[::-1])
    f, _, _ = glmls.reference.mls(
        src, dst, points * scale, MLSConfig(weight="gaussian", radius=PHYSICAL)
    )
    assert_allclose(default, f / scale, rtol=0, atol=1e-12)
