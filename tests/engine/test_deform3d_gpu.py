"""The GPU's deformed meshes (glmls.engine.deform3) against the float64 reference of
glmls.core.mesh3, fed the GPU's own f and J: det J, the carried normals (from the faces, or
the mesh's own), the vertex and face folds; meshes that fold, without faces, with degenerate
faces; and dispatches split in pieces.

Tolerances: det J within 1e-5 of the product of J's row lengths (float32 arithmetic on
float32 J); unit normals within 1e-4 where the reference's sum of face normals is at least
1% of the sum of their lengths (else the sum nearly cancels and its direction is
ill-conditioned); fold flags equal wherever the reference's sign test is clear of 0 by
1e-4 (relative: the cosine of the angle between the carried and the deformed normal, and
det J against the product of J's row lengths)."""

from __future__ import annotations

import numpy as np
import pytest

import glmls
from glmls import reference
from glmls.core import mesh3
from glmls.engine.deform3 import deform_mesh3

CLEAR = 1e-4


def _random_mesh(rng, count=3000, faces=6000, size=128.0):
    vertices = rng.uniform(0, size, (count, 3))
    return vertices, rng.integers(0, count, (faces, 3))


def _handles(rng, spread, count=24, size=128.0):
    src = rng.uniform(0, size, (count, 3))
    return src, src + rng.normal(0, spread, src.shape)


def _row_scale(jacobian):
    return np.prod(np.linalg.norm(jacobian, axis=2), axis=1)


def _compare(out, vertices, faces, normals=None):
    """``out`` (the GPU's) against the reference from the GPU's own f and J."""
    ref = mesh3.deform_mesh(vertices, faces, normals, out.vertices, out.jacobian)
    assert out.vertices.dtype == out.jacobian.dtype == out.normals.dtype == np.float64
    assert out.det_j.dtype == np.float64 and out.face_folds.dtype == bool
    assert out.normals.shape == out.vertices.shape == vertices.shape
    assert out.jacobian.shape == (len(vertices), 3, 3) and out.face_folds.shape == (len(faces),)
    scale = np.maximum(_row_scale(out.jacobian), 1e-30)
    # det J within float32's rounding of 0 is 0 (J singular to rounding, a fold): only where
    # J's smallest singular value is within 1e-2 of its largest (float32's J is good to
    # ~1e-4 here), and its sign there is float32's to decide, not the reference's
    flat = out.det_j == 0
    singular = np.linalg.svd(out.jacobian[flat], compute_uv=False)
    assert (singular[:, 2] <= 1e-2 * singular[:, 0]).all()
    assert np.abs(out.det_j - ref.det_j)[~flat].max(initial=0) <= 1e-5 * scale.max(initial=0)
    # vertex folds: the GPU's det's sign, and the reference's where clear of 0
    assert (out.vertex_folds == (out.det_j <= 0)).all()
    clear = (np.abs(ref.det_j) > CLEAR * scale) & ~flat
    assert (out.vertex_folds == ref.vertex_folds)[clear].all()
    # normals, where well conditioned
    if normals is None and len(faces):
        before = mesh3.face_normals(vertices, faces)
        total = np.zeros(len(vertices))
        np.add.at(total, faces.ravel(), np.repeat(np.linalg.norm(before, axis=1), 3))
        summed = np.zeros_like(vertices)
        for c in range(3):
            np.add.at(summed, faces[:, c], before)
        good = np.linalg.norm(summed, axis=1) >= 0.01 * total
    else:
        good = np.ones(len(vertices), bool)
    good &= clear
    assert np.abs(out.normals - ref.normals)[good].max(initial=0) < 1e-4
    assert (out.normals[(ref.normals == 0).all(axis=1)] == 0).all()
    # face folds, where the sign test is clear
    if len(faces):
        a, b, d = faces.T
        cof = mesh3.cofactor(out.jacobian)
        before = mesh3.face_normals(vertices, faces)
        carried = np.einsum("fi,fij->fj", before, cof[a] + cof[b] + cof[d])
        after = mesh3.face_normals(out.vertices, faces)
        norms = np.linalg.norm(carried, axis=1) * np.linalg.norm(after, axis=1)
        cosine = np.einsum("ij,ij->i", carried, after) / np.maximum(norms, 1e-300)
        sure = (np.abs(cosine) > CLEAR) & (norms > 0) & clear[a] & clear[b] & clear[d]
        assert (out.face_folds == ref.face_folds)[sure].all()
        assert (out.face_folds[norms == 0]).all()  # a zero normal folds
    return ref


