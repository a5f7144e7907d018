"""A radius weight made interpolating, at a point with one handle in reach and the next one
far out of it: f is the translation by that handle's q - p (docs/mathematics.md, one
handle), on the GPU as in the float64 reference, in 2D and 3D, f, M and J alike.

The interpolating weights are taken relative to the next handle's squared distance m, the
nearest's bounded where (d^2 / m)^alpha falls below 2^-50 (``near2``, mls/core.glsl): with
the next handle thousands of radii away or alpha large, that bound lies past R, and the
weight's function must see the handle's own distance, not the bound, or the one handle in
reach weighs 0 and f is the identity there.

Tolerance: 1e-5 of the coordinates' extent (float32's rounding of the scaled coordinates,
a few 1e-8 of it, with room).
"""

from __future__ import annotations

import numpy as np
import pytest

import glmls
from glmls import reference

RADIUS_WEIGHTS = ("cressman", "shepard", "linear")
MOVE2 = np.array([3.0, -2.0])
MOVE3 = np.array([3.0, -2.0, 1.0])


def _one_in_reach(move, far, weight, alpha, v):
    """Handles at 10 (every coordinate) moved by ``move`` and ``far`` px along x kept, the
    options of a radius weight of R = 3 made interpolating, and the reference's f at ``v``:
    the translation by ``move``."""
    p = np.full((2, len(move)), 10.0)
    p[1, 0] += far
    q = p + [move, np.zeros_like(move)]
    options = {"weight": weight, "radius": 3.0, "interpolating": True, "alpha": alpha}
    expected, _, _ = reference.mls(p, q, v, **options)
    np.testing.assert_allclose(expected, v + move, atol=1e-9)
    return p, q, options, expected


@pytest.mark.parametrize("weight", RADIUS_WEIGHTS)
@pytest.mark.parametrize(("far", "alpha"), [(42.0, 8.0), (500.0, 4.0), (5e5, 1.5), (5e5, 10.0)])
def test_one_handle_in_reach_translates_2d(gl, weight, far, alpha):
    v = np.array([[11.0, 10.0], [10.0, 12.0], [10.3, 9.6], [12.5, 10.5]])
    p, q, options, expected = _one_in_reach(MOVE2, far, weight, alpha, v)
    with glmls.MLS(p, q, ctx=gl, **options) as m:
        f = m(v)
        matrices, translations = m.matrices(v)
    tolerance = 1e-5 * far
    np.testing.assert_allclose(f, expected, atol=tolerance)
    np.testing.assert_allclose(matrices, np.broadcast_to(np.eye(2), matrices.shape), atol=1e-5)
    np.testing.assert_allclose(translations, np.broadcast_to(MOVE2, v.shape), atol=tolerance)


@pytest.mark.parametrize("weight", RADIUS_WEIGHTS)
@pytest.mark.parametrize(("far", "alpha"), [(50.0, 8.0), (5e5, 1.5), (5e5, 10.0)])
def test_one_handle_in_reach_translates_3d(gl, weight, far, alpha):
    v = np.array([[11.0, 10.0, 10.0], [10.5, 10.5, 10.5], [10.0, 10.0, 12.0]])
    p, q, options, expected = _one_in_reach(MOVE3, far, weight, alpha, v)
    with glmls.MLS(p, q, ctx=gl, **options) as m:
        f = m(v)
        _, jacobian = m.jacobian(v)
        back = m.inverse(expected)
    tolerance = 1e-5 * far
    np.testing.assert_allclose(f, expected, atol=tolerance)
    np.testing.assert_allclose(jacobian, np.broadcast_to(np.eye(3), jacobian.shape), atol=1e-4)
    np.testing.assert_allclose(back, v, atol=max(tolerance, 1e-3))


SEGMENT = np.array([[[0.0, 0.0], [10.0, 0.0]]])
TURNED = np.array([[[0.0, 0.0], [0.0, 10.0]]])  # the segment turned a quarter
QUARTER = np.array([[0.0, 1.0], [-1.0, 0.0]])  # its M (row vectors)


@pytest.mark.parametrize(
    ("handles", "options"),
    [
        ([[5000.0, 0.0]], {"weight": "cressman", "radius": 50.0, "interpolating": True}),
        ([[5000.0, 0.0]], {"weight": "shepard", "radius": 50.0}),
        (np.zeros((0, 2)), {"weight": "linear", "radius": 10.0, "interpolating": True}),
    ],
    ids=["cressman-far-point", "shepard", "linear-lone-segment"],
)
def test_a_point_snapped_onto_a_segment_takes_its_turn(gl, handles, options):
    """At a point on a segment (snapped to it) a radius weight sees the segment's nodes at
    their own distances, not at the weights' bound (m 2^(-100 / alpha), m a far handle's
    squared distance or the scaled unit), which at alpha 10 lies past R and would weigh the
    segment 0 (M = I): M is the segment's quarter turn, as the reference and the points
    beside it have it."""
    p = np.asarray(handles, float).reshape(-1, 2)
    v = np.array([[5.0, 0.0], [5.0, 5e-4], [5.0, 2e-3], [2.5, -1e-4]])
    segments = {"src_segments": SEGMENT, "dst_segments": TURNED}
    options = options | {"alpha": 10.0, "shape": (1024, 1024)}
    expected, expected_m, _ = reference.mls(p, p, v, **segments, **options)
    np.testing.assert_allclose(expected_m, np.broadcast_to(QUARTER, expected_m.shape), atol=1e-6)
    with glmls.MLS(p, p, ctx=gl, **segments, **options) as m:
        f = m(v)
        matrices, _ = m.matrices(v)
    np.testing.assert_allclose(matrices, expected_m, atol=1e-4)
    np.testing.assert_allclose(f, expected, atol=1e-4)
