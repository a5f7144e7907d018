"""Mesh faces are integer vertex indices: other dtypes are refused with a message naming the
dtype (and the shape), before any GPU work."""

from __future__ import annotations

import numpy as np
import pytest

from glmls.core.mesh3 import as_mesh


@pytest.mark.parametrize("dtype", [np.float64, np.float32, np.bool_, object])
def test_faces_that_are_not_integers_are_refused_naming_their_dtype(dtype):
    faces = np.array([[0, 1, 2]], dtype=dtype)
    with pytest.raises(TypeError, match=rf"integer vertex indices, got dtype {np.dtype(dtype)}"):
        as_mesh((np.eye(3), faces))


def test_faces_of_a_wrong_shape_name_shape_and_dtype():
    with pytest.raises(ValueError, match=r"got shape \(1, 2\) \(dtype int"):
        as_mesh((np.eye(3), np.array([[0, 1]])))


def test_integer_faces_of_any_width_pass():
    for dtype in (np.uint8, np.int32, np.int64):
        _, faces, _ = as_mesh((np.eye(3), np.array([[0, 1, 2]], dtype=dtype)))
        assert faces.dtype == np.int64 and faces.tolist() == [[0, 1, 2]]


@pytest.mark.parametrize(
    "mesh", [(np.eye(3), np.array([[0, 1, 2]]), None), [np.eye(3).tolist(), [[0, 1, 2]]]]
)
def test_a_sequence_that_is_no_mesh_is_named_not_left_to_numpy(mesh):
    # a (vertices, faces) pair is a tuple of two; anything else is read as the points
    with pytest.raises(ValueError, match=r"mesh vertices must have shape \(N, 3\)"):
        as_mesh(mesh)
