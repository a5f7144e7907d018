"""The output canvas and the border modes' reach past the image.

- ``Frame``: which part of the deformed plane the output shows: ``shape`` (H, W) output
  pixels, output pixel (column i, row j) showing the point ``origin`` + (i, j). The default
  frame is the source image's own (origin (0, 0), the input's shape).
- :class:`Bounds` (:func:`deformed_bounds`): the bounding box of the deformed image and the
  frame that shows all of it.
- :func:`border_margin`: how far past the image the forward methods' mesh must reach, for a
  border mode other than ``constant``, so that the extended source covers the whole frame.
"""

from __future__ import annotations

import math
import operator
import warnings
from collections.abc import Callable, Iterable
from dataclasses import dataclass

import numpy as np

from ..core.box_growth import box_gains, boxes_meet
from ..core.config import check_real, is_integer
from ..core.handles import COORDINATE_LIMIT, point_bounds
from ..core.mesh import MAX_MARGIN, MeshLattice, as_shape
from ..engine.kernel import MLSKernel
from ..engine.passes import evaluate_points
from ..errors import BorderWarning

__all__ = [
    "FIT_SLACK",
    "Bounds",
    "Frame",
    "border_margin",
    "check_origin",
    "check_output_shape",
    "covering_frame",
    "deformed_bounds",
    "encloses_all",
    "make_frame",
    "margin_shortfall",
    "pulled_margins",
    "real_values",
    "search_margins",
]

#: A box edge this close (pixels) to a pixel's edge does not make :class:`Bounds` take in the
#: pixel beyond: float32 noise of f, e.g. the identity's -0.5 read back as -0.5000001.
FIT_SLACK = 1e-3
#: A frame's pixel centres must stay this far (pixels) inside the deformed border of the
#: extended mesh (:func:`border_margin`).
ENCLOSE_PAD = 0.25


