"""Reading PLY meshes: the vertices' x, y, z, their colours, texture coordinates and normals
and the faces, in the file's order (:mod:`glmls.files.ply_write` writes them).

A PLY file (ASCII, or binary of either byte order) is a header of elements, each a count of
rows of properties (scalars, or lists with a count before their items), then the rows of
each element in turn. glmls reads every element so as to find the vertices (``x``, ``y``,
``z`` of ``vertex``), their colours (``red``, ``green``, ``blue`` and ``alpha`` if there:
uchar as they are, other integers 0..255 too, floats 0..1 scaled by 255 and rounded), their
texture coordinates (the first pair of ``s``, ``t``; ``u``, ``v``; ``texture_u``,
``texture_v``; ``texture_s``, ``texture_t``: one per vertex), their normals (``nx``, ``ny``,
``nz``, or ``normal_x``, ``normal_y``, ``normal_z``: as they are, not scaled to unit length)
and the faces (the list ``vertex_indices`` or ``vertex_index`` of ``face``); the rest (a
face's own ``texcoord`` list, face colours and normals, vertex normals of some axes only,
other properties and elements) glmls does not keep, and names. A face of more than three
vertices is a fan from its first vertex, in its place among the faces; a face of fewer is
refused, and so is an ASCII file of more values than the header's counts of rows take, a
face element whose list of vertex indices is not found (none, or several lists of other
names), faces in another element (``tristrips``) and a colour out of its range: faces not
read are never dropped silently. Faults are ``ValueError``s that say where, which
:func:`glmls.files.meshes.read_mesh` reports naming the file.

An ASCII body is words separated by whitespace (spaces, tabs, line ends). A value of a
``float`` or ``double`` property is a decimal number of ASCII digits with an optional sign,
point and exponent (``-0.5``, ``.5``, ``1e-3``, ``1E+02``, ``nan`` and ``inf`` too, refused
where a value must be finite); a value of an integer property (``uchar``, ``int`` and the
rest, a list's count too) is a plain decimal integer, ASCII digits with an optional sign
(``7``, ``+7``, ``-1``; a count not negative), not ``7.0`` or ``1e2``. What else Python reads
as a number (``1_0``, which it takes for 10, other scripts' digits) is refused, naming the
element, the row and the property.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from .parsing import brief, first_not_number, is_number

__all__ = ["COLORS", "MeshContent", "fan_triangles", "read_ply"]

#: PLY's scalar types and their NumPy codes (without the byte order).
_TYPES = {
    "char": "i1",
    "int8": "i1",
    "uchar": "u1",
    "uint8": "u1",
    "short": "i2",
    "int16": "i2",
    "ushort": "u2",
    "uint16": "u2",
    "int": "i4",
    "int32": "i4",
    "uint": "u4",
    "uint32": "u4",
    "float": "f4",
    "float32": "f4",
    "double": "f8",
    "float64": "f8",
}
_ORDERS = {"ascii": "", "binary_little_endian": "<", "binary_big_endian": ">"}
_FACE_LISTS = ("vertex_indices", "vertex_index")
#: The vertex colour properties, in the order of their channels.
COLORS = ("red", "green", "blue", "alpha")
#: The triples of vertex properties that hold a normal (x, y, z), the first found read.
_NORMAL_TRIPLES = (("nx", "ny", "nz"), ("normal_x", "normal_y", "normal_z"))
_NORMALS = tuple(name for triple in _NORMAL_TRIPLES for name in triple)
#: The pairs of vertex properties that hold a texture coordinate (u, v), the first found read.
_UV_PAIRS = (("s", "t"), ("u", "v"), ("texture_u", "texture_v"), ("texture_s", "texture_t"))
_TEXTURE = (*(name for pair in _UV_PAIRS for name in pair), "texcoord")


class MeshContent(NamedTuple):
    """What a reader of a mesh format reads: the parts a :class:`~glmls.Mesh` holds and the names
    of those of the file it does not."""

    vertices: np.ndarray  # (V, 3) float64
    faces: np.ndarray  # (F, 3) int64
    colors: np.ndarray | None  # (V, 3) or (V, 4) uint8
    unkept: tuple[str, ...]  # what else the file holds, for a message
    uv: np.ndarray | None = None  # (T, 2) float64 texture coordinates
    face_uv: np.ndarray | None = None  # (F, 3) int64 indices into uv of the faces' corners
    normals: np.ndarray | None = None  # (V, 3) float64 vertex normals, one per vertex


@dataclass
class _Property:
    name: str
    kind: str  # the NumPy code of a scalar, or of a list's items
    count: str | None = None  # a list's count type; None for a scalar


@dataclass
class _Element:
    name: str
    rows: int
    properties: list[_Property] = field(default_factory=list)


def _scalar(word: str) -> str:
    if word not in _TYPES:
        raise ValueError(f"unknown PLY type {word!r}")
    return _TYPES[word]


def _header(content: bytes) -> tuple[str, list[_Element], int]:
    """(the byte order code, or "" for ASCII; the elements; where the rows begin)."""
    # the line end_header itself: a comment may name it before
    found = re.search(rb"^end_header[ \t]*\r?$", content, re.MULTILINE)
    if not content.startswith(b"ply") or found is None:
        raise ValueError("no PLY header (ply ... end_header)")
    end = found.start()
    start = content.find(b"\n", end)
    if start < 0:
        raise ValueError("nothing after the header")
    order, elements = None, []
    for raw in content[:end].decode("latin-1").splitlines()[1:]:
        words = raw.split()
        if not words or words[0] in ("comment", "obj_info"):
            continue
        if words[0] == "format" and len(words) == 3 and words[1] in _ORDERS:
            order = _ORDERS[words[1]]
        elif (
            words[0] == "element" and len(words) == 3 and words[2].isascii() and words[2].isdigit()
        ):
            elements.append(_Element(words[1], int(words[2])))
        elif words[0] == "property" and elements and len(words) == 5 and words[1] == "list":
            elements[-1].properties.append(
                _Property(words[4], _scalar(words[3]), _scalar(words[2]))
            )
        elif words[0] == "property" and elements and len(words) == 3:
            elements[-1].properties.append(_Property(words[2], _scalar(words[1])))
        else:
            raise ValueError(f"a header line PLY does not have: {raw.strip()[:60]!r}")
    for element in elements:  # which column is x? (the last read would win)
        names = [p.name for p in element.properties]
        twice = next((name for k, name in enumerate(names) if name in names[:k]), None)
        if twice is not None:
            raise ValueError(f"element {element.name!r} declares property {twice!r} twice")
    if order is None:
        raise ValueError("no 'format ascii|binary_little_endian|binary_big_endian 1.0' line")
    return order, elements, start + 1


def _fixed_dtype(element: _Element, order: str, lengths: int) -> np.dtype:
    """The record of a row whose lists all hold ``lengths`` items."""
    parts = []
    for index, p in enumerate(element.properties):
        if p.count is None:
            parts.append((f"p{index}", order + p.kind))
        else:
            parts.append((f"n{index}", order + p.count))
            parts.append((f"p{index}", order + p.kind, (lengths,)))
    return np.dtype(parts)


def _binary_rows(content: bytes, at: int, element: _Element, order: str) -> tuple[list, int]:
    """Each property's values (an array, or a list of arrays for a list property) and where
    the next element begins."""
    lists = [i for i, p in enumerate(element.properties) if p.count is not None]
    if element.rows == 0:
        return [np.zeros(0) for _ in element.properties], at
    first = _fixed_dtype(element, order, 0)
    if lists:  # every list as long as the first row's first list: one read, checked
        head = np.frombuffer(content, first, 1, at)
        length = int(head[f"n{lists[0]}"][0])
        dtype = _fixed_dtype(element, order, length)
        if at + dtype.itemsize * element.rows <= len(content):
            rows = np.frombuffer(content, dtype, element.rows, at)
            if all((rows[f"n{i}"] == length).all() for i in lists):
                values = [rows[f"p{i}"] for i in range(len(element.properties))]
                return values, at + dtype.itemsize * element.rows
        return _binary_loop(content, at, element, order)
    rows = np.frombuffer(content, first, element.rows, at)
    return [rows[f"p{i}"] for i in range(len(element.properties))], at + first.itemsize * rows.size


def _binary_loop(content: bytes, at: int, element: _Element, order: str) -> tuple[list, int]:
    """Row by row: lists of different lengths."""
    values: list[list] = [[] for _ in element.properties]
    for _ in range(element.rows):
        for index, p in enumerate(element.properties):
            if p.count is None:
                kind = np.dtype(order + p.kind)
                values[index].append(np.frombuffer(content, kind, 1, at)[0])
                at += kind.itemsize
                continue
            counter = np.dtype(order + p.count)
            length = int(np.frombuffer(content, counter, 1, at)[0])
            at += counter.itemsize
            kind = np.dtype(order + p.kind)
            values[index].append(np.frombuffer(content, kind, length, at))
            at += kind.itemsize * length
    return values, at


def _ascii_rows(words: list[bytes], at: int, element: _Element) -> tuple[list, int]:
    """As :func:`_binary_rows`, from the whitespace-separated words of an ASCII body;
    ``ValueError`` naming the row and property of a word that is not a number of its type."""
    width = len(element.properties)
    if element.rows and all(p.count is None for p in element.properties):
        block = words[at : at + element.rows * width]
        if len(block) < element.rows * width:
            raise ValueError(f"the rows of {element.name!r} end early")
        _check_columns(
            block, [(f"property {p.name!r}", _integer(p.kind)) for p in element.properties]
        )
        table = np.array(block, dtype=np.float64).reshape(element.rows, width)
        return list(table.T), at + element.rows * width
    fixed = _ascii_fixed(words, at, element)
    if fixed is not None:
        return fixed
    values: list[list] = [[] for _ in element.properties]
    for row in range(element.rows):
        for index, p in enumerate(element.properties):
            if p.count is None:
                _check_columns([words[at]], [(f"property {p.name!r}", _integer(p.kind))], row)
                values[index].append(float(words[at]))
                at += 1
                continue
            length = _count(words[at], row, p)
            items = words[at + 1 : at + 1 + length]
            _check_columns(items, [(f"list {p.name!r}", _integer(p.kind))] * len(items), row)
            values[index].append(np.array(items, dtype=np.float64))
            at += 1 + length
    if at > len(words):
        raise ValueError(f"the rows of {element.name!r} end early")
    return [v if element.properties[i].count else np.array(v) for i, v in enumerate(values)], at


def _ascii_fixed(words: list[bytes], at: int, element: _Element) -> tuple[list, int] | None:
    """:func:`_ascii_rows` at once where every row is as long as the first (its lists of
    the same lengths, as a mesh of triangles alone has them); None where they are not."""
    spans, start = [], at
    columns: list[tuple[str, bool]] = []  # each column's (name, integer type)
    for p in element.properties:  # the first row's columns: (count column or None, width)
        if start >= len(words):
            return None
        length = 0 if p.count is None else _count(words[start], 0, p)
        spans.append((length, start - at))
        start += 1 if p.count is None else 1 + length
        if p.count is None:
            columns.append((f"property {p.name!r}", _integer(p.kind)))
        else:
            columns += [(f"the count of list {p.name!r}", True)]
            columns += [(f"list {p.name!r}", _integer(p.kind))] * length
    width = start - at
    block = words[at : at + element.rows * width]
    if element.rows == 0 or len(block) < element.rows * width:
        return None
    try:
        table = np.array(block, dtype=np.float64).reshape(element.rows, width)
    except ValueError:  # rows of other lengths, or a word that is no number: named row by row
        return None
    values: list = []
    for p, (length, column) in zip(element.properties, spans, strict=True):
        if p.count is None:
            values.append(table[:, column])
            continue
        if (table[:, column] != length).any():
            return None
        values.append(table[:, column + 1 : column + 1 + length])
    _check_columns(block, columns)  # the rows line up: each word is of its column
    return values, at + element.rows * width


def _integer(kind: str) -> bool:
    """Whether the NumPy code ``kind`` is of an integer type (its words plain integers)."""
    return kind[0] in "iu"


def _word(word: bytes) -> str:
    return brief(word.decode("utf-8", "backslashreplace"))


def _count(word: bytes, row: int, p: _Property) -> int:
    """The count of items of the list ``p`` in ``row``: a whole number, not negative."""
    if not is_number(word, integer=True) or int(word) < 0:
        raise ValueError(f"row {row}, the count of list {p.name!r}: {_word(word)}, not a count")
    return int(word)


def _check_columns(block: list[bytes], columns: list[tuple[str, bool]], first: int = 0) -> None:
    """``ValueError`` naming the row (``first`` the first) and column of the first word of
    ``block``, rows of one word per column (name, integer type), that is not a decimal number
    (:func:`glmls.files.parsing.is_number`), or not an integer in an integer column."""
    width = len(columns)
    faults = []
    for column, (_, integer) in enumerate(columns):
        row = first_not_number(block[column::width], integer=integer)
        if row is not None:
            faults.append((row, column))
    if faults:
        row, column = min(faults)
        name, integer = columns[column]
        kind = "an integer" if integer else "a number"
        raise ValueError(
            f"row {first + row}, {name}: {_word(block[row * width + column])}, not {kind}"
        )


def _indices(values: np.ndarray, where: str) -> np.ndarray:
    """``values`` as int64 vertex indices; ``ValueError`` (``where`` before it) for one that is
    not a whole number, or too large for int64, which the cast would turn into another index
    silently."""
    if values.dtype.kind != "f":
        return values.astype(np.int64)
    if (values != np.round(values)).any():  # NaN too
        raise ValueError(f"{where}vertex indices that are not whole numbers")
    huge = np.abs(values) >= 2.0**62  # infinities too
    if huge.any():
        raise ValueError(f"{where}vertex index {values[huge][0]:g}, beyond any vertex")
    return values.astype(np.int64)


def fan_triangles(polygons: list) -> np.ndarray:
    """(F, 3) int64 triangles of polygons (vertex index sequences), each polygon a fan from
    its first vertex in its place; ``ValueError`` naming a face of fewer than 3 vertices."""
    triangles = []
    for index, polygon in enumerate(polygons):
        corners = np.asarray(polygon).ravel()
        if len(corners) < 3:
            raise ValueError(f"face {index}: a face of {len(corners)} vertices, not a polygon")
        corners = _indices(corners, f"face {index}: ")
        for k in range(1, len(corners) - 1):
            triangles.append((corners[0], corners[k], corners[k + 1]))
    return np.array(triangles, dtype=np.int64).reshape(-1, 3)


def _face_list(elements: list[_Element], face: dict[str, object]) -> str | None:
    """The name of the face element's list of vertex indices; None for a file of no faces.
    ``ValueError`` for faces that are there but not found, which would be dropped silently:
    a face element of rows but no such list, or faces in another element (``tristrips``)."""
    faces = [e for e in elements if e.name == "face"]
    lists = [p.name for e in faces for p in e.properties if p.count]
    name = next((n for n in _FACE_LISTS if n in face), lists[0] if len(lists) == 1 else None)
    if name is None and sum(e.rows for e in faces):
        names = ", ".join(p.name for e in faces for p in e.properties) or "none"
        raise ValueError(
            f"element 'face': no list {' or '.join(_FACE_LISTS)} of vertex indices among its "
            f"properties ({names})"
        )
    for element in elements:
        if name is None and element.rows and element.name != "vertex":
            if any(p.count and p.name in _FACE_LISTS for p in element.properties):
                raise ValueError(
                    f"element {element.name!r}: faces glmls does not read (it reads the "
                    "triangles and polygons of element 'face')"
                )
    return name


def read_ply(content: bytes) -> MeshContent:
    """The vertices (V, 3) float64, faces (F, 3) int64, vertex colours and what else there is
    of a PLY file's bytes; ``ValueError`` for a file that is not one, or whose vertices have no
    x, y and z."""
    order, elements, at = _header(content)
    words = content[at:].split() if order == "" else []
    position = 0 if order == "" else at
    found: dict[str, dict[str, object]] = {}
    for element in elements:
        try:
            if order == "":
                values, position = _ascii_rows(words, position, element)
            else:
                values, position = _binary_rows(content, position, element, order)
        except IndexError:
            raise ValueError(f"element {element.name!r}: its rows end early") from None
        except ValueError as error:
            raise ValueError(f"element {element.name!r}: {error}") from None
        found[element.name] = {p.name: v for p, v in zip(element.properties, values, strict=True)}
    if order == "" and position < len(words):  # more rows than the header counts
        raise ValueError(
            f"{len(words) - position} values after the rows the header counts "
            f"({', '.join(f'{e.rows} {e.name}' for e in elements)}): a count too small?"
        )
    if order != "" and content[position:].strip():  # a trailing newline is written by some tools
        raise ValueError(
            f"{len(content) - position} bytes after the rows the header counts "
            f"({', '.join(f'{e.rows} {e.name}' for e in elements)}): a count too small?"
        )
    vertex = found.get("vertex", {})
    if not all(axis in vertex for axis in "xyz"):
        raise ValueError("no vertex element with x, y and z")
    vertices = np.stack([np.asarray(vertex[a], dtype=np.float64) for a in "xyz"], axis=1)
    colors, channels = _vertex_colors(elements, vertex)
    uv, uv_names = _vertex_scalars(elements, vertex, _UV_PAIRS, "texture coordinate")
    normals, normal_names = _vertex_scalars(elements, vertex, _NORMAL_TRIPLES, "normal")
    face = found.get("face", {})
    name = _face_list(elements, face)
    unkept = _unkept(elements, {"x", "y", "z", *channels, *uv_names, *normal_names}, name)
    faces = np.zeros((0, 3), np.int64) if name is None else _triangles(face[name])
    # a coordinate per vertex: each corner's is its vertex's
    face_uv = None if uv is None else faces
    return MeshContent(vertices, faces, colors, unkept, uv, face_uv, normals)


def _triangles(polygons: object) -> np.ndarray:
    """(F, 3) int64 fans of the face element's lists of vertex indices."""
    if isinstance(polygons, np.ndarray) and polygons.ndim == 2 and polygons.shape[1] >= 3:
        # polygons of one size: their fans at once, each in its face's place
        corners = _indices(polygons, "face ")
        steps = np.arange(1, corners.shape[1] - 1)
        fans = np.stack(
            [np.repeat(corners[:, :1], len(steps), 1), corners[:, steps], corners[:, steps + 1]],
            axis=-1,
        )
        return fans.reshape(-1, 3)
    return fan_triangles(list(polygons))  # type: ignore[call-overload]


