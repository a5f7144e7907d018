"""The shader loader: #include resolved once per program, cycles refused, defines (floats and
identifiers too), compile errors naming file and line, programs compiled once."""

from __future__ import annotations

import builtins
import errno
import io
import json
import shutil
import subprocess
import sys
from pathlib import Path

import moderngl
import numpy as np
import pytest

from glmls.gl import bindings
from glmls.gl.context import create_headless
from glmls.gl.shaders import ShaderCompileError, ShaderLibrary, define_value, dump, library

COMPUTE_MAIN = """\
layout(local_size_x = 1) in;
#include "lib/out.glsl"
void main() {
    out_values[0] = VALUE;
    out_values[1] = float(COUNT);
}
"""
OUT = """\
layout(std430, binding = BIND_DEFORMED) writeonly buffer Out {
    float out_values[];
};
"""


@pytest.fixture
def shader_dir(tmp_path):
    (tmp_path / "lib").mkdir()
    (tmp_path / "lib" / "out.glsl").write_text(OUT)
    (tmp_path / "main.comp.glsl").write_text(COMPUTE_MAIN)
    return tmp_path


def test_includes_are_resolved_once_with_the_origin_of_every_line(shader_dir):
    (shader_dir / "twice.glsl").write_text('#include "lib/out.glsl"\n#include "lib/out.glsl"\n')
    source = ShaderLibrary(shader_dir).compose("twice.glsl", {"VALUE": 1.5})
    assert source.text.startswith("#version 430 core\n")
    assert source.text.count("buffer Out") == 1
    assert "#define VALUE 1.5" in source.text
    assert f"#define BIND_DEFORMED {bindings.DEFORMED.index}" in source.text  # the table
    lines = source.text.splitlines()
    buffer_line = next(k for k, line in enumerate(lines, 1) if "buffer Out" in line)
    assert source.locate(buffer_line) == ("lib/out.glsl", 1)
    assert source.locate(1) == ("<defines>", 1)


def test_include_cycles_and_missing_files_are_named(shader_dir):
    (shader_dir / "a.glsl").write_text('#include "b.glsl"\n')
    (shader_dir / "b.glsl").write_text('\n#include "a.glsl"\n')
    library_ = ShaderLibrary(shader_dir)
    with pytest.raises(ShaderCompileError, match=r"a\.glsl -> b\.glsl -> a\.glsl"):
        library_.compose("a.glsl")
    (shader_dir / "c.glsl").write_text('// comment\n#include "nope/missing.glsl"\n')
    with pytest.raises(FileNotFoundError, match=r"c\.glsl:2: .*nope/missing\.glsl"):
        library_.compose("c.glsl")


def test_define_values():
    assert define_value(True) == "1" and define_value(False) == "0"
    assert define_value(7) == "7" and define_value(-3) == "(-3)"
    assert define_value(2.0**-24) == "5.960464477539063e-08"
    assert define_value(1.0) == "1.0" and define_value(-0.5) == "(-0.5)"
    assert define_value("mls_weight_idw") == "mls_weight_idw"
    for bad in (float("nan"), float("inf")):
        with pytest.raises(ValueError, match="finite"):
            define_value(bad)
    for bad in ("two words", "1abc", None, [1]):
        with pytest.raises(TypeError, match="define values"):
            define_value(bad)


@pytest.mark.parametrize("value", [2.0**-24, 0.1, -1234.5678, 1e30, 3.0])
def test_float_defines_reach_the_gpu_as_float32(gl, shader_dir, value):
    """A float define is a GLSL float literal: the shader sees float32(value)."""
    own = create_headless(shaders=ShaderLibrary(shader_dir))
    try:
        with own:
            out = own.mgl.buffer(reserve=8)
            program = own.compute("main.comp.glsl", {"VALUE": value, "COUNT": 12})
            out.bind_to_storage_buffer(bindings.DEFORMED.index)
            program.run(group_x=1)
            own.mgl.memory_barrier()
            values = np.frombuffer(out.read(), np.float32)
    finally:
        own.release()
    assert values[0] == np.float32(value)
    assert values[1] == 12.0


