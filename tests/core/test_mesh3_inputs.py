"""The forms a mesh or point cloud takes (glmls.core.mesh3.as_mesh): an object with vertices
and no faces (trimesh.PointCloud), or faces None, is a point cloud."""

from __future__ import annotations

import numpy as np
import trimesh

from glmls.core.mesh3 import as_mesh


def test_an_object_of_vertices_only_is_a_point_cloud():
    points = np.random.default_rng(0).uniform(0, 10, (5, 3))
    vertices, faces, normals = as_mesh(trimesh.PointCloud(points))
    np.testing.assert_array_equal(vertices, points)
    assert faces.shape == (0, 3) and normals is None


def test_an_object_whose_faces_are_none_is_a_point_cloud():
    class Unfaced:
        vertices = np.random.default_rng(1).uniform(0, 10, (4, 3))
        faces = None

    vertices, faces, normals = as_mesh(Unfaced())
    np.testing.assert_array_equal(vertices, Unfaced.vertices)
    assert faces.shape == (0, 3) and normals is None
    vertices, faces, _ = as_mesh((Unfaced.vertices, None))
    assert faces.shape == (0, 3)
