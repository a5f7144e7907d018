"""tools/check_shaders.py's own checks (``python -m pytest tools``): glslang's errors, a
stage's and a program's link, reported at the shader file and line they came from."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

TOOL = Path(__file__).resolve().parent / "check_shaders.py"
VERTEX = "#version 430 core\nout vec2 v_x;\nvoid main() {\n    v_x = vec2(0.0);\n}\n"
FRAGMENT = (
    "#version 430 core\nin vec3 v_x;\nout vec4 c;\nvoid main() {\n    c = vec4(v_x, 1.0);\n}\n"
)
COMPUTE = "#version 430 core\nlayout(local_size_x = 1) in;\nvoid main() {\n    uint q = 1.5;\n}\n"

pytestmark = pytest.mark.skipif(shutil.which("glslangValidator") is None, reason="no glslang")


def dumped(folder: Path, name: str, text: str, entry: str, program: list[str]) -> None:
    """A stage as GLMLS_DUMP_SHADERS writes it: line 1 from the defines, the rest from
    ``entry`` (a real shader file, so that the tool counts it as glmls's)."""
    (folder / name).write_text(text)
    origins = [["<defines>", 1]] + [[entry, k] for k in range(1, text.count("\n"))]
    about = {"entry": entry, "origins": origins, "program": program}
    (folder / (name + ".json")).write_text(json.dumps(about))


def check(folder: Path) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, str(TOOL), str(folder)], capture_output=True, text=True, timeout=120
    )


def test_errors_are_reported_at_their_shader_file_and_line(tmp_path):
    dumped(tmp_path, "x.000000000000.comp", COMPUTE, "volume/survey.comp.glsl", [])
    done = check(tmp_path)
    assert done.returncode == 1
    # line 4 of the source is line 3 of the file (the first line being a define)
    assert "volume/survey.comp.glsl:3: ERROR: '=' :  cannot convert" in done.stdout
    assert "check_shaders: 1 problems" in done.stdout


def test_the_stages_of_a_program_are_linked(tmp_path):
    program = ["v.000000000000.vert", "f.000000000000.frag"]
    dumped(tmp_path, program[0], VERTEX, "common/fullscreen.vert.glsl", program)
    dumped(tmp_path, program[1], FRAGMENT, "draw/picture.frag.glsl", program)
    done = check(tmp_path)
    assert done.returncode == 1
    assert "Types must match" in done.stdout
    assert "not in any dumped program" in done.stdout  # the other shader files


def test_a_clean_folder_passes_and_an_empty_one_does_not(tmp_path):
    dumped(
        tmp_path, "x.000000000000.comp", COMPUTE.replace("1.5", "1u"), "common/fill.comp.glsl", []
    )
    assert check(tmp_path).returncode == 0
    (tmp_path / "x.000000000000.comp").unlink()
    assert "no glmls shader sources" in check(tmp_path).stdout
