"""Three-dimensional handles and points: validation, the volume diagonal and the scaling the
GPU works in.

Points are ``(x, y, z)`` = (column, row, slice) float arrays of shape (N, 3); voxel centres sit
at integer coordinates. A volume's shape is ``(D, H, W)`` (slices, rows, columns).
"""

from __future__ import annotations

import math
import operator
from collections.abc import Iterable, Sequence

import numpy as np

from ..errors import DtypeError
from .config import check_real, is_integer
from .handles import COORDINATE_LIMIT, Scaling, check_one_target, fit_boxes, target_offset

__all__ = [
    "as_points3",
    "as_volume_shape",
    "as_volume_spacing",
    "chosen_spacing",
    "dimension_of",
    "fit_offset3",
    "fit_scaling3",
    "no_radius3",
    "planar_spacing",
    "spacing_conflict",
    "validate_handles3",
    "volume_diagonal",
    "volume_extent",
]


def dimension_of(src: object) -> int:
    """3 where ``src`` has shape (N, 3), else 2 (the 2D validation then speaks);
    ``ValueError`` for (N, C) rows of another width C, which neither takes, for (x, y, z)
    rows in more than two axes (a batch's (1, N, 3)), and for one (x, y, z) handle given as a
    (3,) array (handles are rows: ``[[x, y, z]]``). Ragged rows are 3D where the first row
    has three values, so that the 3D validation names them."""
    try:
        shape = np.shape(src)
    except ValueError:  # ragged rows: named by the validation of the first row's width
        first = next(iter(src), None)  # type: ignore[call-overload]
        return 3 if isinstance(first, (list, tuple, np.ndarray)) and len(first) == 3 else 2
    if len(shape) > 2 and shape[-1] == 3:  # rows of (x, y, z) in too many axes
        raise ValueError(f"src must have shape (N, 3) as (x, y, z) rows, got {shape}")
    if len(shape) == 2 and shape[0] and shape[1] not in (2, 3):
        raise ValueError(
            f"src must have shape (N, 2) as (x, y) rows or (N, 3) as (x, y, z) rows, got {shape}"
        )
    if shape == (3,):  # else the 2D validation would ask for (N, 2) rows
        raise ValueError(
            "src must have shape (N, 3) as (x, y, z) rows, got (3,): one handle is [[x, y, z]]"
        )
    return 3 if len(shape) == 2 and shape[1] == 3 else 2


def as_points3(points: object, name: str = "points") -> np.ndarray:
    """``points`` as a C-contiguous float64 (N, 3) array of finite coordinates within
    ±:data:`~glmls.core.handles.COORDINATE_LIMIT`; ``ValueError``/``TypeError`` if not."""
    try:
        array = np.asarray(points)
    except ValueError:  # ragged rows (or a (vertices, faces, ...) sequence that is no mesh)
        raise ValueError(
            f"{name} must have shape (N, 3) as (x, y, z) rows; got rows of different lengths"
        ) from None
    if array.dtype.kind not in "iuf":
        raise DtypeError(f"{name} must be real numbers, got dtype {array.dtype}")
    if array.ndim != 2 or array.shape[1] != 3:
        # [] is no points; (0, 2) rows, even none, are the points of another dimension
        if array.size == 0 and (array.ndim == 1 or array.shape == (0, 0)):
            return np.zeros((0, 3))
        raise ValueError(f"{name} must have shape (N, 3) as (x, y, z) rows, got {array.shape}")
    array = np.ascontiguousarray(array, dtype=np.float64)
    # two reductions without temporaries decide every good array (NaN fails both
    # comparisons); the rows are looked for only on the way to an error
    if not len(array) or (-COORDINATE_LIMIT <= array.min() and array.max() <= COORDINATE_LIMIT):
        return array
    finite = np.isfinite(array).all(axis=1)
    if not finite.all():
        row = int(np.argmin(finite))
        raise ValueError(f"{name} must be finite; row {row} is {array[row]}")
    if np.abs(array).max() > COORDINATE_LIMIT:
        row = int(np.argmax(np.abs(array).max(axis=1) > COORDINATE_LIMIT))
        raise ValueError(
            f"{name} must lie within ±{COORDINATE_LIMIT:.0e} voxels of the origin (float32 on "
            f"the GPU keeps ~1e-7 of the coordinates' extent); row {row} is "
            f"{array[row].tolist()}"
        )
    return array


def validate_handles3(src: object, dst: object) -> tuple[np.ndarray, np.ndarray]:
    """Check 3D source points p and target points q; return them as float64 (N, 3) arrays.
    Exact duplicate pairs are accepted; one source point with two targets is a
    ``ValueError``."""
    p, q = as_points3(src, "src"), as_points3(dst, "dst")
    if len(p) != len(q):
        raise ValueError(f"src and dst must have the same length, got {len(p)} and {len(q)}")
    check_one_target(p, q)
    return p, q


