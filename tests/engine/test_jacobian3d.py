"""The 3D Jacobian J = df/dv of the points pass (``m.jacobian``, and ``m.deform``'s vertex
records) against the float64 reference's central differences: every transform and weight,
points near (not on) handles, on them and within the snapping distance, and the degenerate
handle sets; f from the same pass equals the plain evaluation bit for bit.

J is the derivative of the solve's closed form, from the moments' derivatives (one pass over
the handles per axis, each weight's slope dw/d(d^2); glmls/shaders/mls3/core.glsl,
``mls3_eval_jacobian``): where the solve takes its plain branch, in closed form; elsewhere
(the degenerate sets' rules, a ridge of 1e-3 of the moments fixing what fewer than four
handles in reach leave free) through the float64 solve, differenced in the moments
(``mls3_ridge_rows``). Points that snap to a handle take central differences of f of step
``JACOBIAN_STEP`` (0.05 voxel). The reference differences float64 f with a step of 1e-3
voxel, and of 1e-5 voxel where J is compared as the derivative (its own error ~1e-10 there).

Tolerances: 1e-3 where at least four handles in general position are in reach and the
weights are smooth (idw, gaussian); as the derivative, J's median error 1e-6 of |J| and its
99th percentile 1e-4 (a central difference over 0.05 voxel errs by ~1e-5 of |J| in the
median there). The weights that reach 0 at d = R (cressman, shepard, linear) leave some
points 3 handles in reach: J's median within 1e-4, its largest error within 0.15
(shepard's f is a cone at a handle, which a stencil next to it straddles: not tested
there). The degenerate sets: median within 1e-4, every point within 1e-3 (measured: affine
median 2e-5, at most 2.7e-4, the float32 moments' derivatives' rounding magnified by the
ridge, up to 1e3; similarity and rigid median 3e-6, at most 2.3e-5)."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import degenerate_sets3, random_rotation

import glmls
from glmls import reference

SIZE = 128.0
#: Where at least four handles in general position are in reach.
TOLERANCE = 1e-3
#: The weights that reach 0 at R: J's median and largest error (see the module's docstring).
BOUNDED_MEDIAN, BOUNDED_MAX = 1e-4, 0.15
#: The degenerate sets (two, three, collinear, coplanar handles): J's median and largest
#: error (see the module's docstring).
RIDGE_MEDIAN, RIDGE_MAX = 1e-4, 1e-3


def _reference_jacobian(src, dst, points, *, h=1e-3, **options):
    """d f_c / d v_r by float64 central differences of step ``h`` voxel, (K, 3, 3). With
    h = 1e-5 (:data:`DERIVATIVE_STEP`), f's derivative to ~1e-10 (f's curvature over the
    step, float64's rounding over it)."""
    rows = [
        reference.mls(src, dst, points + h * e, **options)[0]
        - reference.mls(src, dst, points - h * e, **options)[0]
        for e in np.eye(3)
    ]
    return np.stack(rows, axis=1) / (2 * h)


