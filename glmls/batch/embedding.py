"""Which deformed meshes are embeddings (no point covered by two triangles), and where a
mesh that folds may cover a point twice: the numpy forms of ``batch/check.comp.glsl``'s test,
for the keypoints of :mod:`glmls.batch.labels`. A mesh is (N, rows, columns, 2) vertices in
pixels, its cells' triangles (00, 10, 11) and (00, 11, 01) as ``warp/cells.comp.glsl`` fills
them."""

from __future__ import annotations

import numpy as np

__all__ = [
    "EMBED_MARGIN",
    "SIMPLE_EDGES",
    "boundary",
    "cross",
    "embedded",
    "fold_candidates",
    "simple_rings",
    "star_shaped",
    "triangle_areas",
]


#: Least area (px^2) of a triangle, and turn of a boundary edge about the centre, that
#: :func:`embedded` counts as positive: far above float32 rounding of the GPU's own values.
EMBED_MARGIN = 1e-3


def embedded(vertices: np.ndarray) -> np.ndarray:
    """(N,) bool: the deformed meshes (N, rows, columns, 2) that are embeddings, shown by
    every triangle positive and a simple boundary, by :data:`EMBED_MARGIN` at least: no
    point is then covered twice (``warp/cells_check.comp.glsl`` says why). The boundary is
    shown simple by turning around the centre vertex, once (a star-shaped curve), or, where
    it does not (a long strip bent along its length), edge against edge
    (:func:`simple_rings`)."""
    lower, upper = triangle_areas(vertices)
    positive = (lower > EMBED_MARGIN) & (upper > EMBED_MARGIN)
    ok = positive.reshape(len(vertices), -1).all(axis=1)
    ring = boundary(vertices)
    shown = ok & star_shaped(vertices, ring)
    rest = np.flatnonzero(ok & ~shown)
    if len(rest):
        shown[rest] = simple_rings(np.asarray(ring[rest], np.float64))
    return shown