def as_volume_shape(shape: Sequence[int]) -> tuple[int, int, int]:
    """``shape`` as a (D, H, W) tuple of positive ints; ``ValueError``/``TypeError`` if not."""
    try:
        values = tuple(shape)
    except TypeError:
        raise TypeError(f"shape must be (D, H, W), got {shape!r}") from None
    if len(values) != 3:
        raise ValueError(f"shape must be (D, H, W) integers for 3D handles, got {shape!r}")
    if not all(is_integer(n) for n in values):
        raise TypeError(f"shape must be (D, H, W) integers for 3D handles, got {shape!r}")
    if min(operator.index(n) for n in values) < 1:
        raise ValueError(f"shape must have D, H, W >= 1, got {shape!r}")
    return operator.index(values[0]), operator.index(values[1]), operator.index(values[2])


def as_volume_spacing(spacing: object, name: str = "spacing") -> tuple[float, float, float]:
    """A voxel spacing (dz, dy, dx) as three floats, finite and > 0.

    The one check of a spacing: :class:`glmls.Volume`, :func:`glmls.write_volume`,
    :func:`glmls.files.world_to_volume`, ``glmls.MLS(..., spacing=...)``, the volume warps,
    the 3D analyses, the window and the command line's ``--spacing`` all call it.

    Parameters
    ----------
    spacing : sequence of 3 real numbers
        (dz, dy, dx), ordered as a volume's (D, H, W): a tuple, list or numpy array of
        real numbers (:func:`~glmls.core.config.check_real`: Python or numpy numbers, 0-d
        arrays). One number is no spacing here (the command line's
        ``--spacing D`` reads one number as (D, D, D) itself).
    name : str, default "spacing"
        What the messages call it.

    Returns
    -------
    tuple of float
        (dz, dy, dx).

    Raises
    ------
    TypeError
        Where ``spacing`` is no sequence (a number, a string, None, a dict) or an entry is no
        real number (a string, None, a bool); the message names the value.
    ValueError
        Where there are not three entries, or one is not finite or not > 0; the message names
        the value.

    Examples
    --------
    >>> as_volume_spacing([2, 1, 0.5])
    (2.0, 1.0, 0.5)
    >>> as_volume_spacing((2.0, 0.0, 1.0))
    Traceback (most recent call last):
    ...
    ValueError: spacing must be positive and finite (dz, dy, dx), got (2.0, 0.0, 1.0)
    """
    what = f"{name} must be three real numbers (dz, dy, dx)"
    if isinstance(spacing, (str, bytes, dict)) or not isinstance(spacing, (Iterable, np.ndarray)):
        raise TypeError(f"{what}, got {spacing!r}")
    try:
        values = tuple(spacing)  # type: ignore[call-overload]
    except TypeError:  # a 0-d array
        raise TypeError(f"{what}, got {spacing!r}") from None
    for v in values:
        try:
            check_real(name, v, finite=False)
        except TypeError:
            raise TypeError(
                f"{what}, got {spacing!r} ({v!r} is not a number: a {type(v).__name__})"
            ) from None
    if len(values) != 3:
        raise ValueError(
            f"{name} must be three numbers (dz, dy, dx) like the volume's (D, H, W), "
            f"got {len(values)}: {spacing!r}"
        )
    try:
        steps = tuple(check_real(name, v, low=0, low_open=True) for v in values)
    except ValueError:
        raise ValueError(
            f"{name} must be positive and finite (dz, dy, dx), got {_shown(spacing)}"
        ) from None
    return steps  # type: ignore[return-value]


def _shown(spacing: object) -> str:
    """``spacing`` as the messages show it: a numpy array as its list of numbers."""
    if isinstance(spacing, np.ndarray):
        return repr(tuple(spacing.tolist()))
    return repr(spacing)


def volume_extent(
    shape: Sequence[float], spacing: Sequence[float] | None = None
) -> tuple[float, float, float]:
    """(D dz, H dy, W dx): the size of a (D, H, W) volume of voxels of ``spacing`` (dz, dy,
    dx) in the handles' units (None: voxels, (D, H, W))."""
    steps = (1.0, 1.0, 1.0) if spacing is None else spacing
    return tuple(float(n) * float(d) for n, d in zip(shape, steps, strict=True))  # type: ignore[return-value]


