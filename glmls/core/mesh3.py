"""Triangle meshes and point clouds deformed by a 3D MLS: the input forms
(:func:`as_mesh`), the result (:class:`DeformedMesh`), and the float64 reference of what
the GPU computes for it (:mod:`glmls.engine.deform3`): the vertex normals, the cofactors,
the deformed normals and the folds.

A map folds a vertex where its Jacobian J = df/dv has det J <= 0 (f turns the volume inside
out there, or flattens it), det J counting as 0 where J is singular to its rounding
(``flat_to_zero``: a map that flattens the mesh leaves det J at that rounding, of either
sign, and folds every vertex rather than a random half of them). A face is folded when one
of its vertices is, or when its orientation flips: its deformed normal points against its
original normal carried by f (n C, C the sum of its vertices' cofactor matrices cof(J) =
det(J) J^-T: a face's normal goes to n cof(J) under a linear map J; for a map that does not
fold, the two agree for every face small against the deformation's scale). A face of zero
area folds by this rule (its normal is zero)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import DtypeError
from .handles3 import as_points3
from .summary import fields_repr

__all__ = [
    "COPLANAR_ROUNDINGS",
    "FLAT_ROUNDINGS",
    "DeformedMesh",
    "as_colors",
    "as_mesh",
    "as_normals",
    "as_uv",
    "check_face_indices",
    "cofactor",
    "coplanar",
    "deform_mesh",
    "deformed_normals",
    "determinant",
    "difference_rounding",
    "face_folds",
    "face_normals",
    "flat_to_zero",
    "mesh_colors",
    "mesh_uv",
    "vertex_normals",
    "whole_indices",
]

#: J counts as singular (det J = 0, a fold) where det J is within this many of the roundings
#: of J's entries times the norm of J's cofactor matrix: J's smallest singular value within
#: them of 0 (``flat_to_zero``).
FLAT_ROUNDINGS = 4.0
#: Targets are on one plane (``coplanar``) where the smallest singular value of the
#: centred targets is within this many float64 roundings of their size (eps64 x the
#: Frobenius norm of the targets as given: each coordinate is rounded at its own size, so a
#: far offset rounds more). Targets put on a plane by float64 arithmetic (projected onto
#: it, or a plane's points turned and moved) come within 8 of them at most.
COPLANAR_ROUNDINGS = 32.0


@dataclass(frozen=True, repr=False)
class DeformedMesh:
    """A mesh (or point cloud) deformed by a 3D :class:`~glmls.MLS` (:meth:`glmls.MLS.deform`).

    Attributes
    ----------
    vertices : numpy.ndarray
        (V, 3) float64 f(vertices).
    faces : numpy.ndarray
        (F, 3) int64 vertex indices, as given ((0, 3) for a point cloud).
    normals : numpy.ndarray
        (V, 3) float64 unit vertex normals: the original ones (area-weighted face normals, or
        the mesh's own: a :class:`glmls.Mesh`'s ``normals``, a ``trimesh.Trimesh``'s
        ``vertex_normals``) carried by the inverse transpose of J, n J^-T; zeros where a
        vertex has none (a point cloud without normals of its own, an unused vertex, a zero
        normal) or J is singular.
    jacobian : numpy.ndarray
        (V, 3, 3) float64 J = df/dv at each vertex, row vectors: J[k, r, c] = d f_c / d v_r
        (float32 values from the GPU, as are ``normals`` and ``det_j``).
    det_j : numpy.ndarray
        (V,) float64 det J: the local change of volume; 0 where J is singular to its
        rounding (f flattens the mesh there: float32's from the GPU, float64's in the
        reference ``deform_mesh``; ``flat_to_zero``), and where f maps J's probes
        into one plane (an affine map onto ``coplanar`` targets, its solve the plain
        A^-1 B at each of them), which folds.
    vertex_folds : numpy.ndarray
        (V,) bool: det J <= 0.
    face_folds : numpy.ndarray
        (F,) bool: a vertex of the face folds, or the face's orientation flips (see
        ``glmls.core.mesh3``).
    colors : numpy.ndarray or None
        (V, 3) or (V, 4) uint8 RGB(A) vertex colours, the input mesh's own (a
        :class:`glmls.Mesh`'s ``colors``, a ``trimesh.Trimesh``'s vertex colours): a
        deformation moves a vertex, not its colour. None where the input has none.
    uv : numpy.ndarray or None
        (T, 2) float64 texture coordinates (u, v), the input mesh's own (a
        :class:`glmls.Mesh`'s ``uv``, a ``trimesh.Trimesh``'s ``visual.uv``): a deformation
        moves the surface, and the texture with it, so its coordinates on the surface stay.
        None where the input has none.
    face_uv : numpy.ndarray or None
        (F, 3) int64 indices into ``uv`` of each face's corners (a vertex may have a
        texture coordinate per face, at a seam); None with ``uv``.
    own_normals : bool
        Whether ``normals`` carry the input mesh's own normals (a :class:`glmls.Mesh`'s
        ``normals``, a ``trimesh.Trimesh``'s ``vertex_normals``) rather than those of its
        faces: :func:`glmls.write_mesh` writes ``normals`` only then, so that a file gains no
        normals its input did not have (a file's normals make a viewer shade it smooth).

    Examples
    --------
    >>> import numpy as np
    >>> import glmls
    >>> vertices = np.array([[0, 0, 0], [4, 0, 0], [0, 4, 0]], float)
    >>> with glmls.MLS([[0, 0, 0]], [[0, 0, 1]]) as m:  # a translation along z
    ...     out = m.deform((vertices, np.array([[0, 1, 2]])))
    >>> out.vertices[:, 2].tolist(), out.normals[0].tolist(), out.face_folds.tolist()
    ([1.0, 1.0, 1.0], [0.0, 0.0, 1.0], [False])
    """

    vertices: np.ndarray
    faces: np.ndarray
    normals: np.ndarray
    jacobian: np.ndarray
    det_j: np.ndarray
    vertex_folds: np.ndarray
    face_folds: np.ndarray
    colors: np.ndarray | None = None
    uv: np.ndarray | None = None
    face_uv: np.ndarray | None = None
    own_normals: bool = False

    @property
    def folded(self) -> bool:
        """Whether any vertex or face folds.

        Examples
        --------
        >>> vertices = np.array([[0, 0, 0], [4, 0, 0], [0, 4, 0]], float)
        >>> with glmls.MLS([[0, 0, 0]], [[0, 0, 1]]) as m:  # a translation along z
        ...     print(m.deform((vertices, np.array([[0, 1, 2]]))).folded)
        False
        """
        return bool(self.vertex_folds.any() or self.face_folds.any())

    def __repr__(self) -> str:
        """The arrays' shapes and dtypes, not their values."""
        return fields_repr(self)


def check_face_indices(name: str, faces: np.ndarray, count: int, into: str = "vertices") -> None:
    """``ValueError`` naming the first row of ``faces`` (F, 3) integers with an index below 0
    or from ``count`` on (``into``: what they index, the vertices or uv), that row's number
    and its indices: a large mesh's bad face is found by its number, not by the faces'
    overall range."""
    if not len(faces):
        return
    # compared as they are, before any cast to int64: a uint64 index of 2**63 must not wrap;
    # the extremes first (two reductions over the flat array, where a test per row is ten
    # times slower), the rows only to name a bad one
    if faces.min() >= 0 and faces.max() < count:
        return
    bad = ((faces < 0) | (faces >= count)).any(axis=1)
    row = int(np.argmax(bad))
    where = f"{into} 0..{count - 1}" if count else f"{into}, which is empty"
    raise ValueError(
        f"{name} must index {where}; face {row} is {[int(i) for i in faces[row]]}"
        + (f" ({int(bad.sum())} such faces)" if bad.sum() > 1 else "")
    )


def as_mesh(mesh: object) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """(vertices (V, 3) float64, faces (F, 3) int64, the mesh's own vertex normals or None)
    of ``mesh``: an object with ``.vertices`` and ``.faces`` (a ``trimesh.Trimesh``, a
    :class:`glmls.Mesh`), a ``(vertices, faces)`` tuple, an object with ``.vertices`` alone (a
    ``trimesh.PointCloud``, or one whose ``faces`` are None) or a (V, 3) array of points
    (no faces).
    ``ValueError``/``TypeError`` for anything else, or faces naming missing vertices;
    ``TypeError`` naming the dtype for faces that are not integers (floats included). The
    mesh's own ``vertex_normals`` (a trimesh's) or ``normals`` (a :class:`glmls.Mesh`'s, a
    :class:`DeformedMesh`'s of ``own_normals``) are used where they are (V, 3) (else the
    faces' are): real numbers (``TypeError``), finite (``ValueError``), each row scaled to at
    most 1 (only their directions count)."""
    normals = None
    if hasattr(mesh, "vertices") and hasattr(mesh, "faces"):
        vertices, faces = mesh.vertices, mesh.faces  # type: ignore[attr-defined]
        normals = getattr(mesh, "vertex_normals", None)
        if normals is None and getattr(mesh, "own_normals", True):
            normals = getattr(mesh, "normals", None)
    elif isinstance(mesh, tuple) and len(mesh) == 2:
        vertices, faces = mesh
    elif hasattr(mesh, "vertices"):  # vertices alone (a trimesh.PointCloud): a point cloud
        vertices, faces = mesh.vertices, np.zeros((0, 3), np.int64)  # type: ignore[attr-defined]
    else:
        vertices, faces = mesh, np.zeros((0, 3), np.int64)
    if faces is None:  # an object whose faces are unset: its vertices, a point cloud
        faces = np.zeros((0, 3), np.int64)
    v = as_points3(vertices, "mesh vertices")
    try:
        f = np.asarray(faces)
    except ValueError:  # numpy's own words for ragged rows
        raise ValueError("mesh faces must be (F, 3) integer vertex indices: rows of 3") from None
    if f.size == 0:
        f = np.zeros((0, 3), np.int64)
    if f.dtype.kind not in "iu":  # floats too, whole or not: indices are integers
        raise TypeError(
            f"mesh faces must be integer vertex indices, got dtype {f.dtype} (shape {f.shape}): "
            "convert them with faces.astype(int) where they hold whole numbers"
        )
    if f.ndim != 2 or f.shape[1] != 3:
        raise ValueError(
            f"mesh faces must be (F, 3) integer vertex indices, got shape {f.shape} "
            f"(dtype {f.dtype})"
        )
    check_face_indices("mesh faces", f, len(v))
    if normals is not None:
        normals = _own_normals(normals, v.shape)
    if f.dtype != np.int64 or f.flags.writeable:
        f = f.astype(np.int64)  # a copy: the caller's array may change (a glmls.Mesh's cannot)
    return v, f, normals


def whole_indices(indices: np.ndarray) -> bool:
    """Whether ``indices`` are integers, or floats that are whole numbers (as a file's
    columns of doubles may hold them): not NaN, fractions or infinities, which equal their
    rounding but index nothing."""
    if np.issubdtype(indices.dtype, np.integer):
        return True
    return bool(
        np.issubdtype(indices.dtype, np.floating)
        and np.isfinite(indices).all()
        and (indices == np.round(indices)).all()
    )


def as_colors(colors: object, count: int) -> np.ndarray | None:
    """``colors`` as read-only (``count``, 3) or (``count``, 4) uint8 RGB(A) rows, or None for
    None: integers as they are (each in 0..255), floats in 0..1 scaled by 255 and rounded to
    the nearest integer (an OBJ file's). ``TypeError`` for values that are not real numbers
    (bools too), ``ValueError`` for another shape or a value out of range, naming it."""
    if colors is None:
        return None
    array = np.asarray(colors)
    if array.dtype.kind not in "iuf":
        raise DtypeError(f"colors must be integers 0..255 or floats 0..1, got dtype {array.dtype}")
    if array.ndim != 2 or array.shape[1] not in (3, 4) or len(array) != count:
        raise ValueError(
            f"colors must be (V, 3) or (V, 4) RGB(A) rows for the V = {count} vertices, "
            f"got shape {array.shape}"
        )
    floats = array.dtype.kind == "f"
    bad = ~((array >= 0) & (array <= (1 if floats else 255)))  # NaN too
    if bad.any():
        row = int(np.argwhere(bad)[0][0])
        raise ValueError(
            f"colors must be {'floats 0..1' if floats else 'integers 0..255'}; "
            f"row {row} is {array[row].tolist()}"
        )
    if floats:
        array = np.rint(array * 255.0)
    out = array.astype(np.uint8)  # a copy: the caller's array may change
    out.flags.writeable = False
    return out


def as_normals(normals: object, count: int) -> np.ndarray | None:
    """``normals`` as read-only (``count``, 3) float64 vertex normals, as given (not scaled
    to unit length; zero rows too), or None for None. ``TypeError`` for values that are not
    real numbers (bools, strings, complex too), ``ValueError`` for another shape or a value
    that is not finite, naming it."""
    if normals is None:
        return None
    try:
        array = np.asarray(normals)
    except ValueError:  # ragged rows
        raise ValueError(
            f"normals must be (V, 3) rows (x, y, z) for the V = {count} vertices"
        ) from None
    if array.dtype.kind not in "iuf":
        raise DtypeError(f"normals must be real numbers, got dtype {array.dtype}")
    if array.shape != (count, 3):
        raise ValueError(
            f"normals must be (V, 3) rows (x, y, z) for the V = {count} vertices, "
            f"got shape {array.shape}"
        )
    out = array.astype(np.float64)  # a copy: the caller's array may change
    finite = np.isfinite(out).all(axis=1)
    if not finite.all():
        row = int(np.argmin(finite))
        raise ValueError(f"normals must be finite; row {row} is {out[row].tolist()}")
    out.flags.writeable = False
    return out


def mesh_colors(mesh: object, count: int) -> np.ndarray | None:
    """The vertex colours of a mesh given to :func:`as_mesh` (of ``count`` vertices), by
    :func:`as_colors`: its ``colors`` (a :class:`glmls.Mesh`), or a ``trimesh.Trimesh``'s
    or ``PointCloud``'s own vertex colours; None for arrays, tuples and meshes without them
    (trimesh's default grey is no colour of the mesh's)."""
    colors = getattr(mesh, "colors", None)
    visual = getattr(mesh, "visual", None)
    if colors is None and getattr(visual, "kind", None) == "vertex":
        colors = visual.vertex_colors  # type: ignore[union-attr]
    if colors is not None and np.size(colors) == 0:  # a trimesh.PointCloud without colours
        colors = None
    return as_colors(colors, count)


def as_uv(
    uv: object, face_uv: object, face_count: int
) -> tuple[np.ndarray | None, np.ndarray | None]:
    """``uv`` and ``face_uv`` as read-only (T, 2) float64 texture coordinates and (F, 3) int64
    indices into them of the ``face_count`` faces' corners, or (None, None) for both None.
    ``ValueError`` for one given without the other, another shape, a coordinate that is not
    finite or an index out of 0..T-1; ``TypeError`` for coordinates that are not real
    numbers (bools too) or indices that are not integers (whole floats are taken), naming
    them."""
    if uv is None and face_uv is None:
        return None, None
    if uv is None or face_uv is None:
        given, missing = ("uv", "face_uv") if face_uv is None else ("face_uv", "uv")
        raise ValueError(f"{given} is given without {missing}: texture coordinates need both")
    coordinates, indices = np.asarray(uv), np.asarray(face_uv)
    if coordinates.dtype.kind not in "iuf":
        raise DtypeError(f"uv must be real numbers, got dtype {coordinates.dtype}")
    if coordinates.size == 0:
        coordinates = coordinates.reshape(0, 2)
    if coordinates.ndim != 2 or coordinates.shape[1] != 2:
        raise ValueError(f"uv must be (T, 2) rows (u, v), got shape {coordinates.shape}")
    coordinates = coordinates.astype(np.float64)  # a copy: the caller's array may change
    finite = np.isfinite(coordinates).all(axis=1)
    if not finite.all():
        row = int(np.argmin(finite))
        raise ValueError(f"uv must be finite; row {row} is {coordinates[row].tolist()}")
    if indices.size == 0:
        indices = indices.reshape(0, 3)
    if not whole_indices(indices):
        raise DtypeError(f"face_uv must be integer indices into uv, got dtype {indices.dtype}")
    if indices.ndim != 2 or indices.shape != (face_count, 3):
        raise ValueError(
            f"face_uv must be (F, 3) indices into uv for the F = {face_count} faces, "
            f"got shape {indices.shape}"
        )
    check_face_indices("face_uv", indices, len(coordinates), "uv")
    indices = indices.astype(np.int64)
    coordinates.flags.writeable = False
    indices.flags.writeable = False
    return coordinates, indices


def mesh_uv(mesh: object, faces: np.ndarray) -> tuple[np.ndarray | None, np.ndarray | None]:
    """The texture coordinates of a mesh given to :func:`as_mesh` (of ``faces``), by
    :func:`as_uv`: its ``uv`` and ``face_uv`` (a :class:`glmls.Mesh`), or a
    ``trimesh.Trimesh``'s own ``visual.uv`` (one per vertex: ``face_uv`` is the faces);
    (None, None) for arrays, tuples and meshes without them."""
    uv, face_uv = getattr(mesh, "uv", None), getattr(mesh, "face_uv", None)
    visual = getattr(mesh, "visual", None)
    if uv is None and face_uv is None and getattr(visual, "kind", None) == "texture":
        uv = getattr(visual, "uv", None)
        face_uv = None if uv is None else faces
    return as_uv(uv, face_uv, len(faces))


def _own_normals(normals: object, shape: tuple[int, ...]) -> np.ndarray | None:
    """A mesh's own vertex normals as (V, 3) float64 rows of largest component 1 (0 rows
    stay 0): None where they are not of ``shape``; ``TypeError``/``ValueError`` where they
    are not finite real numbers."""
    array = np.asarray(normals)
    if array.shape != shape:
        return None
    if array.dtype.kind not in "iuf":
        raise DtypeError(f"mesh vertex_normals must be real numbers, got dtype {array.dtype}")
    array = array.astype(np.float64)
    finite = np.isfinite(array).all(axis=1)
    if not finite.all():
        row = int(np.argmin(finite))
        raise ValueError(f"mesh vertex_normals must be finite; row {row} is {array[row].tolist()}")
    top = np.abs(array).max(axis=1, keepdims=True)
    return array / np.where(top > 0, top, 1.0)  # directions: no overflow in float32 later


def face_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(F, 3) (b - a) x (c - a) per face: twice its area times its unit normal (right-hand
    rule over the vertex order)."""
    a = vertices[faces[:, 0]]
    return _cross(vertices[faces[:, 1]] - a, vertices[faces[:, 2]] - a)


def vertex_normals(
    vertices: np.ndarray, faces: np.ndarray, weighted: np.ndarray | None = None
) -> np.ndarray:
    """(V, 3) unit area-weighted vertex normals; zeros for vertices in no face. ``weighted``:
    the :func:`face_normals`, where already known."""
    weighted = face_normals(vertices, faces) if weighted is None else weighted
    count = len(vertices)
    corners = faces.T.ravel()  # every face's vertex 0s, then 1s, then 2s
    normals = np.stack(
        [np.bincount(corners, np.tile(weighted[:, c], 3), minlength=count) for c in range(3)],
        axis=1,
    )
    return _unit(normals)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise a x b of (K, 3) arrays (np.cross is ~3x slower on long arrays)."""
    out = np.empty(np.broadcast_shapes(a.shape, b.shape), np.result_type(a, b))
    out[..., 0] = a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1]
    out[..., 1] = a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2]
    out[..., 2] = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    return out


