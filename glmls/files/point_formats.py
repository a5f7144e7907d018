"""Point-handle files of other tools and of 3D handles: BigWarp's landmark CSV and JSON (2D
and 3D), elastix point files (``.pts``), and the JSON and CSV point tables of 3D handles
(``{"src": [[x, y, z], ...], ...}``, the header ``src_x,src_y,src_z,dst_x,dst_y,dst_z``).
Each reader gives the dimension and the :class:`~glmls.files.handle_formats.HandleRows`;
:func:`points_3d` checks 3D ones. The formats are described in :mod:`glmls.files.landmarks`.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..core.config import counted
from ..errors import InputFileError
from .handle_formats import HandleRows, check_range
from .parsing import Row, brief, fail, field_number, json_list, number, read_text

__all__ = [
    "HANDLE_HEADER_3D",
    "axes",
    "bigwarp_csv",
    "bigwarp_json",
    "elastix_kind",
    "elastix_pair",
    "is_bigwarp_csv",
    "is_bigwarp_json",
    "json_dimension",
    "json_points_3d",
    "points_3d",
    "table_3d",
]

HANDLE_HEADER_3D = ["src_x", "src_y", "src_z", "dst_x", "dst_y", "dst_z"]
#: BigWarp's CSV columns: name, active, [id,] moving point, fixed point.
_BIGWARP_COLUMNS = {6: (2, False), 7: (2, True), 8: (3, False), 9: (3, True)}
_AXES = {2: "(x, y)", 3: "(x, y, z)"}


def axes(ndim: int) -> str:
    return _AXES.get(ndim, f"of {ndim} coordinates")


# -- BigWarp -------------------------------------------------------------------------------


def _numeric(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def is_bigwarp_csv(rows: list[Row]) -> bool:
    """Whether the first row is a BigWarp landmark: an active flag second, or (a flag
    mistyped, which :func:`bigwarp_csv` then names) BigWarp's shape: 6 to 9 columns, a name
    and a flag that are no numbers, then numbers (a header has no numbers)."""
    first = rows[0][1]
    if len(first) >= 2 and first[1].lower() in ("true", "false"):
        return True
    return (
        len(first) in _BIGWARP_COLUMNS
        and not _numeric(first[1])
        and all(_numeric(text) for text in first[-4:])
    )


def bigwarp_csv(path: Path, rows: list[Row]) -> tuple[int, HandleRows]:
    """BigWarp's landmark table: name, active, [id,] moving x y [z], fixed x y [z]; the
    number of columns of the first row says the dimension and whether the id is there."""
    count = len(rows[0][1])
    if count not in _BIGWARP_COLUMNS:
        raise fail(
            path,
            f"line {rows[0][0]}",
            f"expected 6 to 9 BigWarp columns (name, active, [id,] moving and fixed "
            f"points), got {count}",
        )
    ndim, ident = _BIGWARP_COLUMNS[count]
    start = 3 if ident else 2
    handles = HandleRows()
    for line, row in rows:
        where = f"line {line}"
        if len(row) != count:
            raise fail(path, where, f"expected {count} BigWarp columns, got {len(row)}")
        active = row[1].lower()
        if active not in ("true", "false"):
            raise fail(path, where, f"expected true/false, got {brief(row[1])}")
        if active == "false":
            continue  # unpaired landmarks are inactive, their missing points infinite
        values = [field_number(path, where, text) for text in row[start:]]
        handles.add_point(values[:ndim], values[ndim:], where)
    if not handles.src:
        raise fail(path, "content", "no active BigWarp landmarks")
    return ndim, handles


def is_bigwarp_json(data: dict) -> bool:
    """BigWarp's landmarks, as it exports them (``"type": "BigWarpLandmarks"``) or inside
    its settings (under ``"landmarks"``)."""
    return data.get("type") == "BigWarpLandmarks" or isinstance(data.get("landmarks"), dict)


def bigwarp_json(path: Path, data: dict) -> tuple[int, HandleRows]:
    """The active landmarks of BigWarp's JSON: ``"numDimensions"``, ``"movingPoints"``,
    ``"fixedPoints"``, ``"active"`` (every landmark where left out; ``"names"`` not
    needed)."""
    prefix = ""
    if data.get("type") != "BigWarpLandmarks":
        data, prefix = data["landmarks"], '"landmarks".'
    if "active" not in data and isinstance(data.get("movingPoints"), list):
        data = {**data, "active": [True] * len(data["movingPoints"])}  # every landmark
    for key in ("numDimensions", "movingPoints", "fixedPoints", "active"):
        if key not in data:
            raise fail(path, f"{prefix.rstrip('.') or 'top level'}", f'missing the key "{key}"')
    ndim = data["numDimensions"]
    if ndim not in (2, 3) or isinstance(ndim, bool):
        raise fail(path, f'{prefix}"numDimensions"', f"expected 2 or 3, got {brief(ndim)}")
    lists = [
        json_list(path, f'{prefix}"{key}"', data[key], what)
        for key, what in (
            ("movingPoints", "points"),
            ("fixedPoints", "points"),
            ("active", "true/false"),
        )
    ]
    if not len(lists[0]) == len(lists[1]) == len(lists[2]):
        raise fail(
            path,
            prefix.rstrip(".") or "top level",
            f"{counted(len(lists[0]), 'moving point')}, "
            f"{counted(len(lists[1]), 'fixed point')} and "
            f"{counted(len(lists[2]), 'active flag')}",
        )
    handles = HandleRows()
    for index, (moving, fixed, active) in enumerate(zip(*lists, strict=True)):
        if not isinstance(active, bool):
            raise fail(path, f'{prefix}"active"[{index}]', f"expected true/false, got {active!r}")
        if not active:
            continue
        p = _vector(path, f'{prefix}"movingPoints"[{index}]', moving, ndim)
        q = _vector(path, f'{prefix}"fixedPoints"[{index}]', fixed, ndim)
        handles.add_point(
            p, q, f'{prefix}"movingPoints"[{index}]', f'{prefix}"fixedPoints"[{index}]'
        )
    if not handles.src:
        raise fail(path, "content", "no active BigWarp landmarks")
    return ndim, handles


# -- 3D point tables -----------------------------------------------------------------------


def _vector(path: Path, where: str, value: object, ndim: int) -> list[float]:
    if not isinstance(value, list) or len(value) != ndim:
        raise fail(path, where, f"expected an {axes(ndim)} point, got {brief(value)}")
    return [number(path, where, v) for v in value]


def json_dimension(data: dict) -> int:
    """3 where the first ``"src"`` point of a JSON object has three coordinates, else 2 (the
    2D reader then names any fault)."""
    src = data.get("src")
    if isinstance(src, list) and src and isinstance(src[0], list) and len(src[0]) == 3:
        return 3
    return 2


def json_points_3d(path: Path, data: dict) -> HandleRows:
    """``{"src": [[x, y, z], ...], "dst": [...]}``."""
    for key in ("segments", "polylines"):
        if key in data:
            raise fail(path, f'"{key}"', "segments and polylines are 2D handles only")
    sides = []
    for key in ("src", "dst"):
        if key not in data:
            raise fail(path, "top level", f'missing the key "{key}"')
        values = json_list(path, f'"{key}"', data[key], "[x, y, z] points")
        sides.append([_vector(path, f'"{key}"[{i}]', v, 3) for i, v in enumerate(values)])
    if len(sides[0]) != len(sides[1]):
        raise fail(path, '"src"/"dst"', f"{len(sides[0])} sources but {len(sides[1])} targets")
    handles = HandleRows()
    for index, (p, q) in enumerate(zip(*sides, strict=True)):
        handles.add_point(p, q, f'"src"[{index}]', f'"dst"[{index}]')
    return handles


def table_3d(path: Path, rows: list[Row]) -> HandleRows:
    """The rows after the header ``src_x,src_y,src_z,dst_x,dst_y,dst_z``."""
    handles = HandleRows()
    for line, row in rows:
        if len(row) != 6:
            raise fail(path, f"line {line}", f"expected 6 columns, got {len(row)}")
        values = [field_number(path, f"line {line}", text) for text in row]
        handles.add_point(values[:3], values[3:], f"line {line}")
    return handles


# -- elastix -------------------------------------------------------------------------------


def _elastix_points(path: Path) -> tuple[np.ndarray, list[str]]:
    """The points of an elastix point file: ``index`` or ``point``, the count, then one point
    a line (2 or 3 numbers separated by blanks)."""
    lines = [
        (number_, text.split())
        for number_, text in enumerate(read_text(path).splitlines(), start=1)
        if text.strip()
    ]
    if not lines or lines[0][1][0].lower() not in ("index", "point") or len(lines[0][1]) != 1:
        where = f"line {lines[0][0]}" if lines else "content"
        got = " ".join(lines[0][1]) if lines else "an empty file"
        raise fail(
            path, where, f"expected 'index' or 'point' (an elastix point file), got {brief(got)}"
        )
    if len(lines) < 2 or len(lines[1][1]) != 1:
        where = f"line {lines[1][0]}" if len(lines) > 1 else "content"
        raise fail(path, where, "expected the number of points, alone on its line")
    count = field_number(path, f"line {lines[1][0]}", lines[1][1][0])
    if count != math.floor(count) or count < 1:
        raise fail(path, f"line {lines[1][0]}", f"expected a count >= 1, got {lines[1][1][0]}")
    body = lines[2:]
    if len(body) != count:
        raise fail(
            path,
            "content",
            f"{counted(len(body), 'point')}, but line {lines[1][0]} says {int(count)}",
        )
    ndim = len(body[0][1])
    points, where = [], []
    for line, fields in body:
        if len(fields) != ndim or ndim not in (2, 3):
            expected = (
                f"{ndim} coordinates, as the first point"
                if ndim in (2, 3)
                else "2 or 3 coordinates"
            )
            raise fail(path, f"line {line}", f"expected {expected}, got {len(fields)}")
        points.append([field_number(path, f"line {line}", text) for text in fields])
        where.append(f"line {line}")
    return np.array(points, dtype=np.float64), where


def elastix_kind(path: Path) -> str:
    """``"index"`` (voxel indices) or ``"point"`` (coordinates): the first word of an elastix
    point file; ``InputFileError`` as its reader's where it is neither."""
    expected = "expected 'index' or 'point' (an elastix point file)"
    for line, text in enumerate(read_text(path).splitlines(), start=1):
        words = text.split()
        if words:
            if len(words) == 1 and words[0].lower() in ("index", "point"):
                return words[0].lower()
            raise fail(path, f"line {line}", f"{expected}, got {brief(text.strip())}")
    raise fail(path, "content", f"{expected}, got an empty file")


