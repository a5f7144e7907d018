"""The lattices of a volume (D, H, W) on which the 3D analysis evaluates f, and the checks of
its arguments. Points are (x, y, z) = (column, row, slice), voxel centres at integers.

- voxel centres every ``grid`` voxels: 0, grid, 2 grid, ... along each axis, and the last
  voxel n - 1 always (the error field; between the points it is interpolated trilinearly);
- cell corners every ``grid`` voxels: -0.5, -0.5 + grid, ..., and n - 0.5 always (the last
  step may be shorter), as the 2D mesh: a cell covers the voxels whose centres it holds.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from ..core.config import check_integer
from ..core.handles3 import as_volume_shape as core_volume_shape
from ..core.handles3 import as_volume_spacing, chosen_spacing
from ..core.mesh import MAX_GRID
from ..errors import DtypeError

__all__ = [
    "as_points3",
    "as_volume_shape",
    "axis_centres",
    "axis_corners",
    "check_grid3",
    "check_handles3",
    "check_three_d",
    "deformation_spacing",
    "evaluate",
    "flat_areas",
    "flat_triples",
    "interpolate_axis",
    "lattice_points",
    "real_values",
    "spacing_scale",
]

#: Points per call of ``m`` (and per block of the numpy sums over them).
CHUNK = 1 << 18

#: How many units of f's precision a determinant may lie from 0 and count as 0: f flattens
#: the cell or tetrahedron (its sign is then rounding, not orientation).
FLAT_ULPS = 32


def as_volume_shape(shape: object) -> tuple[int, int, int]:
    """(D, H, W) from a volume's shape (D, H, W) or (D, H, W, C), each an integer >= 1
    (:func:`glmls.core.handles3.as_volume_shape`'s rule: 2.5 is no size); ``ValueError`` /
    ``TypeError`` otherwise."""
    if isinstance(shape, (str, bytes)):
        raise TypeError(f"shape must be (D, H, W) integers, got {shape!r}")
    try:
        dims = tuple(shape)  # type: ignore[call-overload]
    except TypeError:
        raise TypeError(f"shape must be (D, H, W) integers, got {shape!r}") from None
    if len(dims) not in (3, 4):
        raise ValueError(f"shape must be (D, H, W) with D, H, W >= 1, got {shape!r}")
    return core_volume_shape(dims[:3])


def check_grid3(grid: object, name: str = "grid") -> int:
    """``grid`` as an int from 1 to MAX_GRID (a lattice step in voxels): ``TypeError``
    naming ``name`` and the value for another type (a float such as 2.0, a bool, None),
    ``ValueError`` for an integer out of range."""
    return check_integer(name, grid, 1, MAX_GRID, what=f"an integer from 1 to {MAX_GRID} (voxels)")


def spacing_scale(spacing: object) -> np.ndarray:
    """(dx, dy, dz), the handle units per voxel along x, y, z, of ``spacing`` (dz, dy, dx),
    checked by :func:`~glmls.core.handles3.as_volume_spacing`; None: (1, 1, 1)."""
    if spacing is None:
        return np.ones(3)
    return np.array(as_volume_spacing(spacing)[::-1], dtype=np.float64)


def deformation_spacing(m: object, spacing: object) -> object:
    """The spacing an analysis of ``m`` takes: ``spacing`` where given, else ``m.spacing``
    (that of ``glmls.MLS(..., spacing=...)``; None: 1 each); ``ValueError`` where both are
    given and differ."""
    own, given = (
        None if s is None else as_volume_spacing(s) for s in (getattr(m, "spacing", None), spacing)
    )
    return chosen_spacing(given, own)  # type: ignore[arg-type]


def check_three_d(m: object) -> None:
    """``ValueError`` where the deformation ``m`` has 2D handles (an ``m.src`` of (N, 2)
    rows): the 3D analyses would fail later on its (K, 2) results, without saying why."""
    src = getattr(m, "src", None)
    if src is not None and np.ndim(src) == 2 and np.shape(src)[1] == 2:
        raise ValueError(
            f"m is a 2D deformation (src of shape {np.shape(src)}); the volume analyses take "
            "one of (N, 3) handles"
        )


def check_handles3(m: object) -> None:
    """``TypeError`` naming ``m`` unless it has what the error field (eq. 7) needs and a
    function of points alone has not: the handles ``m.src``, ``m.dst`` and the affine fits
    ``m.matrices(points)``; before anything of it is called. ``ValueError`` for 2D handles
    (:func:`check_three_d`)."""
    check_three_d(m)
    missing = [name for name in ("src", "dst") if getattr(m, name, None) is None]
    if not callable(getattr(m, "matrices", None)):
        missing.append("matrices")
    if missing:
        raise TypeError(
            "m must be a glmls.MLS of (N, 3) handles or a glmls.analysis.ReferenceDeformation "
            "(anything with the handles m.src, m.dst and the fits m.matrices(points)): the "
            f"MLS error (eq. 7) is the fits' misses of the handles; got {type(m).__name__}, "
            f"without {', '.join(missing)} (cell_jacobians and tetrahedron_errors take any "
            "function of points)"
        )


def as_points3(points: object, name: str = "points") -> np.ndarray:
    """``points`` as a C-contiguous float64 (N, 3) array of finite (x, y, z) rows;
    ``ValueError`` naming ``name`` for rows of different lengths, as for another shape."""
    try:
        array = np.asarray(points)
    except ValueError:  # ragged rows: numpy's message would not say which argument
        raise ValueError(
            f"{name} must have shape (N, 3) as (x, y, z) rows; got rows of different lengths"
        ) from None
    if array.dtype.kind not in "iuf":
        raise DtypeError(f"{name} must be real numbers, got dtype {array.dtype}")
    if array.ndim != 2 or array.shape[1] != 3:
        if array.size == 0 and (array.ndim == 1 or array.shape == (0, 0)):  # [] is no points
            return np.zeros((0, 3))
        raise ValueError(f"{name} must have shape (N, 3) as (x, y, z) rows, got {array.shape}")
    array = np.ascontiguousarray(array, dtype=np.float64)
    if not np.isfinite(array).all():
        row = int(np.argmax(~np.isfinite(array).all(axis=1)))
        raise ValueError(f"{name} must be finite; row {row} is {array[row].tolist()}")
    return array


def flat_areas(
    area: np.ndarray, a: np.ndarray, b: np.ndarray, precision: float, noise: float | np.ndarray
) -> np.ndarray:
    """Whether the signed areas ``area`` (the cross products of two edges of lengths ``a``
    and ``b``) are 0 within rounding: at most :data:`FLAT_ULPS` times the rounding
    ``precision`` of a b, plus the change an error of ``precision`` x ``noise`` (the scale
    of f at the edges' ends) in each edge makes; :func:`flat_triples` in the plane."""
    return np.abs(area) <= FLAT_ULPS * precision * (a * b + noise * (a + b))


def flat_triples(edges: Sequence[np.ndarray], precision: float, noise: np.ndarray) -> np.ndarray:
    """Whether the triple products a . (b x c) of the edges (a, b, c), (..., 3) each, are 0
    within rounding: at most :data:`FLAT_ULPS` times the rounding ``precision`` of
    |a| |b| |c|, plus the change an error of ``precision`` x ``noise`` (the scale of f at
    the edges' ends) in each edge makes."""
    a, b, c = (np.linalg.norm(e, axis=-1) for e in edges)
    triple = (edges[0] * np.cross(edges[1], edges[2])).sum(-1)
    tolerance = FLAT_ULPS * precision * (a * b * c + noise * (a * b + b * c + a * c))
    return np.abs(triple) <= tolerance


def axis_centres(n: int, grid: int) -> np.ndarray:
    """Voxel centres 0, grid, ... along an axis of n voxels, and n - 1 always."""
    coords = np.arange(0, n, grid, dtype=np.float64)
    return coords if coords[-1] == n - 1 else np.append(coords, n - 1.0)


def axis_corners(n: int, grid: int) -> np.ndarray:
    """Cell corners -0.5, -0.5 + grid, ... along an axis of n voxels, and n - 0.5 always."""
    coords = np.arange(0, n, grid, dtype=np.float64) - 0.5
    return np.append(coords, n - 0.5)


def lattice_points(z: np.ndarray, y: np.ndarray, x: np.ndarray) -> np.ndarray:
    """The (x, y, z) points of the lattice z x y x x in C order of (z, y, x): (K, 3)."""
    zz, yy, xx = np.meshgrid(z, y, x, indexing="ij")
    return np.stack([xx.ravel(), yy.ravel(), zz.ravel()], axis=1)


def real_values(values: object, what: str) -> np.ndarray:
    """``values`` (what ``what`` returned) as a new float64 array; ``TypeError`` naming
    ``what`` for values that are not real numbers (complex, bool, strings, None): casting
    them would drop an imaginary part or read True as 1 without a word."""
    try:
        array = np.asarray(values)
    except ValueError:  # ragged rows
        raise ValueError(f"{what} returned rows of different lengths") from None
    if array.dtype.kind not in "iuf":
        try:  # an object array of plain numbers is numbers
            array = np.asarray(array, dtype=np.float64) if array.dtype.kind == "O" else None
        except (TypeError, ValueError):
            array = None
        if array is None:
            kind = np.asarray(values).dtype
            raise TypeError(f"{what} returned {kind} values, expected real numbers")
    return np.array(array, dtype=np.float64)


def evaluate(
    function: Callable[[np.ndarray], np.ndarray], points: np.ndarray, width: int
) -> np.ndarray:
    """``function`` over (K, 3) points in blocks of :data:`CHUNK`, as (K, width) float64;
    ``ValueError`` if it returns the wrong shape or values that are not finite."""
    out = np.empty((len(points), width))
    for start in range(0, len(points), CHUNK):
        block = points[start : start + CHUNK]
        values = real_values(function(block), "m").reshape(len(block), -1)
        if values.shape[1] != width:
            raise ValueError(f"m returned {values.shape[1]} values per point, expected {width}")
        out[start : start + len(block)] = values
    if not np.isfinite(out).all():
        raise ValueError("m returned NaN or infinite values")
    return out


def interpolate_axis(values: np.ndarray, coords: np.ndarray, n: int, axis: int) -> np.ndarray:
    """``values`` sampled at ``coords`` (increasing, from 0 to n - 1) along ``axis``,
    interpolated linearly to 0 .. n - 1."""
    if len(coords) == n:
        return values
    target = np.arange(n, dtype=np.float64)
    right = np.clip(np.searchsorted(coords, target, side="right"), 1, len(coords) - 1)
    left = right - 1
    t = (target - coords[left]) / (coords[right] - coords[left])
    shape = [1] * values.ndim
    shape[axis] = n
    t = t.reshape(shape)
    a = np.take(values, left, axis=axis)
    b = np.take(values, right, axis=axis)
    return a + t * (b - a)
