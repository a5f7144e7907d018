"""The error-bounded adaptive mesh: a quadtree of cells over the corner lattice, refined
where the piecewise linear mesh would miss f's inverse by more than a tolerance.

How it is built (:func:`build_adaptive`), level by level, numpy bookkeeping and one batched
evaluation of f per level (``evaluate``, on the GPU in the pipeline) and one batched test of
the level's cells (``test``: :func:`.patch.estimate_cells` in float64, or on the GPU
where f stays, with the prediction of step 3 in the same round trip, :mod:`.cells`,
in the pipeline):

1. the roots are the cells of the corner lattice at :data:`ROOT_STEP` pixels (with the
   margin of a border mode), f evaluated at their 5 x 5 grids; cells larger than
   :data:`MAX_LEAF` (the roots) split untested;
2. for every cell of the level, f on its 5 x 5 grid (quarters of its sides): the quadratic
   patch through the 3 x 3 nodes (corners, edge mid-points, centre); its *miss*, its
   largest distance from f, taken from its misses at the 16 other points (there, and where
   the quartic through them peaks: :func:`.patch.estimate_cells`), times
   :data:`SAFETY` over the smallest singular value of the patch's Jacobian on the grid
   bounds the source-space error of the cell; where f bends sharply at or between the
   point handles (``known``), the patch is also measured there, in or next to the cell;
3. cells whose error exceeds the tolerance are split into four (their grid's points are the
   children's nodes), down to 1 px cells, and below (to :data:`MIN_SIZE`) where the map
   stretches (largest singular value > 1: a 1 px cell there covers more than one output
   pixel). Each child is first predicted (by ``test``, with its parent's test: the quartic
   through the parent's grid, :func:`.patch.predict_cells`, where f is smooth): one
   predicted within the tolerance over :data:`PREDICTION_MARGIN` is a leaf, and so is a
   child of 1 px whose patch folds (:func:`.patch.patches_fold`: its nodes are its
   parent's grid points, and a folded cell splits no further than 1 px); f is evaluated
   at the others' test points, and they are tested at the next level;
4. each leaf is drawn as a fan of triangles around its centre through every vertex on its
   boundary: its corners and those of finer neighbours on its edges (hanging vertices), and
   its edges' mid-points where its patch bends too far from the fan
   (:func:`.fans.fan_vertices`). Leaves sharing an edge share exactly its vertices:
   no cracks. The scan refines each pixel's point on the fan by a Newton step on the leaf's
   patch (``adaptive/scan.comp.glsl``), so the patch's error bound is the pixel's.

Fold-overs: the triangles come in scan order, the leaves in row-major order of their top-left
corners (row, then column), each leaf's fan together; where deformed cells overlap the first
cell in scan order shows (``adaptive/scan.comp.glsl`` keeps the first triangle per pixel), as
everywhere in glmls.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ...core.config import check_real
from ...core.mesh import MeshLattice
from .fans import fan_vertices, fans
from .patch import (
    GRID_PLACE,
    NODES,
    SAFETY,
    TESTS,
    estimate_cells,
    interpolate,
    known_errors,
    leaf_powers,
    patches_fold,
)

__all__ = [
    "MAX_LEAF",
    "MAX_POINTS_PER_PIXEL",
    "MIN_SIZE",
    "MIN_TOLERANCE",
    "PREDICTION_MARGIN",
    "ROOT_STEP",
    "SAFETY",
    "AdaptiveMesh",
    "CellTest",
    "build_adaptive",
    "check_adaptive",
    "check_tolerance",
    "interpolate",
]

#: Side of the largest leaves (pixels): coarse enough that smooth regions stay a few cells,
#: fine enough that the test's 16 samples see f's curvature (a 16 px cell's miss is ~64x a
#: 2 px one's) and the scan's Newton step from the fan's linear guess lands within
#: thousandths of a pixel.
MAX_LEAF = 16
#: Side of the root cells (pixels): twice :data:`MAX_LEAF`, never leaves themselves. Their
#: 5 x 5 grids (a quarter as many evaluations of f as grids at :data:`MAX_LEAF`) predict
#: their children, most of which need no evaluation of their own (:data:`PREDICTION_MARGIN`).
ROOT_STEP = 2 * MAX_LEAF
#: A split cell's child is a leaf without evaluating f at its test points where its error
#: predicted from the parent's grid (:func:`.patch.predict_cells`, where f is smooth)
#: is within the tolerance over this margin. (At 1, the quartic's prediction let errors up to
#: 1.45x the tolerance through on idw alpha 2; at 2, every tested map kept the errors of
#: the full test.)
PREDICTION_MARGIN = 2.0
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
#: (nodes, tests, width, height, centres, whole) of a level's cells -> (error, stretch) of
#: each, (K,), as :func:`.patch.estimate_cells` (whose ``fx`` and ``fy`` are then the
#: tester's own: every point ``evaluate`` was given, in order), and (error, stretch) of its
#: four children, (K, 4), as :func:`.patch.predict_cells` (an infinite error where
#: they are not predicted: f not smooth there, or the cell does not split). ``centres``
#: (K, 2): the cells' centres in pixels; ``whole`` (K,) bool: the cells that split untested
#: (their own error is not used).
CellTest = Callable[
    [np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
]

# A split cell's 9 x 9 grid (eighths of its sides), as flat places 9 * row + column: the
# 5 x 5 grid it had (its nodes, then its test points), and the points it adds, on its
# right, bottom, left and top edges (shared with a neighbour that splits too) and inside
_OLD = np.array([18 * r + 2 * c for r, c in NODES + TESTS])
_RIGHT_FLAT = np.array([9 * r + 8 for r in range(1, 9, 2)])
_BOTTOM_FLAT = np.array([72 + c for c in range(1, 9, 2)])
_LEFT_FLAT = np.array([9 * r for r in range(1, 9, 2)])
_TOP_FLAT = np.array(list(range(1, 9, 2)))
_INSIDE_FLAT = np.array([9 * r + c for r in range(1, 8) for c in range(1, 8) if r % 2 or c % 2])
_NEW_FLAT = np.concatenate([_RIGHT_FLAT, _BOTTOM_FLAT, _LEFT_FLAT, _TOP_FLAT, _INSIDE_FLAT])
# the new points' rows and columns on the 9 x 9 grid (eighths of the cell's sides)
_NEW_ROW, _NEW_COL = np.divmod(_NEW_FLAT, 9)
# each child's nodes and test points on the 9 x 9 grid, (4, 9) and (4, 16): children
# (0, 0), (0, 1), (1, 0), (1, 1) (row, then column)
_CHILD_NODES, _CHILD_TESTS = (
    np.array([[9 * (4 * i + r) + 4 * j + c for r, c in where] for i in (0, 1) for j in (0, 1)])
    for where in (NODES, TESTS)
)
_NEEDS = np.array(
    [np.isin(_NEW_FLAT, _CHILD_TESTS[[c for c in range(4) if bits >> c & 1]]) for bits in range(16)]
)
# each child's nodes among its cell's nodes and test points (their columns side by side), (4, 9)
_CHILD_NODES_OF_CELL = np.argsort(GRID_PLACE)[
    [[5 * (2 * i + r // 2) + 2 * j + c // 2 for r, c in NODES] for i in (0, 1) for j in (0, 1)]
]
# the new points' slots on the right, bottom, left and top edges (shared with neighbours)
_RIGHT, _BOTTOM, _LEFT, _TOP = (slice(4 * k, 4 * k + 4) for k in range(4))


def check_tolerance(tolerance: object) -> float:
    """``tolerance`` (pixels) as a float, a real option
    (:func:`~glmls.core.config.check_real`): ``TypeError`` if it is not a real number,
    ``ValueError`` unless it is finite and at least :data:`MIN_TOLERANCE`."""
    what = "a number of pixels, finite and > 0"
    value = check_real("tolerance", tolerance, low=0, low_open=True, what=what)
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
    where it folds; predicted where the leaf was accepted on its prediction); ``levels``,
    the number of refinement levels evaluated."""

    source: np.ndarray
    deformed: np.ndarray
    triangles: np.ndarray
    triangle_leaf: np.ndarray
    leaves: np.ndarray
    nodes: np.ndarray
    estimate: np.ndarray
    levels: int

    @functools.cached_property
    def powers(self) -> np.ndarray:
        """Each leaf's patch in powers, (2, L, 8), as :func:`.patch.leaf_powers`
        (derived, not a field: a mesh from dataclasses.replace works its own out)."""
        return leaf_powers(self.nodes, self.deformed)


