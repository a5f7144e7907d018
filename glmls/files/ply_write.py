"""Writing PLY meshes: binary little-endian, float32 vertices with their uchar colours,
float32 texture coordinates (``s``, ``t``) and float32 normals (``nx``, ``ny``, ``nz``), int32
triangles.

PLY holds one texture coordinate per vertex. A mesh whose faces give a vertex several (a
seam, as an OBJ file holds it: ``f v/vt``) has none that PLY can hold: it is written without
them, which :func:`vertex_uv` tells beforehand.
"""

from __future__ import annotations

import numpy as np

from .ply import COLORS

__all__ = ["per_vertex", "ply_bytes", "vertex_uv"]


def vertex_uv(
    count: int, faces: np.ndarray, uv: np.ndarray | None, face_uv: np.ndarray | None
) -> np.ndarray | None:
    """The (``count``, 2) texture coordinates of the vertices where every corner of a vertex
    has the same one (equal values: indices into ``uv`` may differ), (0, 0) for a vertex of
    no face; None where a vertex has several (a seam) or there are none."""
    if uv is None or face_uv is None:
        return None
    return per_vertex(count, faces, uv, face_uv)


def per_vertex(
    count: int, faces: np.ndarray, values: np.ndarray, corners: np.ndarray
) -> np.ndarray | None:
    """The (``count``, K) values of the vertices, from (N, K) ``values`` and the (F, 3)
    indices ``corners`` into them of each face's corners, where every corner of a vertex has
    the same one (equal values: the indices may differ); zeros for a vertex of no face; None
    where a vertex has several."""
    vertices, at = faces.ravel(), values[corners.ravel()]
    out = np.zeros((count, values.shape[1]))
    out[vertices] = at  # one of each vertex's corners; then every one checked against it
    return out if (out[vertices] == at).all() else None


def ply_bytes(
    vertices: np.ndarray,
    faces: np.ndarray,
    colors: np.ndarray | None,
    uv: np.ndarray | None = None,
    normals: np.ndarray | None = None,
) -> bytes:
    """A binary PLY file of float32 vertices, their uchar colours (``red``, ``green``,
    ``blue``, and ``alpha`` for four channels), their float32 texture coordinates ``uv``
    ((V, 2), as ``s`` and ``t``: :func:`vertex_uv`), their float32 ``normals`` ((V, 3), as
    ``nx``, ``ny``, ``nz``) and triangles (a ``face`` element only where there are some: a
    point cloud has none)."""
    fields = [("x", "<f4"), ("y", "<f4"), ("z", "<f4")]
    if colors is not None:
        fields += [(name, "u1") for name in COLORS[: colors.shape[1]]]
    if uv is not None:
        fields += [("s", "<f4"), ("t", "<f4")]
    if normals is not None:
        fields += [(name, "<f4") for name in ("nx", "ny", "nz")]
    rows = np.empty(len(vertices), np.dtype(fields))
    for axis, name in enumerate("xyz"):
        rows[name] = vertices[:, axis]
    if colors is not None:
        for channel in range(colors.shape[1]):
            rows[COLORS[channel]] = colors[:, channel]
    if uv is not None:
        rows["s"], rows["t"] = uv[:, 0], uv[:, 1]
    if normals is not None:
        rows["nx"], rows["ny"], rows["nz"] = normals.T
    header = ["ply", "format binary_little_endian 1.0", f"element vertex {len(vertices)}"]
    header += [f"property {'float' if kind == '<f4' else 'uchar'} {n}" for n, kind in fields]
    body = [rows.tobytes()]
    if len(faces):
        header += [f"element face {len(faces)}", "property list uchar int vertex_indices"]
        triangles = np.empty(len(faces), np.dtype([("n", "u1"), ("i", "<i4", (3,))]))
        triangles["n"], triangles["i"] = 3, faces
        body.append(triangles.tobytes())
    return ("\n".join([*header, "end_header"]) + "\n").encode("ascii") + b"".join(body)
