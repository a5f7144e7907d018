"""Keypoints moved by the object that placed the pixels: for ``quads`` on a regular mesh, the
mesh's own piecewise linear map (each cell's two triangles (00, 10, 11) and (00, 11, 01),
as ``warp/cells.comp.glsl`` and ``warp/mesh.vert.glsl`` fill them); for the other methods f
itself (for ``backward-swap`` the inverse of the swapped-handles map it samples with). A
keypoint is valid where it lands on the canvas and the output pixel nearest it
shows the keypoint's own neighbourhood (in a fold another part of the image wins that pixel).
"""

from __future__ import annotations

import numpy as np

from ..core.mesh import MeshLattice
from .covering import PAIRS_BLOCK, MeshVertices, boxes_per_mesh, covered_earlier, tile_boxes
from .embedding import embedded, fold_candidates

__all__ = [
    "SLACK",
    "in_lattice",
    "mesh_corners",
    "mesh_keypoints",
    "mesh_map",
    "on_canvas",
    "visible",
    "visible_chunk",
]


def on_canvas(out: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """(P,) bool: the output points ``out`` (P, 2) on a canvas of ``shape`` (H, W), which
    spans [-0.5, W - 0.5) x [-0.5, H - 0.5): output pixel c covers [c - 0.5, c + 0.5)."""
    height, width = shape
    x, y = out[:, 0], out[:, 1]
    return (x >= -0.5) & (x < width - 0.5) & (y >= -0.5) & (y < height - 0.5)


def in_lattice(lattice: MeshLattice, points: np.ndarray) -> np.ndarray:
    """(P,) bool: the (P, 2) source ``points`` inside the domain of ``lattice``'s cells,
    edges included (x and y apart: numpy's reductions over a pair run slowly)."""
    (x0, y0), (x1, y1) = lattice.origin, lattice.last
    x, y = points[:, 0], points[:, 1]
    return (x >= x0) & (x <= x1) & (y >= y0) & (y <= y1)


def mesh_corners(lattice: MeshLattice, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For (P, 2) source ``points``: the (P, 4, 2) corners 00, 10, 01, 11 of the lattice cell
    holding each (the last cell of a row or column where past it) and a (P,) bool, inside the
    lattice's domain."""
    _, low, high, inside = _cells(lattice, points)
    corners = np.empty((len(points), 4, 2))
    corners[:, 0] = low
    corners[:, 1, 0], corners[:, 1, 1] = high[:, 0], low[:, 1]
    corners[:, 2, 0], corners[:, 2, 1] = low[:, 0], high[:, 1]
    corners[:, 3] = high
    return corners, inside


def _cells(lattice: MeshLattice, points: np.ndarray):
    """The (P, 2) (column, row) index of the cell holding each of the (P, 2) ``points``, its
    corners 00 and 11 (P, 2) each, and (P,) bool, inside the lattice's domain
    (:func:`mesh_corners`)."""
    grid = lattice.grid
    count = len(points)
    index = np.empty((count, 2), np.int64)
    low, high = np.empty((count, 2)), np.empty((count, 2))
    # axis by axis: numpy runs (P, 2) arrays against a pair of bounds with inner loops of two
    for axis, cells in enumerate(lattice.cells):  # (columns, rows)
        origin, last = np.float64(lattice.origin[axis]), np.float64(lattice.last[axis])
        values = points[:, axis]
        at = np.floor((values - origin) / grid).astype(np.int64)
        np.clip(at, 0, cells - 1, out=at)
        index[:, axis] = at
        low[:, axis] = np.minimum(origin + at * grid, last)
        high[:, axis] = np.minimum(origin + (at + 1) * grid, last)
    return index, low, high, in_lattice(lattice, points)


def mesh_map(
    corners: np.ndarray, deformed: np.ndarray, points: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The mesh's map at ``points``: (P, 2) output points and the (P, 2, 2) Jacobians (rows:
    d/dx, d/dy) of the triangle each lies in. ``corners``: (P, 4, 2) source corners 00, 10, 01,
    11 (:func:`mesh_corners`), ``deformed``: their images under f."""
    by_corner = np.ascontiguousarray(np.asarray(deformed, np.float64).transpose(1, 2, 0))
    out, ex, ey, size, _ = _triangle_map(corners[:, 0], corners[:, 3], by_corner, points)
    jacobian = np.stack([ex / size[:, :1], ey / size[:, 1:]], axis=1)
    return out, jacobian


def _triangle_map(low: np.ndarray, high: np.ndarray, deformed: np.ndarray, points: np.ndarray):
    """:func:`mesh_map`'s output points, the triangles' edges per unit of the cell's (u, v),
    the cells' sizes and (P,) bool, the point in the upper triangle (00, 11, 01); ``low`` and
    ``high``: the cells' corners 00 and 11; ``deformed``: their images, (4, 2, P) (corner,
    axis, point: each corner's x and y contiguous, as :func:`_cell_vertices` gathers them).
    Axis by axis on (P,) arrays: numpy runs the (P, 2) arrays of strided views, and masks
    broadcast over their pairs, with inner loops of two elements, several times slower."""
    size = np.maximum(high - low, 1e-12)
    u = (points[:, 0] - low[:, 0]) / size[:, 0]
    v = (points[:, 1] - low[:, 1]) / size[:, 1]
    lower = u >= v  # triangle 0 (00, 10, 11): below the diagonal in (u, v); else 1 (00, 11, 01)
    count = len(points)
    out, ex, ey = np.empty((count, 2)), np.empty((count, 2)), np.empty((count, 2))
    for axis in (0, 1):
        d00, d10, d01, d11 = deformed[:, axis]
        ex[:, axis] = edge_u = np.where(lower, d10 - d00, d11 - d01)  # per unit u
        ey[:, axis] = edge_v = np.where(lower, d11 - d10, d01 - d00)  # per unit v
        out[:, axis] = d00 + u * edge_u + v * edge_v
    return out, ex, ey, size, u < v


#: A keypoint shows where the source point of the output pixel nearest it is within this
#: distance (source pixels), plus half the local map's change over that step, of where the
#: keypoint's own map puts that pixel's source point.
SLACK = 0.5


def visible(
    points: np.ndarray,
    out: np.ndarray,
    jacobian: np.ndarray,
    coords: np.ndarray,
    covered: np.ndarray,
    inside: np.ndarray,
    *,
    drawn: bool = False,
) -> np.ndarray:
    """(P,) bool: keypoints ``points`` (source, (P, 2)) landing at ``out`` with local
    ``jacobian`` (P, 2, 2) that show: on the canvas of ``coords`` ((H, W, 2) source point per
    output pixel, the frame's pixel (0, 0) at out (0, 0)), ``covered`` there, ``inside`` the
    source domain, and the source point shown at the nearest output pixel within
    :data:`SLACK` plus the local map's change of the source point that pixel's
    centre should show (else another part of the image folds over it). ``drawn``: ``coords``
    are the source pixels (centres) that a forward fill drew, not the source points of the
    output pixels' centres: the test allows the half pixel's diagonal more, through the
    local map. One image's :func:`visible_chunk`."""
    images = np.zeros(len(points), np.int64)
    return visible_chunk(
        points, images, out, jacobian, coords[None], covered[None], inside, drawn=drawn
    )


#: The least ratio of a Jacobian's singular values, and the range of its singular values,
#: where :func:`visible_chunk` inverts it in closed form: both that and the SVD behind
#: ``np.linalg.pinv`` then lie within about 1e-9 of the inverse (relative to its norm), and
#: the pseudo-inverse is the inverse (it drops singular values below 1e-15 of the largest).
_CONDITION = 1e-6
_RANGE = (1e-100, 1e100)
#: Relative and absolute (per unit of the inverse's norm) margins of the closed form's
#: distances and thresholds about which :func:`visible_chunk` takes the pseudo-inverse too:
#: far above both computations' rounding, so that each flag is the pseudo-inverse's.
_MARGIN = (1e-8, 1e-6)


def visible_chunk(
    points: np.ndarray,
    images: np.ndarray,
    out: np.ndarray,
    jacobian: np.ndarray,
    coords: np.ndarray,
    covered: np.ndarray,
    inside: np.ndarray,
    *,
    drawn: bool = False,
) -> np.ndarray:
    """:func:`visible` for the keypoints of a chunk of images at once: ``points``, ``out``
    (P, 2), ``jacobian`` (P, 2, 2) and ``inside`` (P,) of every image, ``images`` (P,) the
    image of each, ``coords`` (N, H, W, 2) and ``covered`` (N, H, W) the images' canvases.
    The local map's inverse is the Jacobian's pseudo-inverse (``np.linalg.pinv``): in
    closed form where the Jacobian is well conditioned, by the pseudo-inverse itself where
    it is nearly singular or where a distance lies within rounding of its threshold, so
    every flag is the pseudo-inverse's. A Jacobian with a NaN or infinite entry, or one the
    SVD does not resolve, shows nothing."""
    height, width = covered.shape[1:]
    pixel = np.rint(out)
    on = inside & on_canvas(out, (height, width))
    ok = np.zeros(len(points), bool)
    if not on.any():
        return ok
    idx = np.flatnonzero(on)
    # np.take: numpy's fancy indexing of rows runs several times slower
    col = np.take(pixel[:, 0], idx).astype(np.int64).clip(0, width - 1)
    row = np.take(pixel[:, 1], idx).astype(np.int64).clip(0, height - 1)
    image = np.take(images, idx)
    at = (image * height + row) * width + col  # the pixel, flat in the canvases
    keep = _gather(covered, at)  # an uncovered pixel shows no keypoint
    idx, at = idx[keep], at[keep]
    if not len(idx):
        return ok
    shown = _gather(coords, at).astype(np.float64)
    step = np.take(pixel, idx, axis=0) - np.take(out, idx, axis=0)
    picked = np.take(jacobian, idx, axis=0)
    (a, b), (c, d) = picked[:, 0].T, picked[:, 1].T
    with np.errstate(all="ignore"):
        # J's singular values in closed form: half the sum and difference of two lengths
        largest = 0.5 * (
            np.sqrt((a + d) ** 2 + (b - c) ** 2) + np.sqrt((a - d) ** 2 + (b + c) ** 2)
        )
        det = a * d - b * c
        least = np.abs(det) / largest
        regular = (least > _CONDITION * largest) & (least > _RANGE[0]) & (largest < _RANGE[1])
        # x and y apart: numpy runs (k, 2) arrays against (k, 1) ones, and reductions over
        # their pairs, with inner loops of two elements
        sx, sy = step[:, 0], step[:, 1]
        source = np.take(points, idx, axis=0)
        shown_x, shown_y = shown[:, 0], shown[:, 1]
        gap_x = shown_x - (source[:, 0] + (sx * d - sy * c) / det)  # shown - expected
        gap_y = shown_y - (source[:, 1] + (a * sy - b * sx) / det)
        spread = 1.0 / least  # the inverse's 2-norm
        length = np.sqrt(sx * sx + sy * sy)
        threshold = _threshold(spread, length, drawn)
        distance = np.sqrt(gap_x**2 + gap_y**2)
        scale = 1.0 + np.maximum(np.abs(shown_x), np.abs(shown_y))
        scale += np.maximum(np.abs(source[:, 0]), np.abs(source[:, 1]))
        margin = _MARGIN[0] * (scale + threshold) + _MARGIN[1] * spread * (1.0 + length)
        sure = regular & (np.abs(distance - threshold) > margin)
    ok[idx[sure]] = distance[sure] <= threshold[sure]
    finite = np.isfinite(a) & np.isfinite(b) & np.isfinite(c) & np.isfinite(d)
    rest = np.flatnonzero(~sure & finite)
    if len(rest):
        near = _near_by_pinv(source[rest], picked[rest], step[rest], shown[rest], drawn)
        ok[idx[rest]] = near
    return ok


def _gather(canvases: np.ndarray, at: np.ndarray) -> np.ndarray:
    """The values of the (N, H, W[, 2]) ``canvases`` at flat pixel indices ``at``."""
    pixels = int(np.prod(canvases.shape[:3]))
    if canvases.flags.c_contiguous:
        return np.take(canvases.reshape(pixels, -1), at, axis=0).reshape(
            len(at), *canvases.shape[3:]
        )
    return canvases[np.unravel_index(at, canvases.shape[:3])]


def _threshold(spread: np.ndarray, length: np.ndarray, drawn: bool) -> np.ndarray:
    """How far the shown source point may lie from the expected one: :data:`SLACK` (and,
    ``drawn``, the half pixel's diagonal through the local map), plus half the local map's
    change over the ``length`` of the step to the nearest pixel; ``spread`` the local
    inverse's 2-norm."""
    slack = SLACK + (np.sqrt(0.5) * np.maximum(spread, 1.0) if drawn else 0.0)
    return slack + 0.5 * (length * spread)


def _near_by_pinv(
    points: np.ndarray, jacobian: np.ndarray, step: np.ndarray, shown: np.ndarray, drawn: bool
) -> np.ndarray:
    """:func:`visible_chunk`'s test of the source points ``shown`` at the pixels ``step``
    from where the keypoints land, through ``np.linalg.pinv`` of their finite
    ``jacobian``: (k,) bool, False where the SVD does not resolve the Jacobian."""
    with np.errstate(all="ignore"):
        try:
            inverse = np.linalg.pinv(jacobian)  # (k, 2, 2): rows d/du
            spread = np.linalg.norm(inverse, ord=2, axis=(1, 2))
        except np.linalg.LinAlgError:  # e.g. subnormal entries: the others one by one
            if len(jacobian) == 1:
                return np.zeros(1, bool)
            arrays = (points, jacobian, step, shown)
            return np.concatenate(
                [_near_by_pinv(*(x[k : k + 1] for x in arrays), drawn) for k in range(len(points))]
            )
        expected = points + np.einsum("ki,kij->kj", step, inverse)
        threshold = _threshold(spread, np.linalg.norm(step, axis=1), drawn)
        return np.linalg.norm(shown - expected, axis=1) <= threshold


#: A cell's corners (row and column steps) in the order :func:`mesh_map` takes them.
_ROWS, _COLUMNS = np.array([0, 0, 1, 1]), np.array([0, 1, 0, 1])


def mesh_keypoints(
    lattice: MeshLattice,
    vertices: np.ndarray,
    points: np.ndarray,
    moved: np.ndarray | None,
    images: np.ndarray | None = None,
    folded: np.ndarray | None = None,
    nearest: tuple[int, tuple[float, float]] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Keypoints through the deformed meshes of ``lattice`` (``vertices``: f at its points,
    (N, rows, columns, 2), or (rows, columns, 2) for one image): (P, 2) output points (the
    mesh's own map, or ``moved``, points moved otherwise, where given) and (P,) bool,
    inside the lattice's domain and not covered by a triangle earlier in the fill's scan
    order (cell row, column, then triangle (00, 10, 11) before (00, 11, 01)) than the
    keypoint's own: where cells fold, the first shows (``warp/cells.comp.glsl``). ``images``:
    (P,) the image of each point (default: all of image 0). ``folded``: (N,) bool, the
    meshes not shown to be embeddings (``~embedded(vertices)``) where the caller has it.
    ``nearest``: (every, origin): every ``every``-th point (a keypoint, each followed by its
    footprint's edge) is valid only where the fill draws the output pixel nearest it
    (:func:`_nearest_drawn`; ``origin``: the canvas's)."""
    count = len(points)
    if count == 0:
        return np.zeros((0, 2)), np.zeros(0, bool)
    if vertices.ndim == 3:
        vertices = vertices[None]
    image = np.zeros(count, np.int64) if images is None else images
    index, low, high, inside = _cells(lattice, points)
    col, row = index[:, 0], index[:, 1]
    deformed = _cell_vertices(vertices, image, row, col)
    out, _, _, _, upper = _triangle_map(low, high, deformed, points)
    if moved is not None:
        out = moved
    own = (row * (vertices.shape[2] - 1) + col) * 2 + upper
    hidden = np.zeros(count, bool)
    folded = ~embedded(vertices) if folded is None else np.asarray(folded, bool)
    tested = np.flatnonzero(folded[image])  # an embedding hides no point
    if len(tested):  # nor does a fold far from a point
        tested = tested[fold_candidates(vertices, image[tested], out[tested])]
    needed = np.zeros(len(folded), bool)
    needed[image[tested]] = True
    meshes = np.flatnonzero(needed)
    which = (np.cumsum(needed) - 1)[image[tested]]  # the place of each in ``meshes``
    # blocks of points bound the pairs (point, tile) they make whatever the number
    # of keypoints (each point's answer is its own, so the blocks change none)
    block = max(1, PAIRS_BLOCK // boxes_per_mesh(vertices))
    boxes = tile_boxes(vertices, meshes) if len(tested) else ([], [])
    for start in range(0, len(tested), block):
        part = tested[start : start + block]
        hidden[part] = covered_earlier(
            vertices, meshes, boxes, which[start : start + block], out[part], own[part]
        )
    valid = inside & ~hidden
    if nearest is not None:
        every, origin = nearest
        at = np.flatnonzero(valid[::every]) * every
        triangle = upper[at].astype(np.int64)
        valid[at] = _nearest_drawn(vertices, image[at], row[at], col[at], triangle, out[at], origin)
    return out, valid


def _nearest_drawn(vertices, images, row, col, triangle, out, origin) -> np.ndarray:
    """(P,) bool: the fill draws the output pixel nearest each keypoint, a triangle of its
    deformed mesh holding that pixel's centre. A keypoint inside the mesh's domain can land
    within half a pixel of the warped image's edge past the last pixel centre drawn: its
    nearest pixel then shows the background, as with the methods that test the pixel
    itself. ``vertices`` (N, rows, columns, 2) as :func:`mesh_keypoints` takes them,
    ``images``, ``row``, ``col`` and ``triangle`` (P,) each keypoint's mesh, cell and
    triangle there, ``out`` (P, 2) where it lands, ``origin`` the canvas's: output pixel
    (i, j) shows the deformed plane's point ``origin`` + (i, j)."""
    centre = np.empty((len(out), 2))
    for axis in (0, 1):
        centre[:, axis] = np.rint(out[:, axis] - origin[axis]) + origin[axis]
    drawn = _walk(vertices, images, row, col, triangle, centre)
    rest = np.flatnonzero(~drawn)
    if len(rest):  # any triangle of the mesh: the tiles, as for hidden points
        meshes, which = np.unique(images[rest], return_inverse=True)
        boxes = tile_boxes(vertices, meshes)
        anywhere = np.full(len(rest), np.iinfo(np.int64).max)
        block = max(1, PAIRS_BLOCK // boxes_per_mesh(vertices))
        for start in range(0, len(rest), block):
            part = slice(start, start + block)
            drawn[rest[part]] = covered_earlier(
                vertices, meshes, boxes, which[part], centre[rest[part]], anywhere[part]
            )
    return drawn


#: A cell's triangles (00, 10, 11) and (00, 11, 01) as corners of :func:`_cell_vertices`.
_TRIANGLES = np.array([[0, 1, 3], [0, 3, 2]])
#: Across each edge of each triangle (its corners' order): row step, column step and
#: triangle of the neighbour that shares it.
_ACROSS = np.array(
    [[[-1, 0, 1], [0, 1, 1], [0, 0, 1]], [[0, 0, 0], [1, 0, 0], [0, -1, 0]]], np.int64
)
#: Triangles :func:`_walk` steps through toward a point before it leaves it to the tiles.
_WALK_STEPS = 4


def _walk(vertices, images, row, col, triangle, targets) -> np.ndarray:
    """(P,) bool: found in a triangle of its deformed mesh (edges included), each of the
    (P, 2) ``targets``, by a walk from triangle ``triangle`` of cell (``row``, ``col``)
    across the edge it lies furthest beyond, for :data:`_WALK_STEPS` triangles at most;
    False where the walk leaves the mesh, meets a flat triangle or stops (the tiles
    decide there)."""
    _, rows, columns, _ = vertices.shape
    found = np.zeros(len(targets), bool)
    todo = np.arange(len(targets))
    for _ in range(_WALK_STEPS):
        corners = _cell_vertices(vertices, images[todo], row, col)  # (4, 2, k)
        ends, lane = _TRIANGLES[triangle], np.arange(len(todo))  # (k, 3) corners
        x = [corners[ends[:, k], 0, lane] for k in range(3)]
        y = [corners[ends[:, k], 1, lane] for k in range(3)]
        sign = np.sign((x[1] - x[0]) * (y[2] - y[0]) - (y[1] - y[0]) * (x[2] - x[0]))
        qx, qy = targets[todo, 0], targets[todo, 1]
        edges = np.stack(
            [
                ((x[b] - x[a]) * (qy - y[a]) - (y[b] - y[a]) * (qx - x[a])) * sign
                for a, b in ((0, 1), (1, 2), (2, 0))
            ],
            axis=1,
        )
        inside = (sign != 0) & (edges >= 0).all(axis=1)
        found[todo[inside]] = True
        beyond = edges.argmin(axis=1)
        step = _ACROSS[triangle, beyond]  # (k, 3)
        row, col, triangle = row + step[:, 0], col + step[:, 1], step[:, 2]
        going = ~inside & (sign != 0) & (row >= 0) & (row < rows - 1)
        going &= (col >= 0) & (col < columns - 1)
        todo, row, col, triangle = todo[going], row[going], col[going], triangle[going]
        if not len(todo):
            break
    return found


def _cell_vertices(vertices, image: np.ndarray, row: np.ndarray, col: np.ndarray) -> np.ndarray:
    """(4, 2, P) float64: the deformed corners 00, 10, 01, 11 of cell (``row``, ``col``) of
    mesh ``image`` (``vertices``: (N, rows, columns, 2), an array or :class:`MeshVertices`),
    gathered by one flat index, each corner's x and y a contiguous (P,) array."""
    _, rows, columns, _ = vertices.shape
    flat = (image * rows + row) * columns + col
    at = (_ROWS * columns + _COLUMNS)[:, None] + flat  # (4, P)
    if isinstance(vertices, MeshVertices):
        return vertices.flat_points(at, image)
    flat = np.asarray(vertices, np.float64).reshape(-1)  # x and y interleaved (flat_points)
    return np.stack([np.take(flat, 2 * at + axis) for axis in (0, 1)], axis=1)
