"""A 3D MLS of handles in physical units, ``glmls.MLS(..., shape=(D, H, W), spacing=(dz, dy,
dx))``: a radius weight given no radius takes the diagonal of (D dz, H dy, W dx) in every
method (points, matrices, Jacobian, meshes, inverse, residuals), as the float64 reference
with the same ``shape`` and ``spacing`` does; isotropic voxels change nothing; a bad spacing
is refused, naming it."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_array_equal

import glmls
from glmls import reference
from glmls.core.handles3 import volume_diagonal

SHAPE = (10, 20, 40)  # D, H, W
SPACING = (2.0, 1.0, 0.5)  # dz, dy, dx: a cube of 20 units a side
PHYSICAL = volume_diagonal(SHAPE, SPACING)
VOXELS = volume_diagonal(SHAPE)
RADIUS_WEIGHTS = ("cressman", "shepard", "gaussian", "linear")
#: As tests/engine/test_mls3d.py's bound for every transform and weight.
TOLERANCE = 1e-3


@pytest.fixture(scope="module")
def problem():
    rng = np.random.default_rng(5)
    src = rng.uniform(0, 20, (12, 3))  # (x, y, z) in the handles' units
    dst = src + rng.normal(0, 1.0, src.shape)
    points = rng.uniform(-2, 22, (400, 3))
    return src, dst, points


def test_the_physical_diagonal():
    assert PHYSICAL == pytest.approx(math.sqrt(3 * 20.0**2))
    assert VOXELS == pytest.approx(math.sqrt(10**2 + 20**2 + 40**2))


@pytest.mark.parametrize("weight", RADIUS_WEIGHTS)
def test_points_match_the_reference_with_the_physical_diagonal(gl, problem, weight):
    src, dst, points = problem
    with glmls.MLS(src, dst, weight=weight, shape=SHAPE, spacing=SPACING, ctx=gl) as m:
        assert m.spacing == SPACING and m.shape == SHAPE
        assert m.kernel.radius() == PHYSICAL
        f = m(points)
    f_ref, _, _ = reference.mls(src, dst, points, weight=weight, shape=SHAPE, spacing=SPACING)
    explicit, _, _ = reference.mls(src, dst, points, weight=weight, radius=PHYSICAL)
    assert_array_equal(f_ref, explicit)
    assert np.abs(f - f_ref).max() < TOLERANCE
    voxels, _, _ = reference.mls(src, dst, points, weight=weight, shape=SHAPE)
    assert np.abs(voxels - f_ref).max() > 10 * TOLERANCE  # the radius matters here


def _uses(m, points):
    """Every GPU method of a 3D MLS at ``points``, as a dict of arrays."""
    faces = np.array([[0, 1, 2], [1, 2, 3]])
    deformed = m.deform((points[:4], faces))
    matrix, translation = m.matrices(points)
    return {
        "f": m(points),
        "M": matrix,
        "T": translation,
        "J": m.jacobian(points)[1],
        "inverse": m.inverse(m(points[:20])),
        "residuals": m.residuals(points, points + 1.0),
        "vertices": deformed.vertices,
        "normals": deformed.normals,
        "det": deformed.det_j,
    }


@pytest.mark.parametrize("weight", ["gaussian", "cressman"])
def test_every_method_takes_the_physical_diagonal(gl, problem, weight):
    """Bit for bit the MLS given radius=the physical diagonal (the same handles, shape and
    spacing: the same GPU coordinates)."""
    src, dst, points = problem
    common = {"weight": weight, "shape": SHAPE, "spacing": SPACING, "ctx": gl}
    with glmls.MLS(src, dst, **common) as m, glmls.MLS(src, dst, radius=PHYSICAL, **common) as e:
        found, explicit = _uses(m, points), _uses(e, points)
    for key in found:
        assert_array_equal(found[key], explicit[key], err_msg=key)
    with glmls.MLS(src, dst, weight=weight, shape=SHAPE, radius=VOXELS, ctx=gl) as voxels:
        assert np.abs(voxels(points) - found["f"]).max() > 10 * TOLERANCE


def test_the_matrices_and_the_inverse_match_the_reference(gl, problem):
    src, dst, points = problem
    options = {"weight": "gaussian", "transform": "affine", "shape": SHAPE, "spacing": SPACING}
    with glmls.MLS(src, dst, ctx=gl, **options) as m:
        matrix, translation = m.matrices(points)
        back, valid = m.inverse(m(points[:50]), return_valid=True)
    _, m_ref, t_ref = reference.mls(src, dst, points, **options)
    assert np.abs(matrix - m_ref).max() < 1e-5
    assert np.abs(translation - t_ref).max() < TOLERANCE
    assert valid.all() and np.abs(back - points[:50]).max() < 1e-2


@pytest.mark.parametrize("weight", ["idw", "gaussian"])
def test_isotropic_spacing_changes_nothing(gl, problem, weight):
    src, dst, points = problem
    with (
        glmls.MLS(src, dst, weight=weight, shape=SHAPE, ctx=gl) as plain,
        glmls.MLS(src, dst, weight=weight, shape=SHAPE, spacing=(1, 1, 1), ctx=gl) as unit,
    ):
        assert unit.spacing == (1.0, 1.0, 1.0) and plain.spacing is None
        assert unit.scaling == plain.scaling
        found, expected = _uses(unit, points), _uses(plain, points)
    for key in found:
        assert_array_equal(found[key], expected[key], err_msg=key)


def test_spacing_without_shape_only_sets_the_units(gl, problem):
    """A radius given, no shape: f is that of the radius; the spacing is the warps'."""
    src, dst, points = problem
    with glmls.MLS(src, dst, weight="gaussian", radius=15.0, spacing=SPACING, ctx=gl) as m:
        f = m(points)
    f_ref, _, _ = reference.mls(src, dst, points, weight="gaussian", radius=15.0)
    assert np.abs(f - f_ref).max() < TOLERANCE
    with glmls.MLS(src, dst, weight="gaussian", spacing=SPACING, ctx=gl) as m:
        with pytest.raises(ValueError, match="needs an influence radius"):
            m(points)  # no volume to take the diagonal of