def triangle_areas(vertices: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The doubled signed areas of the cells' triangles (00, 10, 11) and (00, 11, 01) of the
    meshes (N, rows, columns, 2): two (N, rows - 1, columns - 1) arrays, positive where
    counter-clockwise (x and y apart: numpy runs operations over (..., 2) pairs with inner
    loops of two elements)."""
    x, y = vertices[..., 0], vertices[..., 1]
    ax, ay, bx, by = x[:, :-1, :-1], y[:, :-1, :-1], x[:, :-1, 1:], y[:, :-1, 1:]
    cx, cy, dx, dy = x[:, 1:, 1:], y[:, 1:, 1:], x[:, 1:, :-1], y[:, 1:, :-1]
    lower = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
    upper = (cx - ax) * (dy - ay) - (cy - ay) * (dx - ax)
    return lower, upper


def boundary(vertices: np.ndarray) -> np.ndarray:
    """(N, B, 2): the boundary vertices of the meshes (N, rows, columns, 2), counter-clockwise
    in the triangles' sense (00 -> 10 -> 11 -> 01)."""
    edges = [
        vertices[:, 0, :-1],
        vertices[:, :-1, -1],
        vertices[:, -1, :0:-1],
        vertices[:, :0:-1, 0],
    ]
    return np.concatenate(edges, axis=1)


def star_shaped(vertices: np.ndarray, ring: np.ndarray) -> np.ndarray:
    """(N,) bool: the meshes' boundaries (``ring``, :func:`_boundary`) shown to be simple
    curves by turning strictly counter-clockwise about the centre vertex, once."""
    rows, columns = vertices.shape[1:3]
    centre = vertices[:, rows // 2, columns // 2][:, None]
    rel = ring - centre
    nxt = np.roll(rel, -1, axis=1)
    turn = cross(rel, nxt)
    angle = np.arctan2(turn, np.einsum("nmi,nmi->nm", rel, nxt)).sum(axis=1)
    return (turn > EMBED_MARGIN).all(axis=1) & (angle < 3 * np.pi)


#: Mesh vertices that :func:`fold_candidates` converts and tests in one block.
_FOLD_BLOCK = 1 << 20

#: Point-box pairs of one mesh past which :func:`fold_candidates` keeps all its points.
_FOLD_PAIRS = 1 << 22

#: Pixels by which :func:`fold_candidates` widens the boxes of the triangles of a fold: far
#: above the rounding of a point's place in its own triangle.
_FOLD_PAD = 1e-6


def fold_candidates(vertices, images: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(P,) bool: the output ``points`` (P, 2) of meshes ``images`` (P,) (of ``vertices``,
    (N, rows, columns, 2), an array or :class:`MeshVertices`) that a triangle of their mesh
    other than their own may hold: every point of a mesh whose boundary is not shown to be
    star-shaped, else those within the box of one of its triangles not positive by
    :data:`EMBED_MARGIN`. Where the boundary is a simple closed curve the triangles that hold
    a point, counted with the signs of their orientations, add up to the curve's winding
    number about it, 0 or 1: a point inside two triangles is inside a negative one (or, on
    an edge, at its border), so the others need no test."""
    keep = np.ones(len(points), bool)
    meshes, place = np.unique(images, return_inverse=True)
    order = np.argsort(place, kind="stable")  # each mesh's points, one run after another
    ends = np.cumsum(np.bincount(place))
    _, rows, columns, _ = vertices.shape
    block = max(1, _FOLD_BLOCK // (rows * columns))
    for first in range(0, len(meshes), block):
        v = np.asarray(vertices[meshes[first : first + block]], np.float64)
        star = star_shaped(v, boundary(v))
        lo, hi, owner = _fold_boxes(v, star)
        # the points of this block's meshes, and the mesh (of the block) each is in
        mine = order[(ends[first - 1] if first else 0) : ends[first + len(v) - 1]]
        local = place[mine] - first
        boxes = np.bincount(owner, minlength=len(v))
        # a mesh folded through and through (more point-box pairs than _FOLD_PAIRS) keeps
        # every point, as does one not shown star-shaped
        pairs = np.bincount(local, minlength=len(v)) * boxes
        tested = star[local] & (pairs[local] <= _FOLD_PAIRS)
        mine, local = mine[tested], local[tested]
        keep[mine] = _in_boxes(points[mine], local, lo, hi, boxes)
    return keep


def _fold_boxes(v: np.ndarray, star: np.ndarray):
    """The boxes (lo, hi: (T, 2), widened by :data:`_FOLD_PAD`) of the triangles of the
    meshes ``v`` (M, rows, columns, 2) not positive by :data:`EMBED_MARGIN`, of the meshes
    where ``star``, ordered by their mesh (``owner``, (T,) indices into ``v``)."""
    x, y = v[..., 0], v[..., 1]
    corners = [(x[:, :-1, :-1], y[:, :-1, :-1]), (x[:, :-1, 1:], y[:, :-1, 1:])]
    corners += [(x[:, 1:, 1:], y[:, 1:, 1:]), (x[:, 1:, :-1], y[:, 1:, :-1])]  # 11, 01
    lows, highs, owners = [], [], []
    for area, ends_at in zip(triangle_areas(v), ((0, 1, 2), (0, 2, 3)), strict=True):
        m, r, c = np.nonzero((area <= EMBED_MARGIN) & star[:, None, None])
        tx = np.stack([corners[k][0][m, r, c] for k in ends_at])
        ty = np.stack([corners[k][1][m, r, c] for k in ends_at])
        lows.append(np.stack([tx.min(axis=0), ty.min(axis=0)], axis=1))
        highs.append(np.stack([tx.max(axis=0), ty.max(axis=0)], axis=1))
        owners.append(m)
    owner = np.concatenate(owners)
    by_mesh = np.argsort(owner, kind="stable")
    lo = np.concatenate(lows)[by_mesh] - _FOLD_PAD
    hi = np.concatenate(highs)[by_mesh] + _FOLD_PAD
    return lo, hi, owner[by_mesh]


def _in_boxes(points: np.ndarray, local: np.ndarray, lo, hi, boxes: np.ndarray) -> np.ndarray:
    """(P,) bool: the ``points`` (P, 2) within one of the boxes (lo, hi) of their mesh
    ``local`` (P,), the boxes ordered by mesh, ``boxes`` (M,) of each; every point against
    its mesh's boxes, in pieces of at most about :data:`_FOLD_PAIRS` pairs."""
    inside = np.zeros(len(points), bool)
    counts = boxes[local]
    first_box = (np.cumsum(boxes) - boxes)[local]
    total = np.cumsum(counts)
    start = 0
    while start < len(points):
        # whole points up to _FOLD_PAIRS pairs (one point at least)
        done = total[start - 1] if start else 0
        stop = max(int(np.searchsorted(total, done + _FOLD_PAIRS, side="right")), start + 1)
        n = counts[start:stop]
        point = np.repeat(np.arange(start, stop), n)
        box = np.repeat(first_box[start:stop] - (np.cumsum(n) - n), n) + np.arange(n.sum())
        px, py = points[point, 0], points[point, 1]
        near = (lo[box, 0] <= px) & (px <= hi[box, 0]) & (lo[box, 1] <= py) & (py <= hi[box, 1])
        inside[np.unique(point[near])] = True
        start = stop
    return inside


#: The most edges of a boundary that :func:`simple_rings` tests pair by pair (as
#: ``batch/check.comp.glsl``'s ``BATCH_SIMPLE_EDGES``): 224 at 224 x 224 and grid 4.
SIMPLE_EDGES = 256

#: Pairs of edges (rings times pairs) that :func:`simple_rings` compares in one block.
_PAIR_BLOCK = 1 << 20


def simple_rings(rings: np.ndarray) -> np.ndarray:
    """(M,) bool: the closed polygons ``rings`` (M, B, 2) shown to be simple curves: every
    two edges that share no vertex more than :data:`EMBED_MARGIN` apart (neither crossing
    nor within that distance), and no edge turning back along the one before it. False
    beyond :data:`SIMPLE_EDGES` edges (not shown)."""
    count, edges = rings.shape[:2]
    if edges > SIMPLE_EDGES or edges < 3:
        return np.zeros(count, bool)
    margin = EMBED_MARGIN
    a, b, p = rings, np.roll(rings, -1, axis=1), np.roll(rings, -2, axis=1)
    ab, bp = b - a, p - b
    back = (np.abs(cross(ab, bp)) <= margin) & (np.einsum("mei,mei->me", ab, bp) <= 0)
    simple = ~back.any(axis=1)
    first, second = np.triu_indices(edges, 2)
    keep = ~((first == 0) & (second == edges - 1))  # those two share vertex 0
    first, second = first[keep], second[keep]
    block = max(1, _PAIR_BLOCK // len(first))
    for start in range(0, count, block):
        part = slice(start, start + block)
        e0, e1 = np.take(a[part], first, axis=1), np.take(b[part], first, axis=1)
        f0, f1 = np.take(a[part], second, axis=1), np.take(b[part], second, axis=1)
        simple[part] &= ~_near(e0, e1, f0, f1, margin).any(axis=1)
    return simple


def _near(a: np.ndarray, b: np.ndarray, p: np.ndarray, q: np.ndarray, margin: float):
    """Segments ab and pq crossing or within ``margin`` of each other: the distance of two
    segments that do not cross is the least of their ends' distances to the other."""
    ab, pq = b - a, q - p
    sp, sq = cross(ab, p - a), cross(ab, q - a)
    sa, sb = cross(pq, a - p), cross(pq, b - p)
    crossing = (sp * sq < 0) & (sa * sb < 0)
    closest = np.minimum(
        np.minimum(_to_segment(p, a, ab), _to_segment(q, a, ab)),
        np.minimum(_to_segment(a, p, pq), _to_segment(b, p, pq)),
    )
    return crossing | ~(closest > margin * margin)  # NaN: near


def _to_segment(point: np.ndarray, start: np.ndarray, along: np.ndarray) -> np.ndarray:
    """Squared distance of ``point`` to the segment from ``start`` by ``along``."""
    rel = point - start
    length = np.einsum("...i,...i->...", along, along)
    t = np.clip(np.einsum("...i,...i->...", rel, along) / np.maximum(length, 1e-300), 0, 1)
    gap = rel - t[..., None] * along
    return np.einsum("...i,...i->...", gap, gap)


def cross(e: np.ndarray, f: np.ndarray) -> np.ndarray:
    """The cross products of the 2D vectors ``e`` and ``f`` (..., 2): the doubled signed area
    of the triangle they span."""
    return e[..., 0] * f[..., 1] - e[..., 1] * f[..., 0]
