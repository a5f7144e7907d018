"""The product speaks of the product: the README, the CHANGELOG, the documentation and the code's
comments and docstrings say what glmls does and how to measure it, never how it was developed
(no work sessions, issue numbers, commits used as baselines, dates of work or borrowed
hardware). Numbers name a machine and a command instead."""

from __future__ import annotations

import io
import re
import tokenize
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent.parent
HERE = Path(__file__).resolve()

_ORDINALS = (
    r"first|second|third|fourth|fifth|sixth|seventh|eighth|ninth|tenth|eleventh|twelfth"
    r"|thirteenth|fourteenth|fifteenth|sixteenth|seventeenth|eighteenth|nineteenth"
    r"|twentieth|thirtieth|(?:twenty|thirty)-\w+|\d+(?:st|nd|rd|th)"
)

# The strictest patterns: they hold in code comments and docstrings too.
STRICT = {
    # a numbered work session: "the twenty-fifth session", "the 3rd session"
    "ordinal session": rf"\b(?:{_ORDINALS})\s+sessions?\b",
    # a session of work named from inside it: "this session", "the last session"
    # (the window's editing session is "a session", "the session" or "Session")
    "this session": r"\b(?:this|that|last|next|previous|earlier|later)\s+session\b",
    # a sitting of work: "in one sitting", "two sittings"
    "sitting": r"\bsittings?\b",
    # a tracker's issue used as a reference: "issue 18", "issue #7", "issues 13-18"
    "issue number": r"\bissues?\s*#?\d+",
    # the developer's checkout: "this tree" (as against a baseline commit)
    "this tree": r"\bthis tree\b",
    # history as a baseline: "against the commit before"
    "the commit before": r"\bthe commit before\b",
}

# Documents (README, CHANGELOG, docs/) hold to these as well.
DOCUMENT_ONLY = {
    # rounds of development: "the third round of work"
    "round of work": r"\brounds? of work\b",
    # hardware lent for a while: "an H100 lent to this project", "a borrowed GPU"
    "lent or borrowed": r"\blent\s+(?:to|for|us|once)\b|\bborrowed\b",
    # a commit hash as a baseline: 7-40 hex digits with at least one digit and one letter
    # (URLs are removed first; a "#" before it makes it a colour, "0x" a number)
    "commit hash": r"(?<![\w#/.-])(?=[0-9a-f]*\d)(?=[0-9a-f]*[a-f])[0-9a-f]{7,40}(?![\w/-])",
    # a date of work: "2026-11-28" (the CHANGELOG's release headings are removed first)
    "date": r"\b20\d\d-[01]\d-[0-3]\d\b",
}

_STRICT = {name: re.compile(pattern, re.IGNORECASE) for name, pattern in STRICT.items()}
_DOCUMENT = _STRICT | {
    name: re.compile(pattern, re.IGNORECASE) for name, pattern in DOCUMENT_ONLY.items()
}
_URL = re.compile(r"<?https?://\S+")
_RELEASE_HEADING = re.compile(r"^## \[[^\]\n]+\] - \d{4}-\d\d-\d\d$", re.MULTILINE)

#: What the documentation build generates inside docs/ (git-ignored): copies of what is
#: checked at its source, the demos and the docstrings.
GENERATED = (("gallery",), ("api", "generated"), ("_build",))

DOCUMENTS = sorted(
    [ROOT / "README.md", ROOT / "CHANGELOG.md"]
    + [
        path
        for suffix in ("md", "rst", "py")
        for path in (ROOT / "docs").rglob(f"*.{suffix}")
        if not any(path.relative_to(ROOT / "docs").parts[: len(g)] == g for g in GENERATED)
    ]
)

# The folders whose Python comments and docstrings are held to the strict patterns.
CODE_FOLDERS = ["glmls", "demos", "tests", "benchmarks", "tools", "scripts"]


def hits(text: str, patterns: dict[str, re.Pattern[str]]) -> list[str]:
    """'name: matched words (line N)' for every match of ``patterns`` in ``text``."""
    found = []
    for name, pattern in patterns.items():
        for match in pattern.finditer(text):
            line = text.count("\n", 0, match.start()) + 1
            found.append(f"{name}: {match.group(0)!r} (line {line})")
    return found


