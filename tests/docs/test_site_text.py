"""What a reader of the documentation site sees in the guides' text: links that name what they
lead to, no repository paths or README passages that the site does not have, the front page's
two commands, and docstrings whose inline literals render."""

from __future__ import annotations

import ast
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"
GUIDES = sorted(DOCS.glob("*.md"))
_FENCE = re.compile(r"^```.*?^```", re.DOTALL | re.MULTILINE)


def prose(path: Path) -> str:
    """The page's text outside its fenced code blocks."""
    return _FENCE.sub("", path.read_text(encoding="utf-8"))


def matches(pattern: str) -> list[str]:
    """Each match of ``pattern`` in the guides' prose, as "page: match"."""
    return [
        f"{path.name}: {m.group(0)}" for path in GUIDES for m in re.finditer(pattern, prose(path))
    ]


def test_links_between_guides_name_the_page_not_its_file():
    # `[warp.md](warp.md)` shows the reader a file name where the other links say what the
    # page is about
    found = matches(r"\[[\w-]+\.md(#[\w-]+)?\]\([^)]*\)")
    assert found == [], "\n".join(found)


def test_guides_link_to_guides_instead_of_naming_their_paths():
    # `docs/performance.md` as text is a path in the repository, not a page of the site
    found = matches(r"(?<![(/\w])docs/[\w-]+\.md")
    assert found == [], "\n".join(found)


def test_guides_do_not_send_the_reader_to_passages_of_the_readme():
    # the site does not include the README: "the README says how ..." leads nowhere there
    found = matches(r"the README says|README's table|caveat of the README")
    assert found == [], "\n".join(found)


def test_the_front_page_gives_the_two_commands_before_its_first_picture():
    text = (DOCS / "index.md").read_text(encoding="utf-8")
    picture = text.index("![")
    for command in (
        "bash scripts/setup.sh && .venv/bin/glmls analyze --example --out out/example",
        "bash scripts/setup.sh && .venv/bin/python -m pytest",
    ):
        assert 0 <= text.find(command) < picture, command


def _docstrings(path: Path) -> list[tuple[int, str]]:
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            doc = ast.get_docstring(node, clean=False)
            if doc:
                found.append((node.body[0].lineno, doc))
    return found


#: What reST lets an inline literal's ``start`` follow: a space, the line's start or an
#: opening punctuation mark; after anything else (``a``..``b``) the backquotes show as text.
_OPENERS = " \n\t([{<'\"/:-\u2018\u201c"


def test_inline_literals_in_docstrings_start_where_rest_reads_them():
    bad = []
    for path in sorted((ROOT / "glmls").rglob("*.py")):
        for line, doc in _docstrings(path):
            # the even pieces lie outside literals, so each odd piece's start is a literal's
            pieces = doc.split("``")
            position = 0
            for index, piece in enumerate(pieces[:-1]):
                position += len(piece)
                if index % 2 == 0 and position > 0 and doc[position - 1] not in _OPENERS:
                    start = max(0, position - 20)
                    bad.append(f"{path.relative_to(ROOT)}:{line}: {doc[start : position + 20]!r}")
                position += 2
    assert bad == [], "\n".join(bad)
