"""The one table of binding points: distinct per kind, defined in every program, and the only
place binding numbers are written (GLSL and tests use its names)."""

from __future__ import annotations

import re
from importlib import resources
from pathlib import Path

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