def _unit(vectors: np.ndarray) -> np.ndarray:
    norm = np.sqrt((vectors * vectors).sum(axis=-1, keepdims=True))
    return np.divide(vectors, norm, out=np.zeros_like(vectors), where=norm > 0)


def cofactor(j: np.ndarray) -> np.ndarray:
    """(K, 3, 3) det(J) J^-T of (K, 3, 3) ``j``, defined (and continuous) for singular J too:
    its rows are the cross products of J's rows."""
    c = np.empty_like(j)
    c[:, 0] = _cross(j[:, 1], j[:, 2])
    c[:, 1] = _cross(j[:, 2], j[:, 0])
    c[:, 2] = _cross(j[:, 0], j[:, 1])
    return c


def determinant(j: np.ndarray, cof: np.ndarray) -> np.ndarray:
    """(K,) det J from J and its :func:`cofactor`."""
    return (j[:, 0] * cof[:, 0]).sum(axis=1)


def coplanar(targets: np.ndarray) -> bool:
    """Whether the (N, 3) float64 ``targets`` lie on one plane, to float64's rounding: the
    smallest singular value of the targets less their mean is at most
    :data:`COPLANAR_ROUNDINGS` x eps64 x the targets' Frobenius norm (scale-invariant; three
    targets or fewer, or ones on a line or at one point, always are). An affine MLS onto
    such targets maps every point where its solve is the plain A^-1 B into that plane: B's
    centred targets have no component along its normal n, so M n = 0.

    Examples
    --------
    >>> import numpy as np
    >>> from glmls.core.mesh3 import coplanar
    >>> turn = np.array([[0.6, 0.0, 0.8], [0.0, 1.0, 0.0], [-0.8, 0.0, 0.6]])
    >>> q = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]]) @ turn + 5.0
    >>> coplanar(q), coplanar(q + [[0, 0, 0], [0, 0, 0], [0, 0, 0], [0, 0, 1e-6]])
    (True, False)
    """
    if len(targets) < 4:
        return True
    spread = np.linalg.svd(targets - targets.mean(axis=0), compute_uv=False)
    size = np.sqrt(np.einsum("ij,ij->", targets, targets))
    return bool(spread[2] <= COPLANAR_ROUNDINGS * np.finfo(np.float64).eps * size)


