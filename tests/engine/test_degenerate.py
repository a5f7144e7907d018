"""Special and degenerate configurations: never a NaN, the documented answer instead."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

import glmls
from glmls import reference

SQUARE = np.array([[0.0, 0.0], [100.0, 0.0], [0.0, 100.0], [100.0, 100.0]])


@pytest.mark.parametrize("transform", glmls.TRANSFORMS)
@pytest.mark.parametrize("weight", glmls.WEIGHTS)
def test_no_handles_is_identity(gl, transform, weight):
    v = np.array([[3.0, 4.0], [-10.0, 500.0]])
    with glmls.MLS(
        np.zeros((0, 2)), [], transform=transform, weight=weight, radius=10.0, ctx=gl
    ) as m:
        assert_allclose(m(v), v)
        big_m, t = m.matrices(v)
    assert_allclose(big_m, np.broadcast_to(np.eye(2), (2, 2, 2)))
    assert_allclose(t, 0)


@pytest.mark.parametrize("transform", glmls.TRANSFORMS)
@pytest.mark.parametrize("weight", glmls.WEIGHTS)
def test_one_handle_is_a_translation(gl, transform, weight):
    v = np.array([[3.0, 4.0], [50.0, 60.0], [20.0, 30.0]])
    with glmls.MLS(
        [[20, 30]], [[25, 27]], transform=transform, weight=weight, radius=1e4, ctx=gl
    ) as m:
        assert_allclose(m(v), v + [5, -3], atol=1e-3)
        big_m, _ = m.matrices(v)
    assert_allclose(big_m, np.broadcast_to(np.eye(2), (3, 2, 2)), atol=1e-6)


@pytest.mark.parametrize("transform", glmls.TRANSFORMS)
@pytest.mark.parametrize(
    "options", [{"weight": "idw", "s": 0.0}, {"weight": "shepard", "radius": 500.0}]
)
def test_point_exactly_on_an_infinite_weight_handle(gl, rng, transform, options):
    q = SQUARE + rng.uniform(-20, 20, SQUARE.shape)
    with glmls.MLS(SQUARE, q, transform=transform, ctx=gl, **options) as m:
        f = m(SQUARE)
        big_m, t = m.matrices(SQUARE)
    assert np.isfinite(big_m).all() and np.isfinite(t).all()
    assert_allclose(f, q, atol=1e-3)
    f_ref, m_ref, _ = reference.mls(SQUARE, q, SQUARE, transform=transform, **options)
    assert_allclose(f_ref, q, atol=1e-9)
    assert_allclose(big_m, m_ref, atol=1e-4)  # the limit of M at the handle


@pytest.mark.parametrize("transform", ["similarity", "rigid"])
def test_at_the_weighted_centroid_f_is_q_star(gl, transform):
    # symmetric handles: p* = centre of the square for every point equidistant from them
    q = SQUARE @ np.array([[0.0, 1.0], [-1.0, 0.0]]) + [300.0, 7.0]
    centre = np.array([[50.0, 50.0]])
    with glmls.MLS(SQUARE, q, transform=transform, ctx=gl) as m:
        assert_allclose(m(centre), q.mean(axis=0, keepdims=True), atol=1e-3)


@pytest.mark.parametrize(
    "src", [[[0, 0], [10, 10]], [[0, 0], [10, 10], [20, 20]], [[0, 0], [1, 1], [0, 0], [2, 2]]]
)
def test_affine_on_collinear_handles_is_rejected(src):
    with pytest.raises(glmls.DegenerateHandlesError, match="not on one line") as info:
        glmls.MLS(src, src, transform="affine")
    assert isinstance(info.value, ValueError)


def test_affine_falls_back_to_similarity_where_few_handles_reach(gl):
    # cressman with a small radius: around (0, 0) only two handles are in reach
    src = np.array([[0.0, 0.0], [10.0, 0.0], [500.0, 500.0], [520.0, 500.0], [500.0, 520.0]])
    dst = src + [[0, 0], [0, 5], [3, 3], [3, 3], [3, 3]]
    v = np.array([[4.0, 1.0], [6.0, -2.0]])
    with glmls.MLS(src, dst, transform="affine", weight="cressman", radius=30.0, ctx=gl) as m:
        f = m(v)
    with glmls.MLS(src, dst, transform="similarity", weight="cressman", radius=30.0, ctx=gl) as m:
        f_sim = m(v)
    assert_allclose(f, f_sim, atol=1e-3)
    f_ref, _, _ = reference.mls(src, dst, v, transform="affine", weight="cressman", radius=30.0)
    assert_allclose(f, f_ref, atol=1e-3)


@pytest.mark.parametrize("weight", ["cressman", "shepard", "linear"])
def test_points_out_of_reach_stay_put(gl, weight):
    v = np.array([[400.0, 400.0], [-300.0, 50.0]])
    with glmls.MLS(SQUARE, SQUARE + 7, weight=weight, radius=50.0, ctx=gl) as m:
        assert_allclose(m(v), v, atol=1e-4)
        big_m, t = m.matrices(v)
    assert_allclose(big_m, np.broadcast_to(np.eye(2), (2, 2, 2)), atol=1e-6)
    assert_allclose(t, 0, atol=1e-4)


@pytest.mark.parametrize("transform", ["similarity", "rigid"])
def test_targets_collapsed_to_one_point(gl, transform):
    q = np.full_like(SQUARE, 40.0)
    v = np.array([[10.0, 80.0], [50.0, 50.0]])
    with glmls.MLS(SQUARE, q, transform=transform, ctx=gl) as m:
        f = m(v)
    f_ref, _, _ = reference.mls(SQUARE, q, v, transform=transform)
    assert np.isfinite(f).all()
    assert_allclose(f, f_ref, atol=1e-3)
