"""Reading and writing triangle meshes: PLY (:mod:`glmls.files.ply`) and OBJ
(:mod:`glmls.files.obj`) read and written by glmls itself, STL through trimesh.

A :class:`Mesh` is its vertices (V, 3) float64, (x, y, z) in the coordinates of the handles
that deform it, its triangles (F, 3) of vertex indices and, where the file has them, its
vertices' colours (V, 3) or (V, 4) uint8 RGB(A), its texture coordinates (T, 2) float64
with the (F, 3) indices of each face's corners into them and its vertex normals (V, 3)
float64. Reading keeps the file's vertices in their order (none merged, none dropped; their
colours and normals with them) and its faces in their order,
except STL's: an STL file stores each triangle's three corners, so the corners at the same
place (equal coordinates, at any scale) are merged into one vertex, in the order of their
first corner (STL has no standard vertex colours). Faces of more than three vertices are
split into triangles (a fan from their first vertex, in the face's place among the faces, in
OBJ and PLY alike); a face of fewer than three is refused. What else a file holds (an OBJ's
normals where a vertex has several (hard edges), STL's facet normals, face colours,
materials, other properties) is not kept:
``read_mesh_and_unkept`` names it. A point cloud is a mesh of no faces: PLY and OBJ hold
one (STL holds triangles only, and refuses it).

Written, by the suffix: PLY (binary) and STL (binary) hold float32 coordinates, as those
formats usually do; OBJ (text) holds them exactly (each float64's shortest repr). PLY and
OBJ hold the vertex colours exactly (PLY as uchar ``red``, ``green``, ``blue`` and
``alpha``; OBJ as ``v x y z r g b [a]``, 0..1); STL does not hold them. OBJ holds the
texture coordinates exactly (``vt u v``, ``f v/vt``); PLY holds one per vertex (float32
``s``, ``t``), and so none of a mesh with seams (a vertex of several); STL holds none. PLY
holds the vertex normals as float32 ``nx``, ``ny``, ``nz``, OBJ exactly (``vn x y z``, one
per vertex, ``f v//vn``); STL holds none (``unwritten`` names what a format drops).
Every fault of a file is an :class:`~glmls.errors.InputFileError` naming it.

The numbers of a text file (OBJ, ASCII PLY, ASCII STL) are decimal numbers of ASCII digits
with an optional sign, point and exponent (``-0.5``, ``1e-3``, ``1E+02``), indices and PLY
integers plain integers (``+7``, ``-1``): what else Python reads as a number (``1_0``, other
scripts' digits) is refused, naming the line (PLY: the element, row and property).
"""

from __future__ import annotations

import dataclasses
import io
import os
from pathlib import Path

import numpy as np

from ..core.mesh3 import as_colors, as_normals, as_uv, check_face_indices, whole_indices
from ..core.summary import fields_repr
from ..errors import DtypeError, InputFileError
from .atomic import atomic_write
from .obj import obj_text, read_obj
from .parsing import as_path, brief, is_number, not_a_file
from .ply import MeshContent, read_ply
from .ply_write import ply_bytes, vertex_uv

__all__ = [
    "MESH_SUFFIXES",
    "Mesh",
    "read_mesh",
    "read_mesh_and_unkept",
    "unwritten",
    "write_mesh",
]

#: The suffixes of the mesh formats.
MESH_SUFFIXES = (".ply", ".obj", ".stl")
_FLOAT32_MAX = float(np.finfo(np.float32).max)


