"""Points next to a handle whose weight is infinite there, against the float64 reference:
the snapping distance follows the order of the weight's pole. Shepard's weight, (R - d) /
(R d), has a pole of order 1 whatever alpha: snapped within 1e-3 px, a point would leave out
the other handles' relative weights of ~1e-3 / d each, which move f by ~1e-3 px in all."""

from __future__ import annotations

import numpy as np
import pytest

import glmls
from glmls import reference

RADII = (1e-4, 5e-4, 9e-4, 2e-3)


def _near(rng, centre, dimension):
    """Points at RADII around ``centre`` in random directions."""
    directions = rng.normal(size=(50, dimension))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    return np.concatenate([centre + r * directions for r in RADII])


@pytest.mark.parametrize("transform", ["affine", "rigid"])
@pytest.mark.parametrize("dimension", [2, 3])
def test_shepard_next_to_a_handle_within_1e4_of_the_reference(gl, dimension, transform):
    rng = np.random.default_rng(100)
    size = 256.0
    src = rng.uniform(0, size, (64, dimension))
    dst = src + rng.normal(0, 8, src.shape)
    points = _near(rng, src[8], dimension)
    shape = (256,) * dimension
    options = {"transform": transform, "weight": "shepard"}
    with glmls.MLS(src, dst, shape=shape, **options) as m:
        f = m(points)
    f_ref, _, _ = reference.mls(src, dst, points, shape=shape, **options)
    # float32 at 256 px: ~2e-5; snapped within 1e-3 px the error reaches ~2e-3
    assert np.abs(f - f_ref).max() < 1e-4


@pytest.mark.parametrize("dimension", [2, 3])
def test_a_point_on_a_shepard_handle_maps_to_its_target(gl, dimension):
    rng = np.random.default_rng(1)
    src = rng.uniform(0, 100, (10, dimension))
    dst = src + rng.normal(0, 3, src.shape)
    with glmls.MLS(src, dst, weight="shepard", shape=(100,) * dimension) as m:
        f = m(src)
    assert np.abs(f - dst).max() < 1e-4
