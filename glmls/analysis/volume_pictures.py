"""Pictures of a volume: three orthogonal slices and a maximum-intensity projection in one
picture, with the handles near each slice drawn as p -> q arrows (:func:`render_handles`).

The layout (one cell per view, ``scale`` picture pixels per voxel)::

    +-----------------+-----------------+
    | z slice  (y, x) | x slice  (y, z) |
    +-----------------+-----------------+
    | y slice  (z, x) | projection (y, x)|
    +-----------------+-----------------+

Each view is labelled in its bottom-left corner (``z = 12``: the slice at z = 12), where it is
big enough. The z slice and the x slice share their rows (y), the z slice and the y slice
their columns (x); the projection is the maximum of the volume along z, or its minimum (for
a mask: any voxel along z).
"""

from __future__ import annotations

import math
import operator
from collections.abc import Sequence

import moderngl
import numpy as np
from PIL import Image, ImageDraw, ImageFont

from ..core.config import check_choice, check_integer, check_real, is_integer
from ..gl.context import GLContext
from .colormaps import apply_colormap, color_limits
from .pictures import render_handles
from .volume_lattice import as_points3, as_volume_shape

__all__ = ["check_slices", "render_volume_slices"]

#: The tint of masked voxels (RGB 0-255) and its opacity.
MASK_COLOR = (230, 30, 30)
MASK_OPACITY = 0.65
#: The colour of NaN voxels of a grey volume (in no grey scale); a field's NaN take its
#: colour map's (:data:`glmls.analysis.colormaps.NAN_COLOR`).
NAN_VOXEL_COLOR = (40, 90, 160)
#: The picture's smallest side per view, in pixels, when ``scale`` is None ...
MIN_VIEW = 192
#: ... as long as no view's side passes this many pixels (a volume one voxel thick keeps
#: pictures of its other sides at a few voxels' size).
MAX_VIEW = 1024
#: The longest side of a view a given ``scale`` may make, pixels (``GL_MAX_TEXTURE_SIZE``
#: on most devices, the side of the 2D pictures).
MAX_PICTURE_SIDE = 16384
#: Grey between the views.
GAP = 6
#: The labels' font size; views less than 4 labels high go without one.
LABEL_SIZE = 12


def check_slices(shape: Sequence[int], slices: object) -> tuple[int, int, int]:
    """(z, y, x) voxel indices of the three slices; the centre of the volume when None.
    Indices that are not integers (glmls's integer rule: 2.0 is none) or slices that are no
    sequence are a ``TypeError``, indices outside the volume or not three a ``ValueError``."""
    dims = as_volume_shape(shape)
    if slices is None:
        return dims[0] // 2, dims[1] // 2, dims[2] // 2
    message = f"slices must be (z, y, x) voxel indices within {dims}, got {slices!r}"
    if isinstance(slices, (str, bytes)):
        raise TypeError(message)
    try:
        index = tuple(slices)  # type: ignore[arg-type]
    except TypeError:
        raise TypeError(message) from None
    if len(index) != 3:
        raise ValueError(message)
    if not all(is_integer(i) for i in index):
        raise TypeError(message)
    z, y, x = (operator.index(i) for i in index)
    if not (0 <= z < dims[0] and 0 <= y < dims[1] and 0 <= x < dims[2]):
        raise ValueError(message)
    return z, y, x


def _grey(values: np.ndarray, vmin: float | None, vmax: float | None) -> np.ndarray:
    if values.dtype == np.uint8 and vmin is None and vmax is None:
        return values
    lo, hi = color_limits(values, vmin=vmin, vmax=vmax)
    if hi <= lo:  # one value (a constant volume): the scale from 0 to it, not all black
        lo, hi = min(lo, 0.0), max(hi, 0.0)
    span = hi - lo if hi > lo else 1.0
    t = np.nan_to_num(np.clip((values - lo) / span, 0, 1), nan=0.0)  # NaN: coloured later
    return np.round(t * 255).astype(np.uint8)