def test_compile_errors_name_the_file_and_line(gl, shader_dir):
    (shader_dir / "lib" / "broken.glsl").write_text(
        "// fine\nfloat broken() {\n    return nope;\n}\n"
    )
    (shader_dir / "bad.comp.glsl").write_text(
        'layout(local_size_x = 1) in;\n#include "lib/broken.glsl"\nvoid main() {}\n'
    )
    own = create_headless(shaders=ShaderLibrary(shader_dir))
    try:
        with own:
            # Mesa: "file:3(12): error", NVIDIA: "file(3) : error"
            broken = r"lib/broken\.glsl(:3\(\d+\)|\(3\)) ?: error"
            with pytest.raises(ShaderCompileError, match=broken):
                own.compute("bad.comp.glsl")
            (shader_dir / "ok.vert.glsl").write_text("void main() { gl_Position = vec4(0.0); }\n")
            (shader_dir / "bad.frag.glsl").write_text(
                "out vec4 c;\n\nvoid main() { c = missing; }\n"
            )
            with pytest.raises(
                ShaderCompileError, match=r"fragment_shader[\s\S]*bad\.frag\.glsl(:3|\(3\))"
            ):
                own.program("ok.vert.glsl", "bad.frag.glsl")
            assert own.mgl.error == "GL_NO_ERROR"
    finally:
        own.release()


def test_driver_locations_of_other_vendors_are_mapped(shader_dir):
    source = ShaderLibrary(shader_dir).compose("main.comp.glsl")
    line = next(k for k, text in enumerate(source.text.splitlines(), 1) if "out_values[1]" in text)
    assert source.explain(f"0({line}) : error C1008: x") == "main.comp.glsl(5) : error C1008: x"
    assert source.explain(f"ERROR: 0:{line}: x") == "ERROR: main.comp.glsl:5: x"
    assert source.explain(f"0:{line}(7): error: x") == "main.comp.glsl:5(7): error: x"


def test_every_packaged_shader_compiles(gl):
    with gl:
        compile_every_entry(gl)


@pytest.mark.skipif(shutil.which("glslangValidator") is None, reason="no glslangValidator")
def test_every_packaged_shader_passes_the_reference_compiler(tmp_path, monkeypatch):
    """Khronos's glslangValidator (apt: glslang-tools), stricter than Mesa, accepts them
    (tools/check_shaders.py; the GL tests compile many more variants than these)."""
    monkeypatch.setenv("GLMLS_DUMP_SHADERS", str(tmp_path))
    own = create_headless()
    try:
        with own:
            compile_every_entry(own)
    finally:
        own.release()
    tool = Path(__file__).resolve().parents[2] / "tools" / "check_shaders.py"
    done = subprocess.run(
        [sys.executable, str(tool), str(tmp_path)], capture_output=True, text=True
    )
    assert done.returncode == 0, done.stdout + done.stderr


