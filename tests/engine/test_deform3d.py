"""Meshes and point clouds deformed by a 3D MLS: vertices, normals carried by J^-T, det J and
the folds, for every input form (trimesh, a (vertices, faces) tuple, points)."""

from __future__ import annotations

import numpy as np
import pytest

import glmls


def _octahedron(scale: float = 10.0, center=(50.0, 50.0, 50.0)):
    vertices = np.array(
        [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float
    )
    faces = np.array(
        [[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]]
    )
    return vertices * scale + center, faces


def _tetra_handles():
    return np.array([[0, 0, 0], [100, 0, 0], [0, 100, 0], [0, 0, 100], [100, 100, 100]], float)


def test_affine_map_normals_and_det(gl):
    vertices, faces = _octahedron()
    src = _tetra_handles()
    linear = np.array([[2.0, 0.0, 0.0], [0.5, 1.0, 0.0], [0.0, 0.0, 0.5]])
    with glmls.MLS(src, src @ linear + 3.0, transform="affine") as m:
        out = m.deform((vertices, faces))
    assert np.abs(out.vertices - (vertices @ linear + 3.0)).max() < 1e-3
    assert np.abs(out.jacobian - linear).max() < 1e-3
    assert np.abs(out.det_j - np.linalg.det(linear)).max() < 1e-3
    normals = (vertices - 50.0) / 10.0  # the octahedron's vertex normals point outwards
    carried = normals @ np.linalg.inv(linear).T
    carried /= np.linalg.norm(carried, axis=1, keepdims=True)
    assert np.abs(out.normals - carried).max() < 1e-3
    assert not out.folded and out.faces.shape == (8, 3)


def test_a_mirror_folds_everything(gl):
    vertices, faces = _octahedron()
    src = _tetra_handles()
    with glmls.MLS(src, src * [-1.0, 1.0, 1.0], transform="affine") as m:
        out = m.deform((vertices, faces))
    assert (out.det_j < 0).all() and out.vertex_folds.all() and out.face_folds.all()
    assert out.folded


def test_trimesh_and_point_clouds(gl):
    trimesh = pytest.importorskip("trimesh")
    mesh = trimesh.creation.icosphere(subdivisions=2, radius=20.0)
    mesh.apply_translation([60.0, 60.0, 60.0])
    rng = np.random.default_rng(4)
    src = rng.uniform(0, 128, (16, 3))
    with glmls.MLS(src, src + rng.normal(0, 2, src.shape)) as m:
        out = m.deform(mesh)
        cloud = m.deform(np.asarray(mesh.vertices))
        assert np.abs(out.vertices - m(mesh.vertices)).max() == 0
    assert out.normals.shape == (len(mesh.vertices), 3)
    # a gentle map: the normals stay close to the sphere's, no folds
    assert (np.einsum("ij,ij->i", out.normals, mesh.vertex_normals) > 0.9).all()
    assert not out.folded
    assert cloud.faces.shape == (0, 3) and cloud.face_folds.shape == (0,)
    assert (cloud.normals == 0).all() and np.abs(cloud.vertices - out.vertices).max() == 0
    with glmls.MLS(src, src + rng.normal(0, 2, src.shape)) as m:  # without colours: no colours
        points = m.deform(trimesh.PointCloud(np.asarray(mesh.vertices)))
        assert points.colors is None and np.abs(points.vertices - m(mesh.vertices)).max() == 0


def test_write_mesh_takes_the_tuple_that_deform_takes(tmp_path):
    vertices = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    faces = np.array([[0, 1, 2], [0, 1, 3]])
    glmls.write_mesh(tmp_path / "m.ply", (vertices, faces))
    back = glmls.read_mesh(tmp_path / "m.ply")
    np.testing.assert_array_equal(back.vertices, vertices)
    np.testing.assert_array_equal(back.faces, faces)


def test_face_flip_without_vertex_folds():
    """A face whose deformed normal opposes its carried one folds even where no vertex does
    (a map that turns the face over between its vertices)."""
    from glmls.core.mesh3 import face_folds, face_normals

    vertices = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float)
    faces = np.array([[0, 1, 2]])
    deformed = vertices[[0, 2, 1]]  # the face's orientation flips
    cofactors = np.repeat(np.eye(3)[None], 3, axis=0)
    before = face_normals(vertices, faces)
    folds = face_folds(before, deformed, faces, cofactors, np.zeros(3, bool))
    assert folds.tolist() == [True]


def test_bad_meshes(gl):
    with glmls.MLS([[0, 0, 0]], [[1, 1, 1]]) as m:
        with pytest.raises(ValueError, match="faces"):
            m.deform((np.zeros((3, 3)), np.array([[0, 1, 5]])))
        with pytest.raises(ValueError, match=r"\(N, 3\)"):
            m.deform(np.zeros((3, 2)))
