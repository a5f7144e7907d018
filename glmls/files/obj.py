"""Reading and writing OBJ meshes: the ``v`` and ``f`` lines, in the file's order.

trimesh splits an OBJ by material (``usemtl``) and joins the parts again, which duplicates
the shared vertices and reorders the faces; its texture coordinates and normals split
vertices too. glmls reads the positions (the first three numbers of a ``v`` line), the
common extension of vertex colours after them (``v x y z r g b``, or ``r g b a``: floats in
0..1, scaled by 255 and rounded; whole numbers 0..255 where one exceeds 1) and the vertex
indices of an ``f`` (or ``fo``) line (``i``, ``i/t``, ``i//n``, ``i/t/n``; negative: from
the last vertex so far), a ``#`` comment ending any line. The rest (texture coordinates,
normals, materials, groups, lines) it does not keep, and names. Faults are ``ValueError``s
that say the line, which :func:`glmls.files.meshes.read_mesh` reports naming the file.
"""

from __future__ import annotations

import numpy as np

from .ply import MeshContent

__all__ = ["obj_text", "read_obj"]

#: The statements glmls does not keep, and how a message names them.
_UNKEPT = {
    "vt": "texture coordinates",
    "vn": "normals",
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
    """The vertices, faces, vertex colours and what else there is of an OBJ file's bytes;
    ``ValueError`` saying the line of a vertex of fewer than 3 numbers, a face of fewer than
    3 vertices, a vertex index that is not one or names no vertex, or a colour out of
    range."""
    text = content.decode("utf-8-sig", errors="replace").replace("\\\r\n", " ").replace("\\\n", " ")
    rows: list[list[str]] = []
    places: list[int] = []
    faces: list[tuple[int, int, int]] = []
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
        elif fields[0] in ("f", "fo"):  # fo: an old name of f
            corners = [_obj_index(number, field, len(rows)) for field in fields[1:]]
            if len(corners) < 3:
                raise ValueError(f"line {number}: a face of fewer than 3 vertices")
            faces += [(corners[0], corners[i], corners[i + 1]) for i in range(1, len(corners) - 1)]
        elif fields[0] in _UNKEPT and fields[1:] not in (["off"], ["0"]):  # s off: none
            unkept[_UNKEPT[fields[0]]] = None
    try:
        vertices = np.array([row[:3] for row in rows], dtype=np.float64).reshape(-1, 3)
    except ValueError as error:
        raise ValueError(f"not a readable .obj mesh: {error}") from None
    colors = _colors(rows, places, unkept)
    triangles = np.array(faces, dtype=np.int64).reshape(-1, 3)
    return MeshContent(vertices, triangles, colors, tuple(unkept))


def _colors(rows: list[list[str]], places: list[int], unkept: dict[str, None]) -> np.ndarray | None:
    """The (V, 3) or (V, 4) uint8 colours of the ``v`` lines' ``rows`` (of the file's lines
    ``places``), where every one has 6 numbers or every one 7; else None, and the colours of
    some named in ``unkept`` (a 4th number alone is a weight, not a colour)."""
    widths = {len(row) for row in rows}
    if widths <= {3, 4}:
        return None
    if widths not in ({6}, {7}):
        unkept["vertex colours (not on every vertex alike)"] = None
        return None
    try:
        values = np.array([row[3:] for row in rows], dtype=np.float64)
    except ValueError as error:
        raise ValueError(f"not a readable .obj mesh: {error}") from None
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


def _obj_index(number: int, field: str, count: int) -> int:
    """The 0-based vertex index of a face's corner ``field`` on line ``number``; ``count``
    vertices are before it, from which a negative index counts back."""
    try:
        index = int(field.split("/", 1)[0])
    except ValueError:
        raise ValueError(f"line {number}: {field!r} is no vertex index") from None
    # a positive index may name a vertex read later; beyond 2**62 none (nor int64) holds it
    if index == 0 or index < -count or index > 2**62:
        raise ValueError(
            f"line {number}: vertex {index} of a face, with {count} vertices before it"
        )
    return index - 1 if index > 0 else count + index


def obj_text(vertices: np.ndarray, faces: np.ndarray, colors: np.ndarray | None) -> str:
    """The OBJ text of a mesh: each coordinate as Python's shortest repr that reads back to
    the same float64 (any magnitude), the colours after it as c / 255 to 6 significant digits
    (which read back to the same byte: they are 1/255 apart) with alpha the 7th number of
    four channels, faces 1-based."""
    if colors is None:
        lines = [f"v {x!r} {y!r} {z!r}" for x, y, z in vertices.tolist()]
    else:
        lines = [
            f"v {x!r} {y!r} {z!r} " + " ".join(f"{c / 255:.6g}" for c in rgba)
            for (x, y, z), rgba in zip(vertices.tolist(), colors.tolist(), strict=True)
        ]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in faces.tolist()]
    return "\n".join(lines) + "\n"
