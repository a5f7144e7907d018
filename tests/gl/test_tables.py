"""Tables (glmls.gl.tables): read-only arrays in 2-D textures that shaders fetch item by item
(common/table.glsl), written from numpy or copied from a GPU buffer."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from helpers import context_with_shaders
from numpy.testing import assert_array_equal

from glmls.gl import bindings
from glmls.gl.tables import TABLE_WIDTH, Tables, table_rows

READ = """\
layout(local_size_x = 64) in;
#include "common/table.glsl"
layout(binding = 0) uniform SAMPLER table;
layout(std430, binding = BIND_DEFORMED) writeonly buffer Out {
    VALUE out_values[];
};
uniform int u_count;
void main() {
    int i = int(gl_GlobalInvocationID.x);
    if (i < u_count) {
        out_values[i] = TABLE_FETCH(table, i);
    }
}
"""


@pytest.fixture(scope="module")
def reader(tmp_path_factory):
    """A context whose shader library holds the package's common/table.glsl and a shader
    that copies items 0 .. u_count - 1 of the table on unit 0 into a buffer."""
    root = tmp_path_factory.mktemp("tables")
    own = context_with_shaders(root, {"read.comp.glsl": READ}, package=("common/table.glsl",))
    yield own
    own.release()


def read_table(gl, count: int, integer: bool) -> np.ndarray:
    """Items 0 .. count - 1 of the table bound to unit 0, (count, 4)."""
    kind = ("usampler2D", "uvec4", np.uint32) if integer else ("sampler2D", "vec4", np.float32)
    program = gl.compute("read.comp.glsl", {"SAMPLER": kind[0], "VALUE": kind[1]})
    out = gl.mgl.buffer(reserve=max(16, count * 16))
    try:
        out.bind_to_storage_buffer(bindings.DEFORMED.index)
        program["u_count"].value = count
        program.run(group_x=max(1, -(-count // 64)))
        gl.mgl.memory_barrier()
        return np.frombuffer(out.read(size=count * 16), kind[2]).reshape(count, 4).copy()
    finally:
        out.release()


@pytest.mark.parametrize("count", [1, 5, TABLE_WIDTH, TABLE_WIDTH + 3, 2 * TABLE_WIDTH + 1])
@pytest.mark.parametrize("components, dtype", [(4, np.float32), (2, np.float32), (4, np.uint32)])
def test_items_are_fetched_where_they_were_written(reader, rng, count, components, dtype):
    """Item i comes back at i, across rows and whatever the texture held before (a larger
    table first: the texture is kept and only the items written are read)."""
    tables = Tables(reader)
    try:
        with reader:
            for size in (count + 2 * TABLE_WIDTH, count):
                if dtype is np.uint32:
                    data = rng.integers(0, 2**32, (size, components), dtype=np.uint32)
                else:
                    data = rng.normal(0, 1e3, (size, components)).astype(np.float32)
                tables.write("items", data, 0)
                got = read_table(reader, count, dtype is np.uint32)
            assert reader.mgl.error == "GL_NO_ERROR"
    finally:
        tables.release()
    assert_array_equal(got[:, :components], data)


def test_copies_from_a_buffer_keep_the_items_copied_before(reader, rng):
    """f appended level by level: each copy brings (first, end) over, earlier items stay;
    a copy that needs a larger texture copies everything again."""
    tables = Tables(reader)
    values = rng.normal(0, 10, (3 * TABLE_WIDTH, 2)).astype(np.float32)
    try:
        with reader:
            source = reader.mgl.buffer(reserve=values.nbytes)
            done = 0
            for end in (7, TABLE_WIDTH - 1, TABLE_WIDTH + 5, 3 * TABLE_WIDTH - 2):
                source.write(values[done:end].tobytes(), offset=done * 8)
                tables.copy("f", source, (done, end), 2, 0)
                done = end
                got = read_table(reader, end, False)
                assert_array_equal(got[:, :2], values[:end])
            assert reader.mgl.error == "GL_NO_ERROR"
            source.release()
    finally:
        tables.release()


def test_a_buffer_without_the_whole_rows_is_refused(reader):
    tables = Tables(reader)
    try:
        with reader:
            source = reader.mgl.buffer(reserve=64)
            with pytest.raises(ValueError, match="fewer than 1 rows"):
                tables.copy("f", source, (0, 4), 2, 0)
            source.release()
    finally:
        tables.release()


@pytest.mark.parametrize(
    "data",
    [
        np.zeros((4, 3), np.float32),
        np.zeros((4, 4), np.float64),
        np.zeros(8, np.float32),
        np.zeros((4, 4), np.int64),
    ],
)
def test_bad_items_are_refused(reader, data):
    tables = Tables(reader)
    try:
        with reader, pytest.raises(ValueError, match="float32 or uint32"):
            tables.write("items", data, 0)
    finally:
        tables.release()


def test_a_table_past_the_textures_limit_is_refused():
    """More rows than GL_MAX_TEXTURE_SIZE: a ValueError naming the count, before any GL."""
    gl = SimpleNamespace(limits={"max_texture_size": 2}, mgl=None)
    tables = Tables(gl)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"16,385 items do not fit"):
        tables.write("items", np.zeros((2 * TABLE_WIDTH + 1, 4), np.float32), 0)


def test_a_table_exactly_at_the_textures_limit_holds_every_item(reader, rng):
    """As many rows as GL_MAX_TEXTURE_SIZE (a stand-in limit of 2 here): every item kept."""
    capped = SimpleNamespace(limits={"max_texture_size": 2}, mgl=reader.mgl)
    tables = Tables(capped)  # type: ignore[arg-type]
    data = rng.uniform(-1, 1, (2 * TABLE_WIDTH, 4)).astype(np.float32)
    try:
        with reader:
            tables.write("items", data, 0)
            assert_array_equal(read_table(reader, len(data), False), data)
    finally:
        tables.release()


def test_rows():
    assert table_rows(0) == 1 and table_rows(1) == 1
    assert table_rows(TABLE_WIDTH) == 1 and table_rows(TABLE_WIDTH + 1) == 2
