"""Labels that ride along a deformation: bounding boxes and polygons become points, move
through the same map that placed the pixels (:func:`glmls.warp_batch`'s keypoints), and
become boxes and polygons again.

A box is ``(x_min, y_min, x_max, y_max)`` in the pixel coordinates of the points (pixel
centres at integers, so an H x W image spans [-0.5, W - 0.5] x [-0.5, H - 0.5]). Its outline
is sampled densely (a point every ``step`` pixels along each side, not only the corners: a
deformation bends the sides), the moved outline's bounding box is clipped to the output
canvas, and a box is valid where what is left has a positive width and height.
"""

from __future__ import annotations

import math
import operator
from collections.abc import Mapping

import numpy as np

from ..batch.inputs import check_coordinates, item_array
from ..core.config import check_real, counted
from ..errors import DtypeError
from ..imaging.options import FIELDS, WarpOptions

__all__ = [
    "box_outlines",
    "boxes_from_outlines",
    "canvas_shape",
    "check_boxes",
    "check_polygons",
    "check_positive",
    "clip_polygon",
    "densify_polygon",
    "outline_sets",
    "warp_options_of",
]


#: The most points :func:`box_outlines` puts on one side of a box, and :func:`densify_polygon`
#: on one edge: 2**22 (64 MiB of float64 points); a smaller ``step`` is refused.
MAX_EDGE_POINTS = 1 << 22
#: How far past the image (times its larger side, plus 64 px) :func:`box_outlines` samples
#: a box's sides every ``step``; further out, at steps that double with the distance.
NEAR_SIDES = 4


def _real_rows(array: np.ndarray, name: str, columns: int, rows: str) -> np.ndarray:
    """``array`` as (``rows``, ``columns``) float64: a ``DtypeError`` naming ``name`` for
    values that are no real numbers, a ``ValueError`` for another shape."""
    real = np.issubdtype(array.dtype, np.number) and array.dtype.kind != "c"
    if array.dtype == object or not real:  # complex would lose its imaginary part
        raise DtypeError(f"{name} has dtype {array.dtype}; expected real numbers")
    if array.ndim != 2 or array.shape[1] != columns:
        raise ValueError(f"{name} has shape {array.shape}; expected ({rows}, {columns})")
    return np.asarray(array, np.float64)


def _finite(array: np.ndarray, name: str, columns: int, rows: str = "B") -> np.ndarray:
    """``array`` as (``rows``, ``columns``) finite float64 coordinates within
    :data:`~glmls.core.handles.COORDINATE_LIMIT`, as the points they become must be."""
    return check_coordinates(_real_rows(array, name, columns, rows), name)


def _real_array(value: object, name: str, columns: int, rows: str) -> np.ndarray:
    """``value`` as a (``rows``, ``columns``) float64 array for the public label helpers,
    which take coordinates of any size: :func:`_real_rows`' errors, and a ``ValueError`` for
    a value that is not finite."""
    array = np.asarray(value)
    if array.size == 0 and array.ndim <= 2:  # [] or np.zeros((0, 2)): none
        array = array.reshape(0, columns)
    array = _real_rows(array, name, columns, rows)
    if not np.isfinite(array).all():
        raise ValueError(f"{name} holds values that are not finite (NaN or inf)")
    return array


def _canvas(shape: object) -> tuple[int, int]:
    """``shape`` as the canvas (H, W), two integers >= 0; a ``ValueError`` naming it else."""
    try:
        height, width = (operator.index(side) for side in shape)  # type: ignore[union-attr]
    except (TypeError, ValueError):
        raise ValueError(f"shape must be (H, W), two integers >= 0, got {shape!r}") from None
    if height < 0 or width < 0:
        raise ValueError(f"shape must be (H, W), two integers >= 0, got {shape!r}")
    return height, width


def _per_image(value: object, name: str, count: int) -> tuple[list, bool]:
    if isinstance(value, np.ndarray) and value.dtype != object:
        if value.ndim != 3:
            raise ValueError(
                f"{name} must be an (N, B, ...) array or a sequence of N arrays, got shape "
                f"{value.shape}"
            )
        items, stacked = list(value), True
    elif isinstance(value, (list, tuple)) or (isinstance(value, np.ndarray) and value.ndim == 1):
        items, stacked = list(value), False  # a 1-D object array: a sequence of arrays
    else:
        raise TypeError(f"{name} must be an array or a sequence, got {type(value).__name__}")
    if len(items) != count:
        raise ValueError(
            f"{name} holds {counted(len(items), 'item')} for {counted(count, 'image')}"
        )
    return items, stacked