def _vertex_scalars(
    elements: list[_Element],
    vertex: dict[str, object],
    groups: tuple[tuple[str, ...], ...],
    what: str,
) -> tuple[np.ndarray | None, tuple[str, ...]]:
    """(the (V, K) float64 values of the first of ``groups`` (K property names each) that
    are all scalars of the vertex element, or None; those names); ``ValueError`` naming the
    first vertex of a value that is not finite (as a ``what``)."""
    element = [e for e in elements if e.name == "vertex"][-1]
    scalars = {p.name for p in element.properties if p.count is None}
    names = next((group for group in groups if set(group) <= scalars), None)
    if names is None:
        return None, ()
    values = np.stack([np.asarray(vertex[name], dtype=np.float64) for name in names], axis=1)
    finite = np.isfinite(values).all(axis=1)
    if not finite.all():
        row = int(np.argmin(finite))
        raise ValueError(
            f"vertex {row}: {what} {', '.join(names)} = {values[row].tolist()}, not finite"
        )
    return values.reshape(-1, len(names)), names


def _vertex_colors(
    elements: list[_Element], vertex: dict[str, object]
) -> tuple[np.ndarray | None, tuple[str, ...]]:
    """(the (V, 3) or (V, 4) uint8 colours of the vertices, or None; the properties they are
    of). Scalars ``red``, ``green`` and ``blue`` (and ``alpha``) each: a uchar as it is,
    another integer in 0..255 too, a float in 0..1 times 255, rounded; ``ValueError`` naming
    the first vertex of another value (an ASCII file holds any number for any type)."""
    element = [e for e in elements if e.name == "vertex"][-1]  # that of ``vertex``
    kinds = {p.name: p.kind for p in element.properties if p.count is None}
    names = tuple(n for n in COLORS if n in kinds)
    if names[:3] != COLORS[:3]:
        return None, ()
    channels = []
    for name in names:
        values = np.asarray(vertex[name], dtype=np.float64)
        if kinds[name][0] == "f":
            bad, span, values = ~((values >= 0) & (values <= 1)), "0..1", values * 255.0
        else:
            bad = ~((values >= 0) & (values <= 255) & (values == np.round(values)))
            span = "0..255"
        if bad.any():
            row = int(np.argmax(bad))
            given = np.asarray(vertex[name], dtype=np.float64)[row]
            raise ValueError(f"vertex {row}: {name} {given:g}, not a colour in {span}")
        channels.append(np.rint(values).astype(np.uint8))
    return np.stack(channels, axis=1), names


