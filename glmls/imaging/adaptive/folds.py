"""Where the deformed adaptive mesh may cover a pixel more than once (numpy): the check that
lets :mod:`.scan` draw an embedding in one pass without keys, and keys only near
reversed triangles where the boundary is a simple curve. The scan checks the boundary here
(:func:`boundary_turns`) and the triangles on the GPU (``adaptive/folds.comp.glsl``),
for which :func:`check_folds` and :func:`hot_tiles` are the float64 references."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..frame import Frame
from .mesh import AdaptiveMesh

__all__ = ["FoldCheck", "boundary_turns", "check_folds", "embedded", "hot_tiles"]


@dataclass(frozen=True)
class FoldCheck:
    """How the deformed mesh covers the plane: ``simple``, its boundary turns once about its
    centroid, always the same way (a simple curve); ``reversed``, the ids of the triangles
    not of the mesh's orientation (or nearly degenerate, with room for float32's rounding).
    Where the boundary is simple, the map's degree is 1 inside it and 0 outside, so a point
    covered twice is covered by a reversed triangle. Nearly degenerate: twice the area within
    1e-5 of the longest side squared (a shape's measure, which float32's rounding of the
    vertices cannot turn over)."""

    simple: bool
    reversed: np.ndarray

    @property
    def embedded(self) -> bool:
        """Each point covered once at most (False may be one too: a boundary that is not
        star-shaped about its centroid; the keyed passes then draw it as exactly)."""
        return self.simple and len(self.reversed) == 0


def check_folds(mesh: AdaptiveMesh) -> FoldCheck:
    """The :class:`FoldCheck` of ``mesh`` (``adaptive/folds.comp.glsl`` finds the same
    reversed triangles on the GPU, for the warp)."""
    simple, orientation = boundary_turns(mesh)
    # one coordinate of one corner at a time: numpy gathers and reduces 1-D arrays fastest
    (ax, bx, cx), (ay, by, cy) = _corners(mesh, mesh.triangles)
    area = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)  # all positive in the source
    longest = np.maximum.reduce(
        [
            (bx - ax) ** 2 + (by - ay) ** 2,
            (cx - bx) ** 2 + (cy - by) ** 2,
            (ax - cx) ** 2 + (ay - cy) ** 2,
        ]
    )
    return FoldCheck(simple, np.flatnonzero(orientation * area <= 1e-5 * longest))


def boundary_turns(mesh: AdaptiveMesh) -> tuple[bool, float]:
    """Whether ``mesh``'s deformed boundary is simple (turns once about its centroid, always
    the same way), and the orientation under f of a triangle that keeps the mesh's: +1
    where the boundary turns as the identity's does (by +2 pi), else -1 (a mirror)."""
    x0, y0 = mesh.leaves[:, 0].min(), mesh.leaves[:, 1].min()
    x1, y1 = mesh.leaves[:, 2].max(), mesh.leaves[:, 3].max()
    # every vertex is a triangle's; contiguous columns and np.take: numpy's fastest
    x, y = (np.ascontiguousarray(mesh.source[:, k]) for k in (0, 1))
    on = np.flatnonzero((x == x0) | (x == x1) | (y == y0) | (y == y1))
    x, y = np.take(x, on), np.take(y, on)
    sides = (  # the source boundary, clockwise about its centre on the screen (y down)
        (y == y0, x, False),
        (x == x1, y, False),
        (y == y1, x, True),
        (x == x0, y, True),
    )
    ring = []
    for side, along, backwards in sides:
        ids = np.flatnonzero(side)
        ids = ids[np.argsort(along[ids])]
        ring.append(on[(ids[::-1] if backwards else ids)[:-1]])  # each corner once
    boundary = np.take(mesh.deformed, np.concatenate(ring), axis=0)
    offset = boundary - boundary.mean(axis=0)
    angle = np.arctan2(offset[:, 1], offset[:, 0])
    turns = (np.diff(angle, append=angle[:1]) + np.pi) % (2 * np.pi) - np.pi
    simple = bool(
        ((turns > 0).all() or (turns < 0).all()) and abs(abs(turns.sum()) - 2 * np.pi) < 1e-6
    )
    return simple, 1.0 if turns.sum() >= 0 else -1.0


def _corners(mesh: AdaptiveMesh, triangles: np.ndarray):
    """((xa, xb, xc), (ya, yb, yc)): the deformed corners of ``triangles`` (T, 3)."""
    x = np.ascontiguousarray(mesh.deformed[:, 0])
    y = np.ascontiguousarray(mesh.deformed[:, 1])
    ids = [np.ascontiguousarray(triangles[:, k]) for k in range(3)]
    return tuple(x[i] for i in ids), tuple(y[i] for i in ids)


def embedded(mesh: AdaptiveMesh) -> bool:
    """Is ``mesh`` (deformed) an embedding, by :func:`check_folds`?"""
    return check_folds(mesh).embedded


def hot_tiles(mesh: AdaptiveMesh, triangles: np.ndarray, frame: Frame) -> np.ndarray:
    """(rows, words) uint32 bits of the 8 x 8 px tiles of ``frame`` that the pixel boxes
    of ``triangles`` (ids), one pixel wider against rounding, reach (bit x & 31 of word
    x >> 5: tile column x)."""
    width, height = frame.size
    columns, rows = (width + 7) // 8, (height + 7) // 8
    xs, ys = _corners(mesh, mesh.triangles[triangles])
    origin = np.asarray(frame.origin)
    first = np.stack([np.minimum.reduce(xs), np.minimum.reduce(ys)], axis=-1) - origin
    last = np.stack([np.maximum.reduce(xs), np.maximum.reduce(ys)], axis=-1) - origin
    first, last = np.floor(first) - 1, np.ceil(last) + 1
    inside = (last[:, 0] >= 0) & (last[:, 1] >= 0) & (first[:, 0] < width) & (first[:, 1] < height)
    first = (np.clip(first[inside], 0, [width - 1, height - 1]) // 8).astype(np.int64)
    last = (np.clip(last[inside], 0, [width - 1, height - 1]) // 8).astype(np.int64)
    # +1 / -1 at the boxes' corners, summed along both axes: the boxes' cover counts
    size = (rows + 1) * (columns + 1)
    marks = sum(
        sign * np.bincount(r * (columns + 1) + c, minlength=size)
        for sign, r, c in (
            (1, first[:, 1], first[:, 0]),
            (-1, first[:, 1], last[:, 0] + 1),
            (-1, last[:, 1] + 1, first[:, 0]),
            (1, last[:, 1] + 1, last[:, 0] + 1),
        )
    ).reshape(rows + 1, columns + 1)
    hot = marks.cumsum(axis=0).cumsum(axis=1)[:rows, :columns] > 0
    words = (columns + 31) // 32
    bits = np.zeros((rows, words * 32), bool)
    bits[:, :columns] = hot
    return np.packbits(bits, axis=1, bitorder="little").view("<u4")
