"""Handles of every kind in files: the JSON keys ``"src"``/``"dst"``, ``"segments"`` and
``"polylines"``, the CSV table with the header ``kind,id,src_x,src_y,dst_x,dst_y``, their
writers, and the checks that turn what a file holds into a
:class:`~glmls.core.handleset.HandleSet`, every fault named by its place in the file. The
formats are described in :mod:`glmls.files.landmarks`."""

from __future__ import annotations

import dataclasses
import json
import re
from pathlib import Path

import numpy as np

from ..core.handles import COORDINATE_LIMIT
from ..core.handleset import HandleSet
from ..core.segments import polyline_segments
from ..errors import InputFileError
from .parsing import Row, brief, fail, field_number, json_list, json_pair, json_points

__all__ = [
    "KINDS",
    "KIND_HEADER",
    "HandleRows",
    "chains",
    "check_range",
    "handle_set",
    "json_handles",
    "json_text",
    "kind_csv_text",
    "kind_table",
]

KIND_HEADER = ["kind", "id", "src_x", "src_y", "dst_x", "dst_y"]
KINDS = ("point", "segment", "polyline")


@dataclasses.dataclass
class HandleRows:
    """What a handle file holds, before the checks, with the place of every handle in the
    file (``"src"[3]``, ``line 7``...) for the messages."""

    src: list = dataclasses.field(default_factory=list)
    dst: list = dataclasses.field(default_factory=list)
    src_where: list[str] = dataclasses.field(default_factory=list)
    dst_where: list[str] = dataclasses.field(default_factory=list)
    src_segments: list = dataclasses.field(default_factory=list)
    dst_segments: list = dataclasses.field(default_factory=list)
    src_segment_where: list[str] = dataclasses.field(default_factory=list)
    dst_segment_where: list[str] = dataclasses.field(default_factory=list)

    def add_point(self, p: object, q: object, src_where: str, dst_where: str | None = None) -> None:
        self.src.append(p)
        self.dst.append(q)
        self.src_where.append(src_where)
        self.dst_where.append(dst_where or src_where)

    def add_segment(
        self, a: object, b: object, src_where: str, dst_where: str | None = None
    ) -> None:
        self.src_segments.append(a)
        self.dst_segments.append(b)
        self.src_segment_where.append(src_where)
        self.dst_segment_where.append(dst_where or src_where)

    def add_polyline(
        self, src: list, dst: list, src_where: list[str], dst_where: list[str] | None = None
    ) -> None:
        """A source polyline and its target of the same K >= 2 vertices: K - 1 segments,
        ``src_where``/``dst_where`` naming each segment."""
        a, b = polyline_segments(src), polyline_segments(dst)
        for k in range(len(a)):
            self.add_segment(a[k], b[k], src_where[k], (dst_where or src_where)[k])


# -- checks -------------------------------------------------------------------------------


def check_range(path: Path, values: np.ndarray, where: list[str], unit: str = " px") -> None:
    """Refuse the first of ``values`` (a point, or a segment's two, per row) that lies beyond
    glmls's coordinate range, naming its place ``where[row]`` in the file at ``path``;
    ``unit``: the coordinates' (" px" in 2D, none for 3D handles in their own units)."""
    if len(values):
        beyond = np.abs(values.reshape(len(values), -1)).max(axis=1) > COORDINATE_LIMIT
        if beyond.any():
            row = int(np.argmax(beyond))
            raise fail(
                path,
                where[row],
                f"{values[row].tolist()} lies beyond ±{COORDINATE_LIMIT:.0e}{unit} of the "
                "origin (glmls's coordinate range)",
            )


_INDEX = re.compile(r"\b(src_segments|dst_segments|src|dst)\[(\d+)\]")


