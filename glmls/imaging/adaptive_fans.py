"""The adaptive mesh's triangles (:mod:`.adaptive`): each leaf a fan around its centre
through every vertex on its boundary, its own corners and mid-points and those of finer
neighbours (hanging vertices), so that neighbours share exactly the vertices of their common
edge: no cracks. An edge's vertices are the run between its two corners in the boundary
vertices sorted along rows (or columns): no search.
"""

from __future__ import annotations

import numpy as np

__all__ = ["fans"]


def fans(
    keys: np.ndarray, nodes: np.ndarray, on_edges: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The triangles (T, 3) uint32 of every leaf's fan around its centre, through each
    boundary vertex (``on_edges``, (V,) bool: every leaf's corners and mid-points, its own
    and finer neighbours' on its edges; ``keys`` (V, 2) int64 the vertices' exact
    coordinates; ``nodes`` (L, 9) each leaf's 3 x 3 patch vertices), in the leaves' scan
    order (that of ``nodes``),
    each leaf's triangles together (its top, right, bottom and left edges in turn), all of
    positive area in the source (x right, y down); and the leaf of each, (T,) uint32."""
    boundary = np.flatnonzero(on_edges)
    count = len(boundary)
    # 1-D arrays throughout: numpy gathers (np.take) and computes on contiguous ones fastest
    bx = np.take(np.ascontiguousarray(keys[:, 0]), boundary)
    by = np.take(np.ascontiguousarray(keys[:, 1]), boundary)
    width = int(max(bx.max(), by.max())) + 1
    # the boundary vertices along rows, then along columns; a stable sort, because the
    # vertices come level by level in long sorted runs, which it merges instead of sorting
    by_row = np.take(boundary, np.argsort(by * width + bx, kind="stable"))
    by_column = np.take(boundary, np.argsort(bx * width + by, kind="stable"))
    ordered = np.concatenate([by_row, by_column]).astype(np.uint32)
    # each vertex's place in both orders: an edge's vertices run from one of its corners'
    # places to the other's (keys are distinct), no search needed
    place = np.empty((2, len(keys)), np.int64)
    place[0, by_row] = np.arange(count)
    place[1, by_column] = np.arange(count, 2 * count)
    top_left, top_right, bottom_left, bottom_right = (
        np.ascontiguousarray(nodes[:, k]) for k in (0, 2, 6, 8)
    )
    along_rows, along_cols = place
    leaves = len(nodes)
    first = np.empty((leaves, 4), np.int64)  # top, right, bottom, left
    last = np.empty((leaves, 4), np.int64)
    for side, (start, end, along) in enumerate(
        (
            (top_left, top_right, along_rows),
            (top_right, bottom_right, along_cols),
            (bottom_left, bottom_right, along_rows),
            (top_left, bottom_left, along_cols),
        )
    ):
        first[:, side] = np.take(along, start)
        last[:, side] = np.take(along, end)
    segments = (last - first).ravel()  # per leaf and edge, leaf by leaf
    total = int(segments.sum())
    # per triangle, repeats of per-edge and per-leaf values, not gathers through an index:
    # a triangle's two boundary vertices are neighbours in ``ordered``, k and k + 1. The top
    # and right edges run clockwise about the centre on the screen (y down), the bottom and
    # left ones the other way: there the two are taken k + 1, k, so that every triangle has
    # a positive area (offsets per edge: cheaper than choosing per triangle)
    start = first.ravel() - (np.cumsum(segments) - segments)
    turned = np.tile(np.array([0, 0, 1, 1]), leaves)
    step = np.arange(total)
    per_leaf = segments.reshape(-1, 4).sum(axis=1)
    triangles = np.empty((total, 3), np.uint32)
    triangles[:, 0] = np.repeat(np.ascontiguousarray(nodes[:, 4]), per_leaf)
    triangles[:, 1] = np.take(ordered, step + np.repeat(start + turned, segments))
    triangles[:, 2] = np.take(ordered, step + np.repeat(start + 1 - turned, segments))
    return triangles, np.repeat(np.arange(leaves, dtype=np.uint32), per_leaf)
