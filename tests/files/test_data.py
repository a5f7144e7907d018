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