def _unkept(elements: list[_Element], kept: set[str], face_list: str | None) -> tuple[str, ...]:
    """What of the file a mesh of vertices, their colours, texture coordinates and normals
    (the vertex properties ``kept``) and triangles does not hold: normals not read (a face's,
    a lone ``nx``), texture coordinates not read (a face's ``texcoord``, a lone ``u``), face
    colours, other properties and elements (those of rows)."""
    notes: dict[str, None] = {}  # in order, once each
    others: dict[str, list[str]] = {"vertex": [], "face": []}
    elsewhere = []
    for element in elements:
        if element.name not in others:
            if element.rows:
                elsewhere.append(element.name)
            continue
        if not element.rows:
            continue
        for p in element.properties:
            if p.name in kept or p.name == face_list:
                continue
            if p.name in _NORMALS:
                notes["face normals" if element.name == "face" else "normals"] = None
            elif p.name in _TEXTURE:
                notes["texture coordinates"] = None
            elif element.name == "face" and p.name in COLORS:
                notes["face colours"] = None
            else:
                others[element.name].append(p.name)
    for name, names in others.items():
        if names:
            notes[f"{name} properties {', '.join(names)}"] = None
    if elsewhere:
        notes[f"elements {', '.join(elsewhere)}"] = None
    return tuple(notes)
