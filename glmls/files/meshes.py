"""Reading and writing triangle meshes: STL through trimesh, PLY and OBJ read by glmls itself
(PLY written by trimesh).

A :class:`Mesh` is its vertices (V, 3) float64, (x, y, z) in the coordinates of the handles
that deform it, and its triangles (F, 3) of vertex indices. Reading keeps the file's
vertices in their order (none merged, none dropped) and its faces in their order, except
STL's: an STL file stores each triangle's three corners, so the corners at the same place
(equal coordinates, at any scale) are merged into one vertex, in the order of their first
corner. An OBJ file is read by glmls itself, its ``v`` and ``f`` (or
``fo``) lines, a ``#`` comment ending any line (objects, groups and materials do not split or
reorder it). Faces of more than three
vertices are split into triangles (a fan from their first vertex, in the face's place among
the faces, in OBJ and PLY alike); a face of fewer than three is refused. Only the geometry
is read and written: vertex colours, normals and texture coordinates are not kept. A point
cloud is a mesh of no faces: PLY and OBJ hold one (STL holds triangles only, and refuses
it).

Written, by the suffix: PLY (binary) and STL (binary) hold float32 coordinates, as those
formats usually do; OBJ (text) holds them exactly (each float64's shortest repr). Every fault of
a file is an :class:`~glmls.errors.InputFileError` naming it.
"""

from __future__ import annotations

import dataclasses
import io
import os
from pathlib import Path

import numpy as np

from ..core.summary import fields_repr
from ..errors import InputFileError
from .atomic import atomic_write
from .parsing import not_a_file
from .ply import read_ply

__all__ = ["MESH_SUFFIXES", "Mesh", "read_mesh", "write_mesh"]

#: The suffixes of the mesh formats.
MESH_SUFFIXES = (".ply", ".obj", ".stl")


@dataclasses.dataclass(frozen=True, eq=False, repr=False)
class Mesh:
    """A triangle mesh: vertices and faces, read-only copies.

    Parameters
    ----------
    vertices : array_like
        (V, 3) (x, y, z) rows, finite; kept as float64.
    faces : array_like
        (F, 3) vertex indices of the triangles, each in [0, V); kept as int64.

    Raises
    ------
    ValueError
        For vertices that are not (V, 3) finite numbers (V >= 1), or faces that are not
        (F, 3) indices of them.
    TypeError
        For vertices that are not real numbers (complex, strings, bools, objects), or faces
        that are not integers.

    See Also
    --------
    read_mesh, write_mesh : the files.

    Examples
    --------
    >>> mesh = glmls.Mesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    >>> mesh.vertices.shape, mesh.faces.tolist()
    ((3, 3), [[0, 1, 2]])
    """

    vertices: np.ndarray
    faces: np.ndarray

    def __post_init__(self) -> None:
        try:
            given, faces = np.asarray(self.vertices), np.asarray(self.faces)
        except ValueError:  # ragged rows
            raise ValueError("vertices and faces must be rows of 3 numbers each") from None
        if given.dtype.kind not in "iuf":  # complex would lose its imaginary part silently
            raise TypeError(f"vertices must be real numbers, got dtype {given.dtype}")
        vertices = np.array(given, dtype=np.float64)
        if vertices.ndim != 2 or vertices.shape[1] != 3 or not len(vertices):
            raise ValueError(f"vertices must be (V, 3) with V >= 1, got shape {vertices.shape}")
        if not np.isfinite(vertices).all():
            raise ValueError("vertices must be finite")
        if faces.size == 0:
            faces = faces.reshape(0, 3)
        # infinities equal their rounding but index nothing: refused with NaN and fractions
        if not np.issubdtype(faces.dtype, np.integer) and not (
            np.issubdtype(faces.dtype, np.floating)
            and np.isfinite(faces).all()
            and (faces == np.round(faces)).all()
        ):
            raise TypeError(f"faces must be integer vertex indices, got dtype {faces.dtype}")
        if faces.ndim != 2 or faces.shape[1] != 3:
            raise ValueError(f"faces must be (F, 3) triangles, got shape {faces.shape}")
        # the range before the cast to int64: a uint64 index of 2**63 must not wrap
        if len(faces) and (faces.min() < 0 or faces.max() >= len(vertices)):
            low, high = int(faces.min()), int(faces.max())
            raise ValueError(f"faces index vertices 0..{len(vertices) - 1}, got {low}..{high}")
        faces = np.array(faces, dtype=np.int64)
        vertices.flags.writeable = False
        faces.flags.writeable = False
        object.__setattr__(self, "vertices", vertices)
        object.__setattr__(self, "faces", faces)

    def __repr__(self) -> str:
        """The arrays' shapes and dtypes, not their values."""
        return fields_repr(self)


def _trimesh():
    import trimesh  # a dependency; imported where used: it is slow to import

    return trimesh