def _relabel(message: str, rows: HandleRows) -> str:
    """``src[3]``, ``src_segments[2]``... in a validation message as places in the file."""
    labels = {
        "src": rows.src_where,
        "dst": rows.dst_where,
        "src_segments": rows.src_segment_where,
        "dst_segments": rows.dst_segment_where,
    }

    def place(match: re.Match) -> str:
        table, index = labels[match.group(1)], int(match.group(2))
        return table[index] if index < len(table) else match.group(0)

    return _INDEX.sub(place, message)


def handle_set(path: Path, rows: HandleRows) -> HandleSet:
    """The checked handles of a file: ``InputFileError`` naming the place of the first fault
    (no handles at all, coordinates out of range, a source segment of zero length, one source
    point or segment given two targets)."""
    if not rows.src and not rows.src_segments:
        raise fail(path, "content", "no handles")
    src = np.array(rows.src, dtype=np.float64).reshape(-1, 2)
    dst = np.array(rows.dst, dtype=np.float64).reshape(-1, 2)
    a = np.array(rows.src_segments, dtype=np.float64).reshape(-1, 2, 2)
    b = np.array(rows.dst_segments, dtype=np.float64).reshape(-1, 2, 2)
    for values, where in (
        (src, rows.src_where),
        (dst, rows.dst_where),
        (a, rows.src_segment_where),
        (b, rows.dst_segment_where),
    ):
        check_range(path, values, where)
    zero = (a[:, 0] == a[:, 1]).all(axis=1)
    if zero.any():
        row = int(np.argmax(zero))
        raise fail(
            path,
            rows.src_segment_where[row],
            f"a source segment of zero length (both ends at {a[row, 0].tolist()}); "
            "a point is a point handle",
        )
    try:
        return HandleSet.validate(src, dst, a, b)
    except ValueError as error:
        raise InputFileError(f"{path}: {_relabel(str(error), rows)}") from None


# -- JSON ---------------------------------------------------------------------------------


def _sides(path: Path, data: dict, key: str, items: str) -> tuple[list, list]:
    """The ``"src"`` and ``"dst"`` lists of ``data[key]``, an object."""
    value = data[key]
    if not isinstance(value, dict):
        raise fail(
            path,
            f'"{key}"',
            f'expected an object {{"src": [...], "dst": [...]}}, got {type(value).__name__}',
        )
    for side in ("src", "dst"):
        if side not in value:
            raise fail(path, f'"{key}"', f'missing the key "{side}"')
    return tuple(json_list(path, f'"{key}"."{s}"', value[s], items) for s in ("src", "dst"))


def _json_segments(path: Path, data: dict, rows: HandleRows) -> None:
    sides = _sides(path, data, "segments", "segments [[x, y], [x, y]]")
    ends = []
    for side, values in zip(("src", "dst"), sides, strict=True):
        parsed = []
        for index, value in enumerate(values):
            where = f'"segments"."{side}"[{index}]'
            if not (isinstance(value, list) and len(value) == 2) or not all(
                isinstance(end, list) for end in value
            ):
                raise fail(path, where, f"expected two [x, y] ends, got {brief(value)}")
            parsed.append([json_pair(path, f"{where}[{k}]", end) for k, end in enumerate(value)])
        ends.append(parsed)
    if len(ends[0]) != len(ends[1]):
        raise fail(path, '"segments"', f"{len(ends[0])} source segments but {len(ends[1])} targets")
    for index, (a, b) in enumerate(zip(*ends, strict=True)):
        rows.add_segment(a, b, f'"segments"."src"[{index}]', f'"segments"."dst"[{index}]')