def check_boxes(boxes: object, count: int) -> tuple[list[np.ndarray], bool]:
    """Per image, its (B_i, 4) float64 boxes, and whether they came as one (N, B, 4) array.

    Parameters
    ----------
    boxes : array_like or sequence of array_like
        An (N, B, 4) array or N arrays (B_i, 4) of ``(x_min, y_min, x_max, y_max)``.
    count : int
        N, the number of images.

    Returns
    -------
    (list of numpy.ndarray, bool)
        The boxes per image and the stacked flag.

    Raises
    ------
    ValueError
        For a wrong count or shape, a value that is not finite or a box whose maximum lies
        below its minimum, naming the item (``boxes[2]``).

    Examples
    --------
    >>> from glmls.augment.labels import check_boxes
    >>> check_boxes([[[0, 0, 4, 4]]], 1)[0][0].tolist()
    [[0.0, 0.0, 4.0, 4.0]]
    >>> check_boxes([[[4, 0, 0, 4]]], 1)
    Traceback (most recent call last):
    ...
    ValueError: boxes[0][0] has x_max < x_min or y_max < y_min: [4.0, 0.0, 0.0, 4.0]
    """
    items, stacked = _per_image(boxes, "boxes", count)
    checked = []
    for i, item in enumerate(items):
        array = item_array(item, f"boxes[{i}]")
        if array.size == 0:
            array = array.reshape(0, 4)
        array = _finite(array, f"boxes[{i}]", 4)
        wrong = np.flatnonzero((array[:, 2] < array[:, 0]) | (array[:, 3] < array[:, 1]))
        if len(wrong):
            j = int(wrong[0])
            raise ValueError(
                f"boxes[{i}][{j}] has x_max < x_min or y_max < y_min: {array[j].tolist()}"
            )
        checked.append(array)
    return checked, stacked


def check_polygons(polygons: object, count: int) -> list[list[np.ndarray]]:
    """Per image, its list of (V, 2) float64 polygons (V >= 1).

    Parameters
    ----------
    polygons : sequence
        N sequences (one per image) of (V, 2) vertex arrays; an image's polygons of one
        size may come as one (P, V, 2) array, and those of a batch as an (N, P, V, 2) array.
    count : int
        N, the number of images.

    Returns
    -------
    list of list of numpy.ndarray
        The polygons per image.

    Raises
    ------
    ValueError
        For a wrong count or shape or a value that is not finite, naming the item
        (``polygons[1][0]``).

    Examples
    --------
    >>> from glmls.augment.labels import check_polygons
    >>> len(check_polygons([[[[0, 0], [4, 0], [4, 4]]]], 1)[0])
    1
    """
    items = _polygon_list(polygons, 4)
    if items is None:
        raise TypeError(f"polygons must be a sequence, got {_kind(polygons)}")
    if len(items) != count:
        raise ValueError(
            f"polygons holds {counted(len(items), 'item')} for {counted(count, 'image')}"
        )
    checked = []
    for i, given in enumerate(items):
        shapes = _polygon_list(given, 3)
        if shapes is None:
            raise TypeError(
                f"polygons[{i}] must be a sequence of (V, 2) arrays, got {_kind(given)}"
            )
        one = []
        for j, polygon in enumerate(shapes):
            name = f"polygons[{i}][{j}]"
            array = _finite(item_array(polygon, name), name, 2, "V")
            if len(array) == 0:
                raise ValueError(f"polygons[{i}][{j}] has no vertices")
            one.append(array)
        checked.append(one)
    return checked


def _polygon_list(value: object, ndim: int) -> list | None:
    """``value``'s items where it is a list or a tuple of them, an array of ``ndim``
    dimensions (a (P, V, 2) array of one image's polygons of one size: ``ndim`` 3) or a 1-D
    object array of them; None where it is none of these."""
    if isinstance(value, (list, tuple)):
        return list(value)
    if isinstance(value, np.ndarray) and (
        (value.ndim == ndim and value.dtype != object)
        or (value.ndim == 1 and value.dtype == object)
    ):
        return list(value)
    return None


def _kind(value: object) -> str:
    """What an error says ``value`` is: its type, and an array's shape."""
    if isinstance(value, np.ndarray):
        return f"an array of shape {value.shape}"
    return type(value).__name__


