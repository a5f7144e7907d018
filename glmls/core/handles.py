"""Validation of handles and points, and the float32-friendly scaling the GPU works in.

Points are ``(x, y)`` = (column, row) float arrays of shape (N, 2); pixel centres sit at
integer coordinates (scikit-image's convention).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..errors import DegenerateHandlesError, DtypeError

#: Handles and points must lie within this many pixels of the origin in x and y: the GPU
#: works in float32 on coordinates scaled to the handles' and image's extent, which keeps
#: ~1e-7 of that extent (0.1 px for handles a million pixels apart).
COORDINATE_LIMIT = 1e6


def point_rows(points: object, dimension: int) -> object:
    """One point given as a (D,) array_like as the (1, D) row scikit-image's transforms make
    of it; anything else as it is (for :func:`as_points` to check).

    Parameters
    ----------
    points : object
        (N, D) points or one (D,) point.
    dimension : int
        D, 2 or 3.

    Returns
    -------
    object
        ``points``, a (D,) point reshaped to (1, D).

    Examples
    --------
    >>> from glmls.core.handles import point_rows
    >>> point_rows([4, 5], 2).tolist(), point_rows([[4, 5]], 2)
    ([[4, 5]], [[4, 5]])
    """
    try:
        shape = np.shape(points)
    except ValueError:  # ragged rows: as_points names them
        return points
    return np.reshape(points, (1, dimension)) if shape == (dimension,) else points


def as_points(points: object, name: str = "points") -> np.ndarray:
    """``points`` as a C-contiguous float64 (N, 2) array; ``ValueError``/``TypeError`` if not."""
    try:
        array = np.asarray(points)
    except ValueError:  # ragged rows
        raise ValueError(f"{name} must have shape (N, 2) as (x, y) rows, got {points!r}") from None
    if array.dtype.kind not in "iuf":  # integers and reals (np.issubdtype: ~4x the time)
        raise DtypeError(f"{name} must be real numbers, got dtype {array.dtype}")
    if array.ndim != 2 or array.shape[1] != 2:
        # [] is no points; (0, 3) rows, even none, are the points of another dimension
        if array.size == 0 and (array.ndim == 1 or array.shape == (0, 0)):
            return np.zeros((0, 2))
        raise ValueError(f"{name} must have shape (N, 2) as (x, y) rows, got {array.shape}")
    array = np.ascontiguousarray(array, dtype=np.float64)
    if not np.isfinite(array).all():
        row = int(np.argmax(~np.isfinite(array[:, 0]) | ~np.isfinite(array[:, 1])))
        raise ValueError(f"{name} must be finite; row {row} is {array[row]}")
    return array


def check_reference_points(points: object) -> np.ndarray:
    """The reference points as (N, 2) float64; ``ValueError`` unless they can be triangulated
    (at least 3, finite, no duplicates, not all on one line)."""
    r = as_points(points, "reference_points")  # raises ValueError on NaN / inf
    if len(r) < 3:
        raise ValueError(f"reference_points: a triangulation needs at least 3 points, got {len(r)}")
    order = np.lexsort((r[:, 1], r[:, 0]))
    same = (r[order[1:]] == r[order[:-1]]).all(axis=1)
    if same.any():
        k = int(np.argmax(same))
        i, j = sorted((int(order[k]), int(order[k + 1])))
        raise ValueError(
            f"reference_points[{i}] and reference_points[{j}] are the same point {r[i].tolist()}"
        )
    centred = r - r.mean(axis=0)
    singular = np.linalg.svd(centred, compute_uv=False)
    if singular[1] <= 1e-10 * singular[0]:
        raise ValueError(
            "reference_points all lie on one line, to within 1e-10 of their extent (the "
            f"singular values of the centred points are {singular[0]:.3g} and "
            f"{singular[1]:.3g}): no triangle can be formed"
        )
    return r


def check_coordinates(points: np.ndarray, name: str = "points") -> np.ndarray:
    """``points`` ((N, 2) float64) if every coordinate lies within :data:`COORDINATE_LIMIT`;
    ``ValueError`` naming the range and the first row beyond it otherwise."""
    # over the whole array (not per column: the limit is the same for x and y)
    if not len(points) or max(-points.min(), points.max()) <= COORDINATE_LIMIT:
        return points
    beyond = np.abs(points).max(axis=1) > COORDINATE_LIMIT
    if beyond.any():
        row = int(np.argmax(beyond))
        raise ValueError(
            f"{name} must lie within ±{COORDINATE_LIMIT:.0e} px of the origin in x and y "
            f"(float32 on the GPU keeps ~1e-7 of the coordinates' extent); row {row} is "
            f"{points[row].tolist()}"
        )
    return points


def point_bounds(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The (x, y) minimum and maximum of non-empty (N, 2) ``points``. Column by column:
    numpy's ``min(axis=0)`` over two columns is ~35x slower (1.8 ms for 65,536 points)."""
    lo = np.array([points[:, 0].min(), points[:, 1].min()])
    hi = np.array([points[:, 0].max(), points[:, 1].max()])
    return lo, hi