def test_a_gentle_map_against_the_reference(gl, rng):
    vertices, faces = _random_mesh(rng)
    src, dst = _handles(rng, 2.0)
    with glmls.MLS(src, dst, transform="rigid", weight="idw") as m:
        out = m.deform((vertices, faces))
        f, jacobian = m.jacobian(vertices)
    assert np.abs(out.vertices - f).max() == 0 and np.abs(out.jacobian - jacobian).max() == 0
    _compare(out, vertices, faces)


def test_a_folding_map_against_the_reference(gl, rng):
    vertices, faces = _random_mesh(rng)
    src, dst = _handles(rng, 25.0)
    with glmls.MLS(src, dst, transform="affine", weight="idw") as m:
        out = m.deform((vertices, faces))
    assert 0 < out.vertex_folds.sum() < len(vertices)
    ref = _compare(out, vertices, faces)
    # faces that flip with no folded vertex are found too
    a, b, d = faces.T
    flips = out.face_folds & ~(out.vertex_folds[a] | out.vertex_folds[b] | out.vertex_folds[d])
    assert flips.any() and ref.face_folds[flips].mean() > 0.9


def test_the_meshs_own_normals(gl, rng):
    class Own:  # as a trimesh.Trimesh: vertices, faces and (any length) vertex normals
        def __init__(self, vertices, faces, normals):
            self.vertices, self.faces, self.vertex_normals = vertices, faces, normals

    vertices, faces = _random_mesh(rng, 500, 800)
    normals = rng.normal(0, 3, vertices.shape)
    normals[:5] = 0.0  # no normal: zeros out
    src, dst = _handles(rng, 6.0)
    with glmls.MLS(src, dst, transform="similarity") as m:
        out = m.deform(Own(vertices, faces, normals))
    _compare(out, vertices, faces, normals)
    assert (out.normals[:5] == 0).all()
    assert np.abs(np.linalg.norm(out.normals[5:], axis=1) - 1).max() < 1e-6


def test_point_clouds_and_empty_meshes(gl, rng):
    vertices, _ = _random_mesh(rng, 300)
    src, dst = _handles(rng, 4.0)
    with glmls.MLS(src, dst) as m:
        cloud = m.deform(vertices)
        tuple_form = m.deform((vertices, np.zeros((0, 3), np.int64)))
        empty = m.deform(np.zeros((0, 3)))
        f, jacobian = m.jacobian(vertices)
    for out in (cloud, tuple_form):
        assert out.faces.shape == (0, 3) and out.face_folds.shape == (0,)
        assert (out.normals == 0).all() and np.abs(out.vertices - f).max() == 0
        assert np.abs(out.jacobian - jacobian).max() == 0
        _compare(out, vertices, out.faces)
    assert empty.vertices.shape == (0, 3) and empty.jacobian.shape == (0, 3, 3)
    assert empty.det_j.shape == empty.vertex_folds.shape == (0,) and not empty.folded


def test_degenerate_faces(gl):
    """Faces of zero area (a repeated vertex, collinear vertices) fold by the rule (their
    normal is zero); a vertex only they use gets no normal; the others are unaffected."""
    vertices = np.array(
        [[10, 10, 10], [20, 10, 10], [10, 20, 10], [30, 30, 30], [40, 40, 40], [50, 50, 50]],
        float,
    )
    faces = np.array([[0, 1, 2], [0, 0, 1], [3, 4, 5], [2, 2, 2]])
    src = np.array([[0, 0, 0], [60, 0, 0], [0, 60, 0], [0, 0, 60]], float)
    with glmls.MLS(src, src * 1.5 + 2.0, transform="affine") as m:
        out = m.deform((vertices, faces))
    _compare(out, vertices, faces)
    assert out.face_folds.tolist() == [False, True, True, True]
    assert np.abs(out.normals[:3] - [0, 0, 1]).max() < 1e-4  # J by float32 differences
    assert (out.normals[3:] == 0).all()
    assert not out.vertex_folds.any()


