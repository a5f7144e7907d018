"""The flat rule of ``m.deform``'s folds on the GPU (glmls.engine.deform3), and the float64
reference's (glmls.core.mesh3.deform_mesh) against it.

- The rule's rounding is float32's of J's central differences, eps32 x scale x max(box,
  |v|) / h, from the vertices as the GPU read them: bit for bit the one from the vertices
  scaled again (``Scaling.to_gpu``) and ``jacobian_steps``, and det J bit for bit the
  plain test of every vertex (``|det J| <= FLAT_ROUNDINGS x rounding x |cof J|``).
- An affine map onto coplanar targets (glmls.core.mesh3.coplanar) maps every point where its
  solve is the plain A^-1 B into their plane: det J is 0 exactly at every vertex whose J
  took that solve at each of its probes, on the GPU (the points pass flags them) and in
  the reference (deform_mesh's ``flat``, from glmls.reference.plain_affine), whatever the
  rounding leaves of det J; nowhere else (a ridge, the identity out of a compact weight's
  reach, similarity, rigid, targets off the plane by 1e-3 of their spread).
- The reference, given f and J by float64 central differences of glmls.reference.mls and
  their step, agrees with the GPU: a map that flattens the mesh (affine, targets on a
  plane, along the axes or turned off them) folds every vertex and face in both, although
  float64's det J there has either sign; on ordinary maps (gentle,
  thin, folding) the vertex folds agree wherever the reference's det J is clear of 0 by
  5e-3 of |cof J| (J's smallest singular value above about 5e-3 of its others; float32's J
  is good to ~2e-3 here, its rounding up to 5e-4 in large units), det J within 5e-3 of
  |cof J| of the reference's.
"""

from __future__ import annotations

import numpy as np
import pytest
from helpers import probes_plain_affine, tilted_plane

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
                if m.kernel.flat:  # the exact rule zeroes more (the plain affine solve)
                    kept = out.det_j != 0
                    assert out.det_j[kept].tobytes() == expected[kept].tobytes()
                else:
                    assert out.det_j.tobytes() == expected.tobytes()
                zeros.append((out.det_j == 0).mean())
    assert max(zeros) == 1.0 and min(zeros) == 0.0  # flat maps and others


def _reference(src, dst, vertices, faces, size, options):
    """The reference's mesh from float64 f and its central differences over 1e-3 size (the
    exact rule where the targets are coplanar and the transform affine), and its det J
    without the rules."""
    h = 1e-3 * size
    f = reference.mls(src, dst, vertices, **options)[0]
    columns = [
        reference.mls(src, dst, vertices + h * e, **options)[0]
        - reference.mls(src, dst, vertices - h * e, **options)[0]
        for e in np.eye(3)
    ]
    jacobian = np.stack(columns, axis=1) / (2 * h)
    raw = mesh3.determinant(jacobian, mesh3.cofactor(jacobian))
    flat = mesh3.coplanar(dst) & probes_plain_affine(src, dst, vertices, h, **options)
    return mesh3.deform_mesh(vertices, faces, None, f, jacobian, step=h, flat=flat), raw


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
            assert flat.all() and out.face_folds.all()
            if name == "tilted":  # float64's det J alone would fold some vertices, not all
                assert (raw > 0).any() and (raw <= 0).any()
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


@pytest.mark.parametrize("size", [1.0, 100.0, 1e4])
def test_an_affine_map_onto_a_tilted_plane_folds_every_vertex(gl, size):
    """Random planes turned off the axes, the sphere (with faces) and points in a box half as
    large again as the handles': f maps every probe of J into the plane (the affine solve is
    the plain A^-1 B everywhere here), so det J is 0 and every vertex and face folds, however
    far float32's J is from singular; and no vertex has a normal (J^-T does not exist), as
    in the reference, where float32's n cof(J) would give the plane's normal or, for normals
    along J's null direction, one of rounding's."""
    rng = np.random.default_rng(7)
    sphere = glmls.data.sphere()
    for _ in range(6):
        src, dst, _ = tilted_plane(rng, size)
        points = rng.uniform(-16, 80, (1500, 3)) * size
        with glmls.MLS(src, dst, transform="affine") as m:
            mesh = m.deform((sphere.vertices * size, sphere.faces))
            cloud = m.deform(points)
        for out in (mesh, cloud):
            assert (out.det_j == 0).all() and out.vertex_folds.all()
        assert mesh.face_folds.all()
        np.testing.assert_array_equal(mesh.normals, 0.0)