def test_repr_and_from_config(gl, problem):
    src, dst, _ = problem
    config = glmls.MLSConfig(weight="linear")
    with glmls.MLS.from_config(src, dst, config, shape=SHAPE, spacing=SPACING, ctx=gl) as m:
        assert repr(m).endswith(", shape=(10, 20, 40), spacing=(2.0, 1.0, 0.5))")
        assert m.kernel.radius() == PHYSICAL
    with glmls.MLS(src, dst, ctx=gl) as plain:
        assert "spacing" not in repr(plain) and plain.spacing is None


@pytest.mark.parametrize(
    ("spacing", "error", "message"),
    [
        ((1.0, 2.0), ValueError, r"got 2: \(1.0, 2.0\)"),
        ((1.0, 0.0, 1.0), ValueError, r"positive and finite .*, got \(1.0, 0.0, 1.0\)"),
        ((1.0, -2.0, 1.0), ValueError, r"positive and finite .*, got \(1.0, -2.0, 1.0\)"),
        ((1.0, math.inf, 1.0), ValueError, r"positive and finite .*, got \(1.0, inf, 1.0\)"),
        ((1.0, math.nan, 1.0), ValueError, "nan"),
        ((1.0, "2", 1.0), TypeError, r"'2' is not a number"),
        ((1.0, True, 1.0), TypeError, "True is not a number"),
        ("2,1,1", TypeError, "got '2,1,1'"),
        (2.0, TypeError, "got 2.0"),
    ],
)
def test_a_bad_spacing_is_refused_naming_it(gl, problem, spacing, error, message):
    src, dst, points = problem
    with pytest.raises(error, match=message):
        glmls.MLS(src, dst, shape=SHAPE, spacing=spacing, ctx=gl)
    with pytest.raises(error, match=message):
        reference.mls(src, dst, points, shape=SHAPE, spacing=spacing)


def test_spacing_is_3d_only(gl):
    src2 = [[0.0, 0.0], [5.0, 1.0]]
    with pytest.raises(ValueError, match=r"spacing=\(1, 1, 1\) is for \(N, 3\) handles"):
        glmls.MLS(src2, src2, spacing=(1, 1, 1), ctx=gl)
    with pytest.raises(ValueError, match=r"spacing=\(1, 1, 1\) is for \(N, 3\) handles"):
        glmls.MLS.from_config(src2, src2, glmls.MLSConfig(), spacing=(1, 1, 1), ctx=gl)
    for function in (reference.mls, reference.mls_error):
        with pytest.raises(ValueError, match=r"is for \(N, 3\) handles"):
            function(src2, src2, [[1.0, 1.0]], spacing=(1, 1, 1))
    with glmls.MLS(src2, src2, ctx=gl) as m:
        assert m.spacing is None
    image = np.zeros((4, 6), np.uint8)  # the image warps take no spacing
    with pytest.raises(TypeError, match="unknown keyword spacing"):
        glmls.warp(image, src2, src2, spacing=(1, 1, 1))
    with pytest.raises(TypeError, match="unknown keyword spacing"):
        glmls.warp_batch([image], [src2], [src2], spacing=(1, 1, 1))


def test_mls_error_takes_the_spacing_too(problem):
    src, dst, points = problem
    options = {"weight": "gaussian", "transform": "affine"}
    found = reference.mls_error(src, dst, points, shape=SHAPE, spacing=SPACING, **options)
    explicit = reference.mls_error(src, dst, points, radius=PHYSICAL, **options)
    assert_array_equal(found, explicit)
