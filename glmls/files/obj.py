"""Reading and writing OBJ meshes: the ``v``, ``vt``, ``vn`` and ``f`` lines, in the file's
order.

trimesh splits an OBJ by material (``usemtl``) and joins the parts again, which duplicates
the shared vertices and reorders the faces; its texture coordinates and normals split
vertices too. glmls reads the positions (the first three numbers of a ``v`` line), the
common extension of vertex colours after them (``v x y z r g b``, or ``r g b a``: floats in
0..1, scaled by 255 and rounded; whole numbers 0..255 where one exceeds 1), the texture
coordinates (``vt u v``; ``v`` is 0 where it is missing, a third number ``w`` of a 3D
texture is not kept), the normals (``vn x y z``, as they are) and the vertex, texture and
normal indices of an ``f`` (or ``fo``) line (``i``, ``i/t``, ``i//n``, ``i/t/n``; negative:
from the last vertex, texture coordinate or normal so far), a ``#`` comment ending any line.
A face's texture coordinates are those of its corners, which may differ from its vertices'
indices (a vertex on a seam has one in each face). A face with texture indices on some of
its corners and not others is refused; where some faces have them and others not, none are
kept (and that is named). A mesh holds one normal per vertex: the normals are kept where
every corner of a vertex names the same one (or equal ones), not where a corner names none
or a vertex has different ones in its faces (a hard edge), which is named. The rest
(materials, groups, lines) it does not keep, and names. Faults are ``ValueError``s that
say the line, which :func:`glmls.files.meshes.read_mesh` reports naming the file.

The words of a line are separated by whitespace (spaces, tabs). A coordinate, texture
coordinate or colour is a decimal number of ASCII digits with an optional sign, point and
exponent (``-0.5``, ``.5``, ``1e-3``, ``1E+02``, ``-0``); an index is ASCII digits with an
optional sign (``7``, ``+7``, ``-1``). What else Python reads as a number (``1_0``, which
it takes for 10, other scripts' digits, ``0x10``) is refused, naming the line, and so is a
coordinate, texture coordinate or colour of ``nan`` or ``inf``.
"""

from __future__ import annotations

import numpy as np

from .parsing import brief, first_not_number, is_number
from .ply import MeshContent
from .ply_write import per_vertex

__all__ = ["obj_text", "read_obj"]

#: The statements glmls does not keep, and how a message names them.
_UNKEPT = {
    "mtllib": "materials",
    "usemtl": "materials",
    "g": "object and group names",
    "o": "object and group names",
    "s": "smoothing groups",
    "l": "lines",
    **dict.fromkeys(
        ("vp", "cstype", "curv", "curv2", "surf", "parm", "trim", "hole", "scrv", "sp"),
        "free-form curves and surfaces",
    ),
}