class _Vertices:
    """Every evaluated vertex: integer keys (x, y in 1/units px from the lattice's origin),
    source points and f, appended level by level."""

    def __init__(self, origin: tuple[float, float], units: int) -> None:
        self.origin = np.asarray(origin, dtype=np.float64)
        self.units = units
        self.keys: list[np.ndarray] = []
        self._f: list[np.ndarray] = []  # per level, joined when read: no copy per level
        self._joined = 0  # how many of them the last join covered
        self._xy = (np.zeros(0), np.zeros(0))
        self.count = 0

    def f(self) -> np.ndarray:
        """f at every vertex, (count, 2) float64."""
        if len(self._f) > 1:
            self._f = [np.concatenate(self._f)]
        return self._f[0] if self._f else np.zeros((0, 2))

    def f_apart(self) -> tuple[np.ndarray, np.ndarray]:
        """f's x and y at every vertex, (count,) float64 each (numpy gathers 1-D fastest)."""
        if self._joined != self.count:
            f = self.f()
            self._xy = (np.ascontiguousarray(f[:, 0]), np.ascontiguousarray(f[:, 1]))
            self._joined = self.count
        return self._xy

    def add_lattice(self, xs: np.ndarray, ys: np.ndarray, evaluate: Evaluate) -> np.ndarray:
        """Evaluate f at the lattice of keys ``xs`` x ``ys`` (distinct, increasing); its
        vertex ids (len(ys), len(xs))."""
        new = np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2)
        return self.add(new, evaluate).reshape(len(ys), len(xs))

    def points(self, keys: np.ndarray) -> np.ndarray:
        """The source points (pixels) of ``keys`` ((n, 2) int64), (n, 2) float64, exact
        (units is a power of 2: the product is the quotient). Column by column: numpy
        broadcasts (n, 2) against (2,) an order of magnitude slower."""
        points = np.empty(keys.shape)
        for axis in (0, 1):
            np.multiply(keys[:, axis], 1.0 / self.units, out=points[:, axis])
            points[:, axis] += self.origin[axis]
        return points

    def add(self, keys: np.ndarray, evaluate: Evaluate) -> np.ndarray:
        """Evaluate f (in one call) at ``keys`` ((n, 2) int64, none of them evaluated
        before, none repeated); their vertex ids (n,)."""
        self.keys.append(keys)
        self._f.append(evaluate(self.points(keys)))
        ids = self.count + np.arange(len(keys))
        self.count += len(keys)
        return ids


