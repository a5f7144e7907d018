"""The flat rule of ``m.deform``'s folds on the GPU (glmls.engine.deform3): its rounding is
float32's of J's central differences, eps32 x scale x max(box, |v|) / h, from the vertices
as the GPU read them: bit for bit the one from the vertices scaled again
(``Scaling.to_gpu``) and ``jacobian_steps``, and det J bit for bit the plain test of every
vertex (``|det J| <= FLAT_ROUNDINGS x rounding x |cof J|``), on flat maps and others.
"""

from __future__ import annotations

import numpy as np
import pytest

import glmls
from glmls.core import mesh3
from glmls.engine import deform3
from glmls.engine.passes3 import jacobian_steps, jacobian_uniforms


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