def checked_extent(
    shape: Sequence[int], spacing: Sequence[float] | None = None, *, name: str = "shape"
) -> tuple[float, float, float]:
    """:func:`volume_extent` of ``shape`` and ``spacing``, if it lies within the coordinate
    range; ``ValueError`` naming ``name``, the shape and the spacing if not: the volume's
    voxels are f's points, and its extent enters f's float32 scaling, as an image's does in
    2D (f drifts by tenths of a voxel beyond it)."""
    extent = volume_extent(shape, spacing)
    if max(extent) > COORDINATE_LIMIT:
        raise ValueError(
            f"{name} {tuple(shape)} with spacing {spacing} has an extent {extent} beyond "
            f"glmls's coordinate range, {COORDINATE_LIMIT:.0e} in the handles' units"
        )
    return extent


def volume_diagonal(shape: Sequence[float], spacing: Sequence[float] | None = None) -> float:
    """Length of the diagonal of a D x H x W volume: in voxels, or with ``spacing`` (dz, dy,
    dx) in the handles' units, that of (D dz, H dy, W dx)."""
    return math.sqrt(sum(e * e for e in volume_extent(shape, spacing)))


def no_radius3(weight: str) -> ValueError:
    """The error of a radius weight given neither ``radius`` nor a volume ``shape``, with
    (N, 3) handles."""
    return ValueError(
        f"weight {weight!r} needs an influence radius: pass radius=R (in the handles' units: "
        "voxels, or a mesh's coordinates), or shape=(D, H, W) to use the volume diagonal"
    )


def planar_spacing(spacing: object) -> None:
    """The spacing of (N, 2) handles, None: ``ValueError`` for any other ``spacing`` (a
    volume's voxels have one; an image's pixels are square)."""
    if spacing is not None:
        raise ValueError(
            f"spacing={spacing!r} is for (N, 3) handles (a volume's voxels); an image's "
            "pixels are square: leave spacing out with (N, 2) handles"
        )


def spacing_conflict(
    given: tuple[float, float, float], own: tuple[float, float, float]
) -> ValueError:
    """The error of a volume operation given ``spacing=given`` on an MLS of ``spacing=own``."""
    return ValueError(
        f"spacing={given} differs from the MLS's spacing={own}: its handles are in the units "
        "of its own spacing, and so is its default radius; leave spacing out to use the "
        "MLS's, or make an MLS with this spacing (or one without spacing, for volumes of "
        "several spacings)"
    )


def chosen_spacing(
    given: tuple[float, float, float] | None, own: tuple[float, float, float] | None
) -> tuple[float, float, float] | None:
    """The spacing (dz, dy, dx) of a volume operation given ``given`` on an MLS of spacing
    ``own`` (both checked, None where there is none): ``given``, else ``own``;
    :func:`spacing_conflict` where both are given and differ."""
    if given is not None and own is not None and tuple(given) != tuple(own):
        raise spacing_conflict(tuple(given), tuple(own))  # type: ignore[arg-type]
    return own if given is None else given


def fit_scaling3(
    src: np.ndarray,
    dst: np.ndarray,
    shape: tuple[int, int, int] | None = None,
    spacing: tuple[float, float, float] | None = None,
) -> Scaling:
    """The scaling ``(v - center) / scale`` for the box around the handles and, if given, the
    volume (x, y, z = column, row, slice; its voxels of ``spacing`` (dz, dy, dx) in the
    handles' units, 1 each when None); ``scale`` is a power of 2 (at least 1)."""
    boxes = [src, dst]
    if shape is not None:
        depth, height, width = shape
        dz, dy, dx = (1.0, 1.0, 1.0) if spacing is None else spacing
        boxes.append(
            np.array(
                [
                    [-0.5 * dx, -0.5 * dy, -0.5 * dz],
                    [(width - 0.5) * dx, (height - 0.5) * dy, (depth - 0.5) * dz],
                ]
            )
        )
    pts = np.concatenate(boxes)
    if len(pts) == 0:
        return Scaling((0.0, 0.0, 0.0), 1.0)  # type: ignore[arg-type]
    center, scale = fit_boxes(pts.min(axis=0), pts.max(axis=0))
    return Scaling(tuple(float(c) for c in center), float(scale))  # type: ignore[arg-type]


def fit_offset3(
    src: np.ndarray,
    dst: np.ndarray,
    shape: tuple[int, int, int] | None = None,
    spacing: tuple[float, float, float] | None = None,
    *,
    bounded: bool = False,
) -> np.ndarray:
    """:func:`~glmls.core.handles.target_offset` (3,) of 3D handles, whole handle units,
    for :func:`fit_scaling3`'s scale of ``src``, the targets and the volume: the GPU holds
    q - t and t is added back to f in float64, so targets far from their sources (say 1e5
    units off) keep float32's precision of the sources' box. Zeros for a weight of bounded
    reach (``bounded``), whose f is the identity beyond the handles, not v + t."""
    if bounded:
        return np.zeros(3)
    return target_offset(src, dst, lambda q: fit_scaling3(src, q, shape, spacing).scale)