def _suffix(path: Path) -> str:
    suffix = path.suffix.lower()
    if suffix not in MESH_SUFFIXES:
        raise ValueError(
            f"{path}: unknown mesh format {suffix or '(no suffix)'}; use {', '.join(MESH_SUFFIXES)}"
        )
    return suffix


def read_mesh(path: str | os.PathLike) -> Mesh:
    """Read a triangle mesh from a PLY, OBJ or STL file.

    Parameters
    ----------
    path : str or os.PathLike
        The file; its suffix (``.ply``, ``.obj``, ``.stl``) chooses the format.

    Returns
    -------
    Mesh
        The vertices in the file's order (STL's shared corners merged) and the triangles
        (none for a point cloud): the geometry only, a file's vertex colours, normals and
        texture coordinates are not kept (``glmls.MLS.deform`` carries normals of its own).

    Raises
    ------
    InputFileError
        Naming the file: missing, unreadable, an unknown suffix, not a mesh of that format,
        no vertices, or coordinates that are not finite.

    See Also
    --------
    write_mesh : the other way.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "sphere.obj"
    >>> glmls.write_mesh(path, glmls.data.sphere())
    >>> mesh = glmls.read_mesh(path)
    >>> mesh.vertices.shape, mesh.faces.shape
    ((162, 3), (320, 3))
    """
    path = Path(path)
    try:
        suffix = _suffix(path)
    except ValueError as error:
        raise InputFileError(str(error)) from None
    if not path.is_file():
        raise InputFileError(f"{path}: {not_a_file(path)}")
    try:
        content = path.read_bytes()
    except OSError as error:
        raise InputFileError(f"{path}: cannot read: {error.strerror or error}") from None
    if suffix == ".obj":
        return _read_obj(path, content)
    if suffix == ".ply":
        return _read_ply(path, content)
    trimesh = _trimesh()
    try:
        loaded = _load(trimesh, content, suffix, "mesh")
    except Exception as error:  # trimesh's parsers raise many kinds on a malformed file
        raise InputFileError(f"{path}: not a readable {suffix} mesh: {error}") from None
    if not isinstance(loaded, trimesh.Trimesh) or len(loaded.vertices) == 0:
        raise InputFileError(f"{path}: no mesh vertices in it")
    if not np.isfinite(loaded.vertices).all():
        raise InputFileError(f"{path}: vertices must be finite")
    corners = np.asarray(loaded.vertices, dtype=np.float64)[np.asarray(loaded.faces)]
    try:
        return Mesh(*_merge_corners(corners.reshape(-1, 3)))
    except (TypeError, ValueError) as error:
        raise InputFileError(f"{path}: {error}") from None


