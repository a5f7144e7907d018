"""The bundled example: photograph, handles and reference points."""

from __future__ import annotations

import numpy as np

from glmls import data


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