def test_repeatable_and_split_into_dispatches(gl, rng):
    """Normal sums in fixed point: the same result every call, however the work is split."""
    vertices, faces = _random_mesh(rng, 2000, 3001)
    src, dst = _handles(rng, 5.0)
    with glmls.MLS(src, dst) as m:
        mesh = mesh3.as_mesh((vertices, faces))
        whole = deform_mesh3(m.kernel, *mesh)
        again = deform_mesh3(m.kernel, *mesh)
        split = deform_mesh3(m.kernel, *mesh, max_groups=3)
    for out in (again, split):
        for name in ("vertices", "normals", "jacobian", "det_j", "face_folds"):
            assert np.array_equal(getattr(out, name), getattr(whole, name)), name


def test_each_face_is_read_by_two_passes(gl, rng, monkeypatch):
    """Normals from the faces: one pass over the faces for the sums' scales, one for the
    folds and the sums together; the given normals take the folds' pass alone."""
    from glmls.engine import deform3

    vertices, faces = _random_mesh(rng, 500, 999)
    src, dst = _handles(rng, 5.0)
    passes = []
    run_1d = deform3.run_1d

    def counted(program, count, **options):
        passes.append(count)
        run_1d(program, count, **options)

    monkeypatch.setattr(deform3, "run_1d", counted)
    with glmls.MLS(src, dst) as m:
        out = m.deform((vertices, faces))
        assert passes.count(len(faces)) == 2
        passes.clear()
        m.deform(glmls.Mesh(vertices, faces, normals=out.normals))
        assert passes.count(len(faces)) == 1
    _compare(out, vertices, faces)


def test_a_smaller_mesh_after_a_larger_one(gl, rng):
    """The passes read faces 4 at a time: a face count that is not a multiple of 4, in
    buffers a larger mesh used before, gives what a fresh MLS gives."""
    src, dst = _handles(rng, 5.0)
    large = _random_mesh(rng, 1500, 4000)
    small = _random_mesh(rng, 700, 1001)
    with glmls.MLS(src, dst) as m:
        m.deform(large)
        after = m.deform(small)
    with glmls.MLS(src, dst) as m:
        fresh = m.deform(small)
    for name in ("vertices", "normals", "jacobian", "det_j", "face_folds"):
        assert np.array_equal(getattr(after, name), getattr(fresh, name)), name
    _compare(after, *small)


def test_derivatives_and_inverse_do_not_depend_on_the_handles_unit(gl):
    """The same handles, mesh and points in millimetres, metres and micrometres (times 1,
    1e-3 and 1e3): J, det J, the normals and the inverse are the same to float32's
    precision. J's central differences and Newton's tolerance are fixed shares of a voxel
    only in a box of a few voxels or more; a mesh of 0.1 m got a step of half its size, one
    of 1e5 um a step below float32's rounding."""
    rng = np.random.default_rng(0)
    src = rng.uniform(0, 100, (8, 3))
    dst = src + rng.normal(0, 6, src.shape)
    points = rng.uniform(10, 90, (200, 3))
    sphere = glmls.data.sphere()
    vertices = np.asarray(sphere.vertices, float)
    vertices = (vertices - vertices.mean(axis=0)) / np.abs(vertices).max() * 40 + 50
    faces = np.asarray(sphere.faces)
    found = {}
    for unit in (1.0, 1e-3, 1e3):
        with glmls.MLS(src * unit, dst * unit) as m:
            _, jacobian = m.jacobian(points * unit)
            out = m.deform((vertices * unit, faces))
            back, valid = m.inverse(m(points * unit), return_valid=True)
        assert valid.all(), unit
        assert np.abs(back / unit - points).max() < 1e-3, unit  # of a 100 mm box
        found[unit] = jacobian, out
    jacobian, out = found[1.0]
    for unit in (1e-3, 1e3):
        other_j, other = found[unit]
        assert np.abs(other_j - jacobian).max() < 1e-3, unit
        assert np.abs(other.det_j - out.det_j).max() < 1e-3, unit
        assert np.abs(other.normals - out.normals).max() < 1e-3, unit


