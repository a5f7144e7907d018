"""The flat rule of ``m.deform``'s folds on the GPU (glmls.engine.deform3), and the float64
reference's (glmls.core.mesh3.deform_mesh) against it.

- The rule's rounding is float32's of J's central differences, eps32 x scale x max(box,
  |v|) / h, from the vertices as the GPU read them: bit for bit the one from the vertices
  scaled again (``Scaling.to_gpu``) and ``jacobian_steps``, and det J bit for bit the
  plain test of every vertex (``|det J| <= FLAT_ROUNDINGS x rounding x |cof J|``).
- The reference, given f and J by float64 central differences of glmls.reference.mls and
  their step, agrees with the GPU: a map that flattens the mesh (affine, targets on a
  plane, along the axes or turned off them) folds every vertex and face in both, although
  float64's det J there has either sign (the GPU's, off a plane turned off the axes, leaves
  a few vertices up to twice the rule's roundings over it: at most 5% of the sphere's here,
  and where that det J is positive the vertex does not fold); on ordinary maps (gentle,
  thin, folding) the vertex folds agree wherever the reference's det J is clear of 0 by
  5e-3 of |cof J| (J's smallest singular value above about 5e-3 of its others; float32's J
  is good to ~2e-3 here, its rounding up to 5e-4 in large units), det J within 5e-3 of
  |cof J| of the reference's.
"""

from __future__ import annotations

import numpy as np
import pytest

import glmls
from glmls import reference
from glmls.core import mesh3
from glmls.engine import deform3
from glmls.engine.passes3 import jacobian_steps, jacobian_uniforms

CLEAR = 5e-3
DET_TOLERANCE = 5e-3


def _maps(rng, size):
    """(name, src, dst, options) of the maps of the comparisons, handles about a sphere of
    radius 20 size at 32 size."""
    src = rng.uniform(0, 64, (10, 3)) * size
    flat = src.copy()
    flat[:, 2] = 32.0 * size
    normal = np.array([1.0, 2.0, -0.5]) / np.linalg.norm([1.0, 2.0, -0.5])
    tilted = src - np.outer(src @ normal - 30.0 * size, normal)
    return [
        ("flat", src, flat, {"transform": "affine"}),
        ("tilted", src, tilted, {"transform": "affine"}),
        ("thin", src, src * [1.0, 1.0, 1e-2], {"transform": "affine"}),
        ("gentle", src, src + rng.normal(0, 2.0 * size, src.shape), {"transform": "rigid"}),
        ("folding", src, src + rng.normal(0, 25.0 * size, src.shape), {"transform": "affine"}),
    ]


def _plain_rule(kernel, vertices, jacobian, det):
    """The rule as the plain test of every vertex, its rounding from the vertices scaled
    again: what the GPU's det J must equal bit for bit."""
    scaling = kernel.scaling
    box = jacobian_uniforms(kernel)["u_jacobian_box"]
    reach = np.maximum(box, np.abs(scaling.to_gpu(vertices)).max(axis=1))
    rounding = np.finfo(np.float32).eps * scaling.scale * reach / jacobian_steps(kernel, vertices)
    size = np.linalg.norm(mesh3.cofactor(jacobian).reshape(len(det), 9), axis=1)
    return rounding, np.where(np.abs(det) <= mesh3.FLAT_ROUNDINGS * rounding * size, 0.0, det)


@pytest.mark.parametrize("size", [1.0, 1e4])
def test_the_rule_equals_the_plain_test_of_every_vertex(gl, rng, monkeypatch, size):
    sphere = glmls.data.sphere()
    vertices = sphere.vertices * size
    calls = []
    rule = deform3.flat_to_zero

    def spy(det, jacobian, rounding):
        calls.append((det.copy(), jacobian.copy(), rounding.copy()))
        return rule(det, jacobian, rounding)

    monkeypatch.setattr(deform3, "flat_to_zero", spy)
    zeros = []
    for _, src, dst, options in _maps(rng, size):
        with glmls.MLS(src, dst, **options) as m:
            for mesh in ((vertices, sphere.faces), vertices):  # with faces, and a cloud
                calls.clear()
                out = m.deform(mesh)
                ((raw, jacobian, rounding),) = calls
                expected_rounding, expected = _plain_rule(m.kernel, vertices, jacobian, raw)
                assert rounding.tobytes() == expected_rounding.tobytes()
                assert out.det_j.tobytes() == expected.tobytes()
                zeros.append((out.det_j == 0).mean())
    assert max(zeros) == 1.0 and min(zeros) == 0.0  # flat maps and others


def _reference(src, dst, vertices, faces, size, options):
    """The reference's mesh from float64 f and its central differences over 1e-3 size, and
    its det J without the rule."""
    h = 1e-3 * size
    f = reference.mls(src, dst, vertices, **options)[0]
    columns = [
        reference.mls(src, dst, vertices + h * e, **options)[0]
        - reference.mls(src, dst, vertices - h * e, **options)[0]
        for e in np.eye(3)
    ]
    jacobian = np.stack(columns, axis=1) / (2 * h)
    raw = mesh3.determinant(jacobian, mesh3.cofactor(jacobian))
    return mesh3.deform_mesh(vertices, faces, None, f, jacobian, step=h), raw


@pytest.mark.parametrize("size", [1.0, 100.0, 1e4])
def test_the_reference_agrees_with_the_gpu(gl, rng, size):
    sphere = glmls.data.sphere()
    vertices, faces = sphere.vertices * size, sphere.faces
    for name, src, dst, options in _maps(rng, size):
        with glmls.MLS(src, dst, **options) as m:
            out = m.deform((vertices, faces))
        ref, raw = _reference(src, dst, vertices, faces, size, options)
        if name in ("flat", "tilted"):
            assert (ref.det_j == 0).all() and ref.vertex_folds.all() and ref.face_folds.all()
            flat = out.det_j == 0
            assert (out.vertex_folds == ref.vertex_folds)[flat].all(), name
            if name == "flat":
                assert flat.all() and out.face_folds.all()
            else:  # float64's det J alone would fold some vertices, not all
                assert (raw > 0).any() and (raw <= 0).any()
                # float32's J off a turned plane: a few vertices a few roundings over the
                # rule's (see the module's docstring)
                assert flat.mean() >= 0.95
                with glmls.MLS(src, dst, **options) as m:
                    rounding, _ = _plain_rule(m.kernel, vertices, out.jacobian, out.det_j)
                cof = np.linalg.norm(mesh3.cofactor(out.jacobian).reshape(-1, 9), axis=1)
                assert (np.abs(out.det_j) <= 2 * mesh3.FLAT_ROUNDINGS * rounding * cof).all()
            continue
        # |cof J| = s1 s2 + ...: det J / |cof J| ~ s3, and J's error moves det J by ~it x |cof J|
        scale = np.linalg.norm(mesh3.cofactor(ref.jacobian).reshape(-1, 9), axis=1)
        assert not (ref.det_j == 0).any() and not (out.det_j == 0).any(), name
        assert (np.abs(out.det_j - ref.det_j) <= DET_TOLERANCE * scale).all(), name
        clear = np.abs(ref.det_j) > CLEAR * scale
        assert clear.mean() > 0.9, name
        assert (out.vertex_folds == ref.vertex_folds)[clear].all(), name
        if name == "folding":
            assert ref.vertex_folds.any() and not ref.vertex_folds.all()
        else:
            assert not out.vertex_folds.any() and not ref.vertex_folds.any(), name
            assert not out.face_folds.any() and not ref.face_folds.any(), name
