"""The inputs of :func:`glmls.warp_batch` checked and split into per-image items: images,
handles, keypoints and masks, each error naming the item's index (``src[3]``)."""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np

from ..core.config import counted
from ..core.handles import COORDINATE_LIMIT, same_source_sets, validate_handles
from ..core.magnitudes import value_exponent
from ..errors import DtypeError
from ..imaging.source import DTYPES, native_order

__all__ = [
    "BatchInput",
    "check_batch",
    "check_batch_image",
    "check_counts",
    "check_point_sets",
    "check_points",
    "item_array",
    "naming",
    "stack_or_list",
]


@dataclass(frozen=True)
class BatchInput:
    """A checked batch: per image, its array and handles (and labels, None where not given).

    ``stacked``: the images came as one array or as a sequence of one shape and dtype (the
    outputs are then stacked too); ``stacked_points``: the keypoints came as one array;
    ``array`` and ``mask_array``: the images and masks as that one array where they came as
    one (``images`` and ``masks`` are then its views)."""

    images: list[np.ndarray]
    src: list[np.ndarray]
    dst: list[np.ndarray]
    keypoints: list[np.ndarray] | None
    masks: list[np.ndarray] | None
    stacked: bool
    stacked_points: bool
    array: np.ndarray | None = None
    mask_array: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.images)

    def groups(self) -> list[list[int]]:
        """The image indices by what one chunk shares: shape, dtype, the masks' dtype and
        the power of two a float image reaches the GPU divided by (one exponent restores the
        chunk: :func:`~glmls.core.magnitudes.value_exponent`); one group where the images,
        and the masks, came as one array each, of one exponent."""
        exponents = [value_exponent(image) for image in self.images]  # 0 but for floats
        if self.array is not None and (self.masks is None or self.mask_array is not None):
            if len(set(exponents)) <= 1:
                return [list(range(len(self)))]
        groups: dict[tuple, list[int]] = {}
        for i, image in enumerate(self.images):
            mask = None if self.masks is None else self.masks[i]
            key = (image.shape, image.dtype.str, None if mask is None else mask.dtype.str)
            key += (exponents[i],)
            groups.setdefault(key, []).append(i)
        return list(groups.values())


#: What the error of a batch's image says where it looks like a volume (D, H, W): a batch is
#: of 2D images.
VOLUMES_HINT = (
    " (a batch holds 2D images; a volume is warped by glmls.MLS(src, dst).warp(volume), one "
    "at a time)"
)


@contextmanager
def naming(index: int, errors: tuple[type[Exception], ...] = (ValueError,)) -> Iterator[None]:
    """An error of ``errors`` raised inside, about the batch's image ``index``, raised again
    with its message prefixed ``images[index]:``, as a batch names its items."""
    try:
        yield
    except errors as error:
        raise type(error)(f"images[{index}]: {error}") from None


def item_array(value: object, name: str) -> np.ndarray:
    """One item of a batch (an image, a handle or keypoint set, a mask) as an array;
    ``ValueError`` naming ``name`` (``src[1]``) where its rows have different lengths, which
    numpy refuses without saying which item."""
    try:
        return np.asarray(value)
    except ValueError:  # ragged: [[1, 2], [3]]
        raise ValueError(
            f"{name} is ragged (rows of different lengths); expected an array of one shape"
        ) from None


def _items(value: object, name: str, item_ndims: tuple[int, ...]) -> tuple[list, bool]:
    """``value`` as a list of per-image arrays: an array whose first axis is the batch, or a
    sequence; the flag says it was one array."""
    if isinstance(value, np.ndarray) and value.dtype == object and value.ndim == 1:
        value = list(value)  # a 1-D array of arrays (ragged ones): a sequence of them
    if isinstance(value, np.ndarray):
        if value.ndim - 1 not in item_ndims:
            wanted = " or ".join(f"{d + 1}" for d in item_ndims)
            raise ValueError(
                f"{name} must be an array of {wanted} dimensions (the batch first) or a "
                f"sequence of arrays, got shape {value.shape}"
            )
        return list(value), True
    if isinstance(value, (str, bytes)) or not isinstance(value, Sequence):
        raise TypeError(
            f"{name} must be an array or a sequence of arrays, got {type(value).__name__}"
        )
    return [item_array(item, f"{name}[{i}]") for i, item in enumerate(value)], False


