"""Handle and reference-point files.

Handles:
- JSON ``{"src": [[x, y], ...], "dst": [[x, y], ...]}``;
- CSV with the header ``src_x,src_y,dst_x,dst_y``;
- BigWarp's landmark CSV (no header; name, active, moving x, moving y, fixed x, fixed y): the
  moving points are the sources, the fixed points the targets; inactive rows are skipped.
Reference points: JSON ``{"points": [[x, y], ...]}`` or CSV with the header ``x,y``.
Coordinates are (x, y) = (column, row) in pixels.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
from pathlib import Path

import numpy as np

from ..errors import InputFileError
from .atomic import atomic_write

__all__ = ["read_handles", "read_points", "write_handles"]

HANDLE_HEADER = ["src_x", "src_y", "dst_x", "dst_y"]
POINT_HEADER = ["x", "y"]


def _fail(path: Path, where: str, what: str) -> InputFileError:
    return InputFileError(f"{path}: {where}: {what}")


def _number(path: Path, where: str, text: object) -> float:
    if isinstance(text, bool) or not isinstance(text, (int, float, str)):
        raise _fail(path, where, f"expected a number, got {text!r}")
    try:
        value = float(text)
    except ValueError:
        raise _fail(path, where, f"expected a number, got {text!r}") from None
    if not math.isfinite(value):
        raise _fail(path, where, f"expected a finite number, got {text!r}")
    return value


def _read_text(path: Path) -> str:
    try:
        return path.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise InputFileError(f"{path}: no such file") from None
    except (OSError, UnicodeDecodeError) as error:
        raise InputFileError(f"{path}: cannot read: {error}") from None


def _json_points(path: Path, data: dict, key: str) -> np.ndarray:
    if key not in data:
        raise _fail(path, "top level", f'missing the key "{key}"')
    rows = data[key]
    if not isinstance(rows, list):
        raise _fail(path, f'"{key}"', f"expected a list of [x, y] pairs, got {type(rows).__name__}")
    points = []
    for index, row in enumerate(rows):
        where = f'"{key}"[{index}]'
        if not isinstance(row, list) or len(row) != 2:
            raise _fail(path, where, f"expected an [x, y] pair, got {row!r}")
        points.append([_number(path, where, value) for value in row])
    return np.array(points, dtype=np.float64).reshape(-1, 2)


def _load_json(path: Path) -> dict:
    try:
        data = json.loads(_read_text(path))
    except json.JSONDecodeError as error:
        raise _fail(path, f"line {error.lineno}", f"invalid JSON: {error.msg}") from None
    except RecursionError:
        raise _fail(path, "content", "JSON nested too deeply to be handles or points") from None
    if not isinstance(data, dict):
        raise _fail(path, "top level", f"expected a JSON object, got {type(data).__name__}")
    return data


def _csv_rows(path: Path) -> list[tuple[int, list[str]]]:
    """(line number, fields) of the non-blank rows."""
    reader = csv.reader(io.StringIO(_read_text(path)))
    try:
        return [(reader.line_num, [f.strip() for f in row]) for row in reader if any(row)]
    except csv.Error as error:  # e.g. a field over csv's limit of 131,072 characters
        raise _fail(path, f"line {reader.line_num}", f"not a CSV table: {error}") from None


def _table(path: Path, rows, columns: int) -> np.ndarray:
    values = []
    for line, row in rows:
        if len(row) != columns:
            raise _fail(path, f"line {line}", f"expected {columns} columns, got {len(row)}")
        values.append([_number(path, f"line {line}", text) for text in row])
    return np.array(values, dtype=np.float64).reshape(-1, columns)


def _is_bigwarp(rows) -> bool:
    first = rows[0][1]
    return len(first) >= 2 and first[1].lower() in ("true", "false")


def _bigwarp(path: Path, rows) -> tuple[np.ndarray, np.ndarray]:
    src, dst = [], []
    for line, row in rows:
        if len(row) == 8:
            raise _fail(path, f"line {line}", "3D BigWarp landmarks are not supported")
        if len(row) != 6:
            raise _fail(path, f"line {line}", f"expected 6 BigWarp columns, got {len(row)}")
        active = row[1].lower()
        if active not in ("true", "false"):
            raise _fail(path, f"line {line}", f"expected true/false, got {row[1]!r}")
        numbers = [_number(path, f"line {line}", text) for text in row[2:]]
        if active == "true":
            src.append(numbers[:2])
            dst.append(numbers[2:])
    return np.array(src, dtype=float).reshape(-1, 2), np.array(dst, dtype=float).reshape(-1, 2)


def _non_empty(path: Path, points: np.ndarray, what: str) -> np.ndarray:
    if len(points) == 0:
        raise _fail(path, "content", f"no {what}")
    return points


def read_handles(path: str | os.PathLike) -> tuple[np.ndarray, np.ndarray]:
    """(src, dst) from a JSON, CSV or BigWarp landmark file; ``InputFileError`` if malformed."""
    path = Path(path)
    if path.suffix.lower() == ".json":
        data = _load_json(path)
        src, dst = _json_points(path, data, "src"), _json_points(path, data, "dst")
        if len(src) != len(dst):
            raise _fail(path, '"src"/"dst"', f"{len(src)} sources but {len(dst)} targets")
        return _non_empty(path, src, "handles"), dst
    rows = _csv_rows(path)
    if not rows:
        raise _fail(path, "content", "no handles")
    if _is_bigwarp(rows):
        src, dst = _bigwarp(path, rows)
        return _non_empty(path, src, "active BigWarp landmarks"), dst
    line, header = rows[0]
    if [h.lower() for h in header] != HANDLE_HEADER:
        raise _fail(
            path,
            f"line {line}",
            f"expected the header {','.join(HANDLE_HEADER)} (or a BigWarp landmark file), "
            f"got {','.join(header)}",
        )
    table = _non_empty(path, _table(path, rows[1:], 4), "handles")
    return table[:, :2], table[:, 2:]


def read_points(path: str | os.PathLike) -> np.ndarray:
    """Reference points (K, 2) from JSON ``{"points": ...}`` or a CSV with header ``x,y``."""
    path = Path(path)
    if path.suffix.lower() == ".json":
        return _non_empty(path, _json_points(path, _load_json(path), "points"), "points")
    rows = _csv_rows(path)
    if not rows:
        raise _fail(path, "content", "no points")
    line, header = rows[0]
    if [h.lower() for h in header] != POINT_HEADER:
        raise _fail(path, f"line {line}", f"expected the header x,y, got {','.join(header)}")
    return _non_empty(path, _table(path, rows[1:], 2), "points")


def write_handles(path: str | os.PathLike, src: np.ndarray, dst: np.ndarray) -> None:
    """Handles as JSON (``.json``) or CSV with the ``src_x,...`` header, written atomically."""
    path = Path(path)
    if path.suffix.lower() == ".json":
        text = json.dumps({"src": np.asarray(src).tolist(), "dst": np.asarray(dst).tolist()})
    else:
        lines = [",".join(HANDLE_HEADER)]
        lines += [",".join(repr(float(x)) for x in (*p, *q)) for p, q in zip(src, dst, strict=True)]
        text = "\n".join(lines) + "\n"
    with atomic_write(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