def warp_options_of(options: Mapping[str, object]) -> WarpOptions:
    """The :class:`glmls.WarpOptions` that a draw's warp ``options`` (keywords of
    :func:`glmls.warp_batch`) stand for."""
    fields = {k: v for k, v in options.items() if k in FIELDS or k == "options"}
    return WarpOptions.of(fields.pop("options", None), **fields)


def canvas_shape(draw: Mapping) -> tuple[int, int]:
    """(H, W) of the canvas that a draw (a record of ``params``) warps onto: its
    ``output_shape``, else its image's shape."""
    chosen = warp_options_of(draw["options"])
    return chosen.output_shape or (int(draw["shape"][0]), int(draw["shape"][1]))


def check_positive(name: str, value: object) -> float:
    """``value`` as a float, a finite number > 0 (numpy's numbers and 0-d arrays too): a
    ``TypeError`` naming ``name`` and the value for one that is no real number (a bool, a
    string, None, a complex), a ``ValueError`` for one that is not finite or not > 0."""
    return check_real(name, value, low=0, low_open=True)


def _samples(length: float, step: float) -> int:
    """Points on an edge of ``length`` px, ``step`` px apart; ``ValueError`` for a length
    that is not finite, or more than ``MAX_EDGE_POINTS`` (2**22) points."""
    if not math.isfinite(length):
        raise ValueError(f"an edge of length {length} px: coordinates must be finite")
    count = max(1, math.ceil(length / step))
    if count > MAX_EDGE_POINTS:
        raise ValueError(
            f"step {step:g} px puts {count} points on an edge of {length:g} px, more than "
            f"{MAX_EDGE_POINTS}: use a larger step"
        )
    return count