def _json_polylines(path: Path, data: dict, rows: HandleRows) -> None:
    sides = _sides(path, data, "polylines", "polylines [[x, y], ...]")
    lines = []
    for side, values in zip(("src", "dst"), sides, strict=True):
        parsed = []
        for index, value in enumerate(values):
            where = f'"polylines"."{side}"[{index}]'
            if not isinstance(value, list) or len(value) < 2:
                raise fail(
                    path,
                    where,
                    f"expected a polyline of at least 2 [x, y] vertices, got {brief(value)}",
                )
            parsed.append([json_pair(path, f"{where}[{k}]", v) for k, v in enumerate(value)])
        lines.append(parsed)
    if len(lines[0]) != len(lines[1]):
        raise fail(
            path, '"polylines"', f"{len(lines[0])} source polylines but {len(lines[1])} targets"
        )
    for index, (src, dst) in enumerate(zip(*lines, strict=True)):
        if len(src) != len(dst):
            raise fail(
                path,
                f'"polylines"."dst"[{index}]',
                f'{len(dst)} vertices, but its source "polylines"."src"[{index}] has {len(src)}',
            )
        src_where, dst_where = (
            [f'"polylines"."{side}"[{index}], vertices {k}-{k + 1}' for k in range(len(src) - 1)]
            for side in ("src", "dst")
        )
        rows.add_polyline(src, dst, src_where, dst_where)


def json_handles(path: Path, data: dict) -> HandleRows:
    """The handles of a JSON object: points ``"src"``/``"dst"`` (which may be left out where
    ``"segments"`` or ``"polylines"`` are given), then segments, then polylines."""
    rows = HandleRows()
    kinds = "segments" in data or "polylines" in data
    if not kinds or "src" in data or "dst" in data:
        src = json_points(path, data, "src", or_3d=True)
        dst = json_points(path, data, "dst", or_3d=True)
        if len(src) != len(dst):
            raise fail(path, '"src"/"dst"', f"{len(src)} sources but {len(dst)} targets")
        for index, (p, q) in enumerate(zip(src, dst, strict=True)):
            rows.add_point(p, q, f'"src"[{index}]', f'"dst"[{index}]')
    if "segments" in data:
        _json_segments(path, data, rows)
    if "polylines" in data:
        _json_polylines(path, data, rows)
    return rows


def chains(a: np.ndarray, b: np.ndarray) -> list[tuple[int, int]]:
    """The runs [start, stop) of consecutive segments that join end to start in the source and
    in the target: the polylines the segments (S, 2, 2) came from."""
    if len(a) == 0:
        return []
    joined = (a[:-1, 1] == a[1:, 0]).all(axis=1) & (b[:-1, 1] == b[1:, 0]).all(axis=1)
    breaks = [k + 1 for k in np.flatnonzero(~joined)]
    starts, stops = [0, *breaks], [*breaks, len(a)]
    return list(zip(starts, stops, strict=True))


def _vertices(segments: np.ndarray, run: tuple[int, int]) -> list:
    start, stop = run
    return np.concatenate([segments[start:stop, 0], segments[stop - 1 : stop, 1]]).tolist()


def json_text(handles: HandleSet) -> str:
    """The JSON form, one key a line: single segments under ``"segments"`` and joined ones
    under ``"polylines"`` where that keeps their order (reading gives ``"segments"`` first),
    else every run under ``"polylines"``."""
    document: dict[str, object] = {"src": handles.src.tolist(), "dst": handles.dst.tolist()}
    a, b = handles.src_segments, handles.dst_segments
    runs = chains(a, b)
    singles = [r for r in runs if r[1] - r[0] == 1]
    longer = [r for r in runs if r[1] - r[0] > 1]
    if singles + longer != runs:
        singles, longer = [], runs
    if singles:
        document["segments"] = {
            "src": [a[start].tolist() for start, _ in singles],
            "dst": [b[start].tolist() for start, _ in singles],
        }
    if longer:
        document["polylines"] = {
            "src": [_vertices(a, run) for run in longer],
            "dst": [_vertices(b, run) for run in longer],
        }
    lines = [f"  {json.dumps(key)}: {json.dumps(value)}" for key, value in document.items()]
    return "{\n" + ",\n".join(lines) + "\n}\n"


# -- CSV with kinds ------------------------------------------------------------------------