def compile_every_entry(gl):
    """The entry files (stages) of glmls/shaders compile with their defines' usual values."""
    mls = {
        "MLS_WEIGHT_FUNCTION": "mls_weight_gaussian",
        "MLS_WEIGHT_USES_S": 0,
        "MLS_REACH_GAUSSIAN": 1,
        "MLS_GAUSSIAN_TOLERANCE": 2.0**-24,
        "MLS_TRANSFORM": 0,
        "MLS_INTERPOLATING": 1,
        "MLS_ALPHA_ONE": 0,
        "MLS_UNROLL": 0,
        "MLS_BINS": 1,
        "MLS_STORAGE": 0,
        "MLS_SEGMENTS": 0,
        "MLS_SEGMENT_CLOSED": 0,
        "MLS_SEGMENT_SUPPORT": 2,
    }
    gl.compute("mls/points.comp.glsl", mls | {"MLS_LATTICE": 1, "MLS_WRITE_MATRIX": 1})
    # segment handles (mls/segments.glsl): binned, closed form and each support's quadrature
    for closed, support in ((1, 0), (0, 0), (0, 1), (0, 2)):
        segments = {"MLS_SEGMENTS": 1, "MLS_SEGMENT_CLOSED": closed, "MLS_SEGMENT_SUPPORT": support}
        points = {"MLS_LATTICE": 0, "MLS_WRITE_MATRIX": 1}
        gl.compute("mls/points.comp.glsl", mls | segments | points)
    gl.compute("mls/error_field.comp.glsl", mls | {"MLS_SEGMENTS": 1, "MLS_ERROR_INTERPOLATE": 0})
    gl.compute("mls/error_field.comp.glsl", mls | {"MLS_ERROR_INTERPOLATE": 0})
    inverse = {"WARP_SWAP": 0, "WARP_NEWTON_STEPS": 8, "WARP_BORDER": 0}
    gl.compute("warp/inverse.comp.glsl", mls | inverse)
    for storage in (1, 2):
        extra = {"MLS_STORAGE": storage, "MLS_UBO_CAPACITY": 1024, "MLS_BINS": 0, "MLS_UNROLL": 16}
        gl.compute("mls/points.comp.glsl", mls | extra | {"MLS_LATTICE": 0, "MLS_WRITE_MATRIX": 0})
    warp = {"WARP_LINEAR": 1, "WARP_OUTPUT_COORDS": 0}
    gl.program("warp/mesh.vert.glsl", "warp/mesh.frag.glsl", warp | {"WARP_SPLAT": 0})
    gl.program("warp/mesh.vert.glsl", "warp/mesh.frag.glsl", warp | {"WARP_SPLAT": 1})
    for stage in range(2):  # paper-quads: the marks, the source points (linear)
        paper = {"WARP_PAPER_STAGE": stage, "PAPER_TOLERANCE": 1.0 / 256}
        gl.compute("warp/paper_quads.comp.glsl", paper)
    gl.program("common/fullscreen.vert.glsl", "warp/cells.frag.glsl", warp)
    gl.program("common/fullscreen.vert.glsl", "draw/picture.frag.glsl")
    for border in range(5):  # glmls.imaging.source.BORDERS
        linear = {"WARP_LINEAR": 1, "WARP_BORDER": border}
        gl.program("common/fullscreen.vert.glsl", "warp/backward.frag.glsl", linear)
        nearest = {"WARP_LINEAR": 0, "WARP_BORDER": border}
        gl.program("common/fullscreen.vert.glsl", "warp/cells_nearest.frag.glsl", nearest)
        gl.program("common/fullscreen.vert.glsl", "warp/paper_quads.frag.glsl", nearest)
        cells = {"WARP_CELLS_SOURCE": 1, "WARP_CELLS_FUSED": 1, "WARP_BORDER": border}
        gl.compute("warp/cells.comp.glsl", cells | {"WARP_CELLS_FAST": 1})
        gl.compute("warp/cells_fixup.comp.glsl", {"WARP_BORDER": border})
    for stage in range(3):
        gl.compute("warp/cells_check.comp.glsl", {"WARP_CHECK_STAGE": stage})
    gl.compute("adaptive/scan.comp.glsl")  # the adaptive mesh (tolerance=)
    # a 3D mesh's normal scales, its folds (with the normal sums or without), its normals
    gl.compute("mls3/mesh_scales.comp.glsl")
    for sums in (0, 1):
        gl.compute("mls3/mesh_folds.comp.glsl", {"MESH3_NORMAL_SUMS": sums})
    gl.compute("mls3/mesh_normals.comp.glsl")
    for border in range(5):
        for linear, coords in ((0, 0), (1, 0), (0, 1)):
            fill = {"WARP_LINEAR": linear, "WARP_OUTPUT_COORDS": coords, "WARP_BORDER": border}
            gl.program("common/fullscreen.vert.glsl", "adaptive/fill.frag.glsl", fill)


def test_an_undefined_macro_in_a_condition_names_its_line(tmp_path):
    """GLSL has no default of 0 for an undefined macro in #if (NVIDIA refuses it; Mesa
    does not): the loader refuses it on every driver. Skipped groups are not evaluated."""
    (tmp_path / "lib").mkdir()
    (tmp_path / "lib" / "part.glsl").write_text(
        "#ifndef HAS_DEFAULT\n#define HAS_DEFAULT 3\n#endif\n"
        "#if HAS_DEFAULT == 3 && defined(GIVEN)\nint a;\n#elif MISSING\nint b;\n#endif\n"
    )
    (tmp_path / "main.comp.glsl").write_text(
        '#if GIVEN\n#include "lib/part.glsl"\n#else\n#if NOT_EVALUATED\n#endif\n#endif\n'
    )
    lib = ShaderLibrary(tmp_path, common={})
    lib.compose("main.comp.glsl", {"GIVEN": 1})  # HAS_DEFAULT by #ifndef; #elif not reached
    with pytest.raises(ShaderCompileError, match=r"main.comp.glsl:1: #if uses GIVEN"):
        lib.compose("main.comp.glsl")
    (tmp_path / "lib" / "part.glsl").write_text("#if 0\n#elif MISSING\n#endif\n")
    with pytest.raises(ShaderCompileError, match=r"lib/part.glsl:2: #if uses MISSING"):
        ShaderLibrary(tmp_path, common={}).compose("main.comp.glsl", {"GIVEN": 1})


