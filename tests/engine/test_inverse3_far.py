"""f's 3D inverse far from the handles: there f tends to the fit of all of them, which the
swapped MLS inverts only up to a share of the distance (exactly for rigid), so Newton's steps
grow with the distance; f(inverse(u)) is u, by the float64 f, within the residual that
the inverse accepts, across glmls's coordinate range, and near the handles the inverse is
that of the fixed steps, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_array_equal

import glmls
from glmls import reference
from glmls.engine import passes3
from glmls.engine.passes3 import length_unit
from glmls.imaging.inverse import accept_residual

TRANSFORMS = ("affine", "similarity", "rigid")
#: Distances (voxels) from the handles' box, up to where f(x) stays in the ±1e6 range.
DISTANCES = (1e3, 1e4, 3e4, 1e5, 4e5)


def _handles(seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """8 handles in a 64^3 box, each moved about 3 voxels a coordinate."""
    rng = np.random.default_rng(seed)
    src = rng.uniform(0, 64, (8, 3))
    return src, src + rng.normal(0, 3, src.shape)


def _far_points(distance: float, count: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    way = rng.normal(size=(count, 3))
    return 32 + distance * way / np.linalg.norm(way, axis=1, keepdims=True)


@pytest.mark.parametrize("transform", TRANSFORMS)
def test_far_points_come_back_by_the_float64_f(gl, transform):
    src, dst = _handles()
    x = np.concatenate([_far_points(d, 40, k) for k, d in enumerate(DISTANCES)])
    u, _, _ = reference.mls(src, dst, x, transform=transform)
    with glmls.MLS(src, dst, transform=transform, ctx=gl) as m:
        s, valid = m.inverse(u, return_valid=True)
        accepted = accept_residual(m.scaling, u, s, unit=length_unit(m.kernel))
    assert valid.all(), x[~valid]
    back, _, _ = reference.mls(src, dst, s, transform=transform)
    miss = np.linalg.norm(back - u, axis=1)
    assert (miss <= accepted).all(), (miss / accepted).max()
    # f is one to one out there: the preimage found is x itself
    assert (np.linalg.norm(s - x, axis=1) <= 1e-5 * np.linalg.norm(x - 32, axis=1)).all()


def test_a_point_2e4_voxels_away_comes_back_as_in_2d(gl):
    """The similarity of 8 handles gave NaN 2e4 voxels away in 3D; 2D returns the point."""
    for dimension in (2, 3):
        rng = np.random.default_rng(0)
        src = rng.uniform(0, 64, (8, dimension))
        dst = src + rng.normal(0, 3, src.shape)
        x = np.full((1, dimension), 2e4)
        with glmls.MLS(src, dst, transform="similarity", ctx=gl) as m:
            s, valid = m.inverse(m(x), return_valid=True)
        assert valid.all(), dimension
        assert np.abs(s - x).max() < 0.05, dimension


@pytest.mark.parametrize("weight", [{}, {"alpha": 2.0}, {"weight": "gaussian", "radius": 40.0}])
def test_near_points_keep_the_fixed_steps_bit_for_bit(gl, monkeypatch, weight):
    """Within NEWTON_FAR3 scaled units of the box's centre a step's cap is
    NEWTON_MAX_STEP3: the inverse there is the one of a cap that never grows."""
    src, dst = _handles(3)
    x = np.random.default_rng(4).uniform(-8, 72, (300, 3))
    for transform in TRANSFORMS:
        with glmls.MLS(src, dst, transform=transform, ctx=gl, **weight) as m:
            u = m(x)
            found, valid = m.inverse(u, return_valid=True)
            monkeypatch.setattr(passes3, "NEWTON_FAR3", 1e30)
            fixed, fixed_valid = m.inverse(u, return_valid=True)
            monkeypatch.undo()
        assert valid.all() and fixed_valid.all(), transform
        assert_array_equal(found, fixed, err_msg=transform)