def build_adaptive(
    evaluate: Evaluate,
    lattice: MeshLattice,
    tolerance: float,
    *,
    min_size: float = MIN_SIZE,
    test: CellTest | None = None,
    max_leaf: float = MAX_LEAF,
    known: tuple[np.ndarray, np.ndarray] | None = None,
) -> AdaptiveMesh:
    """The adaptive mesh over the cells of ``lattice`` (a corner lattice: its step is the
    roots' side), refined until each leaf's estimated source-space error is within
    ``tolerance`` pixels or its side reaches 1 px (``min_size`` where the map stretches);
    cells wider or taller than ``max_leaf`` pixels are always split. ``evaluate`` maps (K, 2)
    float64 points to f at them, (K, 2) float64. ``test``: the cells' test and their
    children's prediction (see :data:`CellTest`; vertex ids count the points given to
    ``evaluate``, from 0, in order): a child predicted within ``tolerance /
    PREDICTION_MARGIN`` is a leaf, and f is not evaluated at its test points; None:
    :func:`.patch.estimate_cells` on the evaluated f, every child tested. With
    either, a child of 1 px whose patch folds is a leaf untested (its bound is infinite
    whatever f is at its test points). ``known``: (points (N, 2), f at them (N, 2)), pixels,
    where f may bend more sharply than a cell's test points show (its cusps at the point
    handles, its turns between close ones: :func:`.cells.known_points`): a cell
    that passes its test is also measured at those in reach of it
    (:func:`.patch.known_errors`)."""
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
    known_keys = None  # the known points in the cells' units, sorted by x, and f there
    if known is not None:
        keys = (np.asarray(known[0], np.float64) - vertices.origin) * units
        order = np.argsort(keys[:, 0], kind="stable")
        known_keys = (keys[order], np.asarray(known[1], np.float64)[order])
    rows = 4 * np.arange(len(ky) - 1)[:, None, None] + np.array([r for r, _ in NODES + TESTS])
    cols = 4 * np.arange(len(kx) - 1)[None, :, None] + np.array([c for _, c in NODES + TESTS])
    ids = ids[rows, cols].reshape(-1, 25)
    nodes, tests = ids[:, :9], ids[:, 9:]
    leaves: list[tuple[np.ndarray, ...]] = []
    levels = 0
    smallest = max(1, round(min_size * units))
    largest = max_leaf * units
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
        side = np.maximum(x1 - x0, y1 - y0)
        whole = side > largest  # larger cells split untested
        if test is None:
            error, stretch = np.full(len(box), np.inf), np.zeros(len(box))
            tested = np.flatnonzero(~whole)
            cells = (nodes[tested], tests[tested], w[tested], h[tested])
            error[tested], stretch[tested] = estimate_cells(*vertices.f_apart(), *cells)
            guess = np.full((len(box), 4), np.inf)
        else:
            centres = vertices.origin + (box[:, :2] + box[:, 2:]) / (2 * units)
            error, stretch, guess, _ = test(nodes, tests, w, h, centres, whole)
            error = np.where(whole, np.inf, error)
            stretch = np.where(whole, 0.0, stretch)
        if known_keys is not None:  # only where the test passes: the others split anyway
            passed = np.flatnonzero(error <= tolerance)
            at = known_errors(*vertices.f_apart(), nodes[passed], box[passed], *known_keys)
            error[passed] = np.maximum(error[passed], at)
        # below 1 px only where a pixel's cell covers more than one output pixel, and not
        # where the map folds: a folded pixel has no single inverse to come closer to
        limit = np.maximum(smallest, np.minimum(units, units / np.maximum(stretch, 1e-12)))
        limit[np.isinf(error)] = units
        # sides of multiples of 8 units: the children's grids are keys too
        split = (error > tolerance) & (side > limit) & ((x1 - x0) % 8 == 0) & ((y1 - y0) % 8 == 0)
        leaves.append(_rows(~split, box, nodes, error))
        box, nodes, tests, guess = _rows(split, box, nodes, tests, guess)
        accepted = guess * PREDICTION_MARGIN <= tolerance  # (K, 4)
        # A child of 1 px (or less) whose patch folds is a leaf whatever f is at its test
        # points (its bound is infinite, and a folded cell splits to 1 px, no further): f
        # is never evaluated there. Its patch is known: its nodes are the cell's grid.
        final = np.flatnonzero(side[split] <= 2 * units)
        if len(final):
            grid = np.concatenate([nodes[final], tests[final]], axis=1)
            child_nodes = grid[:, _CHILD_NODES_OF_CELL].reshape(-1, 9)
            folds = patches_fold(*vertices.f_apart(), child_nodes).reshape(-1, 4)
            accepted[final] |= folds
            guess[final] = np.where(folds, np.inf, guess[final])
        box, nodes, tests = _split(box, nodes, tests, ~accepted, vertices, evaluate)
        if accepted.any():
            done = accepted.T.ravel()  # _split's children come child by child
            leaves.append(_rows(done, box, nodes, guess.T.ravel()))
            box, nodes, tests = _rows(~done, box, nodes, tests)
    return _assemble(vertices, leaves, levels)