def read_obj(content: bytes) -> MeshContent:
    """The vertices, faces, vertex colours, texture coordinates and what else there is of an
    OBJ file's bytes; ``ValueError`` saying the line of a vertex of fewer than 3 numbers, a
    face of fewer than 3 vertices, an index that is not one or names no vertex (or texture
    coordinate), a face with texture indices on some corners only, or a colour out of
    range."""
    text = content.decode("utf-8-sig", errors="replace").replace("\\\r\n", " ").replace("\\\n", " ")
    rows: list[list[str]] = []
    places: list[int] = []
    textures: list[tuple[int, list[str]]] = []  # (line, the numbers) of each vt
    normals: list[tuple[int, list[str]]] = []  # (line, the numbers) of each vn
    faces: list[tuple[int, int, int]] = []
    corners_uv: list[tuple[int, int, int] | None] = []  # each triangle's, or None
    corners_n: list[tuple[int | None, ...]] = []  # each triangle's vn indices (None: none)
    face_lines: list[int] = []  # each triangle's line
    unkept: dict[str, None] = {}  # in order, once each
    for number, line in enumerate(text.splitlines(), start=1):
        fields = line.split("#", 1)[0].split()  # a comment may end a line, after its data
        if not fields:
            continue
        if fields[0] == "v":
            if len(fields) < 4:
                raise ValueError(f"line {number}: a vertex of fewer than 3 numbers")
            rows.append(fields[1:])
            places.append(number)
        elif fields[0] == "vt":
            if len(fields) < 2:
                raise ValueError(f"line {number}: a texture coordinate of no numbers")
            textures.append((number, fields[1:]))
        elif fields[0] == "vn":
            normals.append((number, fields[1:]))
        elif fields[0] in ("f", "fo"):  # fo: an old name of f
            corners = [_obj_index(number, field, len(rows)) for field in fields[1:]]
            if len(corners) < 3:
                raise ValueError(f"line {number}: a face of fewer than 3 vertices")
            fan = range(1, len(corners) - 1)
            faces += [(corners[0], corners[i], corners[i + 1]) for i in fan]
            at = _texture_indices(number, fields[1:], len(textures))
            corners_uv += [None if at is None else (at[0], at[i], at[i + 1]) for i in fan]
            n = _normal_indices(number, fields[1:], len(normals))
            corners_n += [(n[0], n[i], n[i + 1]) for i in fan]
            face_lines += [number] * len(fan)
        elif fields[0] in _UNKEPT and fields[1:] not in (["off"], ["0"]):  # s off: none
            unkept[_UNKEPT[fields[0]]] = None
    vertices = _numbers([row[:3] for row in rows], places, "vertex coordinate")
    finite = np.isfinite(vertices).all(axis=1)
    if not finite.all():
        row = int(np.argmin(finite))
        raise ValueError(f"line {places[row]}: vertex {' '.join(rows[row][:3])!r}, not finite")
    colors = _colors(rows, places, unkept)
    triangles = np.array(faces, dtype=np.int64).reshape(-1, 3)
    uv, face_uv = _texture(textures, corners_uv, face_lines, unkept)
    kept = _normals(normals, len(vertices), triangles, corners_n, face_lines, unkept)
    return MeshContent(vertices, triangles, colors, tuple(unkept), uv, face_uv, kept)


def _normal_indices(number: int, fields: list[str], count: int) -> list[int | None]:
    """The 0-based normal indices of a face's corners ``fields`` on line ``number`` (``count``
    normals before it), None for a corner of none (``i``, ``i/t``)."""
    parts = [field.split("/") for field in fields]
    return [
        _index(number, part[2], count, "normal") if len(part) > 2 and part[2] else None
        for part in parts
    ]


def _normals(
    normals: list[tuple[int, list[str]]],
    count: int,
    faces: np.ndarray,
    corners: list[tuple[int | None, ...]],
    lines: list[int],
    unkept: dict[str, None],
) -> np.ndarray | None:
    """The (``count``, 3) vertex normals of the ``vn`` lines, one per vertex, where every
    corner of the triangles ``faces`` (of the file's ``lines``) names one and all the
    corners of a vertex name the same (the same ``vn``, or equal values); a vertex of no
    face gets the ``vn`` of its own index where the file has one per vertex and every corner
    names that of its vertex (as glmls writes them, and a point cloud's), else 0. Else None,
    and why named in ``unkept``: ``vn`` lines no face names, corners without one, or a
    vertex with different ones in its faces (a hard edge). ``ValueError`` saying the line of
    a normal that is not 3 finite numbers or of a face that names one beyond the last."""
    if not normals:
        return None
    named = [[k is not None for k in corner] for corner in corners]
    if not any(map(any, named)) and (len(faces) or len(normals) != count):
        unkept["normals"] = None  # no face names them, nor are they one per point
        return None
    if not all(map(all, named)):
        unkept["normals (not on every face)"] = None
        return None
    indices = np.array(corners, dtype=np.int64).reshape(-1, 3)
    _check_named(indices, len(normals), lines, "normal")
    values = np.zeros((len(normals), 3))
    for row, (number, given) in enumerate(normals):
        # decimal numbers as every other line's (not Python's "1_0" or other scripts' digits)
        numbers = [float(v) for v in given] if first_not_number(given) is None else []
        if len(numbers) != 3 or not np.isfinite(numbers).all():
            raise ValueError(f"line {number}: normal {' '.join(given)!r}, not 3 finite numbers")
        values[row] = numbers
    if len(values) == count and (indices == faces).all():
        return values  # one per vertex, in order: those of vertices of no face too
    out = per_vertex(count, faces, values, indices)
    if out is None:
        unkept["normals (a vertex has several: hard edges)"] = None
    return out