def test_vertex_colours_go_with_their_vertices(gl, rng):
    import trimesh

    vertices, faces = _random_mesh(rng, 500, 800)
    colors = rng.integers(0, 256, (len(vertices), 4), dtype=np.uint8)
    cloud = glmls.Mesh(vertices, np.zeros((0, 3), np.int64), colors=colors)
    src, dst = _handles(rng, 6.0)
    with glmls.MLS(src, dst, transform="similarity") as m:
        plain = m.deform((vertices, faces))
        rgb = m.deform(glmls.Mesh(vertices, faces, colors=colors[:, :3]))
        own = m.deform(trimesh.Trimesh(vertices, faces, vertex_colors=colors, process=False))
        grey = m.deform(trimesh.Trimesh(vertices, faces, process=False))  # trimesh's default
        points = m.deform(cloud)
    assert plain.colors is None and grey.colors is None
    for out, given in ((rgb, colors[:, :3]), (own, colors), (points, colors)):
        assert out.colors.dtype == np.uint8 and (out.colors == given).all()
        assert np.abs(out.vertices - plain.vertices).max() == 0  # nothing else changes
    ref = mesh3.deform_mesh(vertices, faces, None, rgb.vertices, rgb.jacobian, colors=rgb.colors)
    assert ref.colors is rgb.colors