@dataclasses.dataclass(frozen=True, eq=False, repr=False)
class Mesh:
    """A triangle mesh: vertices, faces, colours, texture coordinates, normals; read-only.

    Parameters
    ----------
    vertices : array_like
        (V, 3) (x, y, z) rows, finite; kept as float64.
    faces : array_like
        (F, 3) vertex indices of the triangles, each in [0, V); kept as int64.
    colors : array_like, optional
        (V, 3) RGB or (V, 4) RGBA rows, one per vertex, kept as uint8: integers 0..255 as
        they are, floats 0..1 (an OBJ file's) scaled by 255 and rounded to the nearest
        integer. None (the default): no colours.
    uv : array_like, optional
        (T, 2) texture coordinates (u, v), finite; kept as float64. None (the default): no
        texture coordinates. Given with ``face_uv``.
    face_uv : array_like, optional
        (F, 3) indices into ``uv`` of each face's corners, in [0, T), kept as int64: a
        vertex may have a coordinate in each of its faces (at a seam of the texture), as in
        an OBJ file (``f v/vt``); ``face_uv=faces`` for one per vertex. None (the default)
        with ``uv``.
    normals : array_like, optional
        (V, 3) vertex normals (x, y, z), one per vertex, finite; kept as float64, as given
        (not scaled to unit length: a zero row is a vertex of no normal).
        :meth:`glmls.MLS.deform` carries them; None (the default): none, and a deformation
        carries the faces' own.

    Raises
    ------
    ValueError
        For vertices that are not (V, 3) finite numbers (V >= 1), faces that are not
        (F, 3) indices of them, colors that are not (V, 3) or (V, 4) values in range, uv
        that are not (T, 2) finite numbers, face_uv that are not (F, 3) indices of them,
        one of uv and face_uv without the other, or normals that are not (V, 3) finite
        numbers.
    TypeError
        For vertices that are not real numbers (complex, strings, bools, objects), faces
        that are not integers, colors, uv or normals that are not real numbers (bools too),
        or face_uv that are not integers.

    See Also
    --------
    read_mesh, write_mesh : the files.

    Examples
    --------
    >>> mesh = glmls.Mesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    >>> mesh.vertices.shape, mesh.faces.tolist()
    ((3, 3), [[0, 1, 2]])
    >>> glmls.Mesh(mesh.vertices, mesh.faces, colors=[[1.0, 0, 0]] * 3).colors[0].tolist()
    [255, 0, 0]

    Two triangles that share vertices 1 and 2 and a texture seam there (vertex 2 has the
    texture coordinate 2 in the first face and 3 in the second):

    >>> square = glmls.Mesh(
    ...     [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]],
    ...     [[0, 1, 2], [1, 3, 2]],
    ...     uv=[[0, 0], [0.5, 0], [0, 0.5], [1, 0.5], [1, 1]],
    ...     face_uv=[[0, 1, 2], [1, 4, 3]],
    ... )
    >>> square.uv[square.face_uv[:, 2]].tolist()  # the third corners: vertex 2 both times
    [[0.0, 0.5], [1.0, 0.5]]

    Vertex normals, one per vertex, kept as given:

    >>> up = glmls.Mesh(mesh.vertices, mesh.faces, normals=[[0, 0, 2]] * 3)
    >>> up.normals.dtype.name, up.normals[0].tolist()
    ('float64', [0.0, 0.0, 2.0])
    """

    vertices: np.ndarray
    faces: np.ndarray
    colors: np.ndarray | None = dataclasses.field(default=None, kw_only=True)
    uv: np.ndarray | None = dataclasses.field(default=None, kw_only=True)
    face_uv: np.ndarray | None = dataclasses.field(default=None, kw_only=True)
    normals: np.ndarray | None = dataclasses.field(default=None, kw_only=True)

    def __post_init__(self) -> None:
        try:
            given, faces = np.asarray(self.vertices), np.asarray(self.faces)
        except ValueError:  # ragged rows
            raise ValueError("vertices and faces must be rows of 3 numbers each") from None
        if given.dtype.kind not in "iuf":  # complex would lose its imaginary part silently
            raise DtypeError(f"vertices must be real numbers, got dtype {given.dtype}")
        vertices = np.array(given, dtype=np.float64)
        if vertices.ndim != 2 or vertices.shape[1] != 3 or not len(vertices):
            raise ValueError(f"vertices must be (V, 3) with V >= 1, got shape {vertices.shape}")
        if not np.isfinite(vertices).all():
            raise ValueError("vertices must be finite")
        if faces.size == 0:
            faces = faces.reshape(0, 3)
        if not whole_indices(faces):
            raise DtypeError(f"faces must be integer vertex indices, got dtype {faces.dtype}")
        if faces.ndim != 2 or faces.shape[1] != 3:
            raise ValueError(f"faces must be (F, 3) triangles, got shape {faces.shape}")
        check_face_indices("faces", faces, len(vertices))
        faces = np.array(faces, dtype=np.int64)
        vertices.flags.writeable = False
        faces.flags.writeable = False
        object.__setattr__(self, "vertices", vertices)
        object.__setattr__(self, "faces", faces)
        object.__setattr__(self, "colors", as_colors(self.colors, len(vertices)))
        uv, face_uv = as_uv(self.uv, self.face_uv, len(faces))
        object.__setattr__(self, "uv", uv)
        object.__setattr__(self, "face_uv", face_uv)
        object.__setattr__(self, "normals", as_normals(self.normals, len(vertices)))

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
        The vertices in the file's order (STL's shared corners merged), the triangles (none
        for a point cloud) and the vertex colours: a PLY file's ``red``, ``green``, ``blue``
        (and ``alpha``) vertex properties (uchar as they are, floats 0..1 scaled by 255 and
        rounded), an OBJ file's ``v x y z r g b`` (0..1, likewise); None for a file without
        them and for STL. The texture coordinates: an OBJ file's ``vt u v`` lines and the
        ``vt`` indices of its faces' corners (``f v/vt``, ``f v/vt/vn``), where every face
        has them (none kept where some faces have them and others not; a face with them on
        some corners only is refused), a PLY file's vertex properties ``s``, ``t`` (or
        ``u``, ``v``, ``texture_u``, ``texture_v``), one per vertex (``face_uv`` is the
        faces); None for a file without them and for STL. The vertex normals, as they are:
        a PLY file's vertex properties ``nx``, ``ny``, ``nz`` (or ``normal_x``,
        ``normal_y``, ``normal_z``), an OBJ file's ``vn`` lines where every corner of a
        vertex names the same one (``f v//vn``, ``f v/vt/vn``; or equal ones) and every
        corner names one (a vertex of no face: 0, or the ``vn`` of its own index where the
        file has one per vertex, as a point cloud's); None for a file without them, for
        STL (its facet normals are the faces') and for an OBJ whose normals are not one per
        vertex (a hard edge: a vertex with different ones in its faces). Not kept: such
        normals, a 3D texture's ``w``, face colours, materials (``mtllib``, ``usemtl``),
        groups and other PLY properties and elements; ``read_mesh_and_unkept`` names
        those a file has.

    Raises
    ------
    InputFileError
        Naming the file: missing, unreadable, an unknown suffix, not a mesh of that format,
        no vertices, coordinates that are not finite, colours out of range, texture
        indices that name no texture coordinate or are on some corners of a face only, or
        normals that are not 3 finite numbers (an OBJ's ``vn``, a PLY's ``nx``, ``ny``,
        ``nz``) or indices that name no normal.
    TypeError
        For a ``path`` that is no path (None, a number).

    See Also
    --------
    write_mesh : the other way.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "sphere.obj"
    >>> glmls.write_mesh(path, glmls.data.sphere())
    >>> mesh = glmls.read_mesh(path)
    >>> mesh.vertices.shape, mesh.faces.shape, mesh.colors
    ((162, 3), (320, 3), None)
    """
    return read_mesh_and_unkept(path)[0]


def read_mesh_and_unkept(path: str | os.PathLike) -> tuple[Mesh, tuple[str, ...]]:
    """:func:`read_mesh`, and the names of what the file holds that the mesh does not keep.

    Parameters
    ----------
    path : str or os.PathLike
        The file.

    Returns
    -------
    mesh : Mesh
        As :func:`read_mesh`.
    unkept : tuple of str
        Such as ``"normals (a vertex has several: hard edges)"``, ``"texture coordinates
        (not on every face)"``, ``"face colours"``, ``"materials"``, ``"vertex properties
        quality"``: empty where the mesh holds all of the file.

    Raises
    ------
    InputFileError
        As :func:`read_mesh`.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "tri.obj"
    >>> _ = path.write_text("v 0 0 0\\nv 1 0 0\\nv 0 1 0\\nvn 0 0 1\\nf 1//1 2 3//1\\n")
    >>> glmls.files.meshes.read_mesh_and_unkept(path)[1]
    ('normals (not on every face)',)
    """
    path = as_path(path)
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
    if suffix == ".stl":
        read = _read_stl(path, content)
    else:
        try:
            read = read_obj(content) if suffix == ".obj" else read_ply(content)
        except ValueError as error:
            where = "" if suffix == ".obj" else "not a readable .ply mesh: "
            raise InputFileError(f"{path}: {where}{error}") from None
    if not len(read.vertices):
        raise InputFileError(f"{path}: no mesh vertices in it")
    try:
        mesh = Mesh(
            read.vertices,
            read.faces,
            colors=read.colors,
            uv=read.uv,
            face_uv=read.face_uv,
            normals=read.normals,
        )
        return mesh, read.unkept
    except (TypeError, ValueError) as error:
        raise InputFileError(f"{path}: {error}") from None


def _read_stl(path: Path, content: bytes) -> MeshContent:
    """The merged corners of an STL file (:func:`_merge_corners`), and its per-face attribute
    bytes named where some are set (some tools keep face colours there)."""
    trimesh = _trimesh()
    fault = _binary_stl_fault(content)
    if fault is not None:
        raise InputFileError(f"{path}: not a readable .stl mesh: {fault}")
    try:
        _check_stl_text(content)
        loaded = _load(trimesh, content, ".stl", "mesh")
    except Exception as error:  # trimesh's parsers raise many kinds on a malformed file
        raise InputFileError(f"{path}: not a readable .stl mesh: {error}") from None
    if not isinstance(loaded, trimesh.Trimesh) or len(loaded.vertices) == 0:
        raise InputFileError(f"{path}: no mesh vertices in it")
    if not np.isfinite(loaded.vertices).all():
        raise InputFileError(f"{path}: vertices must be finite")
    corners = np.asarray(loaded.vertices, dtype=np.float64)[np.asarray(loaded.faces)]
    vertices, faces = _merge_corners(corners.reshape(-1, 3))
    attributes = getattr(loaded, "face_attributes", {}).get("stl")
    set_ = attributes is not None and np.asarray(attributes).any()
    return MeshContent(vertices, faces, None, ("face attributes (colours)",) if set_ else ())


def _binary_stl_fault(content: bytes) -> str | None:
    """What is wrong with a binary STL file (a NUL byte after its 80-byte header, in the
    first 4 KiB: no text holds one, and the count's high bytes, most float32s and the
    triangles' 2-byte attributes are 0) whose size is not the 84 + 50 N bytes of the N
    triangles its header counts: cut short, or bytes after them; None for any other file.
    trimesh reads such a file as ASCII, finding no triangles in it."""
    if len(content) < 84 or b"\0" not in content[80:4096]:
        return None
    count = int.from_bytes(content[80:84], "little")
    expected = 84 + 50 * count
    if expected == len(content):
        return None
    counted = f"a binary STL whose header counts {count} triangles ({expected} bytes)"
    if len(content) < expected:
        return f"{counted}, but the file has {len(content)} bytes: cut short"
    return (
        f"{counted}, but the file has {len(content) - expected} bytes after them (a "
        "wrong count in the header?)"
    )


def _check_stl_text(content: bytes) -> None:
    """``ValueError`` naming the line of an ASCII STL file's ``vertex x y z`` or ``facet
    normal x y z`` whose numbers are not three decimal numbers
    (:func:`glmls.files.parsing.is_number`), of a facet's ``outer loop`` of other than 3
    vertices, or of its last ``solid`` without its ``endsolid`` (cut short: trimesh reads
    the solids before it as the whole file, or none); nothing for a binary file (whose
    header counts its 50-byte triangles), which trimesh tells apart the same way."""
    if len(content) >= 84 and 84 + 50 * int.from_bytes(content[80:84], "little") == len(content):
        return
    text = content.decode("utf-8", errors="replace")
    opened = None  # the line of the solid not yet ended
    loop, corners = None, 0  # the line of the facet's loop not yet ended, its vertices so far
    for number, line in enumerate(text.splitlines(), start=1):
        words = line.split()
        keyword = [word.lower() for word in words[:2]]
        if keyword[:1] in (["solid"], ["endsolid"]):
            opened = number if keyword[0] == "solid" else None
            continue
        if keyword == ["outer", "loop"]:
            loop, corners = number, 0
        elif keyword[:1] == ["endloop"] and loop is not None:
            if corners != 3:  # an STL facet is a triangle (trimesh failed to reshape others)
                raise ValueError(f"line {loop}: a facet of {corners} vertices, not a triangle")
            loop = None
        corners += keyword[:1] == ["vertex"]
        skip = 1 if keyword[:1] == ["vertex"] else 2 if keyword == ["facet", "normal"] else 0
        if not skip:
            continue
        numbers = words[skip:]
        if len(numbers) != 3 or not all(map(is_number, numbers)):
            what = f"{' '.join(keyword[:skip])} {brief(' '.join(numbers))}"
            raise ValueError(f"line {number}: {what}, not 3 numbers")
        # a normal of nan (a degenerate facet's, as some tools write it) is not kept
        if skip == 1 and not np.isfinite([float(word) for word in numbers]).all():
            raise ValueError(f"line {number}: vertex {brief(' '.join(numbers))}, not finite")
    if opened is not None:
        raise ValueError(f"line {opened}: a solid without its endsolid line: cut short")


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


def _load(trimesh, content: bytes, suffix: str, force: str | None):
    return trimesh.load(
        io.BytesIO(content), file_type=suffix[1:], force=force, process=False, maintain_order=True
    )


def write_mesh(
    path: str | os.PathLike,
    mesh: object,
    *,
    faces: object = None,
    colors: object = None,
    uv: object = None,
    face_uv: object = None,
    normals: object = None,
) -> None:
    """Write a triangle mesh to a PLY, OBJ or STL file, whole or not at all.

    Parameters
    ----------
    path : str or os.PathLike
        The file; its suffix (``.ply``, ``.obj``, ``.stl``) chooses the format.
    mesh : Mesh or object or tuple or array_like
        A :class:`Mesh`, any object with ``vertices`` (and ``faces``, unless ``faces`` is
        given), such as the deformed mesh of :meth:`glmls.MLS.deform`
        (:class:`~glmls.DeformedMesh`), a ``(vertices, faces)`` tuple, as
        :meth:`glmls.MLS.deform` takes one, or the vertices (V, 3) themselves.
    faces : array_like, optional
        The triangles (F, 3); default ``mesh.faces``. None of them (F = 0): a point cloud,
        which PLY and OBJ hold and STL does not.
    colors : array_like, optional
        The vertex colours (V, 3) or (V, 4), as :class:`Mesh` takes them; default
        ``mesh.colors`` where it has them. PLY holds them as uchar ``red``, ``green``,
        ``blue`` (and ``alpha``), OBJ as ``v x y z r g b`` (and ``a``) in 0..1 to 6 digits,
        which read back to the same bytes; STL does not hold them (they are not written).
    uv, face_uv : array_like, optional
        The texture coordinates (T, 2) and the indices (F, 3) of the faces' corners into
        them, as :class:`Mesh` takes them; default ``mesh.uv`` and ``mesh.face_uv`` where it
        has them (and neither is given). OBJ holds them exactly (``vt u v`` with each
        float64's shortest repr, ``f a/ta b/tb c/tc``); PLY holds one per vertex, as float32
        ``s`` and ``t`` (a vertex of no face gets 0, 0), and so none of a mesh with seams (a
        vertex with different coordinates in its faces), which is written without them;
        STL holds none. ``unwritten`` names what a file drops.
    normals : array_like, optional
        The vertex normals (V, 3), as :class:`Mesh` takes them; default ``mesh.normals``
        where it has them: a :class:`Mesh`'s, and a :class:`~glmls.DeformedMesh`'s where
        they carry its input's own (``own_normals``: the input had normals, which the
        deformation turned), not where they are its faces' (a file gains no normals its
        input did not have). PLY holds them as float32 ``nx``, ``ny``, ``nz``, OBJ exactly
        (``vn x y z`` with each float64's shortest repr, one per vertex, named by the
        faces' corners: ``f a//a b//b c//c``, ``f a/ta/a b/tb/b c/tc/c``); STL holds none.

    Raises
    ------
    ValueError
        Before writing anything, for an unknown suffix or a bad mesh (no faces where
        neither ``mesh`` nor ``faces`` gives them, colours of another shape or out of range,
        texture coordinates that are not (T, 2) finite with (F, 3) indices into them,
        normals that are not (V, 3) finite; vertices, normals or texture coordinates beyond
        float32's range for PLY, vertices beyond it for STL: the float32 these formats hold
        would make them infinite), or a point cloud to STL.
    TypeError
        Before writing anything, for vertices, colours, texture coordinates or normals that
        are not real numbers or faces or their texture indices that are not integers, or a
        ``path`` that is no path.
    OSError
        Naming ``path``, for a file that cannot be written.

    See Also
    --------
    read_mesh : the other way.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "triangle.ply"
    >>> red = [[255, 0, 0]] * 3
    >>> glmls.write_mesh(path, [[0, 0, 0], [1, 0, 0], [0, 1, 0]], faces=[[0, 1, 2]], colors=red)
    >>> back = glmls.read_mesh(path)
    >>> back.faces.tolist(), back.colors.tolist()
    ([[0, 1, 2]], [[255, 0, 0], [255, 0, 0], [255, 0, 0]])

    An OBJ file holds texture coordinates per face corner, exactly:

    >>> path = path.with_suffix(".obj")
    >>> uv, face_uv = [[0.1, 0.2], [0.9, 0.2], [0.1, 0.8]], [[2, 1, 0]]
    >>> glmls.write_mesh(path, back, uv=uv, face_uv=face_uv)
    >>> back = glmls.read_mesh(path)
    >>> back.uv.tolist() == uv, back.face_uv.tolist()
    (True, [[2, 1, 0]])

    And vertex normals, one per vertex:

    >>> glmls.write_mesh(path, back, normals=[[0, 0, 1], [0, 0.6, 0.8], [0.6, 0, 0.8]])
    >>> glmls.read_mesh(path).normals.tolist()
    [[0.0, 0.0, 1.0], [0.0, 0.6, 0.8], [0.6, 0.0, 0.8]]
    """
    path = as_path(path)
    suffix = _suffix(path)
    if isinstance(mesh, tuple) and len(mesh) == 2 and faces is None:
        mesh, faces = mesh  # (vertices, faces), as MLS.deform takes a mesh
    vertices = getattr(mesh, "vertices", mesh)
    if faces is None:
        faces = getattr(mesh, "faces", None)
        if faces is None:
            raise ValueError(f"{path}: no faces: give faces= (F, 3) with vertices")
    if colors is None:
        colors = getattr(mesh, "colors", None)
    if uv is None and face_uv is None:
        uv, face_uv = getattr(mesh, "uv", None), getattr(mesh, "face_uv", None)
    if normals is None and getattr(mesh, "own_normals", True):  # not a DeformedMesh's faces'
        normals = getattr(mesh, "normals", None)
    checked = Mesh(vertices, faces, colors=colors, uv=uv, face_uv=face_uv, normals=normals)
    if suffix == ".obj":
        text = obj_text(
            checked.vertices,
            checked.faces,
            checked.colors,
            checked.uv,
            checked.face_uv,
            checked.normals,
        )
        data = text.encode("utf-8")
    elif suffix == ".ply":
        per_vertex = vertex_uv(len(checked.vertices), checked.faces, checked.uv, checked.face_uv)
        for name, values in (("vertices", checked.vertices), ("normals", checked.normals)):
            _check_float32(path, name, values, "PLY")
        _check_float32(path, "texture coordinates", per_vertex, "PLY")
        data = ply_bytes(
            checked.vertices, checked.faces, checked.colors, per_vertex, checked.normals
        )
    elif not len(checked.faces):
        raise ValueError(
            f"{path}: an STL file holds triangles only; write a point cloud (no faces) "
            "as .ply or .obj"
        )
    else:
        _check_float32(path, "vertices", checked.vertices, "STL")
        shape = _trimesh().Trimesh(checked.vertices, checked.faces, process=False)
        data = shape.export(file_type="stl")
    with atomic_write(path) as tmp:
        tmp.write_bytes(data)


def _check_float32(path: Path, name: str, values: np.ndarray | None, format_: str) -> None:
    """``ValueError`` for ``values`` beyond float32's range, which a ``format_`` file holds
    them in: written, they would read back infinite (and a reader refuses them)."""
    if values is not None and (np.abs(values) > _FLOAT32_MAX).any():
        row = int(np.argwhere(np.abs(values) > _FLOAT32_MAX)[0][0])
        raise ValueError(
            f"{path}: {name} beyond float32's range (±3.4e38), which {format_} holds; "
            f"row {row} is {values[row].tolist()}"
        )


def unwritten(path: str | os.PathLike, mesh: Mesh) -> tuple[str, ...]:
    """What of ``mesh`` a file of ``path``'s format does not hold, which :func:`write_mesh`
    drops.

    Parameters
    ----------
    path : str or os.PathLike
        The file; its suffix (``.ply``, ``.obj``, ``.stl``) chooses the format.
    mesh : Mesh
        The mesh to write.

    Returns
    -------
    tuple of str
        ``"vertex colours"``, ``"texture coordinates"`` and ``"normals"`` for STL (where the
        mesh has them), ``"texture coordinates (...)"`` for PLY where a vertex has several
        (a seam): empty where the file holds all of the mesh, as OBJ does.

    Raises
    ------
    ValueError
        For an unknown suffix.

    Examples
    --------
    >>> mesh = glmls.Mesh(
    ...     [[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]], uv=[[0, 0], [1, 0], [0, 1]],
    ...     face_uv=[[0, 1, 2]],
    ... )
    >>> glmls.files.meshes.unwritten("out.ply", mesh), glmls.files.meshes.unwritten("out.stl", mesh)
    ((), ('texture coordinates',))
    """
    suffix = _suffix(Path(path))
    names = []
    if suffix == ".stl" and mesh.colors is not None:
        names.append("vertex colours")
    if mesh.uv is not None and suffix == ".stl":
        names.append("texture coordinates")
    elif suffix == ".ply" and mesh.uv is not None:
        if vertex_uv(len(mesh.vertices), mesh.faces, mesh.uv, mesh.face_uv) is None:
            names.append(
                "texture coordinates (a vertex has several, at seams: PLY holds one per vertex)"
            )
    if suffix == ".stl" and mesh.normals is not None:
        names.append("normals")
    return tuple(names)
