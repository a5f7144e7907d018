"""Handle and reference-point files.

Handles are points p -> q, line segments a-b -> c-d and polylines (a polyline is its K - 1
segments, :func:`glmls.core.segments.polyline_segments`). Coordinates are (x, y) = (column, row)
in pixels, pixel centres at integers.

**JSON** (``.json``)::

    {"src": [[x, y], ...], "dst": [[x, y], ...],
     "segments": {"src": [[[x, y], [x, y]], ...], "dst": [[[x, y], [x, y]], ...]},
     "polylines": {"src": [[[x, y], [x, y], ...], ...], "dst": [[[x, y], ...], ...]}}

``"src"``/``"dst"`` are the points (the i-th source goes to the i-th target); segment s runs
from ``"segments"."src"[s][0]`` to ``[s][1]`` and goes to ``"segments"."dst"[s]``; polyline j
has K >= 2 vertices in the source and the same K in the target. ``"segments"`` and
``"polylines"`` may be left out, and ``"src"``/``"dst"`` too where either is given. Other keys
(``"description"``) are ignored. The segments are read in order: ``"segments"``, then each
polyline's.

**CSV** (any other suffix), one of three tables:

- the header ``src_x,src_y,dst_x,dst_y``: a point a row;
- the header ``kind,id,src_x,src_y,dst_x,dst_y``: each row a point (``kind`` ``point``, its
  ``id`` free, may be empty) or a vertex of a ``segment`` (exactly 2 rows) or ``polyline``
  (2 rows or more): consecutive rows of one ``id`` are one segment or polyline, vertices in
  order; an ``id`` names one segment or polyline only. For example::

      kind,id,src_x,src_y,dst_x,dst_y
      point,nose,256,200,262,204
      segment,jaw,180,300,184,310
      segment,jaw,330,300,326,312
      polyline,brow,190,150,190,146
      polyline,brow,230,140,230,134
      polyline,brow,270,150,270,146

- BigWarp's landmark CSV (no header; name, active, moving x, moving y, fixed x, fixed y):
  the moving points are the sources, the fixed points the targets; inactive rows are skipped.

A file must hold at least one handle. A fault is an :class:`~glmls.errors.InputFileError`
naming the file and the place: ``h.json: "segments"."src"[3]: expected two [x, y] ends``,
``h.csv: line 7: expected a finite number``, also for a source segment of zero length, counts
that differ, coordinates beyond ±1e6 px and one source point or segment given two targets.

Reference points: JSON ``{"points": [[x, y], ...]}`` or CSV with the header ``x,y``.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..core.handleset import HandleSet
from .atomic import atomic_write
from .handle_formats import (
    KIND_HEADER,
    HandleRows,
    handle_set,
    json_handles,
    json_text,
    kind_csv_text,
    kind_table,
)
from .parsing import Row, csv_rows, fail, json_points, load_json, number, table

__all__ = [
    "HANDLE_HEADER",
    "KIND_HEADER",
    "POINT_HEADER",
    "read_handle_set",
    "read_handles",
    "read_points",
    "write_handle_set",
    "write_handles",
]

HANDLE_HEADER = ["src_x", "src_y", "dst_x", "dst_y"]
POINT_HEADER = ["x", "y"]


def _is_bigwarp(rows: list[Row]) -> bool:
    first = rows[0][1]
    return len(first) >= 2 and first[1].lower() in ("true", "false")


def _bigwarp(path: Path, rows: list[Row]) -> HandleRows:
    handles = HandleRows()
    for line, row in rows:
        if len(row) == 8:
            raise fail(path, f"line {line}", "3D BigWarp landmarks are not supported")
        if len(row) != 6:
            raise fail(path, f"line {line}", f"expected 6 BigWarp columns, got {len(row)}")
        active = row[1].lower()
        if active not in ("true", "false"):
            raise fail(path, f"line {line}", f"expected true/false, got {row[1]!r}")
        numbers = [number(path, f"line {line}", text) for text in row[2:]]
        if active == "true":
            handles.add_point(numbers[:2], numbers[2:], f"line {line}")
    if not handles.src:
        raise fail(path, "content", "no active BigWarp landmarks")
    return handles


def _point_table(path: Path, rows: list[Row]) -> HandleRows:
    handles = HandleRows()
    for (line, _), values in zip(rows, table(path, rows, 4), strict=True):
        handles.add_point(values[:2], values[2:], f"line {line}")
    return handles


def _csv_handles(path: Path) -> HandleRows:
    rows = csv_rows(path)
    if not rows:
        raise fail(path, "content", "no handles")
    if _is_bigwarp(rows):
        return _bigwarp(path, rows)
    line, header = rows[0]
    names = [h.lower() for h in header]
    if names == HANDLE_HEADER:
        return _point_table(path, rows[1:])
    if names == KIND_HEADER:
        return kind_table(path, rows[1:])
    raise fail(
        path,
        f"line {line}",
        f"expected the header {','.join(HANDLE_HEADER)} or {','.join(KIND_HEADER)} (or a "
        f"BigWarp landmark file), got {','.join(header)}",
    )


def read_handle_set(path: str | os.PathLike) -> HandleSet:
    """The handles of every kind in a JSON, CSV or BigWarp landmark file (see the module's
    description of the formats), checked; ``InputFileError`` naming the place of a fault."""
    path = Path(path)
    if path.suffix.lower() == ".json":
        return handle_set(path, json_handles(path, load_json(path)))
    return handle_set(path, _csv_handles(path))


def read_handles(path: str | os.PathLike) -> tuple[np.ndarray, np.ndarray]:
    """(src, dst) point handles, each (N, 2) float64, from a file of points only;
    ``InputFileError`` if malformed, or if it holds segments or polylines, which only
    :func:`read_handle_set` returns."""
    handles = read_handle_set(path)
    if handles.segments:
        raise fail(
            Path(path),
            "content",
            f"{handles.segments} segment handles (from segments or polylines) besides "
            f"{handles.points} points: read it with read_handle_set",
        )
    return np.array(handles.src), np.array(handles.dst)


def read_points(path: str | os.PathLike) -> np.ndarray:
    """Reference points (K, 2) from JSON ``{"points": ...}`` or a CSV with header ``x,y``."""
    path = Path(path)
    if path.suffix.lower() == ".json":
        points = np.array(json_points(path, load_json(path), "points"), dtype=np.float64)
    else:
        rows = csv_rows(path)
        if not rows:
            raise fail(path, "content", "no points")
        line, header = rows[0]
        if [h.lower() for h in header] != POINT_HEADER:
            raise fail(path, f"line {line}", f"expected the header x,y, got {','.join(header)}")
        points = table(path, rows[1:], 2)
    if len(points) == 0:
        raise fail(path, "content", "no points")
    return points.reshape(-1, 2)


def write_handle_set(path: str | os.PathLike, handles: HandleSet) -> None:
    """``handles`` as JSON (``.json``) or CSV, written atomically, in a form that
    :func:`read_handle_set` reads back to the same handles: CSV with the header
    ``src_x,src_y,dst_x,dst_y`` for points alone, ``kind,id,...`` with segments; segments
    that join end to start (in the source and the target) are written as polylines."""
    if not isinstance(handles, HandleSet):
        raise TypeError(f"handles must be a HandleSet, got {type(handles).__name__}")
    path = Path(path)
    if path.suffix.lower() == ".json":
        text = json_text(handles)
    elif handles.segments:
        text = kind_csv_text(handles)
    else:
        lines = [",".join(HANDLE_HEADER)]
        lines += [
            ",".join(repr(float(x)) for x in (*p, *q))
            for p, q in zip(handles.src, handles.dst, strict=True)
        ]
        text = "\n".join(lines) + "\n"
    with atomic_write(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


def write_handles(
    path: str | os.PathLike,
    src: object,
    dst: object,
    *,
    src_segments: object = None,
    dst_segments: object = None,
) -> None:
    """Point handles (and segments (S, 2, 2), if given) to ``path``: see
    :func:`write_handle_set`. ``ValueError``/``TypeError`` for handles that
    :class:`glmls.MLS` would refuse."""
    write_handle_set(path, HandleSet.validate(src, dst, src_segments, dst_segments))
