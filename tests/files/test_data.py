"""The bundled example: photograph, handles and reference points."""

from __future__ import annotations

import numpy as np
import pytest

from glmls import data
from glmls.data.synthetic import MAX_SUBDIVISIONS, icosphere


def test_bundled_example_data():
    image = data.astronaut()
    assert image.shape == (512, 512, 3) and image.dtype == np.uint8
    src, dst = data.astronaut_handles()
    assert src.shape == dst.shape and src.shape[1] == 2
    assert ((src >= 0) & (src < 512)).all()
    reference = data.astronaut_reference_points()
    assert reference.shape[1] == 2 and len(reference) >= 3


def test_bundled_3d_examples():
    volume = data.phantom()
    assert volume.shape == (64, 64, 64) and volume.dtype == np.uint8
    assert np.array_equal(volume, data.phantom())  # made the same every time
    assert set(np.unique(volume).tolist()) == {0, 40, 110, 160, 200, 255}
    src, dst = data.phantom_handles()
    assert src.shape == dst.shape == (10, 3)
    assert ((src >= 0) & (src < 64)).all() and ((dst >= 0) & (dst < 64)).all()
    mesh = data.sphere()
    assert mesh.vertices.shape == (162, 3) and mesh.faces.shape == (320, 3)
    centre = mesh.vertices.mean(axis=0)
    assert np.allclose(centre, 32.0) and np.allclose(np.linalg.norm(mesh.vertices - 32, axis=1), 20)
    src, dst = data.sphere_handles()
    assert src.shape == dst.shape == (7, 3)


@pytest.mark.parametrize(
    ("subdivisions", "error"),
    [(-1, ValueError), (MAX_SUBDIVISIONS + 1, ValueError), (1.5, TypeError), (True, TypeError)],
)
def test_icosphere_names_a_count_of_subdivisions_it_does_not_make(subdivisions, error):
    """-1 was the icosahedron, True one subdivision, 100 filled the memory (4^100 faces)."""
    with pytest.raises(error, match=r"^subdivisions must be an integer from 0 to 8, got "):
        icosphere(subdivisions)


def test_icosphere_counts():
    for n in (0, 1, 2):
        vertices, faces = icosphere(n)
        assert (len(vertices), len(faces)) == (10 * 4**n + 2, 20 * 4**n)