@dataclasses.dataclass
class _Group:
    kind: str
    ident: str
    rows: list[tuple[int, list[float]]]

    def where(self, first: int = 0, last: int = -1) -> str:
        lines = (self.rows[first][0], self.rows[last][0])
        span = f"line {lines[0]}" if lines[0] == lines[1] else f"lines {lines[0]}-{lines[1]}"
        return f"{span} ({self.kind} {self.ident!r})"


def _finish(path: Path, group: _Group, rows: HandleRows) -> None:
    count = len(group.rows)
    if group.kind == "segment" and count != 2:
        raise fail(
            path,
            group.where(),
            f"{count} row{'s' * (count != 1)}; a segment has 2, its ends (kind polyline for more)",
        )
    if count < 2:
        raise fail(path, group.where(), "1 row; a polyline has at least 2 vertices")
    values = [numbers for _, numbers in group.rows]
    src = [v[:2] for v in values]
    dst = [v[2:] for v in values]
    rows.add_polyline(src, dst, [group.where(k, k + 1) for k in range(count - 1)])


def kind_table(path: Path, table: list[Row]) -> HandleRows:
    """The rows after the header ``kind,id,src_x,src_y,dst_x,dst_y``: a point each, or
    consecutive rows of one id forming a segment (2 rows) or a polyline (2 or more)."""
    rows = HandleRows()
    groups: list[_Group] = []
    current: _Group | None = None  # the group of the row before, if it has one
    first_line: dict[str, int] = {}
    for line, row in table:
        if len(row) != len(KIND_HEADER):
            raise fail(path, f"line {line}", f"expected 6 columns, got {len(row)}")
        kind, ident = row[0].lower(), row[1]
        if kind not in KINDS:
            raise fail(
                path,
                f"line {line}",
                f"unknown kind {brief(row[0])}: expected point, segment or polyline",
            )
        values = [field_number(path, f"line {line}", text) for text in row[2:]]
        if kind == "point":
            rows.add_point(values[:2], values[2:], f"line {line}")
            current = None
            continue
        if not ident:
            raise fail(
                path, f"line {line}", f"a {kind} row needs an id: rows of one id form one {kind}"
            )
        if current is not None and current.ident == ident:
            if current.kind != kind:
                raise fail(
                    path,
                    f"line {line}",
                    f"id {ident!r} is a {current.kind} (line {current.rows[0][0]}), not a {kind}",
                )
            current.rows.append((line, values))
            continue
        if ident in first_line:
            raise fail(
                path,
                f"line {line}",
                f"id {ident!r} was used on line {first_line[ident]}: the rows of one segment or "
                "polyline must follow each other",
            )
        first_line[ident] = line
        current = _Group(kind, ident, [(line, values)])
        groups.append(current)
    for group in groups:
        _finish(path, group, rows)
    return rows


def kind_csv_text(handles: HandleSet) -> str:
    """The CSV table with kinds: points ``p0, p1...``, single segments ``s0...``, joined
    segments as polylines ``l0...``, in the order of the segments."""

    def row(kind: str, ident: str, p: np.ndarray, q: np.ndarray) -> str:
        return ",".join([kind, ident, *(repr(float(x)) for x in (*p, *q))])

    lines = [",".join(KIND_HEADER)]
    points = zip(handles.src, handles.dst, strict=True)
    lines += [row("point", f"p{i}", p, q) for i, (p, q) in enumerate(points)]
    a, b = handles.src_segments, handles.dst_segments
    counts = {"segment": 0, "polyline": 0}
    for start, stop in chains(a, b):
        kind = "segment" if stop - start == 1 else "polyline"
        ident = f"{kind[0] if kind == 'segment' else 'l'}{counts[kind]}"
        counts[kind] += 1
        src, dst = _vertices(a, (start, stop)), _vertices(b, (start, stop))
        lines += [row(kind, ident, p, q) for p, q in zip(src, dst, strict=True)]
    return "\n".join(lines) + "\n"