def _check_named(indices: np.ndarray, count: int, lines: list[int], what: str) -> None:
    """``ValueError`` saying the line (of the file's ``lines``, one per row of ``indices``)
    of the first face whose (F, 3) 0-based ``indices`` name a ``what`` past the ``count`` in
    the file: a positive index may name one read later, or none."""
    beyond = (indices >= count).any(axis=1)
    if beyond.any():
        row = int(np.argmax(beyond))
        raise ValueError(
            f"line {lines[row]}: {what} {int(indices[row].max()) + 1} of a face, "
            f"with {count} in the file"
        )


def _texture_indices(number: int, fields: list[str], count: int) -> list[int] | None:
    """The 0-based texture indices of a face's corners ``fields`` on line ``number`` (``count``
    texture coordinates before it), or None for a face of none; ``ValueError`` for a face of
    some."""
    parts = [field.split("/") for field in fields]
    given = [len(part) > 1 and part[1] != "" for part in parts]
    if not any(given):
        return None
    if not all(given):
        raise ValueError(
            f"line {number}: a face with texture coordinates on some corners and not others"
        )
    return [_index(number, part[1], count, "texture coordinate") for part in parts]


def _texture(
    textures: list[tuple[int, list[str]]],
    corners: list[tuple[int, int, int] | None],
    lines: list[int],
    unkept: dict[str, None],
) -> tuple[np.ndarray | None, np.ndarray | None]:
    """(the (T, 2) texture coordinates of the ``vt`` lines, the (F, 3) indices of the
    triangles' corners into them) where every triangle (of the file's ``lines``) has them;
    else (None, None), and the ``vt`` lines named in ``unkept`` where there are some.
    ``ValueError`` saying the line of a coordinate that is not a finite number or of a face
    that names one beyond the last."""
    given = [at is not None for at in corners]
    if not any(given):
        if textures:
            unkept["texture coordinates"] = None
        return None, None
    if not all(given):
        unkept["texture coordinates (not on every face)"] = None
        return None, None
    face_uv = np.array(corners, dtype=np.int64)
    _check_named(face_uv, len(textures), lines, "texture coordinate")
    uv = np.zeros((len(textures), 2))
    for row, (number, values) in enumerate(textures):
        numbers = [float(v) if is_number(v) else np.nan for v in values[:3]]
        if not np.isfinite(numbers).all():
            raise ValueError(
                f"line {number}: texture coordinate {' '.join(values)!r}, not finite numbers"
            )
        uv[row, : min(len(numbers), 2)] = numbers[:2]  # a missing v is 0
        if len(numbers) > 2 and numbers[2] != 0:
            unkept["3D texture coordinates (w)"] = None
    return uv, face_uv


def _colors(rows: list[list[str]], places: list[int], unkept: dict[str, None]) -> np.ndarray | None:
    """The (V, 3) or (V, 4) uint8 colours of the ``v`` lines' ``rows`` (of the file's lines
    ``places``), where every one has 6 numbers or every one 7; else None, and the colours of
    some named in ``unkept`` (a 4th number alone is a weight, not a colour: named there
    where one is not 1)."""
    widths = {len(row) for row in rows}
    if widths <= {3, 4}:
        weights = [row[3] for row in rows if len(row) == 4]
        if weights and (_numbers([weights], places[:1], "vertex weight") != 1.0).any():
            unkept["vertex weights (w)"] = None  # a rational curve's: 1 by default
        return None
    if widths not in ({6}, {7}):
        unkept["vertex colours (not on every vertex alike)"] = None
        return None
    values = _numbers([row[3:] for row in rows], places, "vertex colour")
    # whole numbers 0..255 with one above 1: bytes, as some tools write them
    whole = bool((values == np.round(values)).all() and (values > 1).any())
    high = 255.0 if whole else 1.0
    bad = ~((values >= 0) & (values <= high))  # NaN too
    if bad.any():
        row, column = np.argwhere(bad)[0]
        raise ValueError(
            f"line {places[row]}: vertex colour {rows[row][3 + column]}, not in 0..1 "
            "(or whole numbers 0..255)"
        )
    return np.rint(values * (255.0 / high)).astype(np.uint8)


