"""Every script in demos/ opens with the header the documentation's gallery needs: a title
line underlined with "=", then a paragraph saying what it shows (the docs build, warnings as
errors, fails on a demo without one)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

DEMOS = sorted((Path(__file__).resolve().parent.parent.parent / "demos").glob("*.py"))


def test_there_are_demos():
    assert len(DEMOS) >= 5


@pytest.mark.parametrize("path", DEMOS, ids=lambda p: p.name)
def test_the_demo_has_a_gallery_header(path):
    docstring = ast.get_docstring(ast.parse(path.read_text(encoding="utf-8")), clean=False)
    assert docstring, f"{path.name}: no docstring"
    lines = docstring.strip("\n").splitlines()
    assert len(lines) >= 4, f"{path.name}: a title, its underline, a blank line, a paragraph"
    title, underline = lines[0], lines[1]
    assert title.strip() and title == title.strip(), f"{path.name}: the first line is the title"
    assert set(underline) == {"="} and len(underline) >= len(title), (
        f"{path.name}: underline the title with '=', at least as long as the title"
    )
    assert not lines[2].strip() and lines[3].strip(), f"{path.name}: a paragraph after the title"
