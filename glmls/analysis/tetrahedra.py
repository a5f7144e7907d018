"""The paper's reference-triangle analysis (section 5, eqs. 10, 11) in three dimensions.

Reference points are split into tetrahedra (their 3D Delaunay triangulation, or the user's
own) and each is compared with its image under f:

- ``distance``: eq. (10) over the six edges, the mean of |L - L'| / L (L an edge's length
  before f, L' after): |s - 1| for a uniform scale by s;
- ``angle``: the change of the face angles, 4 faces x 3 corners, as the 2D measures
  (``glmls.analysis.ANGLE_MEASURES``): ``"degrees"``, the mean of |a - a'| in degrees over the 12
  angles, 0 for every similarity; or ``"paper"``, eq. (11) per angle;
- ``inverted``: f reverses the tetrahedron's orientation (its signed volume changes sign), a
  fold that the face angles do not show, or flattens it: an image whose volume is 0 to
  rounding (within 32 (``FLAT_ULPS``) times f's precision, float64's or float32's on the
  GPU, of its edges' and f's scale) has no orientation, its sign mere rounding, and counts
  as inverted.

**Slivers.** A nearly flat tetrahedron (four points near a plane, common on the hull of a
Delaunay triangulation) has an orientation that the slightest change of f flips, and such
shapes hold little of the object. Its quality is measured by the normalised radius ratio
q = 3 r / R (r the radius of the inscribed sphere, R that of the circumscribed one): 1 for
the regular tetrahedron, about 0.72 for the six tetrahedra that split a cube, and 0 for a
flat one. Tetrahedra with q < ``min_quality`` (default :data:`SLIVER_QUALITY` = 0.1), and
those of zero volume always, are left out of the errors and counted (``slivers``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..core.config import check_real
from ..core.handles3 import as_points3 as points_in_range
from ..errors import DtypeError
from .stats import error_stats
from .triangles import (
    check_angle_measure,
    check_eps,
    deformed_points,
    qhull_simplices,
    unit_scaled,
)
from .volume_field import frame_centre, precision, target_offset
from .volume_lattice import as_points3, check_three_d, flat_triples

__all__ = [
    "SLIVER_QUALITY",
    "TetrahedronErrors",
    "check_tetrahedron_options",
    "delaunay3",
    "tetrahedron_errors",
    "tetrahedron_quality",
]

#: The radius ratio below which a tetrahedron is a sliver, left out of the errors.
SLIVER_QUALITY = 0.1
#: The vertices of each face (opposite vertex 3, 2, 1, 0) and so the 12 face angles.
FACES = np.array([[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]])
#: The six edges of a tetrahedron.
EDGES = np.array([[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]])


@dataclass(frozen=True, eq=False)
class TetrahedronErrors:
    """Per-tetrahedron errors of a 3D deformation over tetrahedra of reference points.

    Made by :func:`tetrahedron_errors` (definitions in ``glmls.analysis.tetrahedra``);
    the arrays are read-only.

    Attributes
    ----------
    points : numpy.ndarray
        The reference points r, (N, 3).
    deformed_points : numpy.ndarray
        f(r), (N, 3).
    simplices : numpy.ndarray
        (T, 4) vertex indices of the tetrahedra measured (slivers left out).
    distance : numpy.ndarray
        (T,): eq. (10) over the six edges.
    angle : numpy.ndarray
        (T,): the mean change of the 12 face angles, in degrees (``"degrees"``) or by eq.
        (11) (``"paper"``); NaN where f collapses an edge to a point.
    inverted : numpy.ndarray
        (T,) bool: f reverses the tetrahedron's orientation, or flattens it to zero volume
        (to rounding).
    quality : numpy.ndarray
        (T,): the radius ratio 3 r / R of each reference tetrahedron, in (0, 1].
    slivers : numpy.ndarray
        (S, 4) vertex indices of the tetrahedra left out as slivers.
    min_quality : float
        The radius ratio below which a tetrahedron is a sliver.
    eps : float
        The epsilon of eq. (11).
    angle_measure : str
        Which measure ``angle`` holds, one of ``glmls.analysis.ANGLE_MEASURES``.

    Examples
    --------
    >>> corners = [[0, 0, 0], [10, 0, 0], [0, 10, 0], [0, 0, 10], [10, 10, 10]]
    >>> errors = glmls.analysis.tetrahedron_errors(lambda r: r * [-1.0, 1, 1], corners)
    >>> errors.simplices.shape, errors.inverted.all().item()  # a mirror turns all over
    ((3, 4), True)
    >>> stats = errors.stats()
    >>> stats["tetrahedra"], stats["slivers"], stats["inverted"], stats["angle"]["max"]
    (3, 0, 3, 0.0)
    """

    points: np.ndarray
    deformed_points: np.ndarray
    simplices: np.ndarray
    distance: np.ndarray
    angle: np.ndarray
    inverted: np.ndarray
    quality: np.ndarray
    slivers: np.ndarray
    min_quality: float = SLIVER_QUALITY
    eps: float = 1e-6
    angle_measure: str = "degrees"

    def stats(self) -> dict[str, object]:
        """JSON-ready statistics of the errors.

        Returns
        -------
        dict
            ``tetrahedra`` (T, those measured), ``slivers`` (how many left out),
            ``min_quality``, ``angle_measure``, ``inverted`` (how many), and the
            :func:`error_stats` of ``distance``, ``angle`` and ``quality``.

        Examples
        --------
        >>> corners = [[0, 0, 0], [10, 0, 0], [0, 10, 0], [0, 0, 10], [10, 10, 10]]
        >>> stats = glmls.analysis.tetrahedron_errors(lambda r: r * 2.0, corners).stats()
        >>> stats["tetrahedra"], stats["inverted"], stats["angle"]["max"]
        (3, 0, 0.0)
        """
        return {
            "tetrahedra": len(self.simplices),
            "slivers": len(self.slivers),
            "min_quality": self.min_quality,
            "angle_measure": self.angle_measure,
            "inverted": int(self.inverted.sum()),
            "distance": error_stats(self.distance),
            "angle": error_stats(self.angle),
            "quality": error_stats(self.quality),
        }


def _signed_volumes(corners: np.ndarray) -> np.ndarray:
    """6 x the signed volume of tetrahedra (T, 4, 3)."""
    u, v, w = (corners[:, k] - corners[:, 0] for k in (1, 2, 3))
    return (u * np.cross(v, w)).sum(-1)


def tetrahedron_quality(corners: object) -> np.ndarray:
    """The normalised radius ratio 3 r / R of tetrahedra: 1 regular, 0 flat.

    Parameters
    ----------
    corners : array_like
        (T, 4, 3) vertices.

    Returns
    -------
    numpy.ndarray
        (T,) in [0, 1]; 0 for a tetrahedron of zero volume. Scale-invariant: a tetrahedron
        1e-150 across has the quality of its copy 1 across.

    Raises
    ------
    ValueError
        For corners that are not (T, 4, 3) finite numbers.
    glmls.DtypeError
        For corners that are not real numbers (complex, strings, objects).

    Examples
    --------
    >>> regular = [[[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]]]
    >>> flat = [[[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 1e-9]]]
    >>> glmls.analysis.tetrahedron_quality(regular).round(6).tolist()
    [1.0]
    >>> bool(glmls.analysis.tetrahedron_quality(flat)[0] < 1e-8)
    True
    """
    given = np.asarray(corners)
    if given.dtype.kind not in "biuf":  # a cast would drop an imaginary part, or fail unnamed
        raise DtypeError(f"corners must be real numbers, got dtype {given.dtype}")
    t = given.astype(np.float64, copy=False)
    if t.ndim != 3 or t.shape[1:] != (4, 3):
        raise ValueError(f"corners must be (T, 4, 3), got {t.shape}")
    if not np.isfinite(t).all():  # a NaN corner would rate 0, as a flat tetrahedron
        bad = int(np.argmin(np.isfinite(t).all(axis=(1, 2))))
        raise ValueError(f"corners must be finite; tetrahedron {bad} is {t[bad].tolist()}")
    # each tetrahedron times the power of two that brings its edges to [0.5, 1): exact,
    # and the ratio's products of up to 7 lengths neither underflow (a tiny tetrahedron
    # would read as flat) nor overflow
    edges = t[:, 1:] - t[:, :1]
    exponent = np.frexp(np.abs(edges).max(axis=(1, 2), initial=0.0))[1]
    u, v, w = np.moveaxis(np.ldexp(edges, -exponent[:, None, None]), 1, 0)
    volume6 = np.abs((u * np.cross(v, w)).sum(-1))
    lengths = [(e * e).sum(-1)[:, None] for e in (u, v, w)]
    centre = lengths[0] * np.cross(v, w) + lengths[1] * np.cross(w, u) + lengths[2] * np.cross(u, v)
    area = 0.5 * sum(
        np.linalg.norm(np.cross(a, b), axis=-1) for a, b in ((u, v), (u, w), (v, w), (v - u, w - u))
    )
    # r = 3 V / area = 6V / (2 area), R = |centre| / (2 (6V)): 3 r / R = 3 (6V)^2 / (area |centre|)
    with np.errstate(divide="ignore", invalid="ignore"):
        quality = (3.0 * volume6**2) / (area * np.linalg.norm(centre, axis=-1))
    return np.where(volume6 > 0, np.clip(np.nan_to_num(quality), 0.0, 1.0), 0.0)


def delaunay3(points: object) -> tuple[np.ndarray, np.ndarray]:
    """(points (N, 3) float64, simplices (T, 4) int): the 3D Delaunay tetrahedra.

    Points that Qhull would leave out (near-duplicates) raise ``ValueError``.

    Parameters
    ----------
    points : array_like
        (N, 3) reference points, N >= 4, distinct, not all on one plane.

    Returns
    -------
    points : numpy.ndarray
        (N, 3) float64.
    simplices : numpy.ndarray
        (T, 4) int64 vertex indices.

    Raises
    ------
    ValueError
        For fewer than 4 points, NaN, duplicates, points all on one plane or beyond
        ``COORDINATE_LIMIT`` (before Qhull, which may crash on them).

    Examples
    --------
    >>> cube = [[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1)]
    >>> points, simplices = glmls.analysis.delaunay3(cube)
    >>> points.shape, simplices.shape[1]
    ((8, 3), 4)
    """
    r = as_points3(points, "reference_points")
    if len(r) < 4:
        raise ValueError(f"reference_points: tetrahedra need at least 4 points, got {len(r)}")
    unique, first = np.unique(r, axis=0, return_index=True)
    if len(unique) < len(r):
        twice = sorted(set(range(len(r))) - {int(i) for i in first})[0]
        raise ValueError(f"reference_points[{twice}] repeats the point {r[twice].tolist()}")
    singular = np.linalg.svd(r - r.mean(axis=0), compute_uv=False)
    if singular[2] <= 1e-10 * singular[0]:
        raise ValueError(
            "reference_points all lie on one plane, to within 1e-10 of their extent (the "
            "singular values of the centred points are "
            f"{', '.join(f'{v:.3g}' for v in singular)}): no tetrahedron can be formed"
        )
    # Qhull may crash the interpreter on points far beyond glmls's coordinate range
    return points_in_range(r, "reference_points"), qhull_simplices(r, "tetrahedra")


def _face_angles(corners: np.ndarray) -> np.ndarray:
    """The 12 face angles (T, 12) in degrees of tetrahedra (T, 4, 3); NaN at the ends of an
    edge of length 0. atan2(|cross|, dot) keeps full precision near 0 and 180 degrees."""
    faces = corners[:, FACES]  # (T, 4, 3 corners, 3)
    edges = np.roll(faces, -1, axis=2) - faces  # corner k -> k + 1
    before = -np.roll(edges, 1, axis=2)  # corner k -> k - 1
    cross = np.linalg.norm(np.cross(edges, before), axis=-1)
    angles = np.degrees(np.arctan2(cross, (edges * before).sum(-1)))
    zero = (np.abs(edges).sum(-1) == 0) | (np.abs(before).sum(-1) == 0)
    return np.where(zero, np.nan, angles).reshape(len(corners), 12)


def tetrahedron_errors_from_points(
    points: np.ndarray,
    deformed: np.ndarray,
    simplices: np.ndarray,
    *,
    angle: str = "degrees",
    eps: float = 1e-6,
    rounding: float = float(np.finfo(np.float64).eps),
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(distance, angle, inverted) per tetrahedron from r, f(r) and the tetrahedra;
    ``rounding``: that of f(r) (``precision``), within which f flattens a tetrahedron."""
    measure = check_angle_measure(angle)
    ref, out = points[simplices], deformed[simplices]
    len_ref = np.linalg.norm(ref[:, EDGES[:, 1]] - ref[:, EDGES[:, 0]], axis=-1)
    len_out = np.linalg.norm(out[:, EDGES[:, 1]] - out[:, EDGES[:, 0]], axis=-1)
    distance = np.mean(np.abs(len_ref - len_out) / len_ref, axis=1)
    a_ref, a_out = _face_angles(ref), _face_angles(out)
    if measure == "paper":
        cos_ref, cos_out = np.cos(np.radians(a_ref)), np.cos(np.radians(a_out))
        errors = (np.abs(cos_ref - cos_out) + eps) / (np.abs(cos_ref) + eps)
    else:
        errors = np.abs(a_ref - a_out)
    # rounding moves each f(r) by about rounding x (|f(r)| + the stretch x |r|): an image
    # within that of zero volume is flattened, its orientation's sign mere rounding
    stretch = (len_out / len_ref).max(axis=1)  # f's, edge by edge: not the shape's aspect
    noise = np.abs(out).max(axis=(1, 2)) + stretch * np.abs(ref).max(axis=(1, 2))
    flat = flat_triples(tuple(out[:, k] - out[:, 0] for k in (1, 2, 3)), rounding, noise)
    turned = np.sign(_signed_volumes(ref)) * np.sign(_signed_volumes(out)) < 0
    inverted = turned | flat
    return distance, np.mean(errors, axis=1), inverted


