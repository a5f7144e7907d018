"""The windows' text draws every character that glmls's own messages use, which the readout
shows (a refused save's "values must lie within float32's range (±3.4e38, ...)" read
"(?3.4e38" in the volume window)."""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np

import glmls
from glmls.app.text import GlyphAtlas

PACKAGE = Path(glmls.__file__).parent


def _message_characters() -> dict[str, str]:
    """Each character past ASCII in glmls's string literals (docstrings aside), and where."""
    found: dict[str, str] = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        if path.name == "text.py" and path.parent.name == "app":
            continue  # the atlas's own list
        tree = ast.parse(path.read_text())
        docstrings = set()
        for node in ast.walk(tree):
            kinds = (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)
            if isinstance(node, kinds) and node.body and isinstance(node.body[0], ast.Expr):
                docstrings.add(id(node.body[0].value))
        for node in ast.walk(tree):
            if isinstance(node, ast.Constant) and isinstance(node.value, str):
                if id(node) not in docstrings:
                    for char in node.value:
                        if ord(char) > 126:
                            found.setdefault(char, f"{path.name}:{node.lineno}")
    return found


def test_every_character_of_glmls_messages_has_a_glyph():
    atlas = GlyphAtlas(14)
    found = _message_characters()
    assert "±" in found  # the scan sees the messages' characters
    missing = {char: where for char, where in found.items() if char not in atlas.advance}
    assert not missing


def test_a_range_is_drawn_with_its_sign_not_a_question_mark():
    atlas = GlyphAtlas(14)
    quads = atlas.quads("±3.4e38", 0.0, 0.0)
    first = quads[:6, 2:4]  # the first glyph's texels: its cell in the atlas
    cell = np.array(atlas.cell, np.float32)
    corner = first.min(axis=0)
    assert tuple(corner) == atlas.origin["±"] and tuple(corner) != atlas.origin["?"]
    assert np.allclose(first.max(axis=0) - corner, cell)
    glyph = _cell(atlas, "±")
    assert glyph.max() == 255 and not np.array_equal(glyph, _cell(atlas, "?"))


def _cell(atlas: GlyphAtlas, char: str) -> np.ndarray:
    x, y = atlas.origin[char]
    return atlas.image[y : y + atlas.cell[1], x : x + atlas.cell[0]]