def _numbers(rows: list[list[str]], places: list[int], what: str) -> np.ndarray:
    """The ``rows`` (of equal lengths; on the file's lines ``places``) as float64;
    ``ValueError`` saying the line of a word that is not a decimal number."""
    width = len(rows[0]) if rows else 0
    words = [word for row in rows for word in row]
    bad = first_not_number(words)
    if bad is not None:
        raise ValueError(f"line {places[bad // width]}: {what} {brief(words[bad])}, not a number")
    return np.array(words, dtype=np.float64).reshape(-1, width if rows else 3)


def _obj_index(number: int, field: str, count: int) -> int:
    """The 0-based vertex index of a face's corner ``field`` on line ``number``; ``count``
    vertices are before it, from which a negative index counts back."""
    return _index(number, field.split("/", 1)[0], count, "vertex")


def _index(number: int, field: str, count: int, what: str) -> int:
    """The 0-based index ``field`` of a ``what`` on line ``number``; ``count`` are before it,
    from which a negative index counts back."""
    if not is_number(field, integer=True):
        raise ValueError(f"line {number}: {brief(field)} is no {what} index")
    index = int(field)
    # a positive index may name one read later; beyond 2**62 none (nor int64) holds it
    if index == 0 or index < -count or index > 2**62:
        plural = "vertices" if what == "vertex" else f"{what}s"
        raise ValueError(
            f"line {number}: {what} {index} of a face, with {count} {plural} before it"
        )
    return index - 1 if index > 0 else count + index


def obj_text(
    vertices: np.ndarray,
    faces: np.ndarray,
    colors: np.ndarray | None,
    uv: np.ndarray | None = None,
    face_uv: np.ndarray | None = None,
    normals: np.ndarray | None = None,
) -> str:
    """The OBJ text of a mesh: each coordinate as Python's shortest repr that reads back to
    the same float64 (any magnitude), the colours after it as c / 255 to 6 significant digits
    (which read back to the same byte: they are 1/255 apart) with alpha the 7th number of
    four channels, the texture coordinates ``uv`` as ``vt u v`` and the vertex ``normals`` as
    ``vn x y z`` (shortest reprs too, one per vertex: the vertex's own index), faces 1-based
    (``f a/ta b/tb c/tc`` with ``face_uv``, ``f a//a b//b c//c`` with normals,
    ``f a/ta/a b/tb/b c/tc/c`` with both)."""
    if colors is None:
        lines = [f"v {x!r} {y!r} {z!r}" for x, y, z in vertices.tolist()]
    else:
        lines = [
            f"v {x!r} {y!r} {z!r} " + " ".join(f"{c / 255:.6g}" for c in rgba)
            for (x, y, z), rgba in zip(vertices.tolist(), colors.tolist(), strict=True)
        ]
    if uv is not None and face_uv is not None:
        lines += [f"vt {u!r} {v!r}" for u, v in uv.tolist()]
    if normals is not None:
        lines += [f"vn {x!r} {y!r} {z!r}" for x, y, z in normals.tolist()]
    at = (faces + 1).tolist()  # 1-based; a vertex's normal is the vn of its own index
    if uv is None or face_uv is None:
        form = "f {0} {1} {2}" if normals is None else "f {0}//{0} {1}//{1} {2}//{2}"
        lines += [form.format(*f) for f in at]
    else:
        form = "f {0}/{3} {1}/{4} {2}/{5}"
        if normals is not None:
            form = "f {0}/{3}/{0} {1}/{4}/{1} {2}/{5}/{2}"
        lines += [form.format(*f, *t) for f, t in zip(at, (face_uv + 1).tolist(), strict=True)]
    return "\n".join(lines) + "\n"