def _merge_corners(corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(vertices, faces) of an STL's triangle corners (3F, 3): corners of equal coordinates
    one vertex, the vertices in the order of their first corner. Equal exactly, at any scale:
    trimesh's merge rounds to 1e-8, which joins the vertices of a mesh of that size (in
    metres) and overflows int64 beyond 1e11."""
    places = corners + 0.0  # -0.0 and 0.0 are one place
    _, first, inverse = np.unique(places, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(first)
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    return places[first[order]], rank[inverse.reshape(-1)].reshape(-1, 3)


def _read_obj(path: Path, content: bytes) -> Mesh:
    """The mesh of an OBJ file's ``v`` and ``f`` lines, in the file's order.

    trimesh splits an OBJ by material (``usemtl``) and joins the parts again, which
    duplicates the shared vertices and reorders the faces; its texture coordinates and normals
    split vertices too. Only the positions (the first three numbers of a ``v`` line) and the
    vertex indices of an ``f`` line (``i``, ``i/t``, ``i//n``, ``i/t/n``; negative: from the
    last vertex so far) are geometry, so those are all that is read."""
    text = content.decode("utf-8-sig", errors="replace").replace("\\\r\n", " ").replace("\\\n", " ")
    vertices: list[list[str]] = []
    faces: list[tuple[int, int, int]] = []
    for number, line in enumerate(text.splitlines(), start=1):
        fields = line.split("#", 1)[0].split()  # a comment may end a line, after its data
        if not fields or fields[0] not in ("v", "f", "fo"):  # fo: an old name of f
            continue  # normals, texture coordinates, groups, materials, lines
        if fields[0] == "v":
            if len(fields) < 4:
                raise InputFileError(f"{path}: line {number}: a vertex of fewer than 3 numbers")
            vertices.append(fields[1:4])
            continue
        corners = [_obj_index(path, number, field, len(vertices)) for field in fields[1:]]
        if len(corners) < 3:
            raise InputFileError(f"{path}: line {number}: a face of fewer than 3 vertices")
        faces += [(corners[0], corners[i], corners[i + 1]) for i in range(1, len(corners) - 1)]
    if not vertices:
        raise InputFileError(f"{path}: no mesh vertices in it")
    try:
        coordinates = np.array(vertices, dtype=np.float64)
    except ValueError as error:
        raise InputFileError(f"{path}: not a readable .obj mesh: {error}") from None
    try:
        return Mesh(coordinates, np.array(faces, dtype=np.int64).reshape(-1, 3))
    except (TypeError, ValueError) as error:
        raise InputFileError(f"{path}: {error}") from None


def _read_ply(path: Path, content: bytes) -> Mesh:
    """The mesh of a PLY file, in the file's order (:mod:`glmls.files.ply`: trimesh reorders
    the faces of a mix of triangles and polygons, and refuses them in a binary file)."""
    try:
        vertices, faces = read_ply(content)
    except ValueError as error:
        raise InputFileError(f"{path}: not a readable .ply mesh: {error}") from None
    if not len(vertices):
        raise InputFileError(f"{path}: no mesh vertices in it")
    try:
        return Mesh(vertices, faces)
    except (TypeError, ValueError) as error:
        raise InputFileError(f"{path}: {error}") from None


def _obj_index(path: Path, number: int, field: str, count: int) -> int:
    """The 0-based vertex index of a face's corner ``field`` on line ``number``; ``count``
    vertices are before it, from which a negative index counts back."""
    try:
        index = int(field.split("/", 1)[0])
    except ValueError:
        raise InputFileError(f"{path}: line {number}: {field!r} is no vertex index") from None
    # a positive index may name a vertex read later; beyond 2**62 none (nor int64) holds it
    if index == 0 or index < -count or index > 2**62:
        raise InputFileError(
            f"{path}: line {number}: vertex {index} of a face, with {count} vertices before it"
        )
    return index - 1 if index > 0 else count + index


def _load(trimesh, content: bytes, suffix: str, force: str | None):
    return trimesh.load(
        io.BytesIO(content), file_type=suffix[1:], force=force, process=False, maintain_order=True
    )


def _obj_text(mesh: Mesh) -> str:
    """The OBJ text of ``mesh``: each coordinate as Python's shortest repr that reads back to
    the same float64 (any magnitude), faces 1-based."""
    lines = [f"v {x!r} {y!r} {z!r}" for x, y, z in mesh.vertices.tolist()]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in mesh.faces.tolist()]
    return "\n".join(lines) + "\n"


def write_mesh(path: str | os.PathLike, mesh: object, *, faces: object = None) -> None:
    """Write a triangle mesh to a PLY, OBJ or STL file, whole or not at all.

    Parameters
    ----------
    path : str or os.PathLike
        The file; its suffix (``.ply``, ``.obj``, ``.stl``) chooses the format.
    mesh : Mesh or object or array_like
        A :class:`Mesh`, any object with ``vertices`` (and ``faces``, unless ``faces`` is
        given), such as the deformed mesh of :meth:`glmls.MLS.deform`, or the vertices
        (V, 3) themselves.
    faces : array_like, optional
        The triangles (F, 3); default ``mesh.faces``. None of them (F = 0): a point cloud,
        which PLY and OBJ hold and STL does not.

    Raises
    ------
    ValueError
        Before writing anything, for an unknown suffix or a bad mesh (no faces where
        neither ``mesh`` nor ``faces`` gives them), or a point cloud to STL.
    TypeError
        Before writing anything, for vertices that are not real numbers or faces that are
        not integers.
    OSError
        Naming ``path``, for a file that cannot be written.

    See Also
    --------
    read_mesh : the other way.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "triangle.ply"
    >>> glmls.write_mesh(path, [[0, 0, 0], [1, 0, 0], [0, 1, 0]], faces=[[0, 1, 2]])
    >>> glmls.read_mesh(path).faces.tolist()
    [[0, 1, 2]]
    """
    path = Path(path)
    suffix = _suffix(path)
    vertices = getattr(mesh, "vertices", mesh)
    if faces is None:
        faces = getattr(mesh, "faces", None)
        if faces is None:
            raise ValueError(f"{path}: no faces: give faces= (F, 3) with vertices")
    checked = Mesh(vertices, faces)
    trimesh = _trimesh()
    if not len(checked.faces):
        if suffix == ".stl":
            raise ValueError(
                f"{path}: an STL file holds triangles only; write a point cloud (no faces) "
                "as .ply or .obj"
            )
        shape = trimesh.PointCloud(checked.vertices)
    else:
        shape = trimesh.Trimesh(checked.vertices, checked.faces, process=False)
    if suffix == ".obj":
        data = _obj_text(checked).encode("utf-8")
    else:
        content = shape.export(file_type=suffix[1:])
        data = content.encode("utf-8") if isinstance(content, str) else content
    with atomic_write(path) as tmp:
        tmp.write_bytes(data)
