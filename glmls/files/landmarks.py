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

**CSV** (any other suffix but ``.pts``), one of these tables, its columns read by the names
in its header (case aside): in any order, beside columns of other names (a landmark's
``name``), which are ignored; a header that lacks a column of its table, or names one twice,
is refused, naming the column:

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

- BigWarp's landmark CSV (no header): name, active, moving x, moving y, fixed x, fixed y;
  3D: moving x y z, fixed x y z (8 columns), as BigWarp's table saves them (fields
  quoted: a name may hold a comma); also with an id column after ``active`` (7 columns, 9
  in 3D), the layout that BigWarp's CSV loader (``LandmarkTableModel.loadCsvHelper``)
  parses.

**BigWarp's landmark JSON** (``.json``): ``{"type": "BigWarpLandmarks", "numDimensions":
3, "movingPoints": [[x, y, z], ...], "fixedPoints": [...], "active": [true, ...],
"names": [...]}``, as BigWarp exports it, or the same object under ``"landmarks"`` (BigWarp's
settings file). Of both BigWarp formats, the moving points are the sources and the fixed
points the targets: glmls moves the moving image's landmarks onto the fixed ones, as
BigWarp's warped moving image does. Inactive landmarks (``false``, BigWarp's unpaired ones
among them) are skipped. BigWarp's coordinates are physical (the pixel indices times the
image's calibration, plus an ImageJ origin where there is one): 3D handles in the units of a
volume's spacing, as glmls's are; glmls's 2D handles are pixels, so those of a calibrated
2D image need dividing by its pixel size.

**3D point handles** (x, y, z) = (column, row, slice) of a volume (D, H, W), or a mesh's
coordinates: JSON ``{"src": [[x, y, z], ...], "dst": [[x, y, z], ...]}``, CSV with the
header ``src_x,src_y,src_z,dst_x,dst_y,dst_z`` (read by name, as the 2D tables: a header of
``src_z`` or ``dst_z`` is 3D), BigWarp's 3D landmarks, or a pair of
**elastix point files** (``.pts``): ``index`` (voxel indices) or ``point`` (physical
coordinates, taken as they are; for a NIfTI volume ITK's LPS world coordinates, which
:func:`glmls.files.world_to_volume` maps with ``lps=True``, :func:`elastix_physical`) on the
first line, the number of points on the second, then
one point a line, its 2 or 3 coordinates separated by blanks; both files of a pair of one
kind (:func:`elastix_indices` says whether they are indices). One file holds one side:
:func:`read_handles` takes the sources' file (elastix's moving points) and ``dst=`` the
targets' (the fixed points), the command line ``--handles`` and ``--targets``. Segments and
polylines are 2D only.

A file must hold at least one handle. A fault is an :class:`~glmls.errors.InputFileError`
naming the file and the place: ``h.json: "segments"."src"[3]: expected two [x, y] ends``,
``h.csv: line 7: expected a finite number``, also for a source segment of zero length, counts
that differ, coordinates beyond ±1e6 px and one source point or segment given two targets,
and handles of another dimension than the one expected (``ndim=`` of :func:`read_handles`).

