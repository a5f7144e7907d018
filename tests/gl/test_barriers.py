"""Memory barriers between GPU commands (``tests/barrier_trace.py``): no command of a few
representative workloads reads what an earlier shader stored, or stores where an earlier one
still reads, without a ``glMemoryBarrier`` between them. llvmpipe runs every command to its
end, in order, so a missing barrier changes no result here; a GPU overlaps consecutive
dispatches and the result is wrong there. ``tools/barrier_survey.py`` runs every path.

The tracer itself: what a program's source says it reads and stores (``tests/glsl_usage.py``),
and that it finds each kind of hazard and passes a barrier."""

from __future__ import annotations

import numpy as np
import pytest
from barrier_trace import tracing
from glsl_usage import END, Access, units, usage

import glmls
from glmls.gl import bindings
from glmls.gl.context import create_headless
from glmls.volume import SlabOptions

# -- what a source reads and stores ------------------------------------------------------------

SOURCE = """#version 430
#define FLAG 1
#define RAISE(counter, n) { atomicMax(counter, n); }
layout(local_size_x = 1) in;
layout(std430, binding = 1) readonly buffer In { uint a; uvec4 b; float rest[]; };
layout(std430, binding = 2) writeonly buffer Out { vec2 out_v[]; };
layout(std430, binding = 3) buffer Count { uint count; uint groups; uint items[]; };
layout(std430, binding = 4) buffer Unused { uint never; };
layout(std430, binding = 5) buffer Branch { uint branch_word; };
layout(r32ui, binding = 0) writeonly uniform uimage2D target;
void unreached() { never = 1u; }
void add(inout uint x) { x += 1u; }
void main() {
    uint k = atomicAdd(count, 1u);
    RAISE(groups, k);
    out_v[k] = vec2(rest[a], float(b.x));
#if FLAG
    uint seen = branch_word;
#else
    branch_word = 2u;
#endif
    imageStore(target, ivec2(0), uvec4(k));
}
"""


def test_a_sources_reads_and_stores():
    found = usage(SOURCE)
    # std430: a at 0, b at 16 (a uvec4's alignment), rest from 32
    assert found["In"] == Access(((0, 4), (16, 32), (32, END)), (), ())
    assert found["Out"] == Access((), ((0, END),), ())
    # count and groups only through atomics (the macro's included), items never named
    assert found["Count"] == Access(((0, 4), (4, 8)), ((0, 4), (4, 8)), ((0, 4), (4, 8)))
    assert found["Unused"] == Access()  # named only by a function main never calls
    assert found["Branch"] == Access(((0, 4),), (), ())  # the store is in a group left out
    assert found["target"] == Access((), ((0, END),), ())


def test_units_from_the_layouts():
    source = SOURCE.replace(
        "#define FLAG 1", "#define FLAG 1\n#define BIND_T 6\n#define UNIT BIND_T"
    )
    source = source.replace("binding = 0) writeonly", "binding = UNIT) writeonly")
    source += "layout(binding = 3) uniform sampler2D table;\n"
    assert units(source) == {"target": 6, "table": 3}


def test_stores_through_parameters_and_increments():
    source = SOURCE.replace("uint k = atomicAdd(count, 1u);", "add(count); ++groups; uint k = 0u;")
    found = usage(source)
    assert found["Count"].stores == ((0, 4), (4, 8)) and found["Count"].atomic == ()


# -- the tracer on commands of its own ---------------------------------------------------------

STORE = f"""#version 430
layout(local_size_x = 1) in;
layout(std430, binding = {bindings.DEFORMED.index}) writeonly buffer Data {{
    uint head;
    uint tail[];
}};
uniform uint u_value;
void main() {{ tail[0] = u_value; }}
"""
READ = f"""#version 430
layout(local_size_x = 1) in;
layout(std430, binding = {bindings.DEFORMED.index}) readonly buffer Data {{
    uint head;
    uint tail[];
}};
layout(std430, binding = {bindings.MATRICES.index}) writeonly buffer Out {{ uint copied; }};
void main() {{ copied = tail[0]; }}
"""


@pytest.fixture(scope="module")
def own():
    """A context of the module's own, compiling every program under the tracer, that walks
    no primitive in pieces: the commands a GPU driver gets (llvmpipe's pieces come with
    barriers of their own). The workloads are small enough for llvmpipe's loop cap."""
    context = create_headless()
    context.piece_pixels = 0
    yield context
    context.release()


def test_each_kind_of_hazard_and_a_barrier(own):
    with own, tracing() as tracer:
        mgl = own.mgl
        store, read = mgl.compute_shader(STORE), mgl.compute_shader(READ)
        data, out = mgl.buffer(reserve=64), mgl.buffer(reserve=16)
        data.bind_to_storage_buffer(bindings.DEFORMED.index)
        out.bind_to_storage_buffer(bindings.MATRICES.index)
        try:
            store["u_value"] = 5
            store.run()
            data.read(size=4)  # the head, which the store left alone: no hazard
            assert tracer.hazards == []
            read.run()  # reads what the store changed
            data.read(size=4, offset=4)
            assert [(h.kind, h.how) for h in tracer.hazards] == [
                ("read after store", "storage"),
                ("read after store", "buffer_update"),
            ]
            tracer.hazards.clear()
            mgl.memory_barrier()
            read.run()
            data.read()
            assert tracer.hazards == []
            store["u_value"] = 6
            store.run()  # stores where the read may still read
            assert [h.kind for h in tracer.hazards] == ["store after access"]
            tracer.hazards.clear()
            store["u_value"] = 7
            store.run()  # where the read may still read, and the last store still stores
            mgl.memory_barrier()
            assert [h.kind for h in tracer.hazards] == ["store after access"] * 2
            assert np.frombuffer(out.read(), np.uint32)[0] == 5
        finally:
            store.release(), read.release(), data.release(), out.release()


