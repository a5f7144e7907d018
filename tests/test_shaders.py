from __future__ import annotations

import pytest

from glmls import shaders


def test_shader_files_are_found_and_composed_with_defines():
    source = shaders.compose(["handles_ssbo.glsl", "mls_core.glsl"], {"MLS_WEIGHT": 3, "X": True})
    assert source.startswith("#version 430 core\n")
    assert "#define MLS_WEIGHT 3" in source and "#define X 1" in source
    assert "#line 1 1" in source and "MLSResult mls_eval(vec2 v)" in source


def test_unknown_shader_and_bad_define():
    with pytest.raises(FileNotFoundError, match=r"nope\.glsl"):
        shaders.load_source("nope.glsl")
    with pytest.raises(TypeError, match="define"):
        shaders.compose([], {"A": 1.5})


def test_programs_are_compiled_once(gl):
    parts = ("handles_ssbo.glsl", "mls_core.glsl", "mls_points.comp.glsl")
    defines = {
        "MLS_WEIGHT": 0,
        "MLS_TRANSFORM": 2,
        "MLS_INTERPOLATING": 0,
        "MLS_ALPHA_ONE": 1,
        "MLS_MESH": 0,
        "MLS_WRITE_MATRIX": 0,
    }
    assert gl.compute(parts, defines) is gl.compute(parts, dict(defines))
