"""The bundled example data and the main job."""

from __future__ import annotations

import numpy as np
from PIL import Image

from glmls import data, example


def test_bundled_example_data():
    image = data.astronaut()
    assert image.shape == (512, 512, 3) and image.dtype == np.uint8
    src, dst = data.astronaut_handles()
    assert src.shape == dst.shape and src.shape[1] == 2
    assert data.astronaut_reference_points().shape[1] == 2


def test_example_writes_the_mesh_picture(gl, tmp_path):
    assert example.main(["--out", str(tmp_path), "--grid", "32"]) == 0
    with Image.open(tmp_path / "mesh.png") as picture:
        assert picture.size == (1024, 512)
        pixels = np.asarray(picture.convert("RGB"))
    # the deformed mesh is drawn in blue on the right half
    right = pixels[:, 512:]
    assert ((right[..., 2] > 120) & (right[..., 0] < 60)).sum() > 1000