IMAGE_STORE = f"""#version 430
layout(local_size_x = 1) in;
layout(rgba8, binding = {bindings.TEXEL_TARGET.index}) writeonly uniform image2D target;
void main() {{ imageStore(target, ivec2(0), vec4(1.0)); }}
"""


def test_an_image_store_then_a_read_back(own):
    with own, tracing() as tracer:
        mgl = own.mgl
        program, texture = mgl.compute_shader(IMAGE_STORE), mgl.texture((2, 2), 4)
        try:
            texture.bind_to_image(bindings.TEXEL_TARGET.index, read=False, write=True)
            program.run()
            texture.read()
            assert [(h.kind, h.how) for h in tracer.hazards] == [
                ("read after store", "texture_update")
            ]
            tracer.hazards.clear()
            program.run()  # stores where the last still may
            assert [h.kind for h in tracer.hazards] == ["store after access"]
            tracer.hazards.clear()
            mgl.memory_barrier()
            assert texture.read()[:4] == bytes([255] * 4)
            assert tracer.hazards == []
        finally:
            program.release(), texture.release()


# -- workloads ---------------------------------------------------------------------------------


def _handles(rng, shape, count=7, spread=3.0):
    src = rng.uniform(2, np.array(shape[::-1]) - 2, (count, len(shape)))
    return src, src + rng.normal(0, spread, src.shape)


def _checked(tracer) -> None:
    assert tracer.commands > 0
    assert not tracer.hazards, "\n" + tracer.report()


@pytest.mark.parametrize("spread", [2.0, 12.0], ids=["gentle", "folding"])
def test_image_warps(own, spread):
    rng = np.random.default_rng(5)
    image = (rng.random((40, 56, 3)) * 255).astype(np.uint8)
    src, dst = _handles(rng, image.shape[:2], spread=spread)
    with tracing() as tracer, glmls.MLS(src, dst, ctx=own) as m:
        for method in glmls.METHODS:
            m.warp(image, method=method, interpolation="linear", border="edge")
            m.warp(image, method=method, border="constant")
        m.warp(image, tolerance=0.05)  # the adaptive mesh
        m.error_field((20, 28))
        m.inverse(rng.uniform(0, 40, (50, 2)))
    _checked(tracer)


def test_batches(own):
    rng = np.random.default_rng(6)
    images = (rng.random((3, 32, 40, 3)) * 255).astype(np.uint8)
    src, dst = _handles(rng, images.shape[1:3], spread=6.0)
    src, dst = np.stack([src] * 3), np.stack([dst] * 3)
    keypoints = rng.uniform(0, 32, (3, 5, 2))
    masks = (rng.random(images.shape[:3]) > 0.5).astype(np.uint8)
    with tracing() as tracer:
        for method in ("quads", "backward", "splat", "paper-quads"):
            glmls.warp_batch(
                images, src, dst, keypoints=keypoints, masks=masks, method=method,
                interpolation="linear", ctx=own,
            )  # fmt: skip
        glmls.warp_batch(images, src, dst, method="paper-quads", border="reflect", ctx=own)
    _checked(tracer)


def test_points_and_meshes_in_3d(own):
    rng = np.random.default_rng(7)
    src, dst = _handles(rng, (30, 30, 30), count=9, spread=2.0)
    vertices = rng.uniform(0, 30, (300, 3))
    with tracing() as tracer, glmls.MLS(src, dst, ctx=own) as m:
        m.jacobian(vertices)
        m.inverse(vertices)
        m.deform((vertices, rng.integers(0, 300, (500, 3))))
    _checked(tracer)


@pytest.mark.parametrize("method", ["quads", "backward"])
def test_volumes_in_slabs_and_bands(own, method):
    # slabs and bands much smaller than the volume: its lattice buffer is filled again for
    # each band of each slab, after the passes over the band it held before
    rng = np.random.default_rng(8)
    shape = (11, 9, 13)
    src, dst = _handles(rng, shape, spread=1.5)
    volume = (rng.random(shape) * 255).astype(np.uint8)
    slabs = SlabOptions(slab_bytes=3000, band_bytes=40000)
    with tracing() as tracer, glmls.MLS(src, dst, shape=shape, ctx=own) as m:
        m.warp(volume, method=method, interpolation="linear", border="edge", slabs=slabs)
        m.warp(volume, method=method, slabs=slabs)
    _checked(tracer)


@pytest.mark.parametrize(
    "slabs",
    [SlabOptions(slab_bytes=3000, band_bytes=40000), SlabOptions(texture_side=7)],
    ids=["slices", "boxes"],
)
def test_volume_folds_in_slabs(own, slabs):
    # a map that folds the volume: the backward method's fold pass copies the points kept
    # from one slab's window to the next and runs Newton from neighbours' points
    rng = np.random.default_rng(1008)
    shape = (16, 18, 20)
    count = int(rng.integers(6, 12))
    src = rng.uniform(0, 1, (count, 3)) * (np.array(shape[::-1]) - 1)
    dst = src + rng.normal(0, 4.0 / np.sqrt(3), src.shape) * rng.uniform(0.8, 1.6)
    volume = (rng.random(shape) * 255).astype(np.uint8)
    with tracing() as tracer, glmls.MLS(src, dst, shape=shape, ctx=own) as m:
        m.warp(volume, method="backward", slabs=slabs)
        m.coordinate_map(shape, border="edge")
    _checked(tracer)
