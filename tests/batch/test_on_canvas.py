"""One rule for "a keypoint lands on the canvas", shared by the batch's single and chunked
paths and the visibility test: output pixel c covers [c - 0.5, c + 0.5)."""

from __future__ import annotations

import numpy as np

from glmls.batch.labels import on_canvas


def test_the_canvas_is_half_open():
    points = np.array([[-0.5, -0.5], [3.49, 1.49], [3.5, 0.0], [0.0, 1.5], [-0.51, 0.0]])
    assert on_canvas(points, (2, 4)).tolist() == [True, True, False, False, False]
    assert on_canvas(np.zeros((0, 2)), (2, 4)).shape == (0,)
