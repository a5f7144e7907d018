"""A batch result prints as a summary of its fields (their shapes and dtypes), not as every
pixel of every image: ``print(result)`` in a notebook is one line."""

from __future__ import annotations

import numpy as np

from glmls import BatchResult
from glmls.augment import AugmentResult


def test_the_repr_gives_shapes_and_dtypes():
    result = BatchResult(
        images=np.zeros((8, 64, 64, 3), np.uint8),
        keypoints=np.zeros((8, 5, 2)),
        keypoints_valid=np.ones((8, 5), bool),
        masks=[np.zeros((4, 5), np.uint8), np.zeros((6, 7), np.uint8)],
    )
    text = repr(result)
    assert text == (
        "BatchResult(images=array((8, 64, 64, 3), uint8), keypoints=array((8, 5, 2), float64), "
        "keypoints_valid=array((8, 5), bool), masks=[2 arrays: (4, 5) uint8, (6, 7) uint8], "
        "maps=None, valid=None, params=None)"
    )


def test_an_augment_result_lists_its_records_and_polygons():
    result = AugmentResult(
        images=np.zeros((2, 8, 8), np.uint8),
        params=[{"seed": 0, "index": 0}, {"seed": 0, "index": 1}],
        polygons=[[np.zeros((4, 2))], []],
    )
    text = repr(result)
    assert text.startswith("AugmentResult(images=array((2, 8, 8), uint8), ")
    assert "params=[2 dicts]" in text and "polygons=[2 lists]" in text
    assert "boxes=None" in text and len(text) < 300
