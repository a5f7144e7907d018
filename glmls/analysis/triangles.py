"""The reference-triangle errors of "Extensions to the MLS method for image deformation"
(section 5, eqs. 10, 11): the Delaunay triangulation of user points, and how f changes each
triangle's edge lengths and angles.

Two angular measures (:data:`ANGLE_MEASURES`):

- ``"degrees"`` (the default): the mean absolute change of the three corner angles, in
  degrees. 0 for every similarity (rotations, uniform scales, translations), bounded by 180,
  and a change of 1 degree counts alike whatever the angle.
- ``"paper"``: eq. (11) as printed, (|cos a - cos a'| + eps) / (|cos a| + eps) per corner.
  Its denominator vanishes at right angles: a right angle that stays right scores 1, not 0
  (eps / eps), and a change of a tenth of a degree there scores ~1,700. A square's corners
  scaled by 0.5 score 0.35 although nothing changed shape, and a mild warp of a rectangle of
  points can headline a mean in the thousands while its distances move by 3 %. Kept for
  reproducing the paper's numbers.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..core.config import check_choice, check_real
from ..core.handles import check_coordinates, check_reference_points
from ..mls import MLS
from .field import frame_centre, target_offset
from .stats import error_stats
from .volume_lattice import flat_areas, real_values

#: The angular measures of :func:`triangle_errors` (the first is the default).
ANGLE_MEASURES = ("degrees", "paper")

__all__ = [
    "ANGLE_MEASURES",
    "TriangleErrors",
    "check_angle_measure",
    "check_eps",
    "check_reference_points",
    "deformed_points",
    "delaunay",
    "qhull_simplices",
    "triangle_errors",
    "triangle_errors_from_points",
    "unit_scaled",
]


@dataclass(frozen=True, eq=False)
class TriangleErrors:
    """Per-triangle errors of a deformation over the Delaunay triangulation of reference points.

    Made by :func:`triangle_errors`; the arrays are read-only.

    Attributes
    ----------
    points : numpy.ndarray
        The reference points r, (N, 2).
    deformed_points : numpy.ndarray
        f(r), (N, 2).
    simplices : numpy.ndarray
        (T, 3) vertex indices of each triangle (scipy's order, counter-clockwise in (x, y)).
    distance : numpy.ndarray
        (T,): eq. (10), the mean relative change of the three edge lengths.
    angle : numpy.ndarray
        (T,): with ``angle_measure`` ``"degrees"``, the mean over the three corners of
        |a - a'| in degrees (a the corner's angle before f, a' after); with ``"paper"``, eq.
        (11): the mean of (|cos a - cos a'| + eps) / (|cos a| + eps). NaN where f collapses
        an edge to a point.
    flipped : numpy.ndarray
        (T,) bool: whether f reverses the triangle's orientation or flattens it to zero
        area, to within f's rounding (32 times float32's epsilon for a :class:`glmls.MLS`,
        float64's for another function, of the edges' and f's scale): a fold-over; the
        corner angles of a mirrored triangle are the same, so ``angle`` does not show it. A
        reference triangle already within that rounding of zero area (two points a fraction
        of a pixel apart), which any f leaves within it, counts only where f clearly
        reverses it.
    eps : float
        The epsilon of eq. (11).
    angle_measure : str
        Which measure ``angle`` holds, one of :data:`ANGLE_MEASURES`.

    Examples
    --------
    >>> square = [[0, 0], [10, 0], [0, 10], [10, 10]]
    >>> errors = glmls.analysis.triangle_errors(lambda r: r * [-1.0, 1.0], square)
    >>> errors.simplices.shape, errors.flipped.tolist()  # a mirror flips every triangle
    ((2, 3), [True, True])
    >>> stats = errors.stats()
    >>> stats["triangles"], stats["flipped"], stats["angle"]["max"]
    (2, 2, 0.0)
    """

    points: np.ndarray
    deformed_points: np.ndarray
    simplices: np.ndarray
    distance: np.ndarray
    angle: np.ndarray
    flipped: np.ndarray
    eps: float
    angle_measure: str = "degrees"

    def stats(self) -> dict[str, object]:
        """JSON-ready statistics of the errors.

        Returns
        -------
        dict
            ``triangles`` (T), ``angle_measure``, ``flipped`` (how many), and the
            :func:`error_stats` of ``distance`` and of ``angle``.

        Examples
        --------
        >>> square = [[0, 0], [10, 0], [0, 10], [10, 10]]
        >>> stats = glmls.analysis.triangle_errors(lambda r: r * 2.0, square).stats()
        >>> stats["triangles"], stats["flipped"], stats["angle"]["max"], stats["distance"]["count"]
        (2, 0, 0.0, 2)
        """
        return {
            "triangles": len(self.simplices),
            "angle_measure": self.angle_measure,
            "flipped": int(self.flipped.sum()),
            "distance": error_stats(self.distance),
            "angle": error_stats(self.angle),
        }


def delaunay(points: object) -> tuple[np.ndarray, np.ndarray]:
    """(points (N, 2) float64, simplices (T, 3) int) of the Delaunay triangulation.

    Unlike a bare ``scipy.spatial.Delaunay``, points that Qhull would silently leave out
    (near-duplicates, in ``coplanar``) raise ``ValueError``, as do points beyond
    :data:`~glmls.core.handles.COORDINATE_LIMIT`.
    """
    r = check_coordinates(check_reference_points(points), "reference_points")
    return r, qhull_simplices(r, "triangulation")


def unit_scaled(r: np.ndarray, *others: np.ndarray) -> tuple[np.ndarray, ...]:
    """``r`` and ``others`` times the one power of two that brings r's largest coordinate
    into [0.5, 1): exact, so the shapes and their errors stay the same, while the products
    of 4 to 7 lengths that areas, volumes and radius ratios take stay clear of float64's
    underflow for points spread over as little as 1e-150."""
    top = float(np.abs(r).max()) if r.size else 0.0
    exponent = int(np.frexp(top)[1]) if np.isfinite(top) and top > 0 else 0
    return tuple(np.ldexp(a, -exponent) for a in (r, *others))


def qhull_simplices(r: np.ndarray, name: str) -> np.ndarray:
    """Qhull's Delaunay simplices of the checked points ``r`` (2D or 3D), int64; ``ValueError``
    where Qhull fails or leaves points out (near-duplicates) of the ``name`` it makes."""
    from scipy.spatial import Delaunay, QhullError  # here: a slow import most calls never need

    try:
        tri = Delaunay(unit_scaled(r)[0])  # Qhull's lifted squares underflow below ~1e-160
    except QhullError as error:
        raise ValueError(f"reference_points cannot be triangulated: {error}") from None
    if len(tri.coplanar):
        left = sorted(int(i) for i in tri.coplanar[:, 0])
        raise ValueError(
            f"reference_points {left} coincide (within Qhull's precision) with other points "
            f"and were left out of the {name}; remove or move them"
        )
    return np.ascontiguousarray(tri.simplices, dtype=np.int64)


def _corner_angles(corners: np.ndarray) -> np.ndarray:
    """The angle at each corner of triangles (T, 3, 2) in degrees (T, 3), in [0, 180]; NaN at
    the ends of an edge of length 0. atan2(|cross|, dot) keeps full precision near 0 and 180
    degrees, where acos(cos) loses half the digits."""
    edges = np.roll(corners, -1, axis=1) - corners  # edge k: corner k -> corner k+1
    before = -np.roll(edges, 1, axis=1)  # corner k -> corner k-1
    cross = edges[..., 0] * before[..., 1] - edges[..., 1] * before[..., 0]
    dot = (edges * before).sum(-1)
    angles = np.degrees(np.arctan2(np.abs(cross), dot))
    degenerate = (np.hypot(*np.moveaxis(edges, -1, 0)) == 0) | (
        np.hypot(*np.moveaxis(before, -1, 0)) == 0
    )
    return np.where(degenerate, np.nan, angles)


def _corner_cosines(corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For triangles (T, 3, 2): the cosine of the angle at each corner k (T, 3), and the length
    of edge k, from corner k to corner k + 1 (T, 3)."""
    edges = np.roll(corners, -1, axis=1) - corners  # edge k: corner k -> corner k+1
    lengths = np.hypot(edges[..., 0], edges[..., 1])
    # angle at corner k between the edges to k+1 and to k-1 (the reversed edge k-1)
    before = -np.roll(edges, 1, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        cosine = (edges * before).sum(-1) / (lengths * np.roll(lengths, 1, axis=1))
    return np.clip(cosine, -1.0, 1.0), lengths


def check_angle_measure(angle: object) -> str:
    """``angle`` if it names one of :data:`ANGLE_MEASURES`: ``TypeError`` for a value that is
    no string (None, a number), ``ValueError`` for another string
    (:func:`~glmls.core.config.check_choice`)."""
    return check_choice("angle", angle, ANGLE_MEASURES)


def check_eps(eps: object) -> float:
    """``eps`` as a float, a finite positive number (eq. (11)'s epsilon; an infinite eps makes
    every corner inf / inf = NaN): a real option (:func:`~glmls.core.config.check_real`),
    ``TypeError`` for another type, ``ValueError`` for a value <= 0 or not finite."""
    return check_real("eps", eps, low=0, low_open=True, what="a finite positive number")


def deformed_points(m: Callable[[np.ndarray], np.ndarray], r: np.ndarray) -> np.ndarray:
    """f(r) = ``m(r)`` as a new float64 array (the caller may freeze it); ``TypeError`` for an
    ``m`` that is not callable or values that are not real numbers (complex, bool),
    ``ValueError`` for another shape than r's or points that are not finite."""
    if not callable(m):
        raise TypeError(f"m must be a glmls.MLS or a function of points, got {type(m).__name__}")
    deformed = real_values(m(r), "m(points)")  # a copy: the caller freezes it
    if deformed.shape != r.shape:
        raise ValueError(f"m(points) returned shape {deformed.shape}, expected {r.shape}")
    if not np.isfinite(deformed).all():
        raise ValueError("m(points) returned NaN or infinite points")
    return deformed


def triangle_errors_from_points(
    points: np.ndarray,
    deformed: np.ndarray,
    simplices: np.ndarray,
    *,
    eps: float = 1e-6,
    angle: str = "degrees",
    rounding: float = float(np.finfo(np.float32).eps),
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(distance, angle, flipped) per triangle from r, f(r) and the triangles (eqs. 10, 11);
    ``angle``: the measure, see :data:`ANGLE_MEASURES`; ``rounding``: that of f(r) (float32's
    for the GPU's), within which f flattens a triangle."""
    measure = check_angle_measure(angle)
    ref = points[simplices]
    out = deformed[simplices]
    cos_ref, len_ref = _corner_cosines(ref)
    cos_out, len_out = _corner_cosines(out)
    distance = np.mean(np.abs(len_ref - len_out) / len_ref, axis=1)
    if measure == "paper":
        errors = (np.abs(cos_ref - cos_out) + eps) / (np.abs(cos_ref) + eps)
        errors[np.isnan(cos_out).any(axis=1)] = np.nan
    else:
        errors = np.abs(_corner_angles(ref) - _corner_angles(out))
    angle_error = np.mean(errors, axis=1)

    def signed_area(t: np.ndarray) -> np.ndarray:
        a, b = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
        return a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]

    # a fold: f turns the triangle over or crushes it flat. Rounding moves each f(r) by about
    # rounding x (|f(r)| + the stretch x |r|): an image within that of zero area has no
    # orientation, its sign mere rounding (as the 3D analysis's flattened tetrahedra)
    area, before = signed_area(out), signed_area(ref)
    a, b = (np.hypot(*(out[:, k] - out[:, 0]).T) for k in (1, 2))
    stretch = (len_out / len_ref).max(axis=1)  # f's, edge by edge: not the shape's aspect
    noise = np.abs(out).max(axis=(1, 2)) + stretch * np.abs(ref).max(axis=(1, 2))
    flat = flat_areas(area, a, b, rounding, noise)
    reversed_ = np.sign(before) * area <= 0
    # a reference triangle itself within that rounding of zero area (points a fraction of a
    # pixel apart): any f, the identity too, leaves it within rounding of flat, so only a
    # clear reversal counts
    sliver = flat_areas(before, len_ref[:, 0], len_ref[:, 2], rounding, noise)
    flipped = np.where(sliver, reversed_ & ~flat, reversed_ | flat)
    return distance, angle_error, flipped


def triangle_errors(
    m: Callable[[np.ndarray], np.ndarray],
    reference_points: object,
    *,
    angle: str = "degrees",
    eps: float = 1e-6,
) -> TriangleErrors:
    """The distance (eq. 10) and angular (eq. 11) errors of the reference triangles.

    The triangles are the Delaunay triangulation of ``reference_points`` (user points,
    distinct from the handles). A uniform scale by s gives distance = |s - 1|, angle 0
    (``"degrees"``), and eps / (|cos a| + eps) per corner with ``"paper"`` (1 at a right
    angle).

    Parameters
    ----------
    m : callable
        A :class:`glmls.MLS`, or any function mapping (K, 2) points to (K, 2) points.
    reference_points : array_like
        The points r, (N, 2) with N >= 3, distinct and not all on one line.
    angle : {"degrees", "paper"}, optional
        ``"degrees"``: the mean absolute change of the corner angles in degrees, 0 for any
        similarity; ``"paper"``: eq. (11) as printed, whose denominator |cos a| + eps makes
        right angles blow up (see ``glmls.analysis.triangles``).
    eps : float, optional
        Eq. (11)'s epsilon (finite, > 0).

    Returns
    -------
    TriangleErrors
        The triangles, r and f(r), and the errors per triangle.

    Raises
    ------
    ValueError
        For fewer than 3 points, NaN, duplicates or points all on one line; an unknown
        ``angle``; ``eps`` <= 0 or infinite; ``m`` returning the wrong shape or points that are not
        finite.
    TypeError
        For an ``m`` that is not callable or that returns values that are not real numbers
        (complex, bool).

    See Also
    --------
    error_stats : the statistics of the errors (``TriangleErrors.stats``).

    Examples
    --------
    >>> square = [[0, 0], [10, 0], [0, 10], [10, 10]]
    >>> twice = glmls.analysis.triangle_errors(lambda r: 2.0 * r, square)
    >>> twice.distance.tolist(), twice.angle.tolist()  # a uniform scale by 2
    ([1.0, 1.0], [0.0, 0.0])
    >>> stretched = glmls.analysis.triangle_errors(lambda r: r * [1.0, 1.5], square)
    >>> stretched.distance.round(3).tolist(), stretched.angle.round(2).tolist()
    ([0.258, 0.258], [7.54, 7.54])
    >>> with glmls.MLS([[0, 0], [10, 0], [0, 10]], [[1, 1], [11, 1], [1, 11]]) as m:
    ...     glmls.analysis.triangle_errors(m, square).distance.round(6).tolist()
    [0.0, 0.0]
    """
    measure = check_angle_measure(angle)
    eps = check_eps(eps)
    r, simplices = delaunay(reference_points)
    deformed = deformed_points(m, r)
    # far targets: the errors of f - t (a whole-pixel t; translations change none of them),
    # whose float32 rounding, which the flatness counts, is that of a map near its sources;
    # both about the centre of the GPU's frame, from which that rounding grows
    centre = frame_centre(m)
    near_deformed = deformed - target_offset(m) - centre
    rounding = np.finfo(np.float32 if isinstance(m, MLS) else np.float64).eps  # the GPU's
    distance, errors, flipped = triangle_errors_from_points(
        *unit_scaled(r - centre, near_deformed),
        simplices,
        eps=eps,
        angle=measure,
        rounding=float(rounding),
    )
    for array in (r, deformed, simplices, distance, errors, flipped):
        array.flags.writeable = False
    return TriangleErrors(r, deformed, simplices, distance, errors, flipped, float(eps), measure)