def set_bounds(sets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The (N, D) minima and maxima of the K >= 1 points of each of the (N, K, D) ``sets``,
    as ``sets.min(axis=1)`` and ``sets.max(axis=1)``. Component by component: numpy reduces
    over K with an inner loop of D elements, ~20x slower."""
    components = range(sets.shape[2])
    lo = np.stack([sets[..., d].min(axis=1) for d in components], axis=1)
    hi = np.stack([sets[..., d].max(axis=1) for d in components], axis=1)
    return lo, hi


def same_source_pair(p: np.ndarray, q: np.ndarray) -> tuple[int, int] | None:
    """Indices i < j of the first two handles (in (x, y[, z]) order) with the same source
    point and different targets, or None."""
    xs = np.sort(p[:, 0])
    if not (xs[1:] == xs[:-1]).any():
        return None  # all x differ (the usual case): no full sort needed
    sub = np.lexsort(p.T[::-1])  # stable: equal points in index order
    ps, qs = p[sub], q[sub]
    same_p = (ps[1:] == ps[:-1]).all(axis=1)
    conflict = same_p & (qs[1:] != qs[:-1]).any(axis=1)
    if not conflict.any():
        return None
    k = int(np.argmax(conflict))
    i, j = sorted((int(sub[k]), int(sub[k + 1])))
    return i, j


def same_source_sets(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """(N,) bool: the handle sets of stacked (N, K, D) sources ``p`` and targets ``q`` that
    hold one source point with two different targets (:func:`same_source_pair` not None),
    for all sets in one sort along their handles."""
    if p.shape[1] < 2:
        return np.zeros(len(p), bool)
    order = np.lexsort(tuple(p[..., d] for d in range(p.shape[2] - 1, -1, -1)), axis=-1)
    ps = np.take_along_axis(p, order[..., None], axis=1)
    qs = np.take_along_axis(q, order[..., None], axis=1)
    # equal sources lie next to each other: a run with two targets has two neighbours differ
    # (component by component: numpy's reductions over the D of (N, K, D) run slowly)
    components = range(p.shape[2])
    same_p = np.logical_and.reduce([ps[:, 1:, d] == ps[:, :-1, d] for d in components])
    differ = np.logical_or.reduce([qs[:, 1:, d] != qs[:, :-1, d] for d in components])
    return (same_p & differ).any(axis=1)


def check_one_target(p: np.ndarray, q: np.ndarray) -> None:
    """``ValueError`` naming the first two handles (N, D) with one source point and different
    targets (f cannot take two values there); exact duplicate pairs pass."""
    pair = same_source_pair(p, q) if len(p) > 1 else None
    if pair is not None:
        i, j = pair
        raise ValueError(
            f"src[{i}] and src[{j}] are the same point {p[i].tolist()} with different "
            f"targets {q[i].tolist()} and {q[j].tolist()}"
        )


def check_gpu_distinct(
    p: np.ndarray,
    q: np.ndarray,
    p32: np.ndarray,
    q32: np.ndarray | Callable[[], np.ndarray],
    scale: float,
) -> None:
    """``ValueError`` if two source points p that differ become one in the GPU's float32
    scaled coordinates ``p32`` while their targets there, ``q32``, differ: f would take the
    mean of the targets at both, silently missing each. Exact duplicates pass.

    Parameters
    ----------
    p, q : numpy.ndarray
        Validated source and target points, (N, D) float64.
    p32, q32 : numpy.ndarray
        The same as the GPU holds them, (N, D) float32 (:meth:`Scaling.to_gpu`); ``q32`` may
        be a function that makes them, called only where two sources merge.
    scale : float
        The scaling's scale (pixels per scaled unit), for the message.
    """
    if len(p) < 2:
        return
    xs = np.sort(p32[:, 0])
    if (xs[1:] != xs[:-1]).all():
        return  # every x differs on the GPU (the usual case): no pair to look for
    if callable(q32):
        q32 = q32()
    pair = same_source_pair(p32, q32)
    if pair is None:
        return
    i, j = pair
    distance = float(np.linalg.norm(p[i] - p[j]))
    spacing = float(np.spacing(np.abs(p32[i])).max()) * scale
    raise ValueError(
        f"src[{i}] {p[i].tolist()} and src[{j}] {p[j].tolist()} are {distance:.3g} px apart, "
        f"closer than float32 on the GPU tells apart at this scale (it steps by {spacing:.3g} "
        f"px there), with different targets {q[i].tolist()} and {q[j].tolist()}"
    )


#: The least spread of distinct source handles the GPU takes, as a share of its scale (the
#: box of the handles and the image, at least 1 unit: :class:`Scaling`): below it their
#: squared distances in float32 fall under the weights' smallest normal numbers, and f came
#: out wrong by a good share of the spread, or NaN.
MIN_GPU_SPREAD = 1e-12


def check_gpu_spread(spread: float, scale: float, name: str = "the source handles") -> None:
    """``ValueError`` where distinct source handles spread over ``spread`` units (the largest
    side of their box) lie closer than float32 on the GPU resolves at ``scale``
    (:data:`MIN_GPU_SPREAD`); 0 (one source point) passes."""
    if 0.0 < spread < MIN_GPU_SPREAD * scale:
        raise ValueError(
            f"{name} span {spread:.3g} units, below the {MIN_GPU_SPREAD * scale:.3g} that "
            "float32 on the GPU resolves at this scale (1e-12 of the box of the handles and "
            "the image, at least 1 unit): give the coordinates in a smaller unit"
        )


def validate_handles(src: object, dst: object) -> tuple[np.ndarray, np.ndarray]:
    """Check source points p and target points q; return them as float64 (N, 2) arrays.

    Exact duplicate pairs are accepted; the same source point with two different targets is
    a ``ValueError`` (f cannot take two values there).
    """
    p = check_coordinates(as_points(src, "src"), "src")
    q = check_coordinates(as_points(dst, "dst"), "dst")
    if len(p) != len(q):
        raise ValueError(f"src and dst must have the same length, got {len(p)} and {len(q)}")
    check_one_target(p, q)
    return p, q


def check_affine_handles(src: np.ndarray) -> None:
    """Affine MLS needs 3 distinct source points not on one line (0 or 1 handle is fine:
    identity and translation)."""
    unique = np.unique(src, axis=0)
    if len(unique) <= 1:
        return
    centred = unique - unique.mean(axis=0)
    singular = np.linalg.svd(centred, compute_uv=False)
    if len(unique) == 2 or singular[1] <= 1e-9 * singular[0]:
        raise DegenerateHandlesError(
            f"affine MLS needs at least 3 source handles not on one line; got {len(unique)} "
            "distinct points on a line. Use transform='similarity' or 'rigid', or add a handle."
        )


def fit_boxes(lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The GPU's centre ((..., D)) and scale ((...,)) of each box ``lo`` .. ``hi`` ((..., D)
    corners): the centre on a multiple of 1/2 nearest the box's, the scale the least power
    of 2 (at least 1) that keeps the box within ``center ± scale``.

    Pixel centres (integers) less such a centre are multiples of 1/2, which float32 holds,
    and a power of 2 scales them exactly: they go to the GPU and back unchanged, so an
    identity map or a whole-pixel shift keeps every pixel's own point, and a displacement
    ``q - p`` of a few pixels scales without rounding.
    """
    lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    center = np.round(lo + hi) / 2
    half = np.maximum(np.maximum(hi - center, center - lo).max(axis=-1), 1.0)
    mantissa, exponent = np.frexp(half)  # half = mantissa * 2**exponent, mantissa in [0.5, 1)
    return center, np.ldexp(1.0, exponent - (mantissa == 0.5))


@dataclass(frozen=True)
class Scaling:
    """Maps pixel coordinates to the GPU's scaled ones: ``(x - center) / scale``.

    Centring and scaling keep float32 coordinates near [-1, 1], where their spacing is ~1e-7
    of the image size, instead of ~1e-4 px at x ~ 1000; the scale is a power of 2
    (:func:`fit_boxes`).
    """

    center: tuple[float, float]
    scale: float

    def to_gpu(self, points: np.ndarray, *, out: np.ndarray | None = None) -> np.ndarray:
        """``points`` (N, D) scaled, float32: into ``out`` where given (a float32 (N, D)
        array or view, such as the first columns of wider rows), which is returned."""
        points = np.asarray(points, dtype=np.float64)
        if points.ndim != 2 or points.shape[1] != len(self.center):
            scaled = ((points - np.asarray(self.center)) / self.scale).astype(np.float32)
            if out is None:
                return scaled
            out[...] = scaled
            return out
        # column by column: numpy broadcasts (N, 2) against (2,) ~3x slower
        if out is None:
            out = np.empty(points.shape, np.float32)
        elif out.shape != points.shape or out.dtype != np.float32:
            raise ValueError(
                f"out must be float32 of shape {points.shape}, got {out.dtype} {out.shape}"
            )
        for axis, center in enumerate(self.center):
            out[:, axis] = (points[:, axis] - center) / self.scale
        return out

    def from_gpu(self, points: np.ndarray) -> np.ndarray:
        return points.astype(np.float64) * self.scale + np.asarray(self.center)

    @classmethod
    def fit(cls, src: np.ndarray, dst: np.ndarray, shape: tuple[int, int] | None = None) -> Scaling:
        """The scaling for the box around the handles and, if given, the image."""
        boxes = [src, dst]
        if shape is not None:
            boxes.append(np.array([[-0.5, -0.5], [shape[1] - 0.5, shape[0] - 0.5]]))
        pts = np.concatenate(boxes)
        if len(pts) == 0:
            return cls((0.0, 0.0), 1.0)
        center, scale = fit_boxes(*point_bounds(pts))
        return cls((float(center[0]), float(center[1])), float(scale))


def float32_rounding(
    scaling, u: np.ndarray, s: np.ndarray, steps: float, stretch: np.ndarray | None = None
) -> np.ndarray:
    """(K,) pixels: ``steps`` float32 steps of the larger scaled coordinate of the points
    ``u`` and ``s`` (K, D) (of 1 where both lie nearer the centre; a NaN counts as 0): how
    near float32 on the GPU can bring f(s) to u there. ``scaling``: a :class:`Scaling`, or
    per point a centre (K, D) and a scale (K,) alike. ``stretch`` (K,): how many times f
    magnifies lengths at s (1 where not given, or less), which takes s's own steps into
    f(s)."""
    center = np.asarray(scaling.center, np.float64)
    scale = np.asarray(scaling.scale, np.float64)
    with np.errstate(invalid="ignore"):
        far_u = np.nan_to_num(np.abs(u - center).max(axis=1) / scale, nan=0.0)
        far_s = np.nan_to_num(np.abs(s - center).max(axis=1) / scale, nan=0.0)
    if stretch is not None:
        far_s = np.maximum(far_s, 1.0) * np.maximum(stretch, 1.0)
    far = np.maximum(far_u, far_s)
    return steps * float(np.finfo(np.float32).eps) * np.maximum(far, 1.0) * scale


#: A target offset (:func:`target_offset`) is taken
#: where it makes the GPU's scale at least this many times finer: for a map whose targets lie
#: far from its sources, not for the displacements of a usual warp.
OFFSET_GAIN = 4.0


def target_offset(
    src: np.ndarray, dst: np.ndarray, scale_of: Callable[[np.ndarray], float]
) -> np.ndarray:
    """The translation t ((D,) float64, whole units) to take off the targets ``dst`` ((N, D)
    points, segment ends included) of sources ``src`` so that the GPU evaluates f - t with
    float32's precision of the sources' box rather than that of the whole span: MLS is
    translation-equivariant where every weight is positive (targets q + t give f + t
    exactly; a weight of bounded reach leaves the identity beyond the handles instead, and
    the caller gives it no offset). t is the rounded difference of the centres of the
    targets' and the sources' boxes where that makes the GPU's scale (``scale_of(targets)``,
    the scaling fitted to ``src`` and those targets) at least :data:`OFFSET_GAIN` times
    finer, else 0."""
    zero = np.zeros(src.shape[1])
    if len(src) == 0:
        return zero
    centre = (src.min(axis=0) + src.max(axis=0)) / 2
    offset = np.round((dst.min(axis=0) + dst.max(axis=0)) / 2 - centre)
    if not offset.any():
        return zero
    return offset if scale_of(dst - offset) * OFFSET_GAIN <= scale_of(dst) else zero


def fit_offset(
    src: np.ndarray, dst: np.ndarray, shape: tuple[int, int] | None = None
) -> np.ndarray:
    """:func:`target_offset` (2,) of 2D handles, whole pixels, for :meth:`Scaling.fit`'s
    scale of ``src``, the targets and the image of ``shape``."""
    return target_offset(src, dst, lambda q: Scaling.fit(src, q, shape).scale)


def pack_handles(src: np.ndarray, dst: np.ndarray, scaling: Scaling) -> np.ndarray:
    """(N, 4) float32 rows (p.x, p.y, q.x, q.y) in scaled coordinates."""
    return np.concatenate([scaling.to_gpu(src), scaling.to_gpu(dst)], axis=1)