def _rows(mask: np.ndarray, *arrays: np.ndarray) -> tuple[np.ndarray, ...]:
    """The rows of each of ``arrays`` where ``mask`` holds (np.compress: ~5x numpy's boolean
    indexing of rows of a few columns)."""
    return tuple(np.compress(mask, array, axis=0) for array in arrays)


def _split(box, nodes, tests, tested, vertices: _Vertices, evaluate: Evaluate):
    """The four children of each cell of ``box`` (their boxes, nodes and test points: child
    (0, 0) of every cell, then (0, 1), (1, 0), (1, 1)), f evaluated (in one call) at the
    points they add that the children ``tested`` ((K, 4) bool, bit 2 i + j: child (i, j))
    need for their test: the cells' 9 x 9 grids in eighths. The test points of untested
    children are -1."""
    count = len(box)
    if count == 0:
        return box, nodes, tests
    # each cell's 9 x 9 vertex ids, a row per place (row by row on the grid), a column per
    # cell: each place's ids contiguous (~2x numpy's speed with the cells as rows)
    grid = np.empty((81, count), np.int64)
    grid[_OLD[:9]] = nodes.T
    grid[_OLD[9:]] = tests.T
    # A neighbour across an edge that splits too (at this level: the same depth, so the
    # same edge) shares the new points on it; found by the corner both have (vertex ids
    # are unique), no search of keys. Every cell makes the points of its right and bottom
    # edges, and of its left and top ones where no splitting neighbour has made them; a
    # shared point is made where a child on either side needs it.
    left = _owner(grid[8], grid[0])  # whose top-right corner is my top-left one
    top = _owner(grid[72], grid[0])  # whose bottom-left corner is my top-left one
    with_left, with_top = np.flatnonzero(left >= 0), np.flatnonzero(top >= 0)
    bits = tested[:, 0] + 2 * tested[:, 1] + 4 * tested[:, 2] + 8 * tested[:, 3]
    need = np.take(_NEEDS, bits, axis=0)  # (K, 56)
    need[left[with_left], _RIGHT] |= need[with_left, _LEFT]
    need[top[with_top], _BOTTOM] |= need[with_top, _TOP]
    need[with_left, _LEFT] = False
    need[with_top, _TOP] = False
    new = np.full((count, len(_NEW_FLAT)), -1, np.int64)
    # the needed points' keys from 1-D gathers (numpy's fastest), the cells' sides in eighths
    # exact (a cell splits only if they are multiples of 8); their places found and filled
    # flat (~5x numpy's 2-D nonzero and scatter)
    flat = np.flatnonzero(need)
    cell = flat // len(_NEW_FLAT)
    slot = flat - len(_NEW_FLAT) * cell
    x0, y0, x1, y1 = (np.ascontiguousarray(box[:, k]) for k in range(4))
    keys = np.empty((len(cell), 2), np.int64)
    keys[:, 0] = x0[cell] + ((x1 - x0) >> 3)[cell] * _NEW_COL[slot]
    keys[:, 1] = y0[cell] + ((y1 - y0) >> 3)[cell] * _NEW_ROW[slot]
    new.ravel()[flat] = vertices.add(keys, evaluate)
    new[with_left, _LEFT] = new[left[with_left], _RIGHT]
    new[with_top, _TOP] = new[top[with_top], _BOTTOM]
    grid[_NEW_FLAT] = new.T
    xm, ym = (x0 + x1) >> 1, (y0 + y1) >> 1
    # child by child, as their nodes; each child's places taken into place (a gather of
    # all four then transposed was ~6x slower: numpy's strided copy of short rows)
    children = np.empty((4, count, 4), np.int64)
    child_nodes = np.empty((4, count, 9), np.int64)
    child_tests = np.empty((4, count, 16), np.int64)
    for k, corners in enumerate(
        ((x0, y0, xm, ym), (xm, y0, x1, ym), (x0, ym, xm, y1), (xm, ym, x1, y1))
    ):
        for side, value in enumerate(corners):
            children[k, :, side] = value
        child_nodes[k] = np.take(grid, _CHILD_NODES[k], axis=0).T
        child_tests[k] = np.take(grid, _CHILD_TESTS[k], axis=0).T
    return children.reshape(-1, 4), child_nodes.reshape(-1, 9), child_tests.reshape(-1, 16)