def box_outlines(
    boxes: np.ndarray,
    step: float,
    *,
    mesh: tuple[int, tuple[int, int]] | None = None,
    near: tuple[int, int] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Points along each box's outline, at most ``step`` pixels apart near the image.

    With ``mesh``, the outline also holds every point where a side crosses an edge of the
    ``quads`` mesh's cells or triangles, and each box's points end with the mesh's vertices
    inside it (on the image): the mesh's map is linear between them, so the moved points'
    bounding box is that of the whole moved box, exactly, also where the map folds (and
    turns the box's inside past its moved outline).

    Parameters
    ----------
    boxes : numpy.ndarray
        (B, 4) boxes ``(x_min, y_min, x_max, y_max)``, or one box as a (4,) row.
    step : float
        The largest distance between two outline points, in pixels (> 0).
    mesh : (int, (int, int)) or None, default None
        ``(grid, (H, W))``: the regular mesh of ``quads`` at ``grid`` over an image of that
        shape (its cells past the image too, as border modes draw them); None: the samples
        every ``step`` alone.
    near : (int, int) or None, default None
        The image's shape (H, W), ``mesh``'s where None: a side's points lie ``step`` apart
        within four times the image's larger side (plus 64 px) of it, and
        further out at steps that double with the distance (f there is near its far-field
        fit, a box there mostly past the canvas): a box of millions of pixels costs hundreds
        of points, not millions. None without ``mesh``: ``step`` apart everywhere.

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)
        (P, 2) points, the boxes' one after another, and (B,) counts per box.

    Raises
    ------
    ValueError
        For a ``step`` that is not a finite number > 0, boxes of another shape, a box that
        is not finite, or a side that would take more than ``MAX_EDGE_POINTS`` (2**22)
        points (near the image, with ``near``).
    TypeError
        For boxes that are not real numbers (a :class:`glmls.DtypeError`), or a ``step``
        that is not a number.

    Examples
    --------
    >>> import numpy as np
    >>> from glmls.augment.labels import box_outlines
    >>> points, counts = box_outlines(np.array([[0.0, 0.0, 4.0, 2.0]]), 2.0)
    >>> counts.tolist(), points[:3].tolist()
    ([6], [[0.0, 0.0], [2.0, 0.0], [4.0, 0.0]])
    >>> box = np.array([[0.0, 0.0, 4.0, 2.0]])  # mesh lines x = 1.5, 3.5; a diagonal at 2
    >>> box_outlines(box, 8.0, mesh=(2, (4, 4)))[0][:4].tolist()
    [[0.0, 0.0], [1.5, 0.0], [2.0, 0.0], [3.5, 0.0]]
    """
    check_positive("step", step)
    given = np.asarray(boxes)
    # one box may come as a (4,) row; a (2, 2) array is no box
    boxes = _real_array(given[None] if given.ndim == 1 and given.size else given, "boxes", 4, "B")
    x0, y0, x1, y1 = boxes.T
    corners = np.stack([np.c_[x0, y0], np.c_[x1, y0], np.c_[x1, y1], np.c_[x0, y1]], axis=1)
    starts = corners.reshape(-1, 2)  # (4 B, 2): the sides, box by box, a -> b
    ends = np.roll(corners, -1, axis=1).reshape(-1, 2)
    with np.errstate(invalid="ignore"):  # inf - inf: a length that _samples refuses
        lengths = np.abs(ends - starts).max(axis=1)
    if near is None and mesh is not None:
        near = mesh[1]
    window = None if near is None else _near_window(near)
    if window is None or np.all(_inside(starts, window) & _inside(ends, window)):
        counts = np.array([_samples(float(length), step) for length in lengths], np.int64)
        owner = np.repeat(np.arange(len(starts)), counts)
        t = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
        t = t / np.repeat(counts, counts)
    else:
        params = [
            _side_parameters(a, b, float(length), step, window)
            for a, b, length in zip(starts, ends, lengths, strict=True)
        ]
        owner = np.repeat(np.arange(len(starts)), [len(t) for t in params])
        t = np.concatenate(params) if params else np.zeros(0)
    if mesh is not None and len(starts):
        side, crossing = _mesh_crossings(starts, ends, *mesh, window)
        owner, t = np.r_[owner, side], np.r_[t, crossing]
        order = np.lexsort((t, owner))
        owner, t = owner[order], t[order]
        keep = np.r_[True, (np.diff(owner) != 0) | (np.diff(t) != 0)]
        owner, t = owner[keep], t[keep]
    points = starts[owner] + t[:, None] * (ends - starts)[owner]
    counts = np.bincount(owner // 4, minlength=len(boxes)).astype(np.int64)
    lines = np.flatnonzero((x1 == x0) | (y1 == y0))
    if len(lines):
        pieces = np.split(points, np.cumsum(counts)[:-1])
        for k in lines:  # a line or a point: its samples once each
            pieces[k] = np.unique(pieces[k], axis=0)
        counts = np.array([len(piece) for piece in pieces], np.int64)
        points = np.concatenate(pieces)
    if mesh is not None and len(boxes):  # where the map folds, a box's inside reaches past
        inner, inner_counts = _inner_vertices(boxes, *mesh)  # its outline: each box's after it
        box = np.arange(len(boxes))
        owner = np.concatenate([np.repeat(box, counts), np.repeat(box, inner_counts)])
        points = np.concatenate([points, inner])[np.argsort(owner, kind="stable")]
        counts = counts + inner_counts
    return points, counts


def _near_window(shape: tuple[int, int]) -> np.ndarray:
    """(2, 2): the low and high corners (x, y) of the region :func:`box_outlines` samples
    every ``step`` about an image of ``shape`` (H, W)."""
    height, width = shape
    reach = NEAR_SIDES * max(height, width) + 64.0
    return np.array([[-0.5 - reach] * 2, [width - 0.5 + reach, height - 0.5 + reach]])


def _inside(points: np.ndarray, window: np.ndarray) -> np.ndarray:
    return np.all((points >= window[0]) & (points <= window[1]), axis=1)


def _side_parameters(
    start: np.ndarray, end: np.ndarray, length: float, step: float, window: np.ndarray
) -> np.ndarray:
    """The parameters t in [0, 1) of the points of the side ``start`` -> ``end`` (an axis's
    segment of ``length`` px): those of the uniform samples every ``step`` (k / count) that
    lie in ``window`` (low and high corners), then outward from it (or from the side's
    point nearest it) at distances ``step`` x 2^j, and the side's start."""
    if not math.isfinite(length) or length / step > 2.0**52:
        _samples(length, step)  # not finite, or past float64's integers: refused as such
    count = max(1, math.ceil(length / step))
    if length == 0:
        return np.zeros(1)
    direction = (end - start) / length
    axis = int(np.argmax(np.abs(direction)))
    other = 1 - axis
    along = (window[:, axis] - start[axis]) / (end[axis] - start[axis])  # t at the window
    low, high = np.sort(along)
    if not window[0, other] <= start[other] <= window[1, other]:
        low = high = float(np.clip((low + high) / 2, 0.0, 1.0))  # the side passes it by
    low, high = max(low, 0.0), min(high, 1.0)
    if low > high:  # the window lies past one end: from the end nearest it
        low = high = 0.0 if high < 0.0 else 1.0
    first, last = math.ceil(low * count), math.floor(high * count)
    if last - first + 1 > MAX_EDGE_POINTS:
        _samples(step * (last - first + 1), step)  # refused: too many near the image
    uniform = np.arange(max(first, 0), min(last, count - 1) + 1) / count
    unit = step / length
    reach = unit * 2.0 ** np.arange(0, 64)
    outward = np.concatenate([low - reach[low - reach > 0.0], high + reach[high + reach < 1.0]])
    t = np.unique(np.concatenate([[0.0], uniform, outward, [min(low, 1.0 - unit / 2)]]))
    return t[(t >= 0.0) & (t < 1.0)]


def outline_sets(
    box_sets: list[np.ndarray],
    steps: list[float],
    meshes: list,
    shapes: list[tuple[int, int]] | None = None,
) -> list[tuple[np.ndarray, np.ndarray]]:
    """:func:`box_outlines` of each image's boxes ``box_sets[i]`` ((B_i, 4), checked), with
    its ``steps[i]``, ``meshes[i]`` and image shape ``shapes[i]`` (``near``): the images of
    one step, mesh and shape in one call (each box's outline is its own, so the points are
    the same), split back per image. A ``ValueError`` names the image (``boxes[i]``) and its
    step."""
    out: list = [None] * len(box_sets)
    groups: dict[tuple, list[int]] = {}
    near = shapes if shapes is not None else [None] * len(box_sets)
    for i, key in enumerate(zip(steps, meshes, near, strict=True)):
        groups.setdefault(key, []).append(i)
    for (step, mesh, shape), members in groups.items():
        try:
            points, counts = box_outlines(
                np.concatenate([box_sets[i] for i in members]), step, mesh=mesh, near=shape
            )
        except ValueError:
            for i in members:  # the first image at fault, named
                try:
                    box_outlines(box_sets[i], step, mesh=mesh, near=shape)
                except ValueError as error:
                    raise ValueError(f"boxes[{i}] with box_step={step:g}: {error}") from None
            raise
        box_counts = np.split(counts, np.cumsum([len(box_sets[i]) for i in members])[:-1])
        ends = np.cumsum([int(c.sum()) for c in box_counts])[:-1]
        for i, piece, part in zip(members, np.split(points, ends), box_counts, strict=True):
            out[i] = (piece, part)
    return out


def _inner_vertices(
    boxes: np.ndarray, grid: int, shape: tuple[int, int]
) -> tuple[np.ndarray, np.ndarray]:
    """The vertices of the regular mesh at ``grid`` over an image of ``shape`` that lie
    strictly inside each of the (B, 4) ``boxes`` (the image's own vertices, every ``grid``
    pixels from -0.5 and its last edge), row by row, and how many per box: the mesh's map is
    linear on each triangle, so the extent of the moved box is that of its moved outline
    points (:func:`box_outlines`) and these, also where the map folds the box's inside past
    its outline."""
    axes = []  # per axis: the values of every box one after another, and their counts
    for low, high, size in (
        (boxes[:, 0], boxes[:, 2], shape[1]),
        (boxes[:, 1], boxes[:, 3], shape[0]),
    ):
        edge = size - 0.5
        first = np.maximum(np.ceil((low + 0.5) / grid), 0)
        last = np.minimum(np.floor((high + 0.5) / grid), math.ceil(size / grid))
        rows, k = _ranges(first, last)
        values = -0.5 + grid * k.astype(np.float64)
        # the lines before the last edge, then the edge itself: each box's in increasing order
        keep = (values > low[rows]) & (values < high[rows]) & (values < edge)
        at_edge = np.flatnonzero((low < edge) & (edge < high))
        owner = np.concatenate([rows[keep], at_edge])
        order = np.argsort(owner, kind="stable")
        values = np.concatenate([values[keep], np.full(len(at_edge), float(edge))])[order]
        axes.append((values, np.bincount(owner, minlength=len(boxes))))
    (xs, nx), (ys, ny) = axes
    counts = nx * ny
    box = np.repeat(np.arange(len(boxes)), counts)
    j = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
    column, row = j % nx[box], j // nx[box]  # row-major: y, then x
    x = xs[np.repeat(np.cumsum(nx) - nx, counts) + column]
    y = ys[np.repeat(np.cumsum(ny) - ny, counts) + row]
    return np.stack([x, y], axis=1), counts


def _ranges(first: np.ndarray, last: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For integer bounds per row, the rows and the integers ``first[i] .. last[i]`` (none
    where ``last < first``), one after another."""
    first, last = np.asarray(first).astype(np.int64), np.asarray(last).astype(np.int64)
    counts = np.maximum(last - first + 1, 0)
    rows = np.repeat(np.arange(len(counts)), counts)
    offsets = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
    return rows, np.repeat(first, counts) + offsets


def _mesh_crossings(
    starts: np.ndarray,
    ends: np.ndarray,
    grid: int,
    shape: tuple[int, int],
    window: np.ndarray | None = None,
):
    """The sides and the t in (0, 1) where the axis-aligned sides a + t (b - a) (``starts``,
    ``ends``: (S, 2)) cross an edge of the regular mesh at ``grid`` over an image of
    ``shape`` (:class:`glmls.core.mesh.MeshLattice` ``corners``): the lines every ``grid``
    pixels from -0.5 and the image's last edge, and each cell's diagonal from its corner 00
    to 11, in the square cells of a mesh extended past the image (y - x a multiple of
    ``grid``) and in the image's last column and row of cells, which its edge cuts short.
    With ``window`` (low and high corners), only within it."""
    moving = np.abs(ends - starts).max(axis=1) > 0
    along = (starts[:, 1] != ends[:, 1]).astype(np.int64)  # 0: the side runs along x
    index = np.arange(len(starts))
    a = starts[index, along]
    b = ends[index, along]
    level = starts[index, 1 - along]
    low, high = np.minimum(a, b), np.maximum(a, b)
    if window is not None:  # a side past the window across has none: an empty range
        low = np.maximum(low, window[0, along])
        high = np.minimum(high, window[1, along])
        past = (level < window[0, 1 - along]) | (level > window[1, 1 - along])
        high = np.where(past, low - 1.0, high)
    sizes = np.array([shape[1], shape[0]], np.float64)  # (W, H)
    size_along, size_across = sizes[along], sizes[1 - along]
    found_side, found_value = [], []

    def add(rows: np.ndarray, values: np.ndarray) -> None:
        found_side.append(rows)
        found_value.append(values)

    # the lines across the side: -0.5 + k grid, and the image's last edge
    rows, k = _ranges(np.ceil((low + 0.5) / grid), np.floor((high + 0.5) / grid))
    add(rows, -0.5 + k * grid)
    add(index, size_along - 0.5)
    # the square cells' diagonals, y - x = k grid: along x, x = level - k grid; along y,
    # y = level + k grid
    sign = np.where(along == 0, -1.0, 1.0)
    first = np.where(along == 0, np.ceil((level - high) / grid), np.ceil((low - level) / grid))
    last = np.where(along == 0, np.floor((level - low) / grid), np.floor((high - level) / grid))
    rows, k = _ranges(first, last)
    add(rows, level[rows] + sign[rows] * k * grid)
    # the image's last column and row of cells, cut short by its edge: in the row of cells
    # (across the side) that holds the side, each cell's diagonal at the side's level
    cells_across = np.ceil(size_across / grid)
    row = np.clip(np.floor((level + 0.5) / grid), 0, cells_across - 1)
    c_low = -0.5 + row * grid
    c_high = np.minimum(c_low + grid, size_across - 0.5)
    s = (level - c_low) / np.maximum(c_high - c_low, 1e-300)
    cells_along = np.ceil(size_along / grid)
    last_low = -0.5 + (cells_along - 1) * grid  # the last cell along: to the image's edge
    add(index, last_low + s * (size_along - 0.5 - last_low))
    short = np.flatnonzero(c_high - c_low < grid)  # a short row: each cell's diagonal
    if len(short):
        shift = s[short] * grid  # the cells before the last along: grid wide
        first = np.ceil((low[short] + 0.5 - shift) / grid)
        last = np.floor((high[short] + 0.5 - shift) / grid)
        rows, k = _ranges(np.maximum(first, 0), np.minimum(last, cells_along[short] - 2))
        add(short[rows], -0.5 + k * grid + shift[rows])
    side = np.concatenate(found_side).astype(np.int64)
    value = np.concatenate(found_value)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (value - a[side]) / (b - a)[side]
    inside = moving[side] & (t > 0) & (t < 1)
    return side[inside], t[inside]


def boxes_from_outlines(
    moved: np.ndarray, counts: np.ndarray, shape: tuple[int, int], *, clip: bool = True
) -> tuple[np.ndarray, np.ndarray]:
    """The boxes around moved outlines, clipped to the canvas, and their validity.

    A box is valid where a positive width and height are left on the canvas of ``shape``.
    With ``clip=False`` the boxes are the outlines' bounding boxes as they are (valid where
    they have a positive width and height).

    Parameters
    ----------
    moved : numpy.ndarray
        (P, 2) moved outline points (:func:`box_outlines`'s, moved).
    counts : numpy.ndarray
        (B,) points per box.
    shape : (int, int)
        The output canvas (H, W).
    clip : bool, default True
        Clip the boxes to the canvas.

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)
        (B, 4) float64 boxes and (B,) bool.

    Raises
    ------
    ValueError
        Where the counts are not integers >= 1 (a box of no points has no extent) or do not
        add up to the points, or for a ``shape`` that is not two integers >= 0.

    Examples
    --------
    >>> import numpy as np
    >>> from glmls.augment.labels import boxes_from_outlines
    >>> moved = np.array([[-3.0, 1.0], [2.0, 1.0], [2.0, 3.0], [30.0, 30.0], [40.0, 31.0]])
    >>> boxes, valid = boxes_from_outlines(moved, np.array([3, 2]), (8, 8))
    >>> boxes.tolist(), valid.tolist()
    ([[-0.5, 1.0, 2.0, 3.0], [7.5, 7.5, 7.5, 7.5]], [True, False])
    >>> boxes_from_outlines(moved, np.array([3, 2]), (8, 8), clip=False)[0][1].tolist()
    [30.0, 30.0, 40.0, 31.0]
    """
    moved = np.asarray(moved, np.float64).reshape(-1, 2)
    counts = np.asarray(counts)
    if counts.ndim != 1 or not (counts.dtype.kind in "iu" or counts.size == 0):
        raise ValueError(f"counts must be a 1-D array of integers, got {counts!r}")
    if counts.size and counts.min() < 1:  # a box of no points has no extent
        k = int(np.argmin(counts))
        raise ValueError(f"counts[{k}] is {int(counts[k])}: each box needs at least 1 point")
    if int(np.sum(counts)) != len(moved):
        raise ValueError(f"the counts add up to {int(np.sum(counts))} points, not {len(moved)}")
    height, width = _canvas(shape)
    boxes = np.zeros((len(counts), 4))
    if len(counts):  # each box's extremes at once: every box has a point (checked above)
        starts = (np.cumsum(counts) - counts).astype(np.int64)
        for axis in (0, 1):
            boxes[:, axis] = np.minimum.reduceat(moved[:, axis], starts)
            boxes[:, axis + 2] = np.maximum.reduceat(moved[:, axis], starts)
    if clip:
        low = np.array([-0.5, -0.5, -0.5, -0.5])
        high = np.array([width, height, width, height], np.float64) - 0.5
        boxes = np.clip(boxes, low, high)
    valid = (boxes[:, 2] > boxes[:, 0]) & (boxes[:, 3] > boxes[:, 1])
    return boxes, valid


def densify_polygon(polygon: np.ndarray, step: float | None) -> np.ndarray:
    """A closed polygon with points added along its edges, at most ``step`` pixels apart.

    Parameters
    ----------
    polygon : numpy.ndarray
        (V, 2) vertices.
    step : float or None
        The largest edge length after densifying (> 0); None: the polygon as it is.

    Returns
    -------
    numpy.ndarray
        (V', 2) vertices: the given ones, in order, with the added ones between them.

    Raises
    ------
    ValueError
        For a ``step`` that is not None or a finite number > 0, a polygon that is not
        (V, 2), a vertex that is not finite, or an edge that would take more than
        ``MAX_EDGE_POINTS`` (2**22) points.
    TypeError
        For vertices that are not real numbers (a :class:`glmls.DtypeError`).

    Examples
    --------
    >>> import numpy as np
    >>> from glmls.augment.labels import densify_polygon
    >>> densify_polygon(np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 2.0]]), 2.0).shape
    (6, 2)
    """
    if step is None:
        return polygon
    check_positive("step", step)
    polygon = _real_array(polygon, "polygon", 2, "V")
    if len(polygon) < 2:
        return polygon
    nxt = np.roll(polygon, -1, axis=0)
    pieces = []
    for a, b in zip(polygon, nxt, strict=True):
        n = _samples(float(np.hypot(*(b - a))), step)
        pieces.append(a + (np.arange(n)[:, None] / n) * (b - a))
    return np.concatenate(pieces)


def clip_polygon(polygon: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """A polygon clipped to the canvas (Sutherland and Hodgman's algorithm).

    The canvas of ``shape`` spans [-0.5, W - 0.5] x [-0.5, H - 0.5]; the result is (0, 2)
    where nothing of the polygon is on it, and where what is left of a polygon that encloses
    an area encloses none (it touches the canvas only along a side or at a corner). No
    vertex is the same as the one before it (to 1e-9 of the coordinates).
    A concave polygon that the canvas cuts into several pieces stays one polygon, the
    pieces joined along the canvas's side.

    Parameters
    ----------
    polygon : numpy.ndarray
        (V, 2) vertices.
    shape : (int, int)
        The canvas (H, W).

    Returns
    -------
    numpy.ndarray
        The clipped polygon's vertices.

    Raises
    ------
    ValueError
        For a polygon that is not (V, 2) or not finite, or a ``shape`` that is not two
        integers >= 0.
    TypeError
        For vertices that are not real numbers (a :class:`glmls.DtypeError`).

    Examples
    --------
    >>> import numpy as np
    >>> from glmls.augment.labels import clip_polygon
    >>> clip_polygon(np.array([[-4.0, 0.0], [4.0, 0.0], [4.0, 2.0]]), (8, 8)).tolist()
    [[-0.5, 0.875], [-0.5, 0.0], [4.0, 0.0], [4.0, 2.0]]
    """
    polygon = _real_array(polygon, "polygon", 2, "V")
    height, width = _canvas(shape)
    x, y = polygon[:, 0], polygon[:, 1]
    if ((x >= -0.5) & (x <= width - 0.5) & (y >= -0.5) & (y <= height - 0.5)).all():
        return _without_slivers(polygon.copy(), polygon)  # every vertex kept, as below
    planes = ((0, -0.5, 1.0), (1, -0.5, 1.0), (0, width - 0.5, -1.0), (1, height - 0.5, -1.0))
    points = [tuple(p) for p in polygon]
    for axis, edge, sign in planes:
        if not points:
            break
        kept = []
        for k, current in enumerate(points):
            previous = points[k - 1]
            inside_now = sign * (current[axis] - edge) >= 0
            inside_before = sign * (previous[axis] - edge) >= 0
            if inside_now != inside_before:
                # from the end on the canvas: from a far one (1e300 px) the crossing would be
                # that far end's rounding error, nowhere near the canvas
                inner, outer = (current, previous) if inside_now else (previous, current)
                t = (edge - inner[axis]) / (outer[axis] - inner[axis])
                crossing = [a + t * (b - a) for a, b in zip(inner, outer, strict=True)]
                crossing[axis] = edge
                kept.append(tuple(crossing))
            if inside_now:
                kept.append(current)
        points = kept
    return _without_slivers(np.array(points, np.float64).reshape(-1, 2), polygon)


def _twice_area(points: np.ndarray) -> float:
    x, y = points[:, 0], points[:, 1]
    # each vertex's next: what np.roll(-1) makes, without its overhead on small arrays
    return float(
        np.dot(x, np.concatenate((y[1:], y[:1]))) - np.dot(y, np.concatenate((x[1:], x[:1])))
    )


def _without_slivers(points: np.ndarray, polygon: np.ndarray) -> np.ndarray:
    """The clipped ``points`` of ``polygon`` without a vertex equal (to 1e-9 of the
    coordinates) to the one before it (the clipper repeats a vertex on a clipping line), and
    (0, 2) where they enclose no area but ``polygon`` did: a polygon that touches the canvas
    only along its side or at a corner is not on it (a polyline given as one stays)."""
    if len(points) == 0:
        return points
    # the crossings of one edge, computed from its two ends, may differ in the last bit
    largest = max(1.0, float(np.abs(points).max()))
    close = 1e-9 * largest
    step = np.abs(points - np.concatenate((points[-1:], points[:-1])))  # from the one before
    repeated = (step[:, 0] <= close) & (step[:, 1] <= close)
    kept = points[~repeated] if not repeated.all() else points[:1]
    # an area within rounding of the coordinates' squares is none
    flat = 1e-12 * largest**2
    if abs(_twice_area(kept)) <= flat and _twice_area(polygon) != 0.0:
        return points[:0]
    return kept