Reference points: JSON ``{"points": [[x, y], ...]}`` or CSV with the header ``x,y`` (read
by name, as the handles' tables).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from ..core.config import check_integer
from ..core.handles3 import validate_handles3
from ..core.handleset import HandleSet
from ..errors import InputFileError
from .atomic import atomic_write
from .handle_formats import (
    KIND_HEADER,
    HandleRows,
    check_range,
    handle_set,
    json_handles,
    json_text,
    kind_csv_text,
    kind_table,
)
from .parsing import (
    Row,
    as_path,
    brief,
    by_name,
    csv_rows,
    fail,
    json_points,
    load_json,
    not_a_file,
    table,
)
from .point_formats import (
    HANDLE_HEADER_3D,
    axes,
    bigwarp_csv,
    bigwarp_json,
    elastix_kind,
    elastix_pair,
    is_bigwarp_csv,
    is_bigwarp_json,
    json_dimension,
    json_points_3d,
    points_3d,
    table_3d,
)

__all__ = [
    "HANDLE_HEADER",
    "HANDLE_HEADER_3D",
    "KIND_HEADER",
    "POINT_HEADER",
    "elastix_indices",
    "elastix_physical",
    "handle_dimension",
    "read_handle_set",
    "read_handles",
    "read_points",
    "write_handle_set",
    "write_handles",
]

HANDLE_HEADER = ["src_x", "src_y", "dst_x", "dst_y"]
POINT_HEADER = ["x", "y"]


def _point_table(path: Path, rows: list[Row]) -> HandleRows:
    handles = HandleRows()
    for (line, _), values in zip(rows, table(path, rows, 4), strict=True):
        handles.add_point(values[:2], values[2:], f"line {line}")
    return handles


#: The z columns, which make a table of points 3D, and have no place in a table of kinds.
_Z_COLUMNS = ("src_z", "dst_z")


def _csv_handles(path: Path) -> tuple[int, HandleRows]:
    rows = csv_rows(path)
    if not rows:
        raise fail(path, "content", "no handles")
    if is_bigwarp_csv(rows):
        return bigwarp_csv(path, rows)
    line, header = rows[0]
    names = {h.lower() for h in header}
    z = [name for name in _Z_COLUMNS if name in names]
    if "kind" in names and z:
        raise fail(
            path,
            f"line {line}",
            f"the header has the column {z[0]} and kind: segments and polylines are 2D "
            f"handles only (the header {','.join(KIND_HEADER)}); 3D point handles take the "
            f"header {','.join(HANDLE_HEADER_3D)}",
        )
    if "kind" in names:
        return 2, kind_table(path, by_name(path, rows, KIND_HEADER))
    if z:
        return 3, table_3d(path, by_name(path, rows, HANDLE_HEADER_3D))
    if names & set(HANDLE_HEADER):
        return 2, _point_table(path, by_name(path, rows, HANDLE_HEADER))
    raise fail(
        path,
        f"line {line}",
        f"expected the header {','.join(HANDLE_HEADER)}, {','.join(HANDLE_HEADER_3D)} or "
        f"{','.join(KIND_HEADER)} (its columns in any order, others ignored; or a BigWarp "
        f"landmark file), got {','.join(header)}",
    )


def _json_handles(path: Path) -> tuple[int, HandleRows]:
    data = load_json(path)
    if is_bigwarp_json(data):
        return bigwarp_json(path, data)
    if json_dimension(data) == 3:
        return 3, json_points_3d(path, data)
    return 2, json_handles(path, data)


def _handle_rows(path: Path, dst: str | os.PathLike | None) -> tuple[int, HandleRows]:
    """The dimension and the handles of a file (or of an elastix pair)."""
    dst = None if dst is None else as_path(dst, "dst")
    suffix = path.suffix.lower()
    if suffix == ".pts":
        if not path.is_file():  # its own fault first: the missing targets would hide it
            raise InputFileError(f"{path}: {not_a_file(path)}")
        if dst is None:
            raise fail(
                path,
                "content",
                "an elastix point file holds the sources only: give the targets' file too "
                "(dst=, or --targets on the command line)",
            )
        return elastix_pair(path, Path(dst))
    if dst is not None:
        raise InputFileError(
            f"{Path(dst)}: a file of targets goes with an elastix point file (.pts) of "
            f"sources, not with {path}"
        )
    if suffix == ".json":
        return _json_handles(path)
    return _csv_handles(path)


def _expect(path: Path, found: int, ndim: int | None, advice: str = "") -> None:
    if ndim is not None and found != ndim:
        raise fail(
            path,
            "content",
            f"{found}D handles {axes(found)}, where {ndim}D handles {axes(ndim)} are "
            f"expected{advice}",
        )


def elastix_indices(path: str | os.PathLike, *, dst: str | os.PathLike | None = None) -> bool:
    """Whether ``path`` and ``dst`` are an elastix pair of ``index`` files: voxel indices,
    which a volume's spacing (dz, dy, dx) puts at (i dx, j dy, k dz) in the handles' units;
    ``InputFileError`` for a ``.pts`` file that is not an elastix point file."""
    if Path(path).suffix.lower() != ".pts" or dst is None:
        return False
    return elastix_kind(Path(path)) == "index"


def elastix_physical(path: str | os.PathLike, *, dst: str | os.PathLike | None = None) -> bool:
    """Whether ``path`` and ``dst`` are an elastix pair of ``point`` files: ITK physical
    points, which for a NIfTI volume are world coordinates in ITK's LPS convention
    (:func:`glmls.files.world_to_volume` with ``lps=True`` maps them); ``InputFileError`` for
    a ``.pts`` file that is not an elastix point file."""
    if Path(path).suffix.lower() != ".pts" or dst is None:
        return False
    return elastix_kind(Path(path)) == "point"


def handle_dimension(path: str | os.PathLike, *, dst: str | os.PathLike | None = None) -> int:
    """The dimension of the handles in a file (or an elastix pair, ``dst`` the targets'),
    2 or 3; ``InputFileError`` for a file that cannot be read as far as that, or that holds
    no handles (of no dimension: a volume's warp would call them 2D)."""
    path = as_path(path)
    found, rows = _handle_rows(path, dst)
    if not rows.src and not rows.src_segments:
        raise fail(path, "content", "no handles")
    return found


def read_handle_set(path: str | os.PathLike, *, dst: str | os.PathLike | None = None) -> HandleSet:
    """The 2D handles of every kind (points, segments, polylines) in a handle file, checked.

    Parameters
    ----------
    path : str or os.PathLike
        A JSON, CSV or BigWarp file (the module's formats), or the sources' elastix ``.pts``.
    dst : str or os.PathLike, optional
        The targets' elastix point file, where ``path`` is the sources'.

    Returns
    -------
    glmls.HandleSet
        The points and segments, a polyline as its segments.

    Raises
    ------
    glmls.InputFileError
        Naming the place of a fault; also for 3D handles (:func:`read_handles` reads those).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from glmls.files import read_handle_set
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "h.csv"
    >>> _ = path.write_text("kind,id,src_x,src_y,dst_x,dst_y\\n"
    ...     "point,,5,5,6,5\\nsegment,a,0,0,0,1\\nsegment,a,0,9,1,9\\n")
    >>> handles = read_handle_set(path)
    >>> handles.points, handles.segments, handles.dst_segments.tolist()
    (1, 1, [[[0.0, 1.0], [1.0, 9.0]]])
    """
    path = as_path(path)
    ndim, rows = _handle_rows(path, dst)
    _expect(path, ndim, 2, ": read_handles reads 3D point handles")
    return handle_set(path, rows)


def read_handles(
    path: str | os.PathLike,
    *,
    dst: str | os.PathLike | None = None,
    ndim: int | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """(src, dst) point handles, each (N, 2) or (N, 3) float64 as the file holds them.

    ``path`` is a file of the module's formats, or an elastix point file (``.pts``) of the
    sources with ``dst`` the elastix point file of the targets. ``ndim`` (2 or 3): the
    dimension expected. ``InputFileError`` if malformed, of another dimension than
    ``ndim``, or if it holds segments or polylines, which only :func:`read_handle_set`
    returns.

    Parameters
    ----------
    path : str or os.PathLike
        The handle file (JSON, CSV, BigWarp's CSV or JSON, an elastix ``.pts``).
    dst : str or os.PathLike, optional
        The targets' elastix point file, where ``path`` is the sources'.
    ndim : {2, 3}, optional
        The dimension the handles must have.

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)
        src and dst, (N, 2) or (N, 3) float64.

    Raises
    ------
    glmls.InputFileError
        For a file that is missing or malformed, of another dimension than ``ndim``, or
        holding segments or polylines.
    TypeError, ValueError
        For an ``ndim`` that is not an integer (a bool, a string) or not 2 or 3, and
        (``TypeError``) a ``path`` or ``dst`` that is no path (None, a number).

    Examples
    --------
    >>> import json, pathlib, tempfile
    >>> from glmls.files import read_handles
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (folder / "h.json").write_text(json.dumps({"src": [[1, 2, 3]], "dst": [[2, 2, 3]]}))
    >>> src, dst = read_handles(folder / "h.json", ndim=3)
    >>> src.tolist(), dst.tolist()
    ([[1.0, 2.0, 3.0]], [[2.0, 2.0, 3.0]])
    >>> _ = (folder / "bigwarp.csv").write_text('"Pt-0","true","10","12","4","11","12","5"')
    >>> read_handles(folder / "bigwarp.csv")[1].tolist()  # the fixed points: the targets
    [[11.0, 12.0, 5.0]]
    """
    if ndim is not None:  # before the file: the error is the caller's, not the file's
        ndim = check_integer("ndim", ndim, 2, 3, what="2, 3 or None")
    path = as_path(path)
    found, rows = _handle_rows(path, dst)
    if not rows.src and not rows.src_segments:
        raise fail(path, "content", "no handles")  # of no dimension: none to compare
    _expect(path, found, ndim)
    if found == 3:
        return points_3d(path, rows)
    handles = handle_set(path, rows)
    if handles.segments:
        raise fail(
            path,
            "content",
            f"{handles.segments} segment handles (from segments or polylines) besides "
            f"{handles.points} points: read it with read_handle_set",
        )
    return np.array(handles.src), np.array(handles.dst)


def read_points(path: str | os.PathLike) -> np.ndarray:
    """Reference points from JSON ``{"points": [[x, y], ...]}`` or a CSV with header ``x,y``.

    The CSV's columns are read by name: in any order, beside columns of other names.

    Parameters
    ----------
    path : str or os.PathLike
        The file; ``.json`` is JSON, any other suffix CSV.

    Returns
    -------
    numpy.ndarray
        (K, 2) float64, K >= 1.

    Raises
    ------
    glmls.InputFileError
        For a missing or malformed file, one of no points, 3D points (a JSON point of three
        numbers, a CSV header with a ``z`` column), or a point beyond the ±1e6 px
        coordinate range (which glmls's other point files refuse too).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from glmls.files import read_points
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "points.csv"
    >>> _ = path.write_text("x,y\\n10,20\\n30,40\\n")
    >>> read_points(path).tolist()
    [[10.0, 20.0], [30.0, 40.0]]
    """
    path = as_path(path)
    if path.suffix.lower() == ".json":
        points = np.array(json_points(path, load_json(path), "points"), dtype=np.float64)
        where = [f'"points"[{k}]' for k in range(len(points))]
    else:
        rows = csv_rows(path)
        if not rows:
            raise fail(path, "content", "no points")
        line, header = rows[0]
        if "z" in (name.lower() for name in header):  # by name, z would go unread
            raise fail(
                path,
                f"line {line}",
                "expected 2D points (the header x,y), got 3D points (the header "
                f"{brief(','.join(header), 200)})",
            )
        picked = by_name(path, rows, POINT_HEADER)
        points = table(path, picked, 2)
        where = [f"line {number}" for number, _ in picked]
    if len(points) == 0:
        raise fail(path, "content", "no points")
    points = points.reshape(-1, 2)
    check_range(path, points, where)  # as the handles of a file
    return points


def write_handle_set(path: str | os.PathLike, handles: HandleSet) -> None:
    """Write 2D handles to a file that :func:`read_handle_set` reads back to the same handles.

    JSON for ``.json``, else CSV (``src_x,src_y,dst_x,dst_y``; ``kind,id,...`` with segments,
    those that join end to start as polylines), written whole or not at all.

    Parameters
    ----------
    path : str or os.PathLike
        The output file (its folders made as needed).
    handles : glmls.HandleSet
        The handles.

    Raises
    ------
    TypeError
        When ``handles`` is not a :class:`glmls.HandleSet`, or holds arrays that are no real
        numbers (one made by its constructor, which keeps what it is given).
    ValueError
        For a ``.pts`` path: an elastix point file holds one side's points only; for
        handles that :meth:`glmls.HandleSet.validate` refuses (a value that is not finite, a
        source point with two targets, ...) or none at all: no file is written.
    OSError
        When the file cannot be written (the message names ``path``).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from glmls.files import read_handle_set, write_handle_set
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "h.json"
    >>> segment = [[[5, 0], [5, 9]]]
    >>> handles = glmls.HandleSet.validate([[0, 0]], [[1, 0]], segment, segment)
    >>> write_handle_set(path, handles)
    >>> back = read_handle_set(path)
    >>> back.points, back.segments, back.dst.tolist()
    (1, 1, [[1.0, 0.0]])
    """
    if not isinstance(handles, HandleSet):
        raise TypeError(f"handles must be a HandleSet, got {type(handles).__name__}")
    # HandleSet's constructor keeps what it is given: checked as validate checks, so that
    # the file reads back (its reader refuses a NaN)
    _write_set(
        path,
        HandleSet.validate(handles.src, handles.dst, handles.src_segments, handles.dst_segments),
    )


def _write_set(path: str | os.PathLike, handles: HandleSet) -> None:
    """Write ``handles``, checked by :meth:`HandleSet.validate`, as :func:`write_handle_set`
    says."""
    path = _handle_file(path)
    if not len(handles):  # its reader refuses a file of none: it would not read back
        raise ValueError(f"{path}: no handles to write; a handle file holds one at least")
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
    """Write handles to a file that :func:`read_handles` reads back to the same handles.

    JSON for ``.json``, else CSV (``src_x,src_y,dst_x,dst_y`` or ``src_x,...,dst_z``), written
    whole or not at all; 2D handles with segments as :func:`write_handle_set` writes them.

    Parameters
    ----------
    path : str or os.PathLike
        The output file (its folders made as needed).
    src, dst : array_like
        (N, 2) or (N, 3) source and target points.
    src_segments, dst_segments : array_like, optional
        (S, 2, 2) segment handles, 2D only.

    Raises
    ------
    ValueError, TypeError
        For handles that :class:`glmls.MLS` would refuse, segments beside 3D points, and a
        ``.pts`` path (an elastix point file holds one side's points only).
    OSError
        When the file cannot be written (the message names ``path``).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from glmls.files import read_handles, write_handles
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "h3d.csv"
    >>> write_handles(path, [[1, 2, 3]], [[2, 2, 3]])
    >>> print(path.read_text().splitlines()[0])
    src_x,src_y,src_z,dst_x,dst_y,dst_z
    >>> read_handles(path)[1].tolist()
    [[2.0, 2.0, 3.0]]
    """
    path = _handle_file(path)
    if np.ndim(src) == 2 and np.shape(src)[1] == 3:
        if src_segments is not None or dst_segments is not None:
            raise ValueError("segment handles are 2D; 3D handles are points only")
        _write_3d(Path(path), *_check_3d(src, dst))
        return
    _write_set(path, HandleSet.validate(src, dst, src_segments, dst_segments))


def _handle_file(path: str | os.PathLike) -> Path:
    """``path`` as a Path; ``ValueError`` for an elastix ``.pts``, which holds the points of
    one side only (a table written there would read back as no elastix point file)."""
    path = as_path(path)
    if path.suffix.lower() == ".pts":
        raise ValueError(
            f"{path}: an elastix point file (.pts) holds the points of one side only; write "
            "the handles as .json or .csv"
        )
    return path


def _check_3d(src: object, dst: object) -> tuple[np.ndarray, np.ndarray]:
    """3D handles as :class:`glmls.MLS` checks them (real numbers, finite, within the
    coordinate range, no source point with two targets), and at least one: what
    :func:`read_handles` reads back."""
    p, q = validate_handles3(src, dst)
    if not len(p):
        raise ValueError(f"src must be (N, 3) with N >= 1, got shape {p.shape}")
    return p, q


def _write_3d(path: Path, src: np.ndarray, dst: np.ndarray) -> None:
    if path.suffix.lower() == ".json":
        text = (
            f'{{\n  "src": {json.dumps(src.tolist())},\n  "dst": {json.dumps(dst.tolist())}\n}}\n'
        )
    else:
        lines = [",".join(HANDLE_HEADER_3D)]
        lines += [",".join(repr(float(x)) for x in (*p, *q)) for p, q in zip(src, dst, strict=True)]
        text = "\n".join(lines) + "\n"
    with atomic_write(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