def flat_to_zero(det: np.ndarray, jacobian: np.ndarray, rounding: float | np.ndarray) -> np.ndarray:
    """``det`` (V,), det J of the (V, 3, 3) ``jacobian``, in place and returned, with 0 where
    J is singular to ``rounding`` (a number or (V,): the rounding of J's entries): where
    |det J| <= :data:`FLAT_ROUNDINGS` x ``rounding`` x |cof J| (Frobenius norm, s1 s2 and
    more for J's singular values s1 >= s2 >= s3), which puts s3 within
    :data:`FLAT_ROUNDINGS` roundings of 0. A map that flattens space (targets on a plane)
    leaves det J at its rounding, of either sign; so it folds everywhere.

    Examples
    --------
    >>> import numpy as np
    >>> from glmls.core.mesh3 import flat_to_zero
    >>> j = np.array([np.diag([1.0, 1.0, 1e-15]), np.diag([1.0, 1.0, 1e-3])])
    >>> flat_to_zero(np.array([1e-15, 1e-3]), j, 1e-12).tolist()
    [0.0, 0.001]
    """
    # |cof J| <= |J|^2 / sqrt(3) (s1 s2 + s2 s3 + s1 s3 against (s1^2 + s2^2 + s3^2)^2 / 3):
    # a det J clear of that bound is kept, and |cof J| (9 cross products, most of the rule's
    # time) is taken only for the others; 0.578 > 1 / sqrt(3) by 1e-3, far more than the
    # roundings of either side
    rows = jacobian.reshape(len(det), 9)
    bound = 0.578 * np.einsum("ij,ij->i", rows, rows)
    near = np.abs(det) <= FLAT_ROUNDINGS * rounding * bound
    count = int(np.count_nonzero(near))
    if 2 * count > len(det):  # most of them (a flat map): every vertex, without the gathers
        size = np.linalg.norm(cofactor(jacobian).reshape(len(det), 9), axis=1)
        det[np.abs(det) <= FLAT_ROUNDINGS * rounding * size] = 0.0
        return det
    (which,) = np.nonzero(near)
    if np.ndim(rounding):
        rounding = rounding[which]  # type: ignore[index]
    size = np.linalg.norm(cofactor(jacobian[which]).reshape(count, 9), axis=1)
    det[which[np.abs(det[which]) <= FLAT_ROUNDINGS * rounding * size]] = 0.0
    return det


