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


@pytest.mark.parametrize("path", DEMOS, ids=lambda p: p.name)
def test_the_command_line_in_a_header_is_a_literal_block(path):
    """An indented command after a plain paragraph is a block quote, in which Sphinx makes
    "--out" an en dash ("–out"): a reader who copies it gets an unknown option."""
    docstring = ast.get_docstring(ast.parse(path.read_text(encoding="utf-8")), clean=False)
    lines = docstring.splitlines()
    for number, line in enumerate(lines):
        if line.startswith("    python demos/") and not lines[number - 1].startswith("    "):
            before = [text for text in lines[:number] if text.strip()][-1]
            assert before.endswith("::"), f"{path.name}: '{line.strip()}' after '{before}'"
