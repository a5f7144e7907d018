"""Reading text input files (handles, points): every fault an
:class:`~glmls.errors.InputFileError` that names the file, the place in it (a JSON path such as
``"segments"."src"[3]`` or a CSV line) and the fault."""

from __future__ import annotations

import csv
import io
import json
import math
import os
import re
import stat
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..errors import InputFileError

__all__ = [
    "as_path",
    "brief",
    "by_name",
    "csv_rows",
    "fail",
    "field_number",
    "first_not_number",
    "is_number",
    "json_list",
    "json_pair",
    "json_points",
    "load_json",
    "not_a_file",
    "number",
    "read_head",
    "read_text",
    "table",
]

#: (line number, stripped fields) of one non-blank CSV row.
Row = tuple[int, list[str]]


def fail(path: Path, where: str, what: str) -> InputFileError:
    """The error for ``what`` went wrong at ``where`` in ``path``."""
    return InputFileError(f"{path}: {where}: {what}")


def brief(value: object, limit: int = 60) -> str:
    """``repr(value)``, cut to about ``limit`` characters (a hostile file may hold megabytes)."""
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def number(path: Path, where: str, value: object) -> float:
    """A finite float from a JSON number; a string (``"12.5"``) or a boolean (``true``, which
    Python takes for 1) is refused, as a number in quotes is text to every other JSON reader."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise fail(path, where, f"expected a number, got {brief(value)}")
    return _finite(path, where, value)


#: A number in a text field: ASCII digits with an optional sign, point and exponent, or
#: nan/inf (refused as not finite); not the rest of what Python's float() takes, digit
#: separators ("1_000", which it reads as 1000) and other scripts' digits, that a CSV
#: writer does not mean as numbers.
_DECIMAL = re.compile(
    r"[+-]?(?:\d+\.?\d*|\.\d+)(?:e[+-]?\d+)?|[+-]?(?:nan|inf|infinity)", re.IGNORECASE | re.ASCII
)


#: A whole number in a text field (an OBJ index, a PLY integer property): ASCII digits with an
#: optional sign; not a point or an exponent, nor what else Python's int() takes ("1_0",
#: " 7 ", other scripts' digits).
_INTEGER = re.compile(r"[+-]?\d+", re.ASCII)

#: The patterns by (bytes, integer): for text, and for bytes (a PLY body) from the same source.
_PATTERNS = {
    (False, False): _DECIMAL,
    (False, True): _INTEGER,
    (True, False): re.compile(_DECIMAL.pattern.encode("ascii"), _DECIMAL.flags),
    (True, True): re.compile(_INTEGER.pattern.encode("ascii"), _INTEGER.flags),
}


def is_number(word: str | bytes, *, integer: bool = False) -> bool:
    """Whether ``word`` is a decimal number as :data:`_DECIMAL` reads it (``nan`` and ``inf``
    among them, which a reader refuses where a value must be finite), or with ``integer`` a
    whole number as :data:`_INTEGER` reads it."""
    return _PATTERNS[isinstance(word, bytes), integer].fullmatch(word) is not None


def first_not_number(
    words: Sequence[str] | Sequence[bytes], *, integer: bool = False
) -> int | None:
    """The index of the first of ``words`` that is not a number as :func:`is_number` reads
    it; None where every one is (or there are none)."""
    if not len(words):
        return None
    matches = list(map(_PATTERNS[isinstance(words[0], bytes), integer].fullmatch, words))
    try:
        return matches.index(None)
    except ValueError:
        return None


def field_number(path: Path, where: str, text: str) -> float:
    """A finite float from a field of a text file (a CSV cell, a word of an elastix point
    file): a decimal number, as :data:`_DECIMAL` reads it."""
    if not isinstance(text, str) or not is_number(text):
        raise fail(path, where, f"expected a number, got {brief(text)}")
    return _finite(path, where, text)


def _finite(path: Path, where: str, value: int | float | str) -> float:
    try:
        result = float(value)
    except OverflowError:  # a JSON integer beyond float's range
        raise fail(path, where, f"expected a finite number, got {brief(value)}") from None
    if not math.isfinite(result):  # nan, inf, or digits beyond float's range ("1e999")
        raise fail(path, where, f"expected a finite number, got {brief(value)}")
    return result


def as_path(path: object, name: str = "path") -> Path:
    """``path`` (a str, bytes or an os.PathLike of either) as a :class:`~pathlib.Path`;
    ``TypeError`` naming it for anything else (None, a number, an array given in its
    place)."""
    try:
        return Path(os.fsdecode(os.fspath(path)))  # type: ignore[arg-type]
    except TypeError:
        given = " ".join(brief(path).split())  # an array's repr spans lines
        raise TypeError(
            f"{name} must be a file path (str or os.PathLike), got {given} ({type(path).__name__})"
        ) from None


def not_a_file(path: Path) -> str:
    """Why ``path``, which is not a regular file, cannot be read as one: "no such file", or
    what it is (a folder, a device or another kind of entry), for a message naming it."""
    if path.is_dir():
        return "a folder, not a file"
    if path.exists():
        return "not a regular file (a device, a pipe or a socket)"
    return "no such file"


def read_head(path: Path, size: int) -> bytes:
    """The first ``size`` bytes of the image file ``path`` (fewer where it is shorter), which
    say its format; ``ValueError`` naming a folder, whose ``open`` error would name no image
    (missing and unreadable files raise ``open``'s own errors, which name the path)."""
    try:
        with open(path, "rb") as file:
            return file.read(size)
    except IsADirectoryError:
        raise ValueError(f"{path}: a folder, not an image file") from None


def read_text(path: Path) -> str:
    try:
        mode = path.stat().st_mode
        if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
            # /dev/zero, a disk: read whole, they never end or fill the memory (a pipe ends)
            raise InputFileError(f"{path}: a device, not a file")
        return path.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise InputFileError(f"{path}: no such file") from None
    except IsADirectoryError:
        raise InputFileError(f"{path}: a folder, not a file") from None
    except (OSError, UnicodeDecodeError) as error:
        raise InputFileError(f"{path}: cannot read: {error}") from None


class _DuplicateKey(Exception):
    """A key twice in one JSON object (``json`` keeps the last without a word)."""


def _unique_keys(pairs: list[tuple[str, object]]) -> dict:
    data = dict(pairs)
    if len(data) != len(pairs):
        seen: set[str] = set()
        raise _DuplicateKey(next(k for k, _ in pairs if k in seen or seen.add(k)))
    return data


def load_json(path: Path) -> dict:
    """The top-level JSON object of ``path``; a key given twice in one object is refused
    (which of the two was meant is not known)."""
    text = read_text(path)  # its own InputFileError (missing, unreadable) passes through as is
    if not text.strip():
        raise fail(path, "content", "an empty file")
    try:
        data = json.loads(text, object_pairs_hook=_unique_keys)
    except _DuplicateKey as error:
        raise fail(
            path, "content", f"the key {json.dumps(error.args[0])} twice in one object"
        ) from None
    except json.JSONDecodeError as error:
        raise fail(path, f"line {error.lineno}", f"invalid JSON: {error.msg}") from None
    except ValueError as error:  # an integer of more than 4,300 digits
        raise fail(path, "content", f"invalid JSON: {error}") from None
    except RecursionError:
        raise fail(path, "content", "JSON nested too deeply to be handles or points") from None
    if not isinstance(data, dict):
        raise fail(path, "top level", f"expected a JSON object, got {type(data).__name__}")
    return data


def json_list(path: Path, where: str, value: object, what: str) -> list:
    """``value`` if it is a JSON list, else an error saying a list of ``what`` was expected."""
    if not isinstance(value, list):
        raise fail(path, where, f"expected a list of {what}, got {type(value).__name__}")
    return value


def json_pair(path: Path, where: str, value: object, *, or_3d: bool = False) -> list[float]:
    """An ``[x, y]`` pair of finite numbers (``or_3d``: the message names the 3D form too,
    for the handles' lists, which hold [x, y, z] points in a 3D file)."""
    if not isinstance(value, list) or len(value) != 2:
        form = "an [x, y] pair (or [x, y, z] points in every row)" if or_3d else "an [x, y] pair"
        raise fail(path, where, f"expected {form}, got {brief(value)}")
    return [number(path, where, v) for v in value]


def json_points(path: Path, data: dict, key: str, *, or_3d: bool = False) -> list[list[float]]:
    """The ``[x, y]`` pairs under the top-level ``key`` (``or_3d``: :func:`json_pair`'s)."""
    if key not in data:
        raise fail(path, "top level", f'missing the key "{key}"')
    rows = json_list(path, f'"{key}"', data[key], "[x, y] pairs")
    return [
        json_pair(path, f'"{key}"[{index}]', row, or_3d=or_3d) for index, row in enumerate(rows)
    ]


def csv_rows(path: Path) -> list[Row]:
    """(line number, fields) of the non-blank rows."""
    # skipinitialspace: a quoted field after ", " (written by hand) is a quoted field
    reader = csv.reader(io.StringIO(read_text(path)), skipinitialspace=True)
    try:
        return [(reader.line_num, [f.strip() for f in row]) for row in reader if any(row)]
    except csv.Error as error:  # e.g. a field over csv's limit of 131,072 characters
        raise fail(path, f"line {reader.line_num}", f"not a CSV table: {error}") from None


def by_name(path: Path, rows: list[Row], needed: Sequence[str]) -> list[Row]:
    """The rows after the header ``rows[0]``, each the fields of the ``needed`` columns in
    that order: the header names them (case aside) in any order, beside columns of other
    names, which are left out (a landmark's ``name``). ``InputFileError`` naming the column
    a header lacks or names twice, or a row of another number of fields than the header."""
    line, header = rows[0]
    names = [name.lower() for name in header]
    expected = f"expected the header {','.join(needed)} (its columns in any order, others ignored)"
    lacking = [name for name in needed if name not in names]
    if lacking:
        what = "column" if len(lacking) == 1 else "columns"
        raise fail(
            path,
            f"line {line}",
            f"the header lacks the {what} {', '.join(lacking)}: {expected}, got "
            f"{brief(','.join(header), 200)}",
        )
    for name in needed:
        where = [str(index) for index, other in enumerate(names, start=1) if other == name]
        if len(where) > 1:
            raise fail(
                path,
                f"line {line}",
                f"the header names the column {name} {_times(len(where))} (columns "
                f"{', '.join(where)}): {expected}",
            )
    columns = [names.index(name) for name in needed]
    picked = []
    for number_, row in rows[1:]:
        if len(row) != len(header):
            raise fail(path, f"line {number_}", f"expected {len(header)} columns, got {len(row)}")
        picked.append((number_, [row[index] for index in columns]))
    return picked


def _times(count: int) -> str:
    return "twice" if count == 2 else f"{count} times"


def table(path: Path, rows: list[Row], columns: int) -> np.ndarray:
    """The rows as numbers, (len(rows), columns) float64."""
    values = []
    for line, row in rows:
        if len(row) != columns:
            raise fail(path, f"line {line}", f"expected {columns} columns, got {len(row)}")
        values.append([field_number(path, f"line {line}", text) for text in row])
    return np.array(values, dtype=np.float64).reshape(-1, columns)
