"""A batch's chunks of different sizes share their GL textures: an atlas is drawn, filled and
read in the first rows of one kept from a larger chunk, and the results do not change with
the chunking, for every path that draws an atlas."""

from __future__ import annotations

import numpy as np
import pytest

import glmls
from glmls.gl.resources import Resources

SHAPE = (20, 26)
COUNT = 7

#: per case: warp_batch's options (each path that draws into an atlas)
CASES = {
    "quads-linear-labels": {"interpolation": "linear", "grid": 2},
    "quads-nearest-float": {"grid": 2, "float": True},
    "quads-linear-edge": {"interpolation": "linear", "border": "edge", "grid": 2},
    "backward-maps": {"method": "backward", "return_maps": True},
    "backward-swap": {"method": "backward-swap", "interpolation": "linear"},
    "paper-quads": {"method": "paper-quads", "interpolation": "linear"},
    "splat": {"method": "splat"},
}


@pytest.fixture
def served(monkeypatch):
    """The (asked, made) sizes of the tall textures that served an atlas."""
    calls: list[tuple[tuple[int, int], tuple[int, int]]] = []
    texture = Resources.texture

    def spy(self, role, size, components, dtype="f4", *, tall=False):
        made = texture(self, role, size, components, dtype, tall=tall)
        if tall:
            calls.append((tuple(size), made.size))
        return made

    monkeypatch.setattr(Resources, "texture", spy)
    return calls


@pytest.mark.parametrize("case", list(CASES))
def test_chunks_of_any_size_give_the_same_result(gl, rng, served, case):
    options = dict(CASES[case])
    dtype = np.float32 if options.pop("float", False) else np.uint8
    if dtype == np.uint8:
        batch = rng.integers(0, 256, (COUNT, *SHAPE, 3), dtype=np.uint8)
    else:
        batch = rng.uniform(0, 1, (COUNT, *SHAPE, 3)).astype(np.float32)
    src = rng.uniform((2, 2), (SHAPE[1] - 3, SHAPE[0] - 3), (COUNT, 6, 2))
    dst = src + rng.normal(0, 2.5, src.shape)
    masks = rng.integers(0, 5, (COUNT, *SHAPE), dtype=np.uint16)
    points = rng.uniform(0, SHAPE[0] - 1, (COUNT, 3, 2))
    labels = {"masks": masks}
    if options.get("method") not in ("backward", "backward-swap"):
        labels["keypoints"] = points  # (the backward methods' keypoints take the single path)

    def run(budget):
        return glmls.warp_batch(batch, src, dst, max_batch_bytes=budget, **labels, **options)

    # small chunks first, then the whole batch (its atlas grows), then small ones again in it
    results = [run(1), run(None), run(40_000), run(1)]
    for result in results[1:]:
        for name in ("images", "masks", "keypoints", "keypoints_valid", "maps", "valid"):
            np.testing.assert_array_equal(getattr(result, name), getattr(results[0], name))
    assert any(asked[1] < made[1] for asked, made in served), "no atlas in a taller texture"
    if options.get("method", "quads") == "quads":  # bit-equal to the single warps
        singles = [glmls.warp(*item, **options) for item in zip(batch, src, dst, strict=True)]
        np.testing.assert_array_equal(results[0].images, np.stack(singles))
    assert gl.mgl.error == "GL_NO_ERROR"