def check_batch_image(array: np.ndarray, name: str) -> np.ndarray:
    """One image of a batch, (H, W) or (H, W, C) with C in 1..4, of a dtype glmls takes and
    not empty, in native byte order; ``DtypeError``/``ValueError`` naming it ``name``."""
    array = native_order(array)  # big-endian images are their values, as for one warp
    if array.dtype not in DTYPES:
        names = ", ".join(np.dtype(d).name for d in DTYPES)
        raise DtypeError(f"{name} has dtype {array.dtype}; expected one of {names}")
    if array.ndim not in (2, 3) or (array.ndim == 3 and not 1 <= array.shape[2] <= 4):
        hint = VOLUMES_HINT if array.ndim == 3 else ""  # (D, H, W)
        raise ValueError(
            f"{name} has shape {array.shape}; expected (H, W) or (H, W, C), C 1..4{hint}"
        )
    if array.size == 0:
        raise ValueError(f"{name} is empty: shape {array.shape}")
    return array


def check_points(array: np.ndarray, name: str, *, rows: str) -> np.ndarray:
    """``array`` as (``rows``, 2) finite float64 points within the coordinate limit (none may
    be given as ``[]``): the check of every handle set and keypoint set of a batch (and of
    :class:`glmls.augment.Augment`'s keypoints and recorded handles). ``TypeError`` for
    values that are not real numbers, ``ValueError`` for another shape, a value that is not
    finite or one beyond the limit, each naming ``name`` and the first such row."""
    if array.dtype == object or not (
        np.issubdtype(array.dtype, np.number) and not np.issubdtype(array.dtype, np.complexfloating)
    ):
        raise DtypeError(f"{name} has dtype {array.dtype}; expected real numbers")
    if array.size == 0 and array.ndim <= 2:  # [] or np.zeros((0, 2)): no points
        array = array.reshape(0, 2)
    if array.ndim != 2 or array.shape[1] != 2:
        raise ValueError(f"{name} has shape {array.shape}; expected ({rows}, 2)")
    return check_coordinates(np.asarray(array, dtype=np.float64), name)


def check_coordinates(rows: np.ndarray, name: str) -> np.ndarray:
    """``rows``, a 2-d float64 array of coordinates (points, or boxes' corners), if every
    value is finite and within the coordinate limit; ``ValueError`` naming ``name`` and the
    first row that is not."""
    finite = np.isfinite(rows).all(axis=1)
    if not finite.all():
        row = int(np.argmin(finite))
        raise ValueError(f"{name} holds values that are not finite (NaN or inf): row {row}")
    reach = np.abs(rows).max(axis=1, initial=0.0)
    if len(rows) and reach.max() > COORDINATE_LIMIT:
        # as for one warp: float32 on the GPU keeps ~1e-7 of the coordinates' extent
        row = int(np.argmax(reach))
        raise ValueError(
            f"{name} must lie within ±{COORDINATE_LIMIT:g} px of the origin in x and y; "
            f"row {row} reaches {reach[row]:g}"
        )
    return rows


def _mask(array: np.ndarray, name: str, shape: tuple[int, int]) -> np.ndarray:
    if array.dtype == bool or not np.issubdtype(array.dtype, np.integer):
        raise DtypeError(f"{name} has dtype {array.dtype}; expected an integer or bool dtype")
    if array.shape != shape:
        raise ValueError(f"{name} has shape {array.shape}; expected its image's {shape}")
    if array.dtype not in (np.uint8, np.uint16) and array.size:
        low, high = int(array.min()), int(array.max())
        if low < -(1 << 24) or high > 1 << 24:
            raise ValueError(
                f"{name} holds labels from {low} to {high}; labels beyond +-2**24 are not "
                "supported (use uint8, uint16 or smaller labels)"
            )
    return array


def _point_items(value: object, name: str, *, rows: str) -> tuple[list[np.ndarray], bool]:
    """Per-image (P, 2) float64 point sets of ``value`` (:func:`_items`), each checked by
    :func:`check_points`: an (N, P, 2) array of real numbers, or a sequence of arrays of one
    shape and dtype, all at once (:func:`check_point_sets`)."""
    if not isinstance(value, np.ndarray) or value.ndim != 3 or len(value) == 0:
        items, stacked = _items(value, name, (2,))
        return check_point_sets(items, lambda i: f"{name}[{i}]", rows=rows), stacked
    return _checked_stack(value, lambda i: f"{name}[{i}]", rows=rows), True


def check_counts(
    src: Sequence[np.ndarray], dst: Sequence[np.ndarray], name_of: Callable[[int, str], str]
) -> None:
    """``ValueError`` naming item i's point sets (``name_of(i, "src")``, ``name_of(i,
    "dst")``) where its sources and targets differ in number."""
    for i, (p, q) in enumerate(zip(src, dst, strict=True)):
        if len(p) != len(q):
            raise ValueError(
                f"{name_of(i, 'src')} and {name_of(i, 'dst')} hold {len(p)} and {len(q)} points"
            )


