"""Results print as their fields' shapes and dtypes (``glmls.core.summary``): ``print`` of a
deformed mesh, a mesh or a volume in a notebook is one line, not every vertex and voxel."""

from __future__ import annotations

import numpy as np

import glmls
from glmls.core.summary import describe


def test_describe_names_shapes_lengths_and_short_values():
    assert describe(None) == "None"
    assert describe(np.zeros((2, 3), np.float32)) == "array((2, 3), float32)"
    assert describe([np.zeros(2), np.zeros((1, 2), bool)]) == (
        "[2 arrays: (2,) float64, (1, 2) bool]"
    )
    assert describe([np.zeros(1)] * 5).endswith(", ...]")
    assert describe([{"a": 1}, {"b": 2}]) == "[2 dicts]"
    assert describe((2.0, 1.0, 0.5)) == "(2.0, 1.0, 0.5)"
    assert describe([0.5] * 40) == "[40 floats]"
    assert describe("x" * 100) == "<str>" and describe(3) == "3"


def test_deformed_mesh_mesh_and_volume_print_their_shapes():
    vertices = np.array([[0, 0, 0], [4, 0, 0], [0, 4, 0]], float)
    mesh = glmls.Mesh(vertices, [[0, 1, 2]])
    assert repr(mesh) == (
        "Mesh(vertices=array((3, 3), float64), faces=array((1, 3), int64), colors=None, "
        "uv=None, face_uv=None, normals=None)"
    )
    deformed = glmls.DeformedMesh(
        vertices, np.array([[0, 1, 2]]), vertices, np.zeros((3, 3, 3)), np.ones(3),
        np.zeros(3, bool), np.zeros(1, bool),
    )  # fmt: skip
    text = repr(deformed)
    assert text.startswith("DeformedMesh(vertices=array((3, 3), float64), faces=")
    assert "jacobian=array((3, 3, 3), float64)" in text and len(text) < 300
    volume = glmls.Volume(np.zeros((4, 5, 6), np.uint8), spacing=(2.0, 1.0, 1.0))
    assert (
        repr(volume)
        == "Volume(data=array((4, 5, 6), uint8), spacing=(2.0, 1.0, 1.0), affine=None, nifti=None)"
    )


def test_describe_keeps_shapes_of_a_ragged_list_with_gaps():
    """A per-image list may hold None where an image has nothing: the arrays' shapes still
    show, and None in its place."""
    assert describe([np.zeros(3), None]) == "[2 arrays: (3,) float64, None]"
    assert describe([None, None]) == "[None, None]"


def test_describe_shows_scalars_as_values():
    """A 0-d array and a numpy scalar are one number: shown as the number."""
    assert describe(np.array(2.5)) == "array(2.5, float64)"
    assert describe(np.float32(3)) == "3.0"
    assert describe([np.int64(1), np.int64(2)]) == "[1, 2]"


def test_describe_names_tensors_as_tensors():
    class Tensor:  # the shape and dtype attributes of a torch tensor, without torch
        shape, dtype = (2, 3), "torch.float32"

    assert describe(Tensor()) == "Tensor((2, 3), torch.float32)"
    assert describe([Tensor()] * 2) == "[2 Tensors: (2, 3) torch.float32, (2, 3) torch.float32]"