def difference_rounding(
    points: np.ndarray, deformed: np.ndarray, step: float | np.ndarray
) -> np.ndarray:
    """(V,) float64's rounding of J by central differences of a float64 f over ``step`` (a
    number or (V,), handle units) at ``points`` (V, 3) where f is ``deformed`` (V, 3): eps64
    x the largest |coordinate| of v and f(v) over the step (the differences subtract f's
    values, each rounded to float64 at the size of its coordinates).

    Examples
    --------
    >>> import numpy as np
    >>> from glmls.core.mesh3 import difference_rounding
    >>> v = np.array([[100.0, 0.0, 0.0]])
    >>> float(difference_rounding(v, v * 2, 1e-3)[0] / np.finfo(float).eps)
    200000.0
    """
    reach = np.maximum(np.abs(points).max(axis=1), np.abs(deformed).max(axis=1))
    return np.finfo(np.float64).eps * reach / step


def _carry(normals: np.ndarray, matrices: np.ndarray) -> np.ndarray:
    """Row-wise n @ C for (K, 3) n and (K, 3, 3) C."""
    return (
        normals[:, 0:1] * matrices[:, 0]
        + normals[:, 1:2] * matrices[:, 1]
        + normals[:, 2:3] * matrices[:, 2]
    )


def face_folds(
    face_normals_before: np.ndarray,
    deformed: np.ndarray,
    faces: np.ndarray,
    cofactors: np.ndarray,
    vertex_folds: np.ndarray,
) -> np.ndarray:
    """(F,) bool: a vertex of the face folds, or its deformed normal (from ``deformed``, (V,
    3)) points against its original one (``face_normals_before``, (F, 3)) carried by the sum
    of its vertices' :func:`cofactor` matrices (V, 3, 3): their dot product is <= 0."""
    if not len(faces):
        return np.zeros(0, bool)
    c = cofactors
    a, b, d = faces[:, 0], faces[:, 1], faces[:, 2]
    carried = _carry(face_normals_before, c[a] + c[b] + c[d])
    after = face_normals(deformed, faces)
    flips = (after * carried).sum(axis=1) <= 0
    return vertex_folds[a] | vertex_folds[b] | vertex_folds[d] | flips