def check_point_sets(
    items: Sequence[np.ndarray], name_of: Callable[[int], str], *, rows: str
) -> list[np.ndarray]:
    """Each of ``items`` checked by :func:`check_points` (``name_of(i)``: item i's name in
    an error), as (P, 2) float64 points: where they are arrays of one (P, 2) shape and one
    dtype, all at once, the error (if any) naming the first bad item as its own check would."""
    first = items[0] if len(items) else None
    alike = (
        isinstance(first, np.ndarray)
        and first.ndim == 2
        and first.size > 0
        and all(
            isinstance(a, np.ndarray) and a.shape == first.shape and a.dtype == first.dtype
            for a in items
        )
    )
    if not alike:
        return [check_points(a, name_of(i), rows=rows) for i, a in enumerate(items)]
    return _checked_stack(np.stack(items), name_of, rows=rows)  # type: ignore[arg-type]


def _checked_stack(
    value: np.ndarray, name_of: Callable[[int], str], *, rows: str
) -> list[np.ndarray]:
    """The items of an (N, P, 2) array of real numbers (N >= 1) checked by
    :func:`check_points` in one pass: float64 views of one array."""
    check_points(value[0], name_of(0), rows=rows)  # dtype and shape, alike for every item
    points = np.asarray(value, dtype=np.float64)
    finite = np.isfinite(points).all(axis=(1, 2))
    limit = points.size and np.abs(points).max() > COORDINATE_LIMIT
    if not finite.all() or limit:
        for i, item in enumerate(points):  # the first bad item names itself
            check_points(item, name_of(i), rows=rows)
    return list(points)


def _check_targets(src: list[np.ndarray], dst: list[np.ndarray]) -> None:
    """No image has a source point with two different targets (its MLS refuses it, as
    :func:`glmls.warp` does): the error names the image. Handle sets of one size are
    tested in one sort (:func:`~glmls.core.handles.same_source_sets`), and only an image
    that fails is checked again for its message."""
    if len({len(p) for p in src}) == 1 and len(src[0]) > 1:
        suspects = np.flatnonzero(same_source_sets(np.stack(src), np.stack(dst))).tolist()
    else:
        suspects = [i for i, p in enumerate(src) if len(p) > 1]
    for i in suspects:
        with naming(i):
            validate_handles(src[i], dst[i])


def check_batch(
    images: object, src: object, dst: object, keypoints: object, masks: object
) -> BatchInput:
    """The checked :class:`BatchInput`; ``ValueError``/``TypeError`` naming the bad item."""
    if isinstance(images, np.ndarray):
        images = native_order(images)
    image_list, stacked = _items(images, "images", (2, 3))
    count = len(image_list)
    if not count:
        raise ValueError(f"images is an empty batch (shape {np.shape(images)}): nothing to warp")
    array = images if stacked else None
    if array is not None:  # one shape and dtype: the first image's check is every image's
        check_batch_image(image_list[0], "images[0]")
    else:
        image_list = [check_batch_image(a, f"images[{i}]") for i, a in enumerate(image_list)]
    if not stacked and image_list:
        first = image_list[0]
        stacked = all(a.shape == first.shape and a.dtype == first.dtype for a in image_list)
    handles = []
    for name, value in (("src", src), ("dst", dst)):
        items, _ = _point_items(value, name, rows="K")  # K = 0: f is the identity
        if len(items) != count:
            raise ValueError(
                f"{name} holds {counted(len(items), 'handle set')} for {counted(count, 'image')}"
            )
        handles.append(items)
    check_counts(*handles, lambda i, key: f"{key}[{i}]")
    _check_targets(*handles)
    points, stacked_points = None, False
    if keypoints is not None:
        points, stacked_points = _point_items(keypoints, "keypoints", rows="P")
        if len(points) != count:
            raise ValueError(
                f"keypoints holds {counted(len(points), 'point set')} for {counted(count, 'image')}"
            )
        stacked_points = stacked_points or len({len(a) for a in points}) == 1
    mask_list, mask_array = None, None
    if masks is not None:
        mask_list, one = _items(masks, "masks", (2,))
        if len(mask_list) != count:
            raise ValueError(
                f"masks holds {counted(len(mask_list), 'mask')} for {counted(count, 'image')}"
            )
        if one and array is not None and masks.dtype in (np.uint8, np.uint16):  # type: ignore[union-attr]
            _mask(mask_list[0], "masks[0]", image_list[0].shape[:2])
            mask_array = masks
        else:
            mask_list = [
                _mask(m, f"masks[{i}]", image_list[i].shape[:2]) for i, m in enumerate(mask_list)
            ]
    return BatchInput(
        image_list, *handles, points, mask_list, stacked, stacked_points, array, mask_array
    )


def stack_or_list(arrays: list[np.ndarray], stacked: bool):
    """``arrays`` stacked along a new first axis where ``stacked`` and they share one shape
    and dtype, else the list."""
    first = arrays[0]
    if stacked and all(a.shape == first.shape and a.dtype == first.dtype for a in arrays):
        return np.stack(arrays)
    return arrays
