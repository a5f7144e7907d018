"""A keypoint next to a fold is valid only where its pixel's footprint is seen whole.

A keypoint stands for the source pixel at it: the output pixels that show that pixel are
those whose source points fall in its footprint (the source points that the sampling
weighs: within half a pixel on each axis for nearest sampling, within one pixel, the
bilinear tent, for linear sampling). Where the map folds, the layer that wins an output
pixel can hide part of a footprint while the keypoint itself stays shown: the pixel then
appears cut off, its visible part's centre a pixel or more from the keypoint. So each
keypoint is moved and tested with the eight points of its footprint's edge (corners and
edge midpoints), and is valid only where none of them that lands on the canvas, inside the
image, is hidden; not where the footprint's image turns over in part (f folds inside it),
nor where that image is not centred on the keypoint's (the map bends strongly across the
pixel).
Off the canvas and outside the image, a footprint point says nothing of folds: the
keypoint's own test decides there.
"""

from __future__ import annotations

import numpy as np

from ..core.handles import COORDINATE_LIMIT
from .labels import on_canvas

__all__ = [
    "BEND",
    "RING",
    "bent",
    "footprint_radius",
    "footprint_sets",
    "seen_whole",
    "turned",
    "with_footprints",
]

#: The unit ring of a footprint's edge: its corners and edge midpoints, the centre first.
RING = np.array([[x, y] for y in (0.0, -1.0, 1.0) for x in (0.0, -1.0, 1.0)])

#: Just inside the edge, where the sampling still weighs the pixel.
_INSIDE = 0.99


def footprint_radius(interpolation: str) -> float:
    """How far from a source pixel's centre, on each axis, its footprint reaches."""
    return _INSIDE * (1.0 if interpolation == "linear" else 0.5)


def with_footprints(points: np.ndarray, radius: float) -> np.ndarray:
    """(P * 9, 2): each of the (P, 2) ``points`` followed by its footprint's edge points,
    kept within the coordinates the GPU takes (a keypoint that far lies off any canvas)."""
    out = (points[:, None, :] + radius * RING).reshape(-1, 2)
    return np.clip(out, -COORDINATE_LIMIT, COORDINATE_LIMIT, out=out)


def footprint_sets(sets: list[np.ndarray], radius: float) -> list[np.ndarray]:
    """:func:`with_footprints` of each image's (P_i, 2) point set: for sets of one size, of
    all at once (the same sums)."""
    if len({len(p) for p in sets}) != 1:
        return [with_footprints(p, radius) for p in sets]
    every = np.stack(sets)
    ring = radius * RING
    out = np.empty((*every.shape[:2], len(RING), 2))
    for axis in (0, 1):  # apart: numpy adds over (..., 2) pairs with inner loops of two
        out[..., axis] = every[:, :, None, axis] + ring[:, axis]
    if np.abs(every).max(initial=0.0) > COORDINATE_LIMIT - 1.0:
        np.clip(out, -COORDINATE_LIMIT, COORDINATE_LIMIT, out=out)
    return list(out.reshape(len(sets), -1, 2))


def seen_whole(
    points: np.ndarray,
    moved: np.ndarray,
    valid: np.ndarray,
    source: tuple[int, int],
    canvas: tuple[int, int],
    *,
    hidden: bool = True,
) -> tuple[np.ndarray, np.ndarray]:
    """The keypoints' (P, 2) output points and (P,) validity from ``moved`` and ``valid`` of
    :func:`with_footprints`' ``points`` (P * 9): a keypoint's own, cleared where its
    footprint's image turns over in part (:func:`turned`) or is not centred on the
    keypoint's (:func:`bent`) and, with ``hidden``, where a
    footprint point on the ``canvas`` (H, W) and inside the ``source`` image (H, W) is not
    valid. ``hidden=False`` for the methods that push pixels forward (``splat``,
    ``paper-quads``), whose nearest output pixel shows a neighbouring source pixel for some
    of the pixels: there the footprint's edge says nothing of folds."""
    count = len(points) // len(RING)
    at = points.reshape(count, len(RING), 2)
    out = moved.reshape(count, len(RING), 2)
    ok = valid.reshape(count, len(RING))
    inside = on_canvas(at.reshape(-1, 2), source).reshape(count, len(RING))  # same bounds
    landed = on_canvas(out.reshape(-1, 2), canvas).reshape(count, len(RING))
    cut = (inside & landed & ~ok)[:, 1:].any(axis=1) if hidden else np.zeros(count, bool)
    return out[:, 0].copy(), ok[:, 0] & ~cut & ~turned(out) & ~bent(out)


#: How far (output pixels) the mean of a footprint's edge points' images may lie from the
#: keypoint's: under a map that is linear across the pixel they are one point.
BEND = 0.5


def bent(out: np.ndarray) -> np.ndarray:
    """(P,) bool: the footprints whose image, (P, 9, 2) as :func:`with_footprints` orders
    their points, is not centred on the keypoint's: the mean of the edge points' images
    lies more than :data:`BEND` from the keypoint's. Where the map bends that much across
    one pixel (next to a fold of ``backward-swap``'s map, whose inverse stretches the pixel
    eightfold there), what shows of the pixel is centred that far off the keypoint."""
    gap_x = out[:, 1:, 0].mean(axis=1) - out[:, 0, 0]
    gap_y = out[:, 1:, 1].mean(axis=1) - out[:, 0, 1]
    with np.errstate(invalid="ignore"):
        return ~(gap_x * gap_x + gap_y * gap_y <= BEND * BEND)


#: The footprint's edge points in turn around its centre: the fan of eight triangles.
_AROUND = np.array([2, 8, 6, 7, 1, 4, 3, 5, 2])


def turned(out: np.ndarray) -> np.ndarray:
    """(P,) bool: the footprints whose image, (P, 9, 2) as :func:`with_footprints` orders
    their points, turns over in part: a triangle of the fan about the centre whose image has
    the other orientation, or none (f folds inside the footprint)."""
    # x and y apart, each point's edge points in turn (np.take: numpy's fancy indexing along
    # an inner axis runs several times slower), relative to the centre
    x = np.take(out[..., 0], _AROUND, axis=1) - out[:, :1, 0]
    y = np.take(out[..., 1], _AROUND, axis=1) - out[:, :1, 1]
    area = x[:, :-1] * y[:, 1:] - y[:, :-1] * x[:, 1:]
    return (area <= 0).any(axis=1)