def _views(array: np.ndarray, at: tuple[int, int, int], project) -> list[np.ndarray]:
    """z slice (H, W), x slice (H, D), y slice (D, W), projection along z (H, W)."""
    z, y, x = at
    return [array[z], np.swapaxes(array[:, :, x], 0, 1), array[:, y], project(array)]


def _view_points(points: np.ndarray, view: int) -> np.ndarray:
    """(x, y, z) points as the (column, row) of a view."""
    return points[:, [(0, 1), (2, 1), (0, 2), (0, 1)][view]]


def render_volume_slices(
    volume: object,
    *,
    src: object = None,
    dst: object = None,
    slices: object = None,
    near: float | None = None,
    mask: object = None,
    cmap: object = None,
    vmin: float | None = None,
    vmax: float | None = None,
    percentile: float | None = None,
    scale: int | None = None,
    projection: str = "max",
    spacing: object = None,
    ctx: moderngl.Context | GLContext | None = None,
) -> np.ndarray:
    """Three orthogonal slices and the maximum-intensity projection of a volume, in one picture.

    Layout in ``glmls.analysis.volume_pictures``. A grey volume is drawn from ``vmin``
    (black) to ``vmax`` (white) (where they are equal, as for a constant volume, from 0 to
    that value: a constant positive volume is white), an RGB volume as it is,
    and with ``cmap`` a field (an error) through that colour map, its limits from the whole
    volume. Of a float volume, infinite voxels take the ends of the scale, NaN voxels
    ``NAN_VOXEL_COLOR`` (a field's the colour map's NaN colour), and the limits and
    projection are those of the other voxels.

    Parameters
    ----------
    volume : array_like
        (D, H, W) values, or (D, H, W, 3) uint8 colours.
    src, dst : array_like, optional
        Handles (N, 3) (x, y, z), drawn as arrows on each slice within ``near`` voxels of
        them (their source or target), and on the projection all.
    slices : tuple of int, optional
        (z, y, x) voxel indices of the slices; the volume's centre by default.
    near : float, optional
        How far from a slice a handle is drawn on it, in voxels; by default a tenth of the
        volume's largest side (at least 1).
    mask : array_like, optional
        (D, H, W) bool: voxels tinted red (on the projection: any along z).
    cmap : str or array_like, optional
        A colour map (:func:`apply_colormap`) for a field; None: grey or RGB.
    vmin, vmax, percentile : float, optional
        The limits of the grey scale or colour map (:func:`color_limits`); for a grey
        uint8 volume 0 and 255 by default.
    scale : int, optional
        Picture pixels per voxel (nearest neighbour); by default the smallest that makes
        each view's smaller side at least 192 pixels, but no larger than keeps each view's
        sides within 1024 pixels (1 for a volume with a side over 1024 voxels); one that
        makes a view's side longer than 16384 pixels is a ``ValueError``.
    projection : {"max", "min"}, optional
        The fourth view: the maximum of the volume along z, or the minimum (for a field
        whose low values matter, as det J).
    spacing : tuple of float, optional
        (dz, dy, dx), the voxels' size: each axis is drawn in proportion to it, so that the
        views keep the volume's true shape (an axis of the smallest spacing takes ``scale``
        pixels a voxel, a coarser one proportionally more, as long as no view passes 1024
        pixels a side where it fits at one pixel a voxel). Handles stay in voxels (x, y, z)
        as given. None: cubic voxels.
    ctx : moderngl.Context or GLContext, optional
        The context to draw the handles with (default: glmls's shared headless one).

    Returns
    -------
    numpy.ndarray
        The picture, (h, w, 3) uint8.

    Raises
    ------
    ValueError
        For a volume that is not (D, H, W) or (D, H, W, 3) real values, or bad handles,
        slices, ``near``, mask, limits, scale or projection.
    TypeError
        For slices, a scale, a ``near`` or a projection of the wrong type (a float index or
        scale, a string ``near``, a projection that is no string), naming it.

    Examples
    --------
    >>> z, y, x = np.mgrid[0:8, 0:12, 0:16]
    >>> volume = (x * 16).astype(np.uint8)
    >>> picture = glmls.analysis.render_volume_slices(volume, scale=2)
    >>> picture.shape  # (2 * (12 + 12) + 6, 2 * (16 + 16) + 6)
    (54, 70, 3)
    >>> picture[0, 0].tolist(), picture[0, 31].tolist()  # the z slice: x = 0 and x = 15
    ([0, 0, 0], [240, 240, 240])
    """
    array = np.asarray(volume)
    rgb_volume = array.ndim == 4
    if array.ndim not in (3, 4) or (rgb_volume and array.shape[3] != 3) or 0 in array.shape:
        raise ValueError(f"volume must be (D, H, W) or (D, H, W, 3), got shape {array.shape}")
    if array.dtype.kind not in "iuf" or (rgb_volume and array.dtype != np.uint8):
        raise ValueError(f"volume must be real numbers (RGB: uint8), got dtype {array.dtype}")
    if near is not None:
        check_real("near", near, low=0, what="a finite number >= 0 (voxels)")
    dims = array.shape[:3]
    stretch = _stretch(spacing)
    at = check_slices(dims, slices)
    check_choice("projection", projection, ("max", "min"))
    # NaN voxels (outside a scan's field of view) left out of the projection where a column
    # has others
    extreme = np.fmax if projection == "max" else np.fmin
    views = _views(array, at, lambda a: extreme.reduce(a, axis=0))
    if rgb_volume:
        pictures = [np.ascontiguousarray(v) for v in views]
    else:
        values = array.astype(np.float64) if array.dtype != np.uint8 else array
        if cmap is not None:
            lo, hi = color_limits(values, vmin=vmin, vmax=vmax, percentile=percentile)
            pictures = [apply_colormap(v, cmap=cmap, vmin=lo, vmax=hi) for v in views]
        else:
            lo, hi = (
                (vmin, vmax)
                if values.dtype == np.uint8
                else color_limits(values, vmin=vmin, vmax=vmax, percentile=percentile)
            )
            pictures = [np.repeat(_grey(v, lo, hi)[..., None], 3, axis=2) for v in views]
            for picture, view in zip(pictures, views, strict=True):
                picture[np.isnan(view)] = NAN_VOXEL_COLOR
    if mask is not None:
        folds = np.asarray(mask, dtype=bool)
        if folds.shape != dims:
            raise ValueError(f"mask must be {dims} like the volume, got shape {folds.shape}")
        tint = np.array(MASK_COLOR, np.float64)
        for picture, hit in zip(pictures, _views(folds, at, lambda a: a.any(axis=0)), strict=True):
            picture[hit] = np.round((1 - MASK_OPACITY) * picture[hit] + MASK_OPACITY * tint).astype(
                np.uint8
            )
    extents = [n * k for n, k in zip(dims, stretch, strict=True)]  # in the finest voxels
    if scale is None:
        scale = max(1, min(math.ceil(MIN_VIEW / min(extents)), int(MAX_VIEW // max(extents))))
    else:
        scale = check_integer("scale", scale, 1)
        if max(extents) * scale > MAX_PICTURE_SIDE:  # before the pictures are allocated
            raise ValueError(
                f"scale {scale} makes a view {round(max(extents) * scale)} pixels on a side, more "
                f"than {MAX_PICTURE_SIDE}; give a smaller scale"
            )
    # picture pixels along z, y, x: a coarse axis in proportion, within 1024 where it fits
    sizes = [
        max(n * scale, min(round(e * scale), max(MAX_VIEW, n * scale)))
        for n, e in zip(dims, extents, strict=True)
    ]
    picks = [np.arange(size) * n // size for n, size in zip(dims, sizes, strict=True)]
    axes = [(1, 2), (1, 0), (0, 2), (1, 2)]  # each view's rows and columns: z = 0, y = 1, x = 2
    pictures = [p[np.ix_(picks[r], picks[c])] for p, (r, c) in zip(pictures, axes, strict=True)]
    factor = np.array([sizes[2] / dims[2], sizes[1] / dims[1], sizes[0] / dims[0]])  # x, y, z
    if src is not None or dst is not None:
        p, q = as_points3(src, "src"), as_points3(dst, "dst")
        if p.shape != q.shape:
            raise ValueError(f"src and dst must have the same shape, got {p.shape} and {q.shape}")
        reach = max(1.0, max(dims) / 10) if near is None else float(near)
        position = (at[0], at[2], at[1], None)  # the slice each view cuts, along z, x, y
        axis = (2, 0, 1, None)
        for view in range(4):
            keep = np.ones(len(p), bool)
            if axis[view] is not None:
                c, s = axis[view], position[view]
                keep = (np.abs(p[:, c] - s) <= reach) | (np.abs(q[:, c] - s) <= reach)
            if keep.any():
                a = _view_points((p[keep] + 0.5) * factor, view) - 0.5
                b = _view_points((q[keep] + 0.5) * factor, view) - 0.5
                pictures[view] = render_handles(pictures[view], a, b, ctx=ctx)
    names = [f"z = {at[0]}", f"x = {at[2]}", f"y = {at[1]}", f"{projection} along z"]
    return _montage(pictures, sizes, names)


def _stretch(spacing: object) -> tuple[float, float, float]:
    """(dz, dy, dx) over the smallest of them; ``ValueError``/``TypeError`` naming
    ``spacing`` unless it is three finite positive numbers."""
    if spacing is None:
        return 1.0, 1.0, 1.0
    message = f"spacing must be three finite positive numbers (dz, dy, dx), got {spacing!r}"
    if isinstance(spacing, (str, bytes)):
        raise TypeError(message)
    try:
        values = list(spacing)  # type: ignore[call-overload]
    except TypeError:
        raise TypeError(message) from None
    if len(values) != 3:
        raise ValueError(message)
    what = "three finite positive numbers (dz, dy, dx)"
    values = [check_real("spacing", v, low=0, low_open=True, what=what) for v in values]
    least = min(values)
    return values[0] / least, values[1] / least, values[2] / least


def _label(picture: np.ndarray, text: str) -> np.ndarray:
    """``text`` in white on a dark box in the bottom-left corner of a view."""
    if picture.shape[0] < 4 * LABEL_SIZE or picture.shape[1] < 8 * LABEL_SIZE:
        return picture
    image = Image.fromarray(picture)
    draw = ImageDraw.Draw(image)
    font = ImageFont.load_default(size=LABEL_SIZE)
    width = int(font.getlength(text))
    top = picture.shape[0] - LABEL_SIZE - 6
    draw.rectangle((0, top, width + 6, picture.shape[0]), fill=(0, 0, 0))
    draw.text((3, top + 2), text, fill=(255, 255, 255), font=font)
    return np.asarray(image)


def _montage(pictures: list[np.ndarray], sizes: list[int], names: list[str]) -> np.ndarray:
    depth, height, width = sizes
    rows = (height, max(depth, height))
    columns = (width, max(depth, width))
    out = np.full((rows[0] + GAP + rows[1], columns[0] + GAP + columns[1], 3), 128, np.uint8)
    for k, picture in enumerate(pictures):
        picture = _label(picture, names[k])
        top = 0 if k in (0, 1) else rows[0] + GAP
        left = 0 if k in (0, 2) else columns[0] + GAP
        out[top : top + picture.shape[0], left : left + picture.shape[1]] = picture
    return out