def test_texture_coordinates_go_with_their_face_corners(gl, rng):
    vertices, faces = _random_mesh(rng, 500, 800)
    uv = rng.uniform(-1, 2, (3 * len(faces) // 2, 2))
    face_uv = rng.integers(0, len(uv), faces.shape)
    src, dst = _handles(rng, 6.0)
    with glmls.MLS(src, dst, transform="similarity") as m:
        plain = m.deform((vertices, faces))
        out = m.deform(glmls.Mesh(vertices, faces, uv=uv, face_uv=face_uv))
        direct = deform_mesh3(m.kernel, vertices, faces, None, uv=out.uv, face_uv=out.face_uv)
    assert plain.uv is None and plain.face_uv is None
    assert out.uv.dtype == np.float64 and out.face_uv.dtype == np.int64
    assert (out.uv == uv).all() and (out.face_uv == face_uv).all()
    assert np.abs(out.vertices - plain.vertices).max() == 0  # nothing else changes
    assert direct.uv is out.uv and direct.face_uv is out.face_uv
    ref = mesh3.deform_mesh(
        vertices, faces, None, out.vertices, out.jacobian, uv=out.uv, face_uv=out.face_uv
    )
    assert ref.uv is out.uv and ref.face_uv is out.face_uv
    _compare(out, vertices, faces)


def test_a_deformation_owns_its_arrays(gl):
    """The read-back goes through a host array the MLS keeps between calls: what a call
    returns is its own, unchanged by the next call (of another mesh, larger or smaller), and
    shares no memory with it."""
    rng = np.random.default_rng(3)
    src, dst = _handles(rng, 4.0)
    small = _random_mesh(rng, 500, 900)
    large = _random_mesh(rng, 4000, 7000)
    with glmls.MLS(src, dst) as m:
        first = m.deform(small)
        kept = {name: getattr(first, name).copy() for name in ("vertices", "normals", "jacobian")}
        kept["det_j"] = first.det_j.copy()
        second = m.deform(large)
        third = m.deform((large[0] + 1.0, large[1]))
        for name, values in kept.items():
            np.testing.assert_array_equal(getattr(first, name), values)
            assert not np.shares_memory(getattr(first, name), getattr(second, name))
            assert not np.shares_memory(getattr(second, name), getattr(third, name))
        assert not np.array_equal(second.vertices, third.vertices)
        assert gl.mgl.error == "GL_NO_ERROR"


def test_tables_of_several_rows(gl, rng):
    """The passes over faces fetch vertices, faces and records from tables of TABLE_WIDTH
    texels a row: a mesh whose every table spans rows, its last row partly filled."""
    from glmls.gl.tables import TABLE_WIDTH

    vertices, faces = _random_mesh(rng, TABLE_WIDTH + 808, 11001)
    src, dst = _handles(rng, 5.0)
    with glmls.MLS(src, dst) as m:
        out = m.deform((vertices, faces))
        own = m.deform(glmls.Mesh(vertices, faces, normals=out.normals))
    assert len(faces) * 3 // 4 > TABLE_WIDTH  # the faces' table: 3 texels per 4 faces
    _compare(out, vertices, faces)
    _compare(own, vertices, faces, out.normals)


def test_a_mesh_larger_than_its_tables_is_refused(gl, rng, monkeypatch):
    """A mesh needs 4 texels per vertex (1 without faces) in tables of max_texture_size
    rows: past them, a ValueError before any GPU work; a point cloud of as many vertices
    fits."""
    from glmls.gl.context import GLContext
    from glmls.gl.tables import TABLE_WIDTH

    limits = GLContext.limits
    one_row = property(lambda self: {**limits.fget(self), "max_texture_size": 1})
    vertices, faces = _random_mesh(rng, TABLE_WIDTH // 4 + 1, 100)
    src, dst = _handles(rng, 5.0)
    with glmls.MLS(src, dst) as m:
        whole = m.deform(vertices)
        monkeypatch.setattr(GLContext, "limits", one_row)
        with pytest.raises(ValueError, match="does not fit this GL's tables"):
            m.deform((vertices, faces))
        cloud = m.deform(vertices)
        small = m.deform((vertices[: TABLE_WIDTH // 4], faces % (TABLE_WIDTH // 4)))
    assert np.array_equal(cloud.vertices, whole.vertices)
    _compare(small, vertices[: TABLE_WIDTH // 4], faces % (TABLE_WIDTH // 4))


@pytest.mark.parametrize("size", [1.0, 100.0, 1e4])
def test_a_map_that_flattens_folds_every_vertex_and_face(gl, rng, size):
    """Targets on a plane (affine): f flattens space, J is singular (the float64 reference's
    central differences say so, its smallest singular value ~1e-10 of its largest), and the
    GPU's det J, float32's rounding of either sign, is 0: every vertex and face folds. A
    thin map well above the rounding (z squeezed by 1e-2) keeps its det J and folds none."""
    sphere = glmls.data.sphere()
    vertices = sphere.vertices * size
    src = rng.uniform(0, 64, (10, 3)) * size
    flat = src.copy()
    flat[:, 2] = 32.0 * size
    step = 1e-3 * size
    columns = [
        (
            reference.mls(src, flat, vertices + step * e, transform="affine")[0]
            - reference.mls(src, flat, vertices - step * e, transform="affine")[0]
        )
        / (2 * step)
        for e in np.eye(3)
    ]
    singular = np.linalg.svd(np.stack(columns, axis=1), compute_uv=False)
    assert (singular[:, 2] < 1e-8 * singular[:, 0]).all()
    thin = src * [1.0, 1.0, 1e-2]
    with glmls.MLS(src, flat, transform="affine") as m:
        out = m.deform((vertices, sphere.faces))
        cloud = m.deform(vertices)
    with glmls.MLS(src, thin, transform="affine") as m:
        kept = m.deform((vertices, sphere.faces))
    assert (out.det_j == 0).all() and out.vertex_folds.all() and out.face_folds.all()
    assert (cloud.det_j == 0).all() and cloud.vertex_folds.all()
    assert np.isfinite(out.normals).all()
    np.testing.assert_allclose(kept.det_j, 1e-2, atol=5e-3)  # float32's J: within ~2e-3
    assert not kept.vertex_folds.any() and not kept.face_folds.any()
