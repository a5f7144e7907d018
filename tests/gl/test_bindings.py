"""The one table of binding points: distinct per kind, defined in every program, and the only
place binding numbers are written (GLSL and tests use its names)."""

from __future__ import annotations

import re
from importlib import resources
from pathlib import Path

import numpy as np
from numpy.testing import assert_array_equal

from glmls.gl import bindings
from glmls.gl.shaders import library

SHADERS = Path(str(resources.files("glmls").joinpath("shaders")))
TESTS = Path(__file__).resolve().parent.parent


def glsl_files() -> dict[str, str]:
    return {str(p.relative_to(SHADERS)): p.read_text() for p in sorted(SHADERS.rglob("*.glsl"))}


def test_indices_are_distinct_within_each_kind():
    for kind in bindings.KINDS:
        indices = [b.index for b in bindings.ALL if b.kind == kind]
        assert len(indices) == len(set(indices)), kind
    assert len({b.name for b in bindings.ALL}) == len(bindings.ALL)
    assert all(b.index >= 0 for b in bindings.ALL)


def test_shaders_bind_only_through_the_table():
    defines = bindings.defines()
    used = set()
    for name, text in glsl_files().items():
        for value in re.findall(r"binding\s*=\s*([A-Za-z0-9_]+)", text):
            assert not value.isdigit(), f"{name}: binding literal {value}"
            assert value in defines, f"{name}: {value} is not in glmls.gl.bindings"
            used.add(value)
    assert used == set(defines), f"unused bindings: {set(defines) - used}"


def test_every_program_gets_the_table():
    source = library().compose("draw/color.frag.glsl").text
    for binding in bindings.ALL:
        assert f"#define {binding.define} {binding.index}\n" in source


def test_no_binding_number_in_the_tests():
    """Tests bind through the table too (bindings.X.index), never a number."""
    pattern = re.compile(r"bind_to_(storage_buffer|uniform_block|image)\(\s*\d|\.use\(\s*\d")
    for path in TESTS.rglob("*.py"):
        for number, line in enumerate(path.read_text().splitlines(), 1):
            assert not pattern.search(line), f"{path.name}:{number}: {line.strip()}"


def test_the_driver_offers_enough_binding_points(gl):
    for limit, needed in bindings.needed().items():
        offered = gl.mgl.info.get(limit)
        assert offered is None or int(offered) >= needed, limit


def test_rgba8_texels_move_whole_through_r32ui_images(gl, rng):
    """bind_texels: an RGBA8 texture read and written as r32ui images keeps every byte (the
    fused quads and the adaptive colour pass copy texels this way)."""
    texels = rng.integers(0, 256, (5, 7, 4), dtype=np.uint8)
    source_image, target_image = bindings.TEXEL_SOURCE, bindings.TEXEL_TARGET
    code = f"""#version 430
    layout(local_size_x = 1) in;
    layout(r32ui, binding = {source_image.index}) readonly uniform uimage2D source;
    layout(r32ui, binding = {target_image.index}) writeonly uniform uimage2D target;
    void main() {{
        ivec2 p = ivec2(gl_GlobalInvocationID.xy);
        imageStore(target, p, imageLoad(source, p));
    }}
    """
    with gl:
        mgl = gl.mgl
        source = mgl.texture((7, 5), 4, texels.tobytes(), dtype="f1")
        target = mgl.texture((7, 5), 4, dtype="f1")
        program = mgl.compute_shader(code)
        others = [mgl.texture((7, 5), 4, dtype="f4"), mgl.texture((7, 5), 3, dtype="f1")]
        try:
            assert bindings.holds_texels(source) and bindings.holds_texels(target)
            assert not any(bindings.holds_texels(t) for t in [*others, None, "texture"])
            bindings.bind_texels(source, source_image, write=False)
            bindings.bind_texels(target, target_image, write=True)
            program.run(7, 5)
            mgl.memory_barrier()
            copied = np.frombuffer(target.read(), np.uint8).reshape(5, 7, 4)
        finally:
            for obj in (source, target, program, *others):
                obj.release()
    assert_array_equal(copied, texels)