def document_text(path: Path) -> str:
    text = path.read_text(encoding="utf-8")
    if path.name == "CHANGELOG.md":
        text = _RELEASE_HEADING.sub("", text)
    return _URL.sub("", text)


def comments_and_docstrings(source: str) -> str:
    """The comments and docstrings of Python ``source``, each at its own line number (the rest
    of the text blanked), so that a hit's line is the file's."""
    lines = [""] * (source.count("\n") + 2)
    previous = tokenize.NEWLINE
    for token in tokenize.generate_tokens(io.StringIO(source).readline):
        kind = token.type
        is_docstring = kind == tokenize.STRING and previous in (
            tokenize.NEWLINE,
            tokenize.NL,
            tokenize.INDENT,
            tokenize.DEDENT,
        )
        if kind == tokenize.COMMENT or is_docstring:
            for offset, text in enumerate(token.string.split("\n")):
                lines[token.start[0] - 1 + offset] += " " + text
        if kind not in (tokenize.COMMENT, tokenize.NL):
            previous = kind
        elif kind == tokenize.NL and previous in (tokenize.NEWLINE, tokenize.NL):
            previous = tokenize.NL
    return "\n".join(lines)


def code_files(folders: list[str]) -> list[Path]:
    return sorted(path for folder in folders for path in (ROOT / folder).rglob("*.py"))


@pytest.mark.parametrize("path", DOCUMENTS, ids=lambda p: p.relative_to(ROOT).as_posix())
def test_documents_speak_of_the_product(path):
    found = hits(document_text(path), _DOCUMENT)
    assert not found, f"{path.relative_to(ROOT)}: development diary wording:\n" + "\n".join(found)


@pytest.mark.parametrize(
    "path",
    [p for p in code_files(CODE_FOLDERS) if p != HERE],
    ids=lambda p: str(p.relative_to(ROOT)),
)
def test_code_comments_speak_of_the_product(path):
    source = path.read_text(encoding="utf-8")
    found = hits(comments_and_docstrings(source), _STRICT)
    assert not found, f"{path.relative_to(ROOT)}: development diary wording:\n" + "\n".join(found)


@pytest.mark.parametrize(
    ("text", "caught"),
    [
        ("measured in the twenty-fifth session", True),
        ("as this session found", True),
        ("in one sitting", True),
        ("after two rounds of work", True),
        ("filed as issue #18", True),
        ("see issue 7", True),
        ("faster than this tree", True),
        ("against the commit before", True),
        ("an H100 lent to this project", True),
        ("a borrowed GPU", True),
        ("against bb0b9ce's grid 1", True),
        ("measured on 2026-11-21", True),
        ("the window saves a session as a replay file", False),
        ("the editing session (glmls.app.session.Session) records events", False),
        ("3 rounds x 15 calls each", False),
        ("the colour #1f77b4 and 0x7fffffff", False),
        ("float32 arrays of 1048576 values; deadbeef", False),
        ("a tissue 12 px wide", False),
    ],
)
def test_the_patterns(text, caught):
    assert bool(hits(text, _DOCUMENT)) == caught, hits(text, _DOCUMENT)


def test_the_changelog_keeps_its_release_dates():
    text = "## [0.2.0] - 2026-11-28\n\n- measured on 2026-11-21\n"
    path_text = _RELEASE_HEADING.sub("", text)
    assert hits(path_text, _DOCUMENT) == ["date: '2026-11-21' (line 3)"]


def test_comments_and_docstrings_are_what_is_scanned():
    source = (
        '"""Module docstring: the fifth session."""\n'
        "x = 'issue 18 in a string is data'\n"
        "# this tree, in a comment\n"
        "def f():\n"
        '    """in one sitting"""\n'
        "    return 'sitting'\n"
    )
    found = hits(comments_and_docstrings(source), _STRICT)
    assert found == [
        "ordinal session: 'fifth session' (line 1)",
        "sitting: 'sitting' (line 5)",
        "this tree: 'this tree' (line 3)",
    ]