@dataclass(frozen=True)
class Frame:
    """The output canvas: ``shape`` (H, W) pixels; output pixel (column i, row j) shows the
    deformed plane's point ``origin`` + (i, j) (pixels; with the identity map, the source
    pixel there). Build with :func:`make_frame`, which validates."""

    shape: tuple[int, int]
    origin: tuple[float, float] = (0.0, 0.0)

    @property
    def size(self) -> tuple[int, int]:
        """(W, H)."""
        return self.shape[1], self.shape[0]

    @property
    def pixels(self) -> int:
        return self.shape[0] * self.shape[1]

    def uniforms(self, kernel: MLSKernel | None = None) -> dict[str, object]:
        """Those of ``glmls/shaders/warp/frame.glsl`` and the target's size, for the passes
        over ``kernel``'s f: the origin in the GPU's coordinates of the deformed plane, less
        the kernel's :attr:`~glmls.engine.kernel.MLSKernel.offset` (in float64, before
        float32 takes it: a canvas over targets far from their sources keeps the precision
        of f near them)."""
        frame = self if kernel is None else self.moved(-kernel.offset)
        return {"u_target_size": self.size, "u_origin": frame.origin}

    def moved(self, shift: np.ndarray) -> Frame:
        """This canvas over the deformed plane moved by ``shift`` ((2,) pixels)."""
        if not np.any(shift):
            return self
        x, y = np.add(self.origin, shift).tolist()
        return Frame(self.shape, (x, y))

    def centre_box(self, pad: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """(low, high) corners of the box of the output pixel centres, in the deformed
        plane's pixels, widened by ``pad``."""
        low = np.asarray(self.origin, dtype=np.float64)
        high = low + np.array([self.shape[1] - 1, self.shape[0] - 1], dtype=np.float64)
        return low - pad, high + pad


def check_output_shape(output_shape: object) -> tuple[int, int] | None:
    """``output_shape`` as (H, W) ints >= 1 (None stays None: the input's shape):
    ``TypeError`` for another type, or sides that are not integers
    (:func:`~glmls.core.config.is_integer`: 5.0 and True are not), ``ValueError`` for
    another length or a side below 1; both name the value."""
    if output_shape is None:
        return None
    message = f"output_shape must be (H, W) integers, got {output_shape!r}"
    if isinstance(output_shape, (str, bytes)) or not isinstance(
        output_shape, (Iterable, np.ndarray)
    ):
        raise TypeError(message)
    dims = list(output_shape)  # type: ignore[call-overload]
    if len(dims) != 2:
        raise ValueError(message)
    if not all(is_integer(n) for n in dims):
        raise TypeError(message)
    shape = (operator.index(dims[0]), operator.index(dims[1]))
    if min(shape) < 1:
        raise ValueError(f"output_shape must have H, W >= 1, got {output_shape!r}")
    return shape


def check_origin(origin: object) -> tuple[float, float] | None:
    """``origin`` as (x0, y0) finite floats within the coordinate limit (None stays None:
    (0, 0)): ``TypeError`` for another type, or values that are not real numbers (a bool, a
    string, a complex), ``ValueError`` for another length or a value that is not finite or
    beyond the limit; both name the value."""
    if origin is None:
        return None
    message = f"origin must be (x0, y0) real numbers, got {origin!r}"
    if isinstance(origin, (str, bytes)) or not isinstance(origin, (Iterable, np.ndarray)):
        raise TypeError(message)
    values = list(origin)  # type: ignore[call-overload]
    if len(values) != 2:
        raise ValueError(message)
    within = f"finite and within ±{COORDINATE_LIMIT:.0e} px"
    point = real_values("origin", values, repr(origin), "(x0, y0) real numbers", within)
    return point  # type: ignore[return-value]


def real_values(name: str, values: list, shown: str, kind: str, within: str) -> tuple[float, ...]:
    """``values``, the entries of the tuple option ``name`` (``shown`` as the messages show
    it), as floats within the coordinate range (``check_real``):
    ``TypeError`` saying ``name`` must be ``kind``, and the entry's type, for one that is no
    real number; ``ValueError`` saying it must be ``within`` for one not finite or beyond."""
    limit = COORDINATE_LIMIT
    point = []
    for value in values:
        try:
            point.append(check_real(name, value, low=-limit, high=limit))
        except TypeError:
            raise TypeError(
                f"{name} must be {kind}, got {shown} ({value!r} is a {type(value).__name__})"
            ) from None
        except ValueError:
            raise ValueError(f"{name} must be {within}, got {shown}") from None
    return tuple(point)


def make_frame(
    output_shape: object, origin: object, image_shape: tuple[int, int], max_size: int
) -> Frame:
    """The ``Frame`` of ``output_shape`` (H, W; None: ``image_shape``) and ``origin``
    (x0, y0; None: (0, 0)); ``ValueError`` naming a bad value (:func:`check_output_shape`,
    :func:`check_origin`), or a side beyond ``max_size`` (the GL limit)."""
    shape = check_output_shape(output_shape) or image_shape
    if max(shape) > max_size:
        raise ValueError(
            f"output_shape {shape} exceeds the GL limit of {max_size} pixels per side on "
            "this device"
        )
    point = check_origin(origin)
    return Frame(shape) if point is None else Frame(shape, point)


def covering_frame(points: np.ndarray) -> Frame:
    """The ``Frame`` of whole pixels whose pixel centres' box holds ``points``
    (non-empty (K, 2) float64 pixels): origin the box's floor, one pixel past its ceiling."""
    low, high = point_bounds(points)
    origin = np.floor(low)
    width, height = (np.ceil(high) - origin).astype(np.int64) + 1
    return Frame((int(height), int(width)), (float(origin[0]), float(origin[1])))


@dataclass(frozen=True)
class Bounds:
    """The bounding box of a deformed image, and the canvas that shows all of it.

    x from ``x0`` to ``x1``, y from ``y0`` to ``y1``, in pixels: the deformed corners of the
    pixel squares, so the identity gives -0.5 to W - 0.5. :attr:`output_shape` and
    :attr:`origin` are the canvas of every pixel the box touches:
    ``m.warp(image, output_shape=b.output_shape, origin=b.origin)`` shows the whole deformed
    image, nothing cut off, with every method (``splat`` rounds points to the nearest pixel,
    so a pixel that its centre leaves outside the box can still be hit). Made by
    :meth:`glmls.MLS.bounds`.

    Parameters
    ----------
    x0, y0 : float
        The box's smallest x and y, pixels.
    x1, y1 : float
        Its largest x and y, pixels.

    Raises
    ------
    TypeError
        For a value that is not a real number (``check_real``).
    ValueError
        For a value that is not finite, or an inverted box (``x1 < x0`` or ``y1 < y0``; an
        empty box, ``x1 == x0``, is a single point); from :attr:`output_shape` and
        :attr:`frame`, for a canvas beyond the coordinate range (a side over 1e6 pixels).

    Examples
    --------
    >>> import glmls
    >>> b = glmls.Bounds(-3.2, 0.5, 40.5, 20.9)
    >>> b.origin, b.output_shape
    ((-3.0, 1.0), (21, 44))
    >>> glmls.Bounds(-0.5, -0.5, 5.5, 3.5).output_shape  # the identity on a 4 x 6 image
    (4, 6)
    """

    x0: float
    y0: float
    x1: float
    y1: float

    def __post_init__(self) -> None:
        for name in ("x0", "y0", "x1", "y1"):
            value = check_real(f"Bounds {name}", getattr(self, name))
            object.__setattr__(self, name, value)
        for low, high in (("x0", "x1"), ("y0", "y1")):
            if getattr(self, high) < getattr(self, low):
                raise ValueError(
                    f"Bounds {high} must be >= {low} (a box's largest value is not below its "
                    f"smallest), got {low}={getattr(self, low)!r}, {high}={getattr(self, high)!r}"
                )

    @property
    def origin(self) -> tuple[float, float]:
        """(x0, y0) of the first pixel the box touches (whole pixels).

        Examples
        --------
        >>> glmls.Bounds(-3.2, 0.5, 40.5, 20.9).origin
        (-3.0, 1.0)
        """
        return (
            float(math.floor(self.x0 + 0.5 + FIT_SLACK)),
            float(math.floor(self.y0 + 0.5 + FIT_SLACK)),
        )

    @property
    def output_shape(self) -> tuple[int, int]:
        """(H, W) of the pixels the box touches, at least 1 x 1.

        ``ValueError`` where no warp can take that canvas: a side or its origin beyond the
        coordinate range (``COORDINATE_LIMIT``, the limit of an
        image's sides and of ``origin``; a device's GL limit on a side is far below it).

        Examples
        --------
        >>> glmls.Bounds(-0.5, -0.5, 5.5, 3.5).output_shape  # the identity on a 4 x 6 image
        (4, 6)
        >>> glmls.Bounds(0.0, 0.0, 1e12, 1.0).output_shape
        Traceback (most recent call last):
            ...
        ValueError: ...
        """
        ox, oy = self.origin
        width = max(1, math.ceil(self.x1 - 0.5 - FIT_SLACK) - int(ox) + 1)
        height = max(1, math.ceil(self.y1 - 0.5 - FIT_SLACK) - int(oy) + 1)
        limit = COORDINATE_LIMIT
        if max(width, height) > limit or max(abs(ox), abs(oy)) > limit:
            raise ValueError(
                f"{self!r} is beyond glmls's coordinate range: its canvas would have a side "
                f"over {limit:.0e} px or an origin beyond ±{limit:.0e} px, which no warp takes"
            )
        return height, width

    @property
    def frame(self) -> Frame:
        """The canvas of :attr:`output_shape` and :attr:`origin` as a ``Frame``.

        Examples
        --------
        >>> frame = glmls.Bounds(-3.2, 0.5, 40.5, 20.9).frame
        >>> frame.shape, frame.origin
        ((21, 44), (-3.0, 1.0))
        """
        return Frame(self.output_shape, self.origin)


def deformed_bounds(bands: Iterable[np.ndarray], kernel: MLSKernel) -> Bounds:
    """The :class:`Bounds` of the deformed points in ``bands`` (arrays of (K, 2) float32
    scaled points, f on a lattice band by band)."""
    low = np.full(2, np.inf)
    high = np.full(2, -np.inf)
    for points in bands:
        if len(points):
            lo, hi = point_bounds(points)
            low, high = np.minimum(low, lo), np.maximum(high, hi)
    (x0, y0), (x1, y1) = kernel.deformed(np.stack([low, high]))
    return Bounds(float(x0), float(y0), float(x1), float(y1))


def _segments_meet_box(a: np.ndarray, b: np.ndarray, low: np.ndarray, high: np.ndarray):
    """Which segments a -> b ((K, 2) each) meet the box [low, high] (Liang-Barsky)."""
    t0 = np.zeros(len(a))
    t1 = np.ones(len(a))
    d = b - a
    for k in range(2):
        dk, ak = d[:, k], a[:, k]
        flat = dk == 0
        safe = np.where(flat, 1.0, dk)
        ta = (low[k] - ak) / safe
        tb = (high[k] - ak) / safe
        inside = (ak >= low[k]) & (ak <= high[k])
        enter = np.where(flat, np.where(inside, -np.inf, np.inf), np.minimum(ta, tb))
        leave = np.where(flat, np.where(inside, np.inf, -np.inf), np.maximum(ta, tb))
        t0 = np.maximum(t0, enter)
        t1 = np.minimum(t1, leave)
    return t0 <= t1


def encloses(ring: np.ndarray, low: np.ndarray, high: np.ndarray) -> bool:
    """Does the closed polygon ``ring`` ((K, 2)) wind around the box [low, high] without
    touching it? Then every point of the box is covered by the piecewise linear image of
    the mesh whose border ``ring`` is (its degree there is the winding number, not 0)."""
    return bool(encloses_all(np.asarray(ring)[None], low, high)[0])


def encloses_all(rings: np.ndarray, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """:func:`encloses` of each of N closed polygons of K points, ``rings`` (N, K, 2): (N,)
    bool."""
    count, corners = rings.shape[:2]
    if corners < 3:
        return np.zeros(count, bool)
    following = np.roll(rings, -1, axis=1)
    meets = _segments_meet_box(rings.reshape(-1, 2), following.reshape(-1, 2), low, high)
    centre = (low + high) / 2
    a, b = rings - centre, following - centre
    cross = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    angles = np.arctan2(cross, a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1])
    finite = np.isfinite(rings).all(axis=(1, 2))
    with np.errstate(invalid="ignore"):
        winds = np.abs(angles.sum(axis=1)) > np.pi
    return finite & ~meets.reshape(count, corners).any(axis=1) & winds


#: The most points of the extended mesh (at grid 1; divided by grid^2), unless the image and
#: the canvas together have more pixels: the margin search stops there.
MARGIN_POINTS = 1 << 24


def border_margin(
    kernel: MLSKernel,
    lattice: MeshLattice,
    frame: Frame,
    *,
    warn: bool = True,
    max_points: int | None = None,
) -> int:
    """The margin (pixels, a multiple of ``lattice.grid``) that the mesh of ``lattice`` needs
    past the image so that its deformed border encloses every pixel centre of ``frame``:
    with a border mode the forward methods then leave no pixel of the frame uncovered.

    Derived from the deformation: 0 where the image's own deformed border already encloses
    the frame; else, starting from the border's largest displacement plus the frame's
    overhang past the image, doubled until the deformed border encloses the frame (f is
    evaluated on the border only); and at least :func:`pulled_margins`, for the plane that
    handles beyond the image pull over the canvas. The search stops where the extended
    mesh would have more than :data:`MARGIN_POINTS` points (or twice the image's and the
    canvas's pixels together), and as soon as the deformed border's box, growing with the
    margin twice as fast as it grew so far, could not reach the canvas's box within that
    budget (a canvas far from the image, a map that collapses the plane); a border whose box
    then misses the canvas altogether gets no margin. Where the border does not enclose the
    canvas, the pixels beyond keep the background, with a :class:`~glmls.errors.BorderWarning` where
    ``warn`` (the backward methods, which only start Newton there, do not warn).
    ``max_points``: that budget of mesh points instead (at grid 1), for a frame that is not
    drawn pixel by pixel (the first guess of f's inverse at scattered points).

    The search runs once per upload of the kernel's handles for each lattice, frame and
    budget (:meth:`~glmls.engine.kernel.MLSKernel.memo`): a warp and the labels that follow
    its mesh ask for the same margin."""
    key = ("border_margin", lattice.shape, lattice.grid, frame.shape, frame.origin, max_points)
    margin, encloses_frame = kernel.memo(
        key, lambda: _search_margin(kernel, lattice, frame, max_points)
    )
    if warn and not encloses_frame:
        warnings.warn(margin_shortfall(margin), BorderWarning, stacklevel=7)  # MLS.warp's caller
    return margin


def margin_shortfall(margin: int) -> str:
    """The :class:`~glmls.errors.BorderWarning` of a mesh whose largest ``margin`` (pixels)
    still leaves part of the canvas uncovered."""
    return (
        f"the mesh reaches {margin} px past the image, the most for this image and canvas, "
        "and f's image of it does not cover the whole canvas: pixels beyond keep the background"
    )


def _search_margin(
    kernel: MLSKernel, lattice: MeshLattice, frame: Frame, max_points: int | None
) -> tuple[int, bool]:
    """:func:`border_margin`'s search: the margin, and whether f's image of its border
    encloses the frame."""

    # in the GPU's frame of the deformed plane (MLSKernel.offset): a canvas over targets far
    # from their sources lies over the image there, as the same map's near its sources
    offset = kernel.offset

    def evaluate(rings: list[np.ndarray | None]) -> list[np.ndarray | None]:
        ring = rings[0]
        assert ring is not None
        f, _ = evaluate_points(kernel, ring, with_matrix=False, shape=lattice.shape)
        return [f - offset]

    handles = kernel.handles
    src = np.concatenate([handles.src, handles.src_segments.reshape(-1, 2)])
    # (the kernel's targets are already moved back by the offset: MLSKernel.upload)
    dst = np.concatenate([handles.dst, handles.dst_segments.reshape(-1, 2)])
    moved = frame.moved(-offset)
    return search_margins(evaluate, 1, lattice, moved, max_points, handles=[(src, dst)])[0]


def pulled_margins(
    handles: list[tuple[np.ndarray, np.ndarray]],
    shape: tuple[int, int],
    low: np.ndarray,
    high: np.ndarray,
) -> np.ndarray:
    """(N,) how far (pixels) past the image each of N maps' mesh must reach for the handles
    that pull the plane beyond the image over the canvas: twice the distance past the image
    of each source handle (or segment end) outside it whose target lies over the canvas's
    box from ``low`` to ``high`` grown by that distance (f folds the plane about such a handle onto
    the canvas, where cells before the image's in scan order may show, whatever the image's
    own border does); 0 where none does. ``handles``: each map's source and target points,
    (K, 2) each."""
    count = len(handles)
    sizes = [len(src) for src, _ in handles]
    most = np.zeros(count)
    if not sum(sizes):
        return most
    src = np.concatenate([np.asarray(a, float).reshape(-1, 2) for a, _ in handles])
    dst = np.concatenate([np.asarray(b, float).reshape(-1, 2) for _, b in handles])
    height, width = shape
    past = np.maximum(
        np.maximum(-0.5 - src[:, 0], src[:, 0] - (width - 0.5)),
        np.maximum(-0.5 - src[:, 1], src[:, 1] - (height - 0.5)),
    )
    outside = past > 0
    if not outside.any():  # every handle over the image: the usual case, one test
        return most
    grown = past[:, None]
    over = outside & np.all((dst >= low - grown) & (dst <= high + grown), axis=1)
    owner = np.repeat(np.arange(count), sizes)
    np.maximum.at(most, owner[over], 2.0 * past[over])
    return most


def search_margins(
    evaluate: Callable[[list[np.ndarray | None]], list[np.ndarray | None]],
    count: int,
    lattice: MeshLattice,
    frame: Frame,
    max_points: int | None = None,
    *,
    handles: list[tuple[np.ndarray, np.ndarray]] | None = None,
) -> list[tuple[int, bool]]:
    """:func:`border_margin`'s search for ``count`` maps at once (a batch's images): per map,
    its margin and whether f's image of the margin's border encloses the frame.
    ``evaluate(rings)``: f of each map at its ring of points (pixels, (K, 2); None for a
    map whose search has ended, whose value goes unread), as
    :func:`~glmls.engine.passes.evaluate_points` gives it (float64): one call per step of
    the search, every map's ring in it. ``handles``: each map's source and target points
    ((K, 2) each, in the frame's coordinates): the margin reaches at least
    :func:`pulled_margins` past the image, so that the plane they pull over the canvas is in
    the mesh whatever the canvas (a larger one would reach it for its own sake)."""
    height, width = as_shape(lattice.shape)
    grid = lattice.grid
    low, high = frame.centre_box(ENCLOSE_PAD)
    overhang = max(0.0, -0.5 - low[0], -0.5 - low[1], high[0] - width + 0.5, high[1] - height + 0.5)
    base = lattice.with_margin(0)
    ring = base.boundary()
    deformed = np.stack(evaluate([ring] * count))  # type: ignore[arg-type]
    found: list[tuple[int, bool] | None] = [None] * count
    inside = encloses_all(deformed, low, high)
    budget = max(MARGIN_POINTS, 2 * (height * width + frame.pixels))
    points = (budget if max_points is None else max_points) * grid * grid
    reach = min(MAX_MARGIN, max(grid, _margin_within(height, width, points) // grid * grid))
    margins = [0] * count
    finite = np.isfinite(deformed).all(axis=(1, 2))
    moved = np.abs(deformed - ring).max(axis=(1, 2), initial=0.0)
    # each map's last evaluated margin and its deformed border's box: how fast the box grows
    # with the margin tells whether the budget's reach could ever enclose the frame
    lows, highs = _boxes(deformed)
    seen = [(0, lows[k], highs[k]) for k in range(count)]
    least = [0] * count
    if handles is not None:
        for k, pulled in enumerate(pulled_margins(handles, (height, width), low, high)):
            least[k] = min(reach, _round_up(pulled, grid)) if pulled > 0 else 0
    for k in range(count):
        if inside[k] and not least[k]:
            found[k] = (0, True)
        elif inside[k]:
            margins[k] = least[k]
        else:
            step = float(moved[k]) if finite[k] else 0.0
            margins[k] = max(least[k], min(reach, _round_up(step + overhang + 1, grid)))
    rings: dict[int, np.ndarray] = {}
    while True:
        active = [k for k in range(count) if found[k] is None]
        if not active:
            return found  # type: ignore[return-value]
        asked: list[np.ndarray | None] = [None] * count
        for k in active:
            if margins[k] not in rings:
                rings[margins[k]] = base.with_margin(margins[k]).boundary()
            asked[k] = rings[margins[k]]
        values = evaluate(asked)
        # the margins each map was evaluated at: the loop below doubles some of them, and a
        # doubled one must wait for its own ring, not be judged by this one's values
        evaluated = list(margins)
        for margin in sorted({evaluated[k] for k in active}):
            alike = [k for k in active if evaluated[k] == margin]
            stacked = np.stack([values[k] for k in alike])  # type: ignore[misc]
            inside = encloses_all(stacked, low, high)
            lows, highs = _boxes(stacked)
            for j, (k, covered) in enumerate(zip(alike, inside.tolist(), strict=True)):
                box = (lows[j], highs[j])
                if covered:
                    found[k] = (margin, True)
                elif margin >= reach or not box_gains(seen[k], (margin, *box), reach, low, high):
                    # a border whose box misses the frame covers none of it: no margin then
                    found[k] = (margin if boxes_meet(box, low, high) else 0, False)
                else:
                    seen[k] = (margin, *box)
                    margins[k] = min(reach, 2 * margin)


def _boxes(rings: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The (low, high) corners of each deformed border's points (``rings``: (N, K, 2)), two
    (N, 2) arrays; non-finite points stand nowhere (a border of none: an empty box, low
    inf and high -inf)."""
    # x and y apart: numpy reduces an (N, K, 2) array over K with an inner loop of 2,
    # ~20x slower than over the (N, K) components
    x, y = rings[..., 0], rings[..., 1]
    finite = np.isfinite(x) & np.isfinite(y)
    lows = np.empty((len(rings), 2))
    highs = np.empty((len(rings), 2))
    for k, values in enumerate((x, y)):
        lows[:, k] = np.where(finite, values, np.inf).min(axis=1, initial=np.inf)
        highs[:, k] = np.where(finite, values, -np.inf).max(axis=1, initial=-np.inf)
    return lows, highs


def _margin_within(height: int, width: int, pixels: int) -> int:
    """The largest margin m with (height + 2m) x (width + 2m) <= ``pixels`` (0 if none): the
    root of 4m^2 + 2(h + w)m + hw - pixels, for long thin images as for square ones."""
    if height * width >= pixels:
        return 0
    m = (math.isqrt((height - width) ** 2 + 4 * pixels) - height - width) // 4
    while (height + 2 * (m + 1)) * (width + 2 * (m + 1)) <= pixels:
        m += 1
    while m > 0 and (height + 2 * m) * (width + 2 * m) > pixels:
        m -= 1
    return m


def _round_up(value: float, step: int) -> int:
    return max(step, step * math.ceil(value / step))