def _near(rng, src, count, low, high):
    """``count`` points at distances in [low, high] (log-uniform) of random handles."""
    directions = rng.normal(size=(count, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    distance = np.exp(rng.uniform(np.log(low), np.log(high), count))
    return src[rng.integers(0, len(src), count)] + directions * distance[:, None]


def _jacobian(src, dst, points, **options):
    """The GPU's f and J, checking f against the plain evaluation (bit for bit)."""
    with glmls.MLS(src, dst, **options) as m:
        f, jacobian = m.jacobian(points)
        assert np.array_equal(f, m(points))
    assert np.isfinite(jacobian).all()
    return jacobian


OPTIONS = [
    {"transform": transform, "weight": weight} | ({"radius": 90.0} if weight != "idw" else {})
    for transform in glmls.TRANSFORMS
    for weight in glmls.WEIGHTS
] + [
    {"transform": "rigid", "alpha": 1.7, "s": 0.5},
    {"transform": "similarity", "weight": "gaussian", "radius": 40.0, "interpolating": True},
]


@pytest.mark.parametrize("options", OPTIONS, ids=lambda o: "-".join(map(str, o.values())))
def test_every_transform_and_weight(gl, options):
    rng = np.random.default_rng(3)
    src = rng.uniform(0, SIZE, (16, 3))
    dst = src + rng.normal(0, 4, src.shape)
    points = np.concatenate([rng.uniform(0, SIZE, (120, 3)), _near(rng, src, 80, 0.06, 3.0)])
    if "radius" in options:
        # J jumps where a handle's weight reaches 0 (at d = R): not within a step of it
        d = np.linalg.norm(points[:, None] - src[None], axis=2)
        points = points[np.abs(d - options["radius"]).min(axis=1) > 0.25]
    jacobian = _jacobian(src, dst, points, **options)
    error = np.abs(jacobian - _reference_jacobian(src, dst, points, **options))
    error = error.max(axis=(1, 2))
    if options.get("weight", "idw") in ("idw", "gaussian"):
        assert error.max() < TOLERANCE
    else:
        assert np.median(error) < BOUNDED_MEDIAN and error.max() < BOUNDED_MAX


@pytest.mark.parametrize("options", [{}, {"alpha": 1.7}, {"transform": "affine", "s": 0.5}])
def test_on_and_next_to_handles(gl, options):
    # on a handle, within the snapping distance, within a step (the probes' own evaluations)
    # and just beyond
    rng = np.random.default_rng(4)
    src = rng.uniform(0, SIZE, (16, 3))
    dst = src + rng.normal(0, 4, src.shape)
    points = np.concatenate(
        [src, src + 1e-4, _near(rng, src, 40, 0.01, 0.055), _near(rng, src, 40, 0.055, 0.1)]
    )
    jacobian = _jacobian(src, dst, points, **options)
    error = np.abs(jacobian - _reference_jacobian(src, dst, points, **options)).max(axis=(1, 2))
    assert error.max() < TOLERANCE


@pytest.mark.parametrize("transform", glmls.TRANSFORMS)
@pytest.mark.parametrize("name", ["two", "three", "coplanar", "collinear", "one", "coincident"])
def test_degenerate_sets(gl, transform, name):
    rng = np.random.default_rng(11)
    src = degenerate_sets3(rng)[name]
    dst = src @ random_rotation(rng).T * 1.1 + 5.0
    if name != "coincident":
        dst += rng.normal(0, 3, src.shape)
    points = rng.uniform(0, 256, (150, 3))
    jacobian = _jacobian(src, dst, points, transform=transform)
    error = np.abs(jacobian - _reference_jacobian(src, dst, points, transform=transform))
    error = error.max(axis=(1, 2))
    if name in ("one", "coincident"):
        # a translation: J = I exactly
        assert (jacobian == np.eye(3)).all()
    else:
        assert np.median(error) < RIDGE_MEDIAN and error.max() < RIDGE_MAX


@pytest.mark.parametrize("transform", glmls.TRANSFORMS)
def test_a_gaussian_tail_among_spread_handles(gl, transform):
    # R = 4 among handles 15-25 voxels apart: most points see one or two handles (the ridge's
    # rules) or one that outweighs the rest by e^60 and more (the weight's cap), and f turns
    # within a few voxels. J from the moments' derivatives through the solve, measured:
    # p99 6e-4 of max(|J|, 1), at most 8e-4 (affine; similarity and rigid 9e-5 and 2e-4);
    # central differences over 0.05 voxel there erred by 1-3e-2 at the p99, up to 9e-2.
    rng = np.random.default_rng(5)
    src = rng.uniform(0, 64, (16, 3))
    dst = src + rng.normal(0, 3, src.shape)
    points = rng.uniform(0, 64, (600, 3))
    options = {"transform": transform, "weight": "gaussian", "radius": 4.0}
    error = _relative_error(src, dst, points, **options)
    assert np.percentile(error, 99) < 2e-3 and error.max() < 5e-3


@pytest.mark.parametrize("transform", glmls.TRANSFORMS)
def test_a_large_turn(gl, transform):
    # the polar factor's derivative about a turn far from the identity
    rng = np.random.default_rng(6)
    src = rng.uniform(0, SIZE, (16, 3))
    dst = (src - 64.0) @ random_rotation(rng).T * 1.3 + 64.0 + rng.normal(0, 4, src.shape)
    points = np.concatenate([rng.uniform(0, SIZE, (120, 3)), _near(rng, src, 40, 0.06, 3.0)])
    jacobian = _jacobian(src, dst, points, transform=transform)
    error = np.abs(jacobian - _reference_jacobian(src, dst, points, transform=transform))
    assert error.max() < TOLERANCE


@pytest.mark.parametrize("transform", glmls.TRANSFORMS)
def test_a_cluster_a_few_steps_away(gl, transform):
    """Handles within 1e-3 voxel of each other, seen from 2 to 4 steps h of the central
    differences away (``jacobian_steps``): within a step the moments move by more than the
    cluster's own spread about p*, yet J, the derivative of the solve there, is finite and
    agrees with central differences of the GPU's own f over h."""
    from glmls.engine.passes3 import jacobian_steps

    rng = np.random.default_rng(4)
    src = 120.0 + rng.uniform(-1e-3, 1e-3, (16, 3))
    dst = src + [1.5, -3.9, 3.3] + rng.normal(0, 1e-3, src.shape)
    direction = rng.normal(size=(40, 3))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    with glmls.MLS(src, dst, transform=transform, alpha=3.7, ctx=gl) as m:
        h = jacobian_steps(m.kernel, np.full((1, 3), 120.0))[0]
        points = 120.0 + direction * rng.uniform(1.8 * h, 4.0 * h, (40, 1))
        assert np.allclose(jacobian_steps(m.kernel, points), h, rtol=0.1)
        h = jacobian_steps(m.kernel, points)[:, None]
        _, jacobian = m.jacobian(points)
        expected = np.stack(
            [(m(points + h * e) - m(points - h * e)) / (2 * h) for e in np.eye(3)], 1
        )
    assert np.isfinite(jacobian).all()
    assert np.abs(jacobian - expected).max() < 1e-3


def test_the_jacobians_second_stage_walks_its_list_with_few_work_groups(gl, monkeypatch):
    """J where it is not the closed form's derivative (at points that snap to a handle)
    comes from a second stage over those points alone; with two work groups a dispatch it
    walks its whole list, and every J and mesh record is the same."""
    from glmls.gl.context import GLContext

    rng = np.random.default_rng(7)
    src = rng.uniform(0, 40, (12, 3))
    dst = src + rng.normal(0, 3, src.shape)
    # a few hundred points next to the handles, and as many within the snapping distance,
    # where J needs f's own evaluations
    near = (src[:, None, :] + rng.normal(0, 0.02, (12, 40, 3))).reshape(-1, 3)
    snapped = (src[:, None, :] + rng.normal(0, 1e-7, (12, 40, 3))).reshape(-1, 3)
    points = np.concatenate([rng.uniform(0, 40, (500, 3)), near, snapped])
    faces = rng.integers(0, len(points), (800, 3))
    with glmls.MLS(src, dst, transform="rigid", ctx=gl) as m:
        f, jacobian = m.jacobian(points)
        mesh = m.deform((points, faces))
        few = dict(GLContext.limits.fget(gl), max_work_groups_x=2)
        monkeypatch.setattr(GLContext, "limits", property(lambda self: few))
        f2, jacobian2 = m.jacobian(points)
        mesh2 = m.deform((points, faces))
    np.testing.assert_array_equal(f2, f)
    np.testing.assert_array_equal(jacobian2, jacobian)
    np.testing.assert_array_equal(mesh2.jacobian, mesh.jacobian)
    np.testing.assert_array_equal(mesh2.normals, mesh.normals)

    # the central differences of f itself at those points agree with J
    numeric = _reference_jacobian(src, dst, near, transform="rigid")
    np.testing.assert_allclose(jacobian[500 : 500 + len(near)], numeric, atol=2e-2)


#: The reference's step where J is compared as f's derivative (voxels)
DERIVATIVE_STEP = 1e-5


def _relative_error(src, dst, points, **options):
    """(K,) the largest error of the GPU's J against f's derivative at each point, relative
    to the derivative's largest entry (at least 1)."""
    jacobian = _jacobian(src, dst, points, **options)
    expected = _reference_jacobian(src, dst, points, h=DERIVATIVE_STEP, **options)
    scale = np.maximum(np.abs(expected).max(axis=(1, 2)), 1.0)
    return np.abs(jacobian - expected).max(axis=(1, 2)) / scale


DERIVATIVE_OPTIONS = [
    {"transform": transform} | options
    for transform in glmls.TRANSFORMS
    for options in (
        {},
        {"alpha": 3.0},
        {"alpha": 0.7, "s": 0.5},
        {"interpolating": True},
        {"weight": "gaussian", "radius": 30.0},
        {"weight": "cressman", "radius": 60.0},
        {"weight": "shepard", "radius": 60.0},
        {"weight": "linear", "radius": 60.0},
    )
]


@pytest.mark.parametrize(
    "options", DERIVATIVE_OPTIONS, ids=lambda o: "-".join(map(str, o.values()))
)
def test_j_is_the_derivative_of_f(gl, options):
    """16 handles in a 64^3 box, points in it and 0.3 to 4 voxels from the handles (where
    the weights bend f most): J against f's derivative, relative to |J| (at least 1)."""
    rng = np.random.default_rng(21)
    src = rng.uniform(0, 64, (16, 3))
    dst = src + rng.normal(0, 4, src.shape)
    points = np.concatenate([rng.uniform(0, 64, (400, 3)), _near(rng, src, 600, 0.3, 4.0)])
    if "radius" in options and options.get("weight") != "gaussian":
        # J jumps where a handle's weight reaches 0 (at d = R)
        d = np.linalg.norm(points[:, None] - src[None], axis=2)
        points = points[np.abs(d - options["radius"]).min(axis=1) > 0.01]
    error = _relative_error(src, dst, points, **options)
    assert np.median(error) < 1e-6
    assert np.percentile(error, 99) < 1e-4 and error.max() < 1e-3


def test_a_weight_without_its_slope(gl, monkeypatch):
    """A registry weight without a GLSL slope (``Weight.slope`` False, as one added by a
    user): the shaders differentiate its function numerically (a relative step of 2^-8 in
    d^2), J within 1e-5 of |J| in the median and 1e-4 at most."""
    import dataclasses

    from glmls.core.weights import REGISTRY

    monkeypatch.setitem(REGISTRY, "idw", dataclasses.replace(REGISTRY["idw"], slope=False))
    rng = np.random.default_rng(22)
    src = rng.uniform(0, 64, (16, 3))
    dst = src + rng.normal(0, 4, src.shape)
    points = np.concatenate([rng.uniform(0, 64, (300, 3)), _near(rng, src, 300, 0.3, 4.0)])
    options = {"transform": "affine", "alpha": 1.5}
    error = _relative_error(src, dst, points, **options)
    assert np.median(error) < 1e-5 and error.max() < 1e-4
