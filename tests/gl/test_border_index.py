"""common/border.glsl's border_index on the GPU against numpy.pad's meanings of the border
rules, for indices in the image, one period out and far beyond it (either sign): the
float-quotient remainder must give numpy's integer one everywhere."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import context_with_shaders

from glmls.gl import bindings
from glmls.imaging.source import BORDERS

INDEX = """
layout(local_size_x = 64) in;
#include "common/border.glsl"
layout(std430, binding = BIND_POINTS) readonly buffer Given { int given[]; };
layout(std430, binding = BIND_DEFORMED) writeonly buffer Found { int found[]; };
uniform int u_count;
uniform int u_size;
void main() {
    int k = int(gl_GlobalInvocationID.x);
    if (k < u_count) {
        found[k] = border_index(given[k], u_size);
    }
}
"""
#: numpy.pad's names of the rules past the image (constant: the index clamped)
PAD = {
    "constant": "edge",
    "edge": "edge",
    "symmetric": "symmetric",
    "reflect": "reflect",
    "wrap": "wrap",
}


@pytest.fixture(scope="module")
def indexer(tmp_path_factory):
    root = tmp_path_factory.mktemp("border")
    own = context_with_shaders(root, {"index.comp.glsl": INDEX}, package=("common/border.glsl",))
    yield own
    own.release()


def expected(indices: np.ndarray, size: int, border: str) -> np.ndarray:
    """numpy.pad's index of the image pixel at each index (any distance out)."""
    reach = int(np.abs(indices).max()) + 1
    padded = np.pad(np.arange(size), reach, mode=PAD[border])
    return padded[indices + reach]


@pytest.mark.parametrize("border", BORDERS)
@pytest.mark.parametrize("size", [1, 2, 3, 7, 224, 4099])
def test_border_index_is_numpy_pad(indexer, border, size):
    rng = np.random.default_rng(size)
    near = np.arange(-3 * size - 5, 3 * size + 5)
    far = rng.integers(-(2**20), 2**20, 20000)
    periods = np.array(
        [k * m for m in (size, 2 * size, max(1, 2 * size - 2)) for k in (-5000, -3, -1, 1, 3, 5000)]
    )
    indices = np.concatenate([near, far, periods, periods - 1, periods + 1]).astype(np.int32)
    count = len(indices)
    with indexer:
        program = indexer.compute("index.comp.glsl", {"WARP_BORDER": BORDERS.index(border)})
        given = indexer.mgl.buffer(indices.tobytes())
        out = indexer.mgl.buffer(reserve=4 * count)
        try:
            given.bind_to_storage_buffer(bindings.POINTS.index)
            out.bind_to_storage_buffer(bindings.DEFORMED.index)
            program["u_count"].value = count
            program["u_size"].value = size
            program.run(group_x=-(-count // 64))
            indexer.mgl.memory_barrier()
            found = np.frombuffer(out.read(), np.int32)
        finally:
            given.release()
            out.release()
        assert indexer.mgl.error == "GL_NO_ERROR"
    want = expected(indices.astype(np.int64), size, border)
    wrong = np.flatnonzero(found != want)
    assert not len(wrong), (indices[wrong[:5]], found[wrong[:5]], want[wrong[:5]])
