"""Meshes through trimesh's formats as trimesh reads them back: the vertex order and the
faces kept (PLY, OBJ), (x, y, z) as written, and after a deformation without reflection
the faces still wound outward, glmls's normals those trimesh computes."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from numpy.testing import assert_allclose, assert_array_equal

import glmls


def _shuffled_sphere():
    sphere = glmls.data.sphere()
    rng = np.random.default_rng(1)
    order = rng.permutation(len(sphere.vertices))
    vertices = np.asarray(sphere.vertices)[order] * [10.0, 12.0, 8.0] + [32.0, 30.0, 20.0]
    return vertices, np.argsort(order)[np.asarray(sphere.faces)]


def _outward(mesh: trimesh.Trimesh) -> float:
    outward = np.einsum("ij,ij->i", mesh.face_normals, mesh.triangles_center - mesh.centroid)
    return float((outward > 0).mean())


@pytest.mark.parametrize("suffix", [".ply", ".obj"])
def test_trimesh_reads_what_glmls_writes_in_order(tmp_path, suffix):
    vertices, faces = _shuffled_sphere()
    path = tmp_path / f"sphere{suffix}"
    glmls.write_mesh(path, glmls.Mesh(vertices, faces))
    loaded = trimesh.load(path, process=False, maintain_order=True)
    assert_allclose(loaded.vertices, vertices, atol=1e-5)  # PLY holds float32
    assert_array_equal(loaded.faces, faces)
    again = glmls.read_mesh(path)
    assert_array_equal(again.faces, faces)


def test_a_deformation_without_reflection_keeps_the_faces_outward(gl, tmp_path):
    vertices, faces = _shuffled_sphere()
    assert _outward(trimesh.Trimesh(vertices, faces, process=False)) == 1.0
    corners = np.array([[0, 0, 0], [64, 0, 0], [0, 64, 0], [0, 0, 64], [64, 64, 64]], float)
    shear = np.array([[1.2, 0.1, 0.0], [0.0, 0.9, 0.2], [0.0, 0.0, 1.1]])  # det > 0
    with glmls.MLS(corners, corners @ shear, transform="affine") as m:
        deformed = m.deform(glmls.Mesh(vertices, faces))
    assert not np.asarray(deformed.face_folds).any()
    glmls.write_mesh(tmp_path / "deformed.ply", deformed)
    loaded = trimesh.load(tmp_path / "deformed.ply", process=False)
    assert_allclose(loaded.vertices, vertices @ shear, atol=1e-3)
    assert _outward(loaded) == 1.0
    agree = np.einsum("ij,ij->i", deformed.normals, loaded.vertex_normals)
    assert agree.min() > 0.99