def test_programs_are_compiled_once(gl):
    defines = {"MLS_ERROR_INTERPOLATE": True}
    entry = "mls/error_field.comp.glsl"
    with gl:
        assert gl.compute(entry, defines) is gl.compute(entry, dict(defines))
        assert isinstance(gl.compute(entry, defines), moderngl.ComputeShader)
    assert library() is library()


def test_compiled_sources_are_dumped_where_the_environment_says(gl, shader_dir, monkeypatch):
    """GLMLS_DUMP_SHADERS=folder: each stage compiled is written there once, with its line
    origins and its program's stages (for tools/check_shaders.py)."""
    folder = shader_dir / "dumped"
    monkeypatch.setenv("GLMLS_DUMP_SHADERS", str(folder))
    (shader_dir / "ok.vert.glsl").write_text("void main() { gl_Position = vec4(0.0); }\n")
    (shader_dir / "ok.frag.glsl").write_text("out vec4 c;\nvoid main() { c = vec4(1.0); }\n")
    own = create_headless(shaders=ShaderLibrary(shader_dir))
    try:
        with own:
            own.compute("main.comp.glsl", {"VALUE": 1.0, "COUNT": 1})
            own.compute("main.comp.glsl", {"VALUE": 2.0, "COUNT": 1})
            own.program("ok.vert.glsl", "ok.frag.glsl")
    finally:
        own.release()
    names = sorted(p.name for p in folder.iterdir() if p.suffix != ".json")
    assert [name.split(".")[0] + "." + name.split(".")[-1] for name in names] == [
        "main.comp",
        "main.comp",
        "ok.frag",
        "ok.vert",
    ]
    about = about_of(folder, names[2])
    assert about["entry"] == "ok.frag.glsl"
    assert about["program"] == [names[3], names[2]]
    text = (folder / names[0]).read_text().splitlines()
    for line, (file, number) in zip(text, about_of(folder, names[0])["origins"], strict=True):
        if file != "<defines>":
            assert line == (shader_dir / file).read_text().splitlines()[number - 1]


def test_a_dump_stopped_midway_leaves_no_partial_source(shader_dir, monkeypatch):
    """A source whose write failed (a full disk, a process stopped) is not left half written
    under its name, where every later dump would keep it."""
    stages = {"compute_shader": ShaderLibrary(shader_dir).compose("main.comp.glsl", {"COUNT": 1})}
    folder = shader_dir / "dumped"
    real_open = io.open

    class HalfWritten:
        def __init__(self, file):
            self.file = file

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            self.file.close()

        def write(self, text):
            self.file.write(text[: len(text) // 2])
            raise OSError(errno.ENOSPC, "No space left on device")

    def full_disk(file, mode="r", *args, **kwargs):
        opened = real_open(file, mode, *args, **kwargs)
        if "w" in mode and not str(file).endswith(".json"):
            return HalfWritten(opened)
        return opened

    monkeypatch.setattr(builtins, "open", full_disk)
    monkeypatch.setattr(io, "open", full_disk)
    with pytest.raises(OSError):
        dump(stages, str(folder))
    monkeypatch.undo()
    dump(stages, str(folder))  # the next run writes it whole
    sources = [p for p in folder.iterdir() if p.suffix == ".comp"]
    assert [p.read_text() for p in sources] == [stages["compute_shader"].text]
    assert all(about_of(folder, p.name)["entry"] == "main.comp.glsl" for p in sources)


def about_of(folder, name):
    return json.loads((folder / (name + ".json")).read_text())
