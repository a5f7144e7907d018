"""The error-bounded adaptive mesh: a quadtree of cells over the corner lattice, refined
where the piecewise linear mesh would miss f's inverse by more than a tolerance.

How it is built (:func:`build_adaptive`), level by level, numpy bookkeeping and one batched
evaluation of f per level (``evaluate``, on the GPU in the pipeline) and one batched test of
the level's cells (``test``: :func:`.adaptive_patch.estimate_cells` in float64, or on the GPU
where f stays, :mod:`.adaptive_cells`, in the pipeline):

1. the roots are the cells of the corner lattice at :data:`ROOT_STEP` pixels (with the
   margin of a border mode), f evaluated at their corners;
2. for every cell of the level, f on its 5 x 5 grid (quarters of its sides): the quadratic
   patch through the 3 x 3 nodes (corners, edge mid-points, centre), its *miss* the
   largest distance from f at the 16 other points; that miss times :data:`SAFETY` over the
   smallest singular value of the patch's Jacobian on the grid bounds the source-space
   error of the cell (:mod:`.adaptive_patch`);
3. cells whose error exceeds the tolerance are split into four (their grid's points are the
   children's nodes; f is evaluated at the children's test points), down to 1 px cells, and
   below (to :data:`MIN_SIZE`) where the map stretches (largest singular value > 1: a 1 px
   cell there covers more than one output pixel);
4. each leaf is drawn as a fan of triangles around its centre through every vertex on its
   boundary: its corners and mid-points and those of finer neighbours on its edges (hanging
   vertices). Two leaves sharing an edge then share exactly the same f-evaluated vertices on
   it: no cracks. The scan refines each pixel's point on the fan by a Newton step on the
   leaf's patch (``warp/adaptive.comp.glsl``), so the patch's error bound is the pixel's.

Fold-overs: the triangles come in scan order, the leaves in row-major order of their top-left
corners (row, then column), each leaf's fan together; where deformed cells overlap the first
cell in scan order shows (``warp/adaptive.comp.glsl`` keeps the first triangle per pixel), as
everywhere in glmls.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..core.mesh import MeshLattice
from .adaptive_patch import NODES, SAFETY, TEST_INDEX, TESTS, estimate_cells, lagrange

__all__ = [
    "MAX_POINTS_PER_PIXEL",
    "MIN_SIZE",
    "MIN_TOLERANCE",
    "ROOT_STEP",
    "SAFETY",
    "AdaptiveMesh",
    "CellTest",
    "build_adaptive",
    "check_adaptive",
    "check_tolerance",
    "interpolate",
]

#: Side of the root cells (pixels): coarse enough that smooth regions stay a few cells, fine
#: enough that the mid-point test sees f's curvature (a 16 px cell's miss is ~64x a 2 px one's).
ROOT_STEP = 16
#: The smallest cell side (pixels), where the map stretches by 4 or more.
MIN_SIZE = 0.25
#: The smallest tolerance (pixels): f's float32 rounding on the GPU is ~1e-4 px at 1024 px,
#: and a test that measures rounding would split cells without end.
MIN_TOLERANCE = 1e-3
#: At most this many evaluations of f per pixel of the lattice (and 65,536 more): past it
#: the build stops with ``ValueError`` instead of filling the memory (a map stretched so far
#: that every cell goes to 1/4 px).
MAX_POINTS_PER_PIXEL = 4
#: Integer units per pixel of the vertices' exact keys (dyadic coordinates), fewer for huge
#: lattices so that a key stays within int64.
_UNITS = 1024

Evaluate = Callable[[np.ndarray], np.ndarray]
#: (nodes, tests, width, height) -> (error, stretch), as :func:`.adaptive_patch.estimate_cells`
#: (whose ``fx`` and ``fy`` are then the tester's own: every point ``evaluate`` was given, in
#: order).
CellTest = Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]

# the points that split children add, on their parent's 9 x 9 grid (eighths): on its edges
# (shared with a neighbour that splits too) and inside it
_EIGHTHS = tuple((r, c) for r in range(9) for c in range(9) if r % 2 or c % 2)
_EIGHTHS_EDGE = tuple((r, c) for r, c in _EIGHTHS if r in (0, 8) or c in (0, 8))
_EIGHTHS_INSIDE = tuple((r, c) for r, c in _EIGHTHS if r not in (0, 8) and c not in (0, 8))


def check_tolerance(tolerance: object) -> float:
    """``tolerance`` (pixels) as a float: ``TypeError`` if it is not a real number,
    ``ValueError`` unless it is finite and at least :data:`MIN_TOLERANCE`."""
    if isinstance(tolerance, (bool, np.bool_)) or not isinstance(
        tolerance, (int, float, np.integer, np.floating)
    ):
        raise TypeError(f"tolerance must be a number of pixels > 0, got {tolerance!r}")
    value = float(tolerance)
    if not math.isfinite(value) or value <= 0.0:
        raise ValueError(f"tolerance must be finite and > 0 (pixels), got {tolerance!r}")
    if value < MIN_TOLERANCE:
        raise ValueError(
            f"tolerance must be at least {MIN_TOLERANCE} px (f is float32 on the GPU: finer "
            f"than that its rounding, not f, decides the cells), got {tolerance!r}"
        )
    return value


def check_adaptive(method: object, grid: object, tolerance: object) -> float | None:
    """``tolerance`` checked (None: the regular mesh at ``grid``, as before). The adaptive
    mesh chooses its own cells, so ``grid`` must stay 1 (``ValueError`` otherwise), and is
    built for ``method="quads"`` only (``ValueError`` naming the option otherwise)."""
    if tolerance is None:
        return None
    value = check_tolerance(tolerance)
    if method != "quads":
        raise ValueError(
            f"tolerance= builds the adaptive mesh of method 'quads', got method {method!r}"
        )
    if grid != 1:
        raise ValueError(
            f"grid and tolerance exclude each other (the adaptive mesh chooses its own cells): "
            f"got grid={grid!r} with tolerance={tolerance!r}"
        )
    return value


@dataclass(frozen=True)
class AdaptiveMesh:
    """The adaptive mesh of an image.

    ``source`` (V, 2) float64 vertices (image pixels, x, y) and ``deformed`` (V, 2) float64
    f at them; ``triangles`` (T, 3) uint32 indices into both in scan order (the leaves'
    order, each leaf's fan together: where triangles overlap the first shows), of positive
    area in the source, and ``triangle_leaf`` (T,) uint32 the leaf of each; ``leaves``
    (L, 4) float64 cells (x0, y0, x1, y1) in scan order, ``nodes`` (L, 9) uint32 the
    vertices of each leaf's quadratic patch (its corners, edge mid-points and centre, 3 x 3
    row by row) and ``estimate`` (L,) each leaf's error bound (pixels of the source; inf
    where it folds); ``levels``, the number of refinement levels evaluated."""

    source: np.ndarray
    deformed: np.ndarray
    triangles: np.ndarray
    triangle_leaf: np.ndarray
    leaves: np.ndarray
    nodes: np.ndarray
    estimate: np.ndarray
    levels: int


class _Vertices:
    """Every evaluated vertex: integer keys (x, y in 1/units px from the lattice's origin),
    source points and f, appended level by level."""

    def __init__(self, origin: tuple[float, float], units: int) -> None:
        self.origin = np.asarray(origin, dtype=np.float64)
        self.units = units
        self.keys: list[np.ndarray] = []
        self.fx = self.fy = np.zeros(0)  # f's coordinates apart: numpy gathers 1-D fastest
        self.count = 0

    def _append(self, f: np.ndarray) -> None:
        self.fx = np.concatenate([self.fx, f[:, 0]])
        self.fy = np.concatenate([self.fy, f[:, 1]])

    def add_lattice(self, xs: np.ndarray, ys: np.ndarray, evaluate: Evaluate) -> np.ndarray:
        """Evaluate f at the lattice of keys ``xs`` x ``ys`` (distinct, increasing); its
        vertex ids (len(ys), len(xs))."""
        new = np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2)
        self.keys.append(new)
        self._append(evaluate(self.origin + new / self.units))
        ids = self.count + np.arange(len(new)).reshape(len(ys), len(xs))
        self.count += len(new)
        return ids

    def add(self, keys: np.ndarray, evaluate: Evaluate, distinct: np.ndarray | None = None):
        """Evaluate f (in one call) at the distinct ``keys`` ((K, n, 2) int64) and at
        ``distinct`` ((K, m, 2), none of them repeated or among ``keys``); the vertex ids
        (K, n + m)."""
        flat = keys.reshape(-1, 2)
        width = int(flat[:, 1].max()) + 1
        unique, inverse = np.unique(flat[:, 0] * width + flat[:, 1], return_inverse=True)
        new = np.stack([unique // width, unique % width], axis=-1)
        ids = self.count + inverse.reshape(keys.shape[:-1])
        if distinct is not None:
            extra = distinct.reshape(-1, 2)
            own = self.count + len(new) + np.arange(len(extra)).reshape(distinct.shape[:-1])
            new = np.concatenate([new, extra])
            ids = np.concatenate([ids, own], axis=1)
        self.keys.append(new)
        self._append(evaluate(self.origin + new / self.units))
        self.count += len(new)
        return ids


def _grid_keys(box: np.ndarray, where: tuple[tuple[int, int], ...], parts: int) -> np.ndarray:
    """(K, len(where), 2) int64 keys of the points ``where`` ((row, column) in 1/parts of the
    sides) of the cells ``box`` (K, 4) (x0, y0, x1, y1, keys)."""
    x0, y0, x1, y1 = (box[:, k, None] for k in range(4))
    rows = np.array([r for r, _ in where])
    cols = np.array([c for _, c in where])
    return np.stack([x0 + (x1 - x0) * cols // parts, y0 + (y1 - y0) * rows // parts], axis=-1)


def build_adaptive(
    evaluate: Evaluate,
    lattice: MeshLattice,
    tolerance: float,
    *,
    min_size: float = MIN_SIZE,
    test: CellTest | None = None,
) -> AdaptiveMesh:
    """The adaptive mesh over the cells of ``lattice`` (a corner lattice: its step is the
    roots' side), refined until each leaf's estimated source-space error is within
    ``tolerance`` pixels or its side reaches 1 px (``min_size`` where the map stretches).
    ``evaluate`` maps (K, 2) float64 points to f at them, (K, 2) float64. ``test``: the
    cells' test (see :data:`CellTest`; vertex ids count the points given to ``evaluate``,
    from 0, in order); None: :func:`.adaptive_patch.estimate_cells` on the evaluated f."""
    xs, ys = lattice.axes
    x_origin, y_origin = lattice.origin
    span = max(xs[-1] - x_origin, ys[-1] - y_origin) + 1.0
    units = _UNITS
    while units > 8 and span * units * (span * units + 1) >= 2**62:
        units //= 2
    vertices = _Vertices((x_origin, y_origin), units)
    kx = np.rint((xs - x_origin) * units).astype(np.int64)
    ky = np.rint((ys - y_origin) * units).astype(np.int64)
    grid = np.stack(np.meshgrid(kx, ky), axis=-1)
    box = np.stack(
        np.broadcast_arrays(grid[:-1, :-1, 0], grid[:-1, :-1, 1], grid[1:, 1:, 0], grid[1:, 1:, 1]),
        axis=-1,
    ).reshape(-1, 4)
    # the roots' 5 x 5 grids make one lattice of quarter steps: evaluated without a search
    # for shared points
    fine_x, fine_y = (
        np.append(k[:-1, None] + (k[1:] - k[:-1])[:, None] * np.arange(4) // 4, k[-1])
        for k in (kx, ky)
    )
    ids = vertices.add_lattice(fine_x, fine_y, evaluate)
    rows = 4 * np.arange(len(ky) - 1)[:, None, None] + np.array([r for r, _ in NODES + TESTS])
    cols = 4 * np.arange(len(kx) - 1)[None, :, None] + np.array([c for _, c in NODES + TESTS])
    ids = ids[rows, cols].reshape(-1, 25)
    nodes, tests = ids[:, :9], ids[:, 9:]
    leaves: list[tuple[np.ndarray, ...]] = []
    levels = 0
    smallest = max(1, round(min_size * units))
    height, width = lattice.padded_shape
    budget = MAX_POINTS_PER_PIXEL * height * width + 65536
    while len(box):
        if vertices.count > budget:
            raise ValueError(
                f"tolerance {tolerance:g} px needs more than {budget:,} evaluations of f on a "
                f"{width} x {height} lattice (f stretches too far for it): use a larger "
                "tolerance, or the regular mesh (tolerance=None)"
            )
        levels += 1
        x0, y0, x1, y1 = box.T
        w, h = (x1 - x0) / units, (y1 - y0) / units
        if test is None:
            error, stretch = estimate_cells(vertices.fx, vertices.fy, nodes, tests, w, h)
        else:
            error, stretch = test(nodes, tests, w, h)
        side = np.maximum(x1 - x0, y1 - y0)
        # below 1 px only where a pixel's cell covers more than one output pixel, and not
        # where the map folds: a folded pixel has no single inverse to come closer to
        limit = np.maximum(smallest, np.minimum(units, units / np.maximum(stretch, 1e-12)))
        limit[np.isinf(error)] = units
        split = (
            (error > tolerance)
            & (side > limit)
            & ((x1 - x0) % 8 == 0)  # the children's grids are keys too
            & ((y1 - y0) % 8 == 0)
        )
        keep = ~split
        leaves.append((box[keep], nodes[keep], error[keep]))
        box, nodes, tests = _split(box[split], nodes[split], tests[split], vertices, evaluate)
    return _assemble(vertices, leaves, levels)


def _split(box, nodes, tests, vertices: _Vertices, evaluate: Evaluate):
    """The four children of each cell of ``box`` (their boxes, nodes and test points), f
    evaluated at the points they add (in one call): the cells' 9 x 9 grids in eighths."""
    if len(box) == 0:
        return box, nodes, tests
    # a neighbour that splits too shares the new points on the edges; those inside are
    # the cell's own (no search for them)
    new = vertices.add(
        _grid_keys(box, _EIGHTHS_EDGE, 8), evaluate, _grid_keys(box, _EIGHTHS_INSIDE, 8)
    )
    grid = np.empty((len(box), 9, 9), np.int64)  # each cell's 9 x 9 vertex ids
    for k, (r, c) in enumerate(NODES + TESTS):
        grid[:, 2 * r, 2 * c] = (nodes if k < 9 else tests)[:, k if k < 9 else k - 9]
    for k, (r, c) in enumerate(_EIGHTHS_EDGE + _EIGHTHS_INSIDE):
        grid[:, r, c] = new[:, k]
    x0, y0, x1, y1 = box.T
    xm, ym = (x0 + x1) // 2, (y0 + y1) // 2
    node_at = np.array([5 * r + c for r, c in NODES])
    children = []
    for i, (top, bottom) in enumerate(((y0, ym), (ym, y1))):
        for j, (left, right) in enumerate(((x0, xm), (xm, x1))):
            own = grid[:, 4 * i : 4 * i + 5, 4 * j : 4 * j + 5].reshape(-1, 25)
            children.append(
                (
                    np.stack([left, top, right, bottom], axis=-1),
                    own[:, node_at],
                    own[:, TEST_INDEX],
                )
            )
    return tuple(np.concatenate(part) for part in zip(*children, strict=True))


def _assemble(vertices: _Vertices, leaves, levels: int) -> AdaptiveMesh:
    keys = np.concatenate(vertices.keys)
    box = np.concatenate([part[0] for part in leaves])
    nodes = np.concatenate([part[1] for part in leaves])
    error = np.concatenate([part[2] for part in leaves])
    width = int(keys.max()) + 2
    order = np.argsort(box[:, 1] * width + box[:, 0], kind="stable")  # scan order
    box, nodes, error = box[order], nodes[order], error[order]
    corners = nodes[:, [0, 2, 6, 8]]
    mids = nodes[:, [1, 7, 3, 5, 4]]  # top, bottom, left, right, centre
    triangles, per_leaf = _fans(keys, box, corners, mids, width)
    triangle_leaf = np.repeat(np.arange(len(box), dtype=np.uint32), per_leaf)
    # only the vertices of the triangles (the patches' nodes are among them): the test
    # points were for the build
    used = np.zeros(len(keys), bool)
    used[triangles.ravel()] = True
    used[nodes.ravel()] = True
    renumber = (np.cumsum(used) - 1).astype(np.uint32)
    source = vertices.origin + keys[used] / vertices.units
    cells = vertices.origin[[0, 1, 0, 1]] + box / vertices.units
    return AdaptiveMesh(
        source,
        np.stack([vertices.fx[used], vertices.fy[used]], axis=-1),
        renumber[triangles],
        triangle_leaf,
        cells,
        renumber[nodes],
        error,
        levels,
    )


def _fans(keys, box, corners, mids, width: int) -> tuple[np.ndarray, np.ndarray]:
    """The triangles (T, 3) uint32 of every leaf's fan around its centre, through each
    boundary vertex (its own and finer neighbours' corners and mid-points), in the leaves'
    scan order (that of ``box``), each leaf's triangles together, all of positive area in
    the source (x right, y down); and how many each leaf has."""
    on_edges = np.zeros(len(keys), bool)  # a mask, not np.unique: no sort
    on_edges[corners.ravel()] = True
    on_edges[mids[:, :4].ravel()] = True
    boundary = np.flatnonzero(on_edges)
    # 1-D arrays throughout: numpy gathers and computes on contiguous ones fastest
    bx = np.ascontiguousarray(keys[:, 0])[boundary]
    by = np.ascontiguousarray(keys[:, 1])[boundary]
    row_keys = by * width + bx
    rows = np.argsort(row_keys)
    row_keys, row_ids = row_keys[rows], boundary[rows]
    col_keys = bx * width + by
    cols = np.argsort(col_keys)
    col_keys, col_ids = col_keys[cols], boundary[cols]
    x0, y0, x1, y1 = (np.ascontiguousarray(box[:, k]) for k in range(4))
    edges = (  # sorted keys and ids, (first, last) key of each leaf's edge
        (row_keys, row_ids, y0 * width + x0, y0 * width + x1),
        (col_keys, col_ids, x1 * width + y0, x1 * width + y1),
        (row_keys, row_ids, y1 * width + x0, y1 * width + x1),
        (col_keys, col_ids, x0 * width + y0, x0 * width + y1),
    )
    spans = []
    for sorted_keys, _, first, last in edges:
        lo = np.searchsorted(sorted_keys, first, side="left")
        hi = np.searchsorted(sorted_keys, last, side="right")
        spans.append((lo, hi - lo - 1))  # segments on the edge
    counts = np.stack([n for _, n in spans], axis=-1)  # (L, 4)
    per_leaf = counts.sum(axis=1)
    start = np.cumsum(per_leaf) - per_leaf
    total = int(per_leaf.sum())
    columns = [np.empty(total, np.uint32) for _ in range(3)]
    centre = np.ascontiguousarray(mids[:, 4])
    base = start.copy()
    # the top and right edges run clockwise about the centre on the screen (y down), the
    # bottom and left ones the other way: swapped, every triangle has a positive area
    for side, ((lo, n), (_, sorted_ids, _, _)) in enumerate(zip(spans, edges, strict=True)):
        leaf = np.repeat(np.arange(len(n)), n)
        k = np.arange(len(leaf)) - np.repeat(np.cumsum(n) - n, n)
        at = base[leaf] + k
        i = lo[leaf] + k
        swap = side >= 2
        columns[0][at] = centre[leaf]
        columns[1 + swap][at] = sorted_ids[i]
        columns[2 - swap][at] = sorted_ids[i + 1]
        base += n
    return np.stack(columns, axis=-1), per_leaf


def interpolate(mesh: AdaptiveMesh, values: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """``values`` ((V,) at ``mesh``'s vertices) at the pixel centres of an image of ``shape``
    (H, W), (H, W) float64: on each leaf, its quadratic patch through the values at its 3 x 3
    nodes (as the warp interpolates f). A pixel centre on an edge between leaves takes the
    leaf after it (boxes are half-open); one no leaf covers is NaN."""
    height, width = shape
    out = np.full((height, width), np.nan)
    x0, y0, x1, y1 = mesh.leaves.T
    first_col = np.clip(np.ceil(x0), 0, width).astype(np.int64)
    first_row = np.clip(np.ceil(y0), 0, height).astype(np.int64)
    cols = np.clip(np.ceil(x1), 0, width).astype(np.int64) - first_col
    rows = np.clip(np.ceil(y1), 0, height).astype(np.int64) - first_row
    counts = cols * rows  # the pixel centres of each leaf
    leaf = np.repeat(np.arange(len(counts)), counts)
    k = np.arange(len(leaf)) - np.repeat(np.cumsum(counts) - counts, counts)
    col = first_col[leaf] + k % cols[leaf]
    row = first_row[leaf] + k // cols[leaf]
    u = (col - x0[leaf]) / (x1 - x0)[leaf]
    v = (row - y0[leaf]) / (y1 - y0)[leaf]
    basis_u, basis_v = lagrange(u), lagrange(v)
    nodes = mesh.nodes[leaf]
    total = np.zeros(len(leaf))
    for a in range(3):
        for b in range(3):
            total += basis_v[a] * basis_u[b] * values[nodes[:, 3 * a + b]]
    out[row, col] = total
    return out
