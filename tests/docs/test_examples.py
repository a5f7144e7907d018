"""Every Python example in the README and docs/ (the documentation site's pages and guides)
runs as written: the blocks of each file, in order, in a fresh process (a window's under
Xvfb), in an empty folder."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from helpers import child_env

ROOT = Path(__file__).resolve().parent.parent.parent
DOCUMENTS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
_BLOCK = re.compile(r"^```python\n(.*?)^```", re.DOTALL | re.MULTILINE)
#: torch's and torchvision's imports, which a page shows where it uses them; run as one
#: program, they go first, as the top of a program of one's own would hold them
_TORCH_IMPORT = re.compile(r"^(?:import|from) (?:torch|torchvision)\b.*$", re.MULTILINE)


def examples(path: Path) -> list[str]:
    return _BLOCK.findall(path.read_text(encoding="utf-8"))


def test_the_documents_have_examples():
    counts = {path.name: len(examples(path)) for path in DOCUMENTS}
    assert counts["README.md"] >= 2
    for name in (
        "index.md",
        "getting-started.md",
        "warp.md",
        "batch.md",
        "handles.md",
        "segments.md",
        "analysis.md",
        "construction.md",
        "study.md",
        "window.md",
        "adaptive.md",
        "architecture.md",
    ):
        assert counts[name] >= 1, name


@pytest.mark.parametrize("path", [p for p in DOCUMENTS if examples(p)], ids=lambda p: p.name)
def test_examples_run_as_written(path, tmp_path):
    code = "\n\n".join(examples(path))
    hoisted = _TORCH_IMPORT.findall(code)
    code = "\n".join([*hoisted, _TORCH_IMPORT.sub("", code)])
    script = tmp_path / "example.py"
    script.write_text(code, encoding="utf-8")
    command = [sys.executable, str(script)]
    if "glmls.app" in code:  # a window: under a virtual screen
        xvfb = shutil.which("xvfb-run")
        if xvfb is None:
            pytest.skip("xvfb-run is not installed (scripts/setup.sh installs it)")
        command = [xvfb, "-a", *command]
    env = child_env()
    done = subprocess.run(
        command, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600
    )
    assert done.returncode == 0, f"{path.name}:\n{done.stderr[-3000:]}"


@pytest.mark.parametrize("path", DOCUMENTS, ids=lambda p: p.name)
def test_every_code_block_is_closed_by_a_bare_fence(path):
    """A closing fence with text after it ("``` The output ...") closes nothing: the block
    swallows the paragraphs after it, up to the next bare fence."""
    inside = None
    for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        if not line.startswith("```"):
            continue
        if inside is None:
            inside = number
        else:
            assert line.rstrip() == "```", f"{path.name}:{number}: {line!r} closes the block"
            inside = None
    assert inside is None, f"{path.name}: the block of line {inside} is never closed"
