"""Docstrings and ``#:`` attribute comments name a guide page with a Sphinx cross-reference
(:doc:`/volumes`, :doc:`the 3D guide </three_d>`), which the docs build resolves and links,
not as a path (``docs/volumes.md``) or a plain "the ... guide"."""

from __future__ import annotations

import ast
import re
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[2] / "glmls"
DOCS = PACKAGE.parent / "docs"

#: A role naming a document, e.g. :doc:`/volumes` or :doc:`the guide </volumes>`.
ROLE = re.compile(r":doc:`(?:[^`<]*<)?(/[\w/-]+)>?`")
#: A guide named as text: a path to a page, or "the ... guide" outside a role.
PLAIN = re.compile(r"\bdocs/[\w/-]+(?:\.md)?|\b(?!README)\w+\.md\b|\bguide\b")


def documentation(path: Path) -> list[tuple[int, str]]:
    """(line, text) of the module's docstrings and its ``#:`` comment blocks."""
    source = path.read_text()
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            doc = ast.get_docstring(node, clean=False)
            if doc:
                line = node.body[0].lineno if node.body else 1
                found.append((line, doc))
    for number, line in enumerate(source.splitlines(), start=1):
        if line.lstrip().startswith("#:"):
            found.append((number, line.lstrip()[2:]))
    return found


def test_guides_are_cross_references():
    plain = []
    for path in sorted(PACKAGE.rglob("*.py")):
        for line, text in documentation(path):
            bare = ROLE.sub("", " ".join(text.split()))
            plain += [
                f"{path.relative_to(PACKAGE.parent)}:{line}: {m}" for m in PLAIN.findall(bare)
            ]
    assert plain == [], "\n".join(plain)


def test_every_cross_reference_names_a_page():
    missing = []
    for path in sorted(PACKAGE.rglob("*.py")):
        for line, text in documentation(path):
            for target in ROLE.findall(" ".join(text.split())):
                if not (DOCS / f"{target.lstrip('/')}.md").is_file():
                    missing.append(f"{path.relative_to(PACKAGE.parent)}:{line}: {target}")
    assert missing == [], "\n".join(missing)
