"""The backward method finds every preimage that f has inside the volume where f does not
fold: Newton's method from a coarse lattice's guess must not stall in a two-cycle (where a
step raises the residual, it is halved) and leave such a voxel to the background."""

from __future__ import annotations

import numpy as np
import pytest

import glmls
from glmls.volume import volume_coordinate_map
from glmls.volume.fields import ReferenceField, newton_inverse


def _preimages(src, dst, transform, shape):
    """Float64 preimages of every voxel centre (Newton from the voxel itself), their
    residuals, and det J at every voxel centre of the volume."""
    field = ReferenceField(src, dst, glmls.MLSConfig(transform=transform), shape=shape)
    u = np.indices(shape)[::-1].reshape(3, -1).T.astype(np.float64)
    s, residual = newton_inverse(field, u, u)
    h = 1e-4
    jac = np.stack(
        [(field.evaluate(u + h * e) - field.evaluate(u - h * e)) / (2 * h) for e in np.eye(3)],
        axis=1,
    )
    return s, residual, np.linalg.det(jac)


CASES = [  # (seed, extent, spread, shape, transform): curved warps of no fold
    (2, 7.0, 1.0, (6, 7, 8), "similarity"),
    (5, 20.0, 1.5, (16, 20, 24), "rigid"),
    (10, 20.0, 1.5, (16, 20, 24), "similarity"),
]


@pytest.mark.parametrize("case", CASES)
@pytest.mark.parametrize("grid", [1, 3, 8])
def test_every_inner_preimage_is_found(gl, case, grid):
    seed, extent, spread, shape, transform = case
    rng = np.random.default_rng(seed)
    count = 6 if seed == 2 else int(rng.integers(4, 20))
    src = rng.uniform(0, extent, (count, 3))
    dst = src + rng.normal(0, spread, src.shape)
    s, residual, det = _preimages(src, dst, transform, shape)
    assert det.min() > 0  # no fold where the voxels are
    top = np.array(shape[::-1], np.float64) - 0.5
    inner = (residual < 1e-6) & np.all((s > -0.49) & (s < top - 0.01), axis=1)
    with glmls.MLS(src, dst, transform=transform, shape=shape) as m:
        points, _, covered = volume_coordinate_map(m, shape, grid=grid)
    covered = covered.reshape(-1)
    missed = np.flatnonzero(inner & ~covered)
    assert len(missed) == 0, f"{len(missed)} voxels with a preimage left uncovered: {missed[:5]}"
    found = inner & covered
    assert np.abs(points.reshape(-1, 3)[found] - s[found]).max() < 0.01


def test_newton_starts_again_from_the_voxel_where_the_cells_guess_leads_off(gl):
    """Next to a fold the cells' piecewise linear inverse may be another sheet's: voxel
    (15, 16, 16) of this map has one preimage, (15.94, 16.19, 15.36) (det J > 0 there), which
    Newton from the cells' guess missed (residual 0.24 voxel) and Newton from u finds."""
    rng = np.random.default_rng(7)
    src = rng.uniform([0, 0, 0], [31, 27, 23], (64, 3))
    dst = src + rng.normal(0, 3 / np.sqrt(3), src.shape)
    with glmls.MLS(src, dst, transform="rigid", shape=(24, 28, 32), ctx=gl) as m:
        coords, residual, covered = m.coordinate_map((24, 28, 32))
        assert covered[15, 16, 16] and residual[15, 16, 16] < 1e-3
        np.testing.assert_allclose(coords[15, 16, 16], [15.94, 16.19, 15.36], atol=0.01)
        np.testing.assert_allclose(m(coords[15, 16, 16][None])[0], [16, 16, 15], atol=1e-3)