@pytest.mark.parametrize("size", [1.0, 100.0, 5e3])
def test_the_gpus_flat_vertices_are_the_references(gl, monkeypatch, size):
    """A compact weight (cressman, radius 30 size) leaves the identity far from every handle
    and a ridge where fewer than 4 handles spread in reach: det J is 0 where the float64
    solve is the plain one at the vertex (J is its derivative there) or, where J falls back
    to central differences, at each of its probes (the GPU's steps), or where the rounding
    rule makes it 0 (a ridge's J, nearly flat), and nowhere else (away from the reach's
    edge, where the probes' float32 and float64 places may fall either side of it); the
    identity keeps J = I and det J = 1 and does not fold."""
    rng = np.random.default_rng(11)
    reach = 30.0 * size
    options = {"transform": "affine", "weight": "cressman", "radius": reach}
    src, dst, _ = tilted_plane(rng, size, 20)
    near = src[rng.integers(0, len(src), 3000)] + rng.normal(0, 6.0 * size, (3000, 3))
    far = rng.uniform(-48, 112, (3000, 3)) * size
    points = np.concatenate([near, far])
    calls = []
    rule = deform3.flat_to_zero

    def spy(det, jacobian, rounding):
        calls.append((det.copy(), jacobian.copy()))
        return rule(det, jacobian, rounding)

    monkeypatch.setattr(deform3, "flat_to_zero", spy)
    with glmls.MLS(src, dst, **options) as m:
        out = m.deform(points)
        steps = jacobian_steps(m.kernel, points)
        ((raw, jacobian),) = calls
        _, ruled = _plain_rule(m.kernel, points, jacobian, raw)
    centre = reference.plain_affine(src, dst, points, **options)
    plain = centre | probes_plain_affine(src, dst, points, steps[:, None], **options)
    distance = np.linalg.norm(points[:, None] - src[None], axis=2)
    edge = (np.abs(distance - reach) < 2 * steps[:, None]).any(axis=1)
    assert 0.05 < plain[~edge].mean() < 0.95
    np.testing.assert_array_equal((out.det_j == 0)[~edge], (plain | (ruled == 0))[~edge])
    alone = (distance > reach + 2 * steps[:, None]).all(axis=1)
    assert alone.mean() > 0.2
    assert (out.det_j[alone] == 1).all() and not out.vertex_folds[alone].any()
    assert (out.jacobian[alone] == np.eye(3)).all()


@pytest.mark.parametrize("size", [1.0, 1e4])
def test_the_rule_is_for_affine_maps_onto_coplanar_targets_alone(gl, rng, monkeypatch, size):
    """Similarity and rigid onto coplanar targets (their M is never singular), and an affine
    map onto targets one of which is off the plane by 1e-3 of their spread: det J is the
    rounding rule's alone, bit for bit (no vertex set to 0 by the exact one)."""
    sphere = glmls.data.sphere()
    vertices = sphere.vertices * size
    calls = []
    rule = deform3.flat_to_zero

    def spy(det, jacobian, rounding):
        calls.append((det.copy(), jacobian.copy()))
        return rule(det, jacobian, rounding)

    monkeypatch.setattr(deform3, "flat_to_zero", spy)
    src, dst, normal = tilted_plane(rng, size)
    off = dst.copy()
    off[3] += 1e-3 * np.linalg.norm(dst - dst.mean(axis=0), axis=1).max() * normal
    for targets, transform in ((dst, "similarity"), (dst, "rigid"), (off, "affine")):
        with glmls.MLS(src, targets, transform=transform) as m:
            assert not m.kernel.flat
            calls.clear()
            out = m.deform((vertices, sphere.faces))
            ((raw, jacobian),) = calls
            _, expected = _plain_rule(m.kernel, vertices, jacobian, raw)
        assert out.det_j.tobytes() == expected.tobytes(), transform