def _owner(corners: np.ndarray, wanted: np.ndarray) -> np.ndarray:
    """For each of ``wanted`` (vertex ids), the index of the cell whose corner (``corners``,
    one per cell, distinct) it is, or -1."""
    order = np.argsort(corners)
    ordered = corners[order]
    at = np.minimum(np.searchsorted(ordered, wanted), len(ordered) - 1)
    return np.where(ordered[at] == wanted, order[at], -1)


def _assemble(vertices: _Vertices, leaves, levels: int) -> AdaptiveMesh:
    keys = np.concatenate(vertices.keys)
    box = np.concatenate([part[0] for part in leaves])
    nodes = np.concatenate([part[1] for part in leaves])
    error = np.concatenate([part[2] for part in leaves])
    width = int(box.max()) + 2  # every vertex lies in a leaf
    order = np.argsort(box[:, 1] * width + box[:, 0], kind="stable")  # scan order
    # rows gathered by np.take and columns one at a time: numpy's fancy indexing of
    # rows of a few columns, and its strided copies, are ~5x slower
    box, nodes, error = (np.take(part, order, axis=0) for part in (box, nodes, error))
    # only the patches' nodes (the triangles' among them): the test points were the build's
    used = np.zeros(len(keys), bool)  # a mask, not np.unique: no sort
    used[nodes.ravel()] = True
    renumber = (np.cumsum(used) - 1).astype(np.uint32)
    kept = np.flatnonzero(used)  # rows gathered by index: ~2x a 2-D boolean mask's speed
    keys = np.take(keys, kept, axis=0)
    # the fans among the kept vertices, in their numbering (no gather per triangle after)
    nodes = np.take(renumber, nodes)
    deformed = np.take(vertices.f(), kept, axis=0)
    cells = vertices.origin[[0, 1, 0, 1]] + box / vertices.units
    powers = leaf_powers(nodes, deformed)
    on_edges = fan_vertices(nodes, deformed, cells, ~np.isfinite(error), powers=powers)
    triangles, triangle_leaf = fans(keys, nodes, on_edges)
    source = vertices.points(keys)
    mesh = AdaptiveMesh(source, deformed, triangles, triangle_leaf, cells, nodes, error, levels)
    mesh.__dict__["powers"] = powers  # the cached property's value, worked out already
    return mesh