def _user_tetrahedra(tetrahedra: object, count: int) -> np.ndarray:
    """The user's tetrahedra (T, 4) as int64 indices into ``count`` points: ``TypeError`` for
    indices that are not integers, ``ValueError`` naming the first bad row."""
    try:
        array = np.asarray(tetrahedra)
    except ValueError:  # ragged rows: numpy's message would not say which argument
        raise ValueError(
            "tetrahedra must be (T, 4) integer indices; got rows of different lengths"
        ) from None
    if array.size and array.dtype.kind not in "iu":
        raise DtypeError(f"tetrahedra must be integer indices, got dtype {array.dtype}")
    if array.ndim != 2 or array.shape[1] != 4:
        raise ValueError(f"tetrahedra must be (T, 4) integer indices, got shape {array.shape}")
    if len(array) == 0:
        raise ValueError("tetrahedra: no tetrahedron given")
    # the range before the cast to int64: a uint64 index of 2**63 must not wrap
    outside = ((array < 0) | (array >= count)).any(axis=1)
    if outside.any():
        row = int(np.argmax(outside))
        raise ValueError(
            f"tetrahedra[{row}] is {array[row].tolist()}: the indices must be those of the "
            f"{count} reference points (0 to {count - 1})"
        )
    ordered = np.sort(array, axis=1)
    repeated = (ordered[:, 1:] == ordered[:, :-1]).any(axis=1)
    if repeated.any():
        row = int(np.argmax(repeated))
        raise ValueError(f"tetrahedra[{row}] is {array[row].tolist()}: it repeats a vertex")
    return np.ascontiguousarray(array, dtype=np.int64)


