"""The adaptive mesh's triangles (:mod:`.mesh`): each leaf a fan around its centre
through every vertex on its boundary (:func:`fan_vertices`: its own corners and those of
finer neighbours, hanging vertices, and mid-points where the fan would bend too far from the
patch), so that neighbours share exactly the vertices of their common edge: no cracks. An
edge's vertices are the run between its two corners in the boundary vertices sorted along
rows (or columns): no search.
"""

from __future__ import annotations

import numpy as np

from .patch import (
    SLOPE_X,
    SLOPE_Y,
    leaf_powers,
    matmul_in_blocks,
    monomials,
    singular_squares,
)

__all__ = ["GUESS_LIMIT", "fan_vertices", "fans"]

#: Source pixels. The scan starts each pixel's Newton step on its leaf's patch from the fan's
#: linear interpolation; a leaf whose four corner triangles would start it farther than this
#: from the patch keeps its edges' mid-points in its fan (eight triangles and more). Measured
#: on the guarantee's 105 maps (:doc:`/adaptive`): their largest errors within 0.02 of
#: the tolerance of those with every mid-point but one (idw alpha 1.5, 0.25 px: 0.97, was
#: 0.80); corners alone erred by up to 1.54 times the tolerance (a similarity map, 0.25 px).
#: W1 and W2 at 0.05 px have 0.51 and 0.55 times the triangles of fans with every mid-point.
GUESS_LIMIT = 0.8

_CORNERS = (0, 2, 6, 8)
_MIDS = (1, 3, 5, 7)  # top, left, right, bottom


def _fan_misses() -> np.ndarray:
    """(8, 8): from a leaf's patch in powers (:func:`.patch.leaf_powers`), how far
    it is from the corner fan's linear interpolation where that is farthest for a quadratic:
    at the edges' mid-points (top, left, right, bottom) and half-way from the centre to
    each corner (the patch is 0 at the centre: its powers leave f there out)."""
    half = 0.5
    corners = [(-half, -half), (half, -half), (-half, half), (half, half)]  # nodes 0, 2, 6, 8
    mids = [((0.0, -half), 0, 1), ((-half, 0.0), 0, 2), ((half, 0.0), 1, 3), ((0.0, half), 2, 3)]
    columns = [
        monomials(*mid) - (monomials(*corners[a]) + monomials(*corners[b])) / 2
        for mid, a, b in mids
    ]
    columns += [monomials(x / 2, y / 2) - monomials(x, y) / 2 for x, y in corners]
    return np.stack(columns, axis=1)


_FAN_MISSES = _fan_misses()


def fan_vertices(
    nodes: np.ndarray,
    deformed: np.ndarray,
    leaves: np.ndarray,
    folded: np.ndarray,
    *,
    powers: np.ndarray | None = None,
) -> np.ndarray:
    """Which vertices the fans run through, (V,) bool: every leaf's corners; the mid-points of
    a leaf's edges where its patch is more than :data:`GUESS_LIMIT` source pixels from its
    corner fan (the patch's distance in output pixels over its smallest stretch at the
    centre), where it folds (``folded``, (L,) bool), where f is not finite, and on the mesh's
    outer edges (so that the image's outline is f's at them). ``nodes`` (L, 9) each leaf's 3
    x 3 patch vertices, ``deformed`` (V, 2) f at the vertices, ``leaves`` (L, 4) the cells
    (x0, y0, x1, y1); ``powers``: the patches as :func:`.patch.leaf_powers` gives
    them (worked out here where None)."""
    nodes = nodes.astype(np.intp, copy=False)  # once: numpy converts other indices per gather
    if powers is None:
        powers = leaf_powers(nodes, deformed)
    count = len(nodes)
    on_edges = np.zeros(len(deformed), bool)
    on_edges[nodes[:, _CORNERS]] = True
    miss = matmul_in_blocks(powers.reshape(2 * count, 8), _FAN_MISSES).reshape(2, count, 8)
    miss *= miss  # squares, not np.hypot: libm's is ~10x slower
    far = miss[0]
    far += miss[1]
    width, height = leaves[:, 2] - leaves[:, 0], leaves[:, 3] - leaves[:, 1]
    (a, c), (b, d) = (
        (powers[0][:, k] / size, powers[1][:, k] / size)
        for k, size in ((SLOPE_X, width), (SLOPE_Y, height))
    )  # the Jacobian [[a, b], [c, d]] at the centre
    _, smallest = singular_squares(a, b, c, d, a * d - b * c)
    # NaN where f is not finite; numpy reduces the rows of the transpose ~5x faster
    far = np.ascontiguousarray(far.T).max(axis=0)
    with np.errstate(invalid="ignore"):
        # the limit in output pixels: times the smallest stretch (squared, as ``far``)
        bent = ~(far <= GUESS_LIMIT**2 * smallest) | folded
    on_edges[np.compress(bent, nodes, axis=0)[:, _MIDS]] = True
    outline = (
        leaves[:, 1] == leaves[:, 1].min(),
        leaves[:, 0] == leaves[:, 0].min(),
        leaves[:, 2] == leaves[:, 2].max(),
        leaves[:, 3] == leaves[:, 3].max(),
    )
    for mid, outer in zip(_MIDS, outline, strict=True):
        on_edges[nodes[outer, mid]] = True
    return on_edges


def fans(
    keys: np.ndarray, nodes: np.ndarray, on_edges: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The triangles (T, 3) uint32 of every leaf's fan around its centre, through each
    boundary vertex (``on_edges``, (V,) bool: :func:`fan_vertices`, every leaf's corners,
    its own and finer neighbours' on its edges, and the mid-points it chose; ``keys`` (V,
    2) int64 the vertices' exact coordinates; ``nodes`` (L, 9) each leaf's 3 x 3 patch
    vertices), in the leaves' scan order (that of ``nodes``),
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