def elastix_pair(path: Path, dst_path: Path) -> tuple[int, HandleRows]:
    """The handles of two elastix point files: the sources (``path``, elastix's moving
    points) and the targets (``dst_path``, the fixed points), in the same order, of the same
    kind (``index`` or ``point``)."""
    src, src_where = _elastix_points(path)
    dst, dst_where = _elastix_points(dst_path)
    kinds = elastix_kind(path), elastix_kind(dst_path)
    if kinds[0] != kinds[1]:
        raise fail(
            dst_path,
            "line 1",
            f"{kinds[1]!r} coordinates, but the sources' {path} holds {kinds[0]!r} ones: "
            "voxel indices and coordinates do not mix; give both files the same kind",
        )
    if src.shape != dst.shape:
        raise fail(
            dst_path,
            "content",
            f"{counted(len(dst), 'point')} of {dst.shape[1]} coordinates, but the sources "
            f"{path} has {len(src)} of {src.shape[1]}",
        )
    handles = HandleRows()
    for k in range(len(src)):
        handles.add_point(
            src[k].tolist(), dst[k].tolist(), src_where[k], f"{dst_path}: {dst_where[k]}"
        )
    return src.shape[1], handles


# -- checks --------------------------------------------------------------------------------


def points_3d(path: Path, rows: HandleRows) -> tuple[np.ndarray, np.ndarray]:
    """The checked 3D point handles (N, 3) each: at least one, within ±1e6 of the origin, no
    source point given two targets (exact duplicate pairs are accepted)."""
    if not rows.src:
        raise fail(path, "content", "no handles")
    src = np.array(rows.src, dtype=np.float64).reshape(-1, 3)
    dst = np.array(rows.dst, dtype=np.float64).reshape(-1, 3)
    for values, where in ((src, rows.src_where), (dst, rows.dst_where)):
        check_range(path, values, where, unit="")  # 3D handles in their own units
    order = np.lexsort(src.T[::-1])
    same = (src[order][1:] == src[order][:-1]).all(axis=1)
    differ = (dst[order][1:] != dst[order][:-1]).any(axis=1)
    conflict = same & differ
    if conflict.any():
        k = int(np.argmax(conflict))
        i, j = sorted((int(order[k]), int(order[k + 1])))
        raise InputFileError(
            f"{path}: {rows.src_where[i]} and {rows.src_where[j]} are the same point "
            f"{src[i].tolist()} with different targets {dst[i].tolist()} and {dst[j].tolist()}"
        )
    return src, dst