def deformed_normals(
    normals: np.ndarray, jacobian: np.ndarray, cof: np.ndarray, det: np.ndarray
) -> np.ndarray:
    """(V, 3) unit n J^-T (as n cof(J), with the sign of det J) for J's :func:`cofactor` and
    determinant; zeros where J is singular or n is 0."""
    return _unit(_carry(normals, cof) * np.sign(det)[:, None])


def deform_mesh(
    vertices: np.ndarray,
    faces: np.ndarray,
    normals: np.ndarray | None,
    deformed: np.ndarray,
    jacobian: np.ndarray,
    *,
    step: float | np.ndarray | None = None,
    colors: np.ndarray | None = None,
    uv: np.ndarray | None = None,
    face_uv: np.ndarray | None = None,
    flat: np.ndarray | None = None,
) -> DeformedMesh:
    """The :class:`DeformedMesh` of a mesh (:func:`as_mesh`'s ``vertices``, ``faces`` and
    ``normals``, None to take them from the faces) from f at its vertices (``deformed``) and
    the Jacobians there, in float64 on the host: the reference of the GPU's
    :func:`glmls.engine.deform3.deform_mesh3`. ``colors``: the vertices' own
    (:func:`mesh_colors`), ``uv`` and ``face_uv`` its texture coordinates (:func:`mesh_uv`),
    carried as they are; ``own_normals`` where ``normals`` are given.

    det J is 0 where J is singular to float64's rounding (``flat_to_zero``, the GPU's
    rule in float64 terms), which folds: ``step`` (a number or (V,), handle units) where
    ``jacobian`` is float64 central differences of f over that step, whose rounding is then
    :func:`difference_rounding`'s; None for a J good to float64's rounding of its own
    entries (eps64 x its largest |J_rc|). The normals are 0 where det J is.

    ``flat``: (V,) bool, the vertices where f is known to map J's probes into one plane (an
    affine MLS onto ``coplanar`` targets, whose solve is the plain A^-1 B at each of
    them: :func:`glmls.reference.plain_affine`), or None: det J is 0 there, however far
    its rounding leaves it from 0.

    Examples
    --------
    >>> import numpy as np
    >>> from glmls.core.mesh3 import deform_mesh
    >>> vertices = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
    >>> c, s = np.cos(0.3), np.sin(0.3)
    >>> flat = np.array([[c, s, 0.0], [-s, c, 0], [0, 0, 0]]) @ np.diag([1.0, 1, 0])
    >>> j = np.repeat(flat[None], 3, axis=0)  # f flattens space onto z = 0, turned
    >>> out = deform_mesh(vertices, np.array([[0, 1, 2]]), None, vertices @ flat, j)
    >>> out.det_j.tolist(), out.face_folds.tolist()
    ([0.0, 0.0, 0.0], [True])
    """
    before = face_normals(vertices, faces)
    own = normals is not None
    if normals is None:
        normals = vertex_normals(vertices, faces, before) if len(faces) else vertices * 0.0
    cof = cofactor(jacobian)
    det = determinant(jacobian, cof)
    if step is None:
        rounding = np.finfo(np.float64).eps * np.abs(jacobian).max(axis=(1, 2))
    else:
        rounding = difference_rounding(vertices, deformed, step)
    det = flat_to_zero(det, jacobian, rounding)
    if flat is not None:
        det[flat] = 0.0
    folds = det <= 0
    return DeformedMesh(
        vertices=deformed,
        faces=faces,
        normals=deformed_normals(normals, jacobian, cof, det),
        jacobian=jacobian,
        det_j=det,
        vertex_folds=folds,
        face_folds=face_folds(before, deformed, faces, cof, folds),
        colors=colors,
        uv=uv,
        face_uv=face_uv,
        own_normals=own,
    )