def check_tetrahedron_options(min_quality: object, angle: object, eps: object) -> str:
    """The options of :func:`tetrahedron_errors`, checked: the angle measure it names;
    ``ValueError`` for ``min_quality`` out of [0, 1), an unknown ``angle`` or ``eps`` <= 0,
    ``TypeError`` for a ``min_quality`` or ``eps`` that is no real number
    (:func:`~glmls.core.config.check_real`)."""
    measure = check_angle_measure(angle)
    check_eps(eps)
    check_real("min_quality", min_quality, low=0, high=1, high_open=True)
    return measure


def tetrahedron_errors(
    m: Callable[[np.ndarray], np.ndarray],
    reference_points: object,
    *,
    tetrahedra: object = None,
    min_quality: float = SLIVER_QUALITY,
    angle: str = "degrees",
    eps: float = 1e-6,
) -> TetrahedronErrors:
    """The distance (eq. 10) and angular errors of reference tetrahedra under f.

    The tetrahedra are the 3D Delaunay triangulation of ``reference_points`` (or
    ``tetrahedra``); slivers (radius ratio below ``min_quality``) are left out and counted.
    A similarity with scale s gives distance |s - 1| and angle 0 (``"degrees"``).

    Parameters
    ----------
    m : callable
        A :class:`glmls.MLS` of 3D handles, a :class:`ReferenceDeformation`, or any function
        mapping (K, 3) points to (K, 3) points.
    reference_points : array_like
        The points r, (N, 3) with N >= 4, distinct and not all on one plane.
    tetrahedra : array_like, optional
        (T, 4) integer indices into ``reference_points``: the user's own tetrahedra instead of
        Delaunay's; a row out of range or repeating a vertex is a ``ValueError`` naming it.
    min_quality : float, optional
        The radius ratio 3 r / R in [0, 1) below which a tetrahedron is a sliver (zero
        volume ones always are); 0.1 by default.
    angle : {"degrees", "paper"}, optional
        The angular measure (see ``glmls.analysis.tetrahedra``).
    eps : float, optional
        Eq. (11)'s epsilon (> 0).

    Returns
    -------
    TetrahedronErrors
        The tetrahedra, r and f(r), the errors per tetrahedron and the slivers.

    Raises
    ------
    ValueError
        For fewer than 4 points, NaN, duplicates, points all on one plane or beyond
        ``COORDINATE_LIMIT``; bad ``tetrahedra``; every tetrahedron
        a sliver; an unknown ``angle``; ``eps`` <= 0; ``min_quality`` out of [0, 1); ``m``
        returning the wrong shape or values that are not finite.
    TypeError
        For ``tetrahedra`` that are not integers, or an ``m`` that is not callable or returns
        values that are not real numbers (complex, bool).

    See Also
    --------
    triangle_errors : the same errors in 2D.
    error_stats : the statistics of the errors (``TetrahedronErrors.stats``).

    Examples
    --------
    >>> cube = [[x, y, z] for z in (0, 10) for y in (0, 10) for x in (0, 10)]
    >>> twice = glmls.analysis.tetrahedron_errors(lambda r: 2.0 * r, cube)
    >>> float(twice.distance.max()), float(twice.angle.max())  # a uniform scale by 2
    (1.0, 0.0)
    >>> turned = glmls.analysis.tetrahedron_errors(lambda r: r[:, [1, 0, 2]] * [-1, 1, 1], cube)
    >>> float(turned.angle.max()) < 1e-12, turned.inverted.any().item()  # a quarter turn
    (True, False)
    >>> stretched = glmls.analysis.tetrahedron_errors(lambda r: r * [1.0, 1, 1.5], cube)
    >>> bool(stretched.angle.min() > 0), stretched.stats()["slivers"]
    (True, 0)
    """
    measure = check_tetrahedron_options(min_quality, angle, eps)
    check_three_d(m)
    if tetrahedra is None:
        r, simplices = delaunay3(reference_points)
    else:
        r = points_in_range(reference_points, "reference_points")
        simplices = _user_tetrahedra(tetrahedra, len(r))
    quality = tetrahedron_quality(r[simplices])
    sliver = (quality < min_quality) | (quality == 0)
    if sliver.all():
        flat = np.flatnonzero(quality == 0)
        raise ValueError(
            f"every one of the {len(simplices)} tetrahedra is a sliver (radius ratio below "
            f"{min_quality}): spread the reference points, or lower min_quality"
            + (
                f"; {len(flat)} of them of zero volume, which no min_quality keeps (the "
                f"first: tetrahedra[{flat[0]}] = {simplices[flat[0]].tolist()}, its 4 points "
                "on one plane)"
                if len(flat)
                else ""
            )
        )
    deformed = deformed_points(m, r)
    kept = simplices[~sliver]
    # the errors do not change with a translation of f(r); less the GPU's offset of far
    # targets, f(r) has the rounding of a map near its sources, which the flatness counts,
    # both about the centre of the GPU's frame, from which that rounding grows
    centre = frame_centre(m)
    distance, errors, inverted = tetrahedron_errors_from_points(
        *unit_scaled(r - centre, deformed - target_offset(m) - centre),
        kept,
        angle=measure,
        eps=eps,
        rounding=precision(m),
    )
    quality, slivers = quality[~sliver], simplices[sliver]
    for array in (r, deformed, kept, distance, errors, inverted, quality, slivers):
        array.flags.writeable = False
    return TetrahedronErrors(
        r,
        deformed,
        kept,
        distance,
        errors,
        inverted,
        quality,
        slivers,
        float(min_quality),
        float(eps),
        measure,
    )
