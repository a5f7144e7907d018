"""The error-bounded adaptive mesh: a quadtree of cells over the corner lattice, refined
where the piecewise linear mesh would miss f's inverse by more than a tolerance.

How it is built (:func:`build_adaptive`), level by level, numpy bookkeeping and one batched
evaluation of f per level (``evaluate``, on the GPU in the pipeline):

1. the roots are the cells of the corner lattice at :data:`ROOT_STEP` pixels (with the
   margin of a border mode), f evaluated at their corners;
2. for every cell of the level, f at its four edge mid-points and its centre; the cell's
   *miss* is the largest distance between f there and the bilinear prediction from the
   corners, an estimate (for smooth f) of the interpolation error of the cell. A miss in the
   output is a source-space error of at most miss / sigma_min, sigma_min the smallest
   singular value of f's Jacobian (estimated on the cell's four quarters);
3. cells whose error exceeds the tolerance are split into four (their corners, mid-points and
   centre are evaluated already), down to 1 px cells, and below (to :data:`MIN_SIZE`) where
   the map stretches (largest singular value > 1: a 1 px cell there covers more than one
   output pixel);
4. each leaf is drawn as a fan of triangles around its centre through every vertex on its
   boundary: its corners and mid-points and those of finer neighbours on its edges (hanging
   vertices). Two leaves sharing an edge then share exactly the same f-evaluated vertices on
   it: no cracks. The fan through the leaf's nine points interpolates f about four times
   better than the bilinear prediction the test measured (the error of linear interpolation
   falls with the square of the size), which is the guarantee's margin.

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

__all__ = [
    "MIN_SIZE",
    "ROOT_STEP",
    "AdaptiveMesh",
    "build_adaptive",
    "check_adaptive",
    "check_tolerance",
]

#: Side of the root cells (pixels): coarse enough that smooth regions stay a few cells, fine
#: enough that the mid-point test sees f's curvature (a 16 px cell's miss is ~64x a 2 px one's).
ROOT_STEP = 16
#: The smallest cell side (pixels), where the map stretches by 4 or more.
MIN_SIZE = 0.25
#: Integer units per pixel of the vertices' exact keys (dyadic coordinates), fewer for huge
#: lattices so that a key stays within int64.
_UNITS = 1024

Evaluate = Callable[[np.ndarray], np.ndarray]


def check_tolerance(tolerance: object) -> float:
    """``tolerance`` (pixels) as a float: ``TypeError`` if it is not a real number,
    ``ValueError`` unless it is finite and > 0."""
    if isinstance(tolerance, (bool, np.bool_)) or not isinstance(
        tolerance, (int, float, np.integer, np.floating)
    ):
        raise TypeError(f"tolerance must be a number of pixels > 0, got {tolerance!r}")
    value = float(tolerance)
    if not math.isfinite(value) or value <= 0.0:
        raise ValueError(f"tolerance must be finite and > 0 (pixels), got {tolerance!r}")
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
    """The adaptive mesh of an image: ``source`` (V, 2) float64 vertices (image pixels, x, y),
    ``deformed`` (V, 2) float64 f at them, ``triangles`` (T, 3) uint32 indices into both in
    scan order (the leaves' order, each leaf's fan together: where triangles overlap the
    first shows), ``leaves`` (L, 4) float64 cells
    (x0, y0, x1, y1) in scan order with ``estimate`` (L,) their estimated error (pixels of
    the source; of the cell's coarse test, before the fan's finer interpolation), and
    ``levels``, the number of refinement levels evaluated."""

    source: np.ndarray
    deformed: np.ndarray
    triangles: np.ndarray
    leaves: np.ndarray
    estimate: np.ndarray
    levels: int


class _Vertices:
    """Every evaluated vertex: integer keys (x, y in 1/units px from the lattice's origin),
    source points and f, appended level by level."""

    def __init__(self, origin: tuple[float, float], units: int) -> None:
        self.origin = np.asarray(origin, dtype=np.float64)
        self.units = units
        self.keys: list[np.ndarray] = []
        self.f: list[np.ndarray] = []
        self.count = 0

    def add(self, keys: np.ndarray, evaluate: Evaluate) -> np.ndarray:
        """Evaluate f at the distinct ``keys`` ((..., 2) int64); their vertex ids."""
        flat = keys.reshape(-1, 2)
        width = int(flat[:, 1].max()) + 1
        unique, inverse = np.unique(flat[:, 0] * width + flat[:, 1], return_inverse=True)
        new = np.stack([unique // width, unique % width], axis=-1)
        self.keys.append(new)
        self.f.append(evaluate(self.origin + new / self.units))
        ids = self.count + inverse.reshape(keys.shape[:-1])
        self.count += len(new)
        return ids


def _singular_values(j: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(smallest, largest) singular values of 2x2 matrices ``j`` (..., 2, 2), closed form."""
    a, b, c, d = j[..., 0, 0], j[..., 0, 1], j[..., 1, 0], j[..., 1, 1]
    q = np.hypot((a + d) / 2, (c - b) / 2)
    r = np.hypot((a - d) / 2, (c + b) / 2)
    return np.abs(q - r), q + r


def _jacobians(f00, f10, f01, f11, w, h) -> np.ndarray:
    """The bilinear cell's mean Jacobian (..., 2, 2): columns d/dx and d/dy."""
    dx = (f10 - f00 + f11 - f01) / (2 * w[:, None])
    dy = (f01 - f00 + f11 - f10) / (2 * h[:, None])
    return np.stack([dx, dy], axis=-1)


def _test(f: np.ndarray, corners: np.ndarray, mids: np.ndarray, w, h):
    """(error, sigma_max) of each cell: a bound on the source-space error of its fan of
    triangles through its nine points, and its largest stretch.

    f's second derivatives come from second differences of the nine points (the largest of
    the three rows, the three columns and the five cross differences: the whole cell's and
    its quarters'). For a quadratic with Hessian H, linear interpolation on a triangle errs by
    at most max |d' H d| / 6 over its edges d; the fan's longest edges are the half
    diagonals (w/2, h/2). (The bilinear mid-point miss alone would be blind to f_xy, which
    bilinear cells reproduce and triangles do not.) That output-space error over sigma_min,
    the smallest singular value of f's Jacobian on the cell's quarters, bounds the distance
    from the source point to f's inverse, to first order."""
    f00, f10, f01, f11 = (f[corners[:, k]] for k in range(4))
    top, bottom, left, right, centre = (f[mids[:, k]] for k in range(5))
    hw, hh = (w / 2)[:, None], (h / 2)[:, None]
    fxx = np.maximum.reduce(
        [
            np.abs(a - 2 * b + c)
            for a, b, c in ((f00, top, f10), (left, centre, right), (f01, bottom, f11))
        ]
    )  # times hw^2
    fyy = np.maximum.reduce(
        [
            np.abs(a - 2 * b + c)
            for a, b, c in ((f00, left, f01), (top, centre, bottom), (f10, right, f11))
        ]
    )  # times hh^2
    fxy = np.maximum.reduce(
        [
            np.abs(f11 - f10 - f01 + f00) / 4,
            np.abs(centre - top - left + f00),
            np.abs(right - f10 - centre + top),
            np.abs(bottom - centre - f01 + left),
            np.abs(f11 - right - bottom + centre),
        ]
    )  # times hw hh
    del hw, hh  # the differences carry the cell's scale already
    out = np.sqrt(((fxx + 2 * fxy + fyy) ** 2).sum(axis=-1)) / 6
    quarters = np.stack(
        [
            _jacobians(f00, top, left, centre, w / 2, h / 2),
            _jacobians(top, f10, centre, right, w / 2, h / 2),
            _jacobians(left, centre, f01, bottom, w / 2, h / 2),
            _jacobians(centre, right, bottom, f11, w / 2, h / 2),
        ]
    )
    low, high = _singular_values(quarters)
    low = low.min(axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        error = np.where(low > 0, out / low, np.inf)
    error[~np.isfinite(out)] = np.inf
    return error, high.max(axis=0)


def build_adaptive(
    evaluate: Evaluate,
    lattice: MeshLattice,
    tolerance: float,
    *,
    min_size: float = MIN_SIZE,
) -> AdaptiveMesh:
    """The adaptive mesh over the cells of ``lattice`` (a corner lattice: its step is the
    roots' side), refined until each leaf's estimated source-space error is within
    ``tolerance`` pixels or its side reaches 1 px (``min_size`` where the map stretches).
    ``evaluate`` maps (K, 2) float64 points to f at them, (K, 2) float64."""
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
    ids = vertices.add(grid, evaluate)
    f = vertices.f[0]
    box = np.stack(
        np.broadcast_arrays(grid[:-1, :-1, 0], grid[:-1, :-1, 1], grid[1:, 1:, 0], grid[1:, 1:, 1]),
        axis=-1,
    ).reshape(-1, 4)
    corners = np.stack([ids[:-1, :-1], ids[:-1, 1:], ids[1:, :-1], ids[1:, 1:]], -1)
    corners = corners.reshape(-1, 4)
    leaves: list[tuple[np.ndarray, ...]] = []
    levels = 0
    smallest = max(1, round(min_size * units))
    while len(box):
        levels += 1
        x0, y0, x1, y1 = box.T
        xm, ym = (x0 + x1) // 2, (y0 + y1) // 2
        mids = vertices.add(
            np.stack(
                [
                    np.stack([xm, y0], -1),
                    np.stack([xm, y1], -1),
                    np.stack([x0, ym], -1),
                    np.stack([x1, ym], -1),
                    np.stack([xm, ym], -1),
                ],
                axis=1,
            ),
            evaluate,
        )
        f = np.concatenate([f, vertices.f[-1]])
        w, h = (x1 - x0) / units, (y1 - y0) / units
        error, stretch = _test(f, corners, mids, w, h)
        side = np.maximum(x1 - x0, y1 - y0)
        # below 1 px only where a pixel's cell covers more than one output pixel
        limit = np.maximum(smallest, np.minimum(units, units / np.maximum(stretch, 1e-12)))
        split = (
            (error > tolerance)
            & (side > limit)
            & ((x1 - x0) % 2 == 0)
            & ((y1 - y0) % 2 == 0)
            & (np.minimum(x1 - x0, y1 - y0) >= 2)
        )
        keep = ~split
        leaves.append((box[keep], corners[keep], mids[keep], error[keep]))
        c, m, b = corners[split], mids[split], box[split]
        t_, b_, l_, r_, c_ = (m[:, k] for k in range(5))
        corners = np.concatenate(
            [
                np.stack([c[:, 0], t_, l_, c_], -1),
                np.stack([t_, c[:, 1], c_, r_], -1),
                np.stack([l_, c_, c[:, 2], b_], -1),
                np.stack([c_, r_, b_, c[:, 3]], -1),
            ]
        )
        bx0, by0, bx1, by1 = b.T
        bxm, bym = (bx0 + bx1) // 2, (by0 + by1) // 2
        box = np.concatenate(
            [
                np.stack([bx0, by0, bxm, bym], -1),
                np.stack([bxm, by0, bx1, bym], -1),
                np.stack([bx0, bym, bxm, by1], -1),
                np.stack([bxm, bym, bx1, by1], -1),
            ]
        )
    keys = np.concatenate(vertices.keys)
    return _assemble(keys, f, vertices, leaves, levels)


def _assemble(keys, f, vertices: _Vertices, leaves, levels: int) -> AdaptiveMesh:
    box = np.concatenate([part[0] for part in leaves])
    corners = np.concatenate([part[1] for part in leaves])
    mids = np.concatenate([part[2] for part in leaves])
    error = np.concatenate([part[3] for part in leaves])
    width = int(keys.max()) + 2
    order = np.argsort(box[:, 1] * width + box[:, 0], kind="stable")  # scan order
    box, corners, mids, error = box[order], corners[order], mids[order], error[order]
    triangles = _fans(keys, box, corners, mids, width)
    source = vertices.origin + keys / vertices.units
    cells = vertices.origin[[0, 1, 0, 1]] + box / vertices.units
    return AdaptiveMesh(source, f, triangles, cells, error, levels)


def _fans(keys, box, corners, mids, width: int) -> np.ndarray:
    """The triangles (T, 3) uint32 of every leaf's fan around its centre, through each
    boundary vertex (its own and finer neighbours' corners and mid-points), in the leaves'
    scan order (that of ``box``), each leaf's triangles together."""
    boundary = np.unique(np.concatenate([corners.ravel(), mids[:, :4].ravel()]))
    bx, by = keys[boundary, 0], keys[boundary, 1]
    rows = np.argsort(by * width + bx)
    row_keys, row_ids = (by * width + bx)[rows], boundary[rows]
    cols = np.argsort(bx * width + by)
    col_keys, col_ids = (bx * width + by)[cols], boundary[cols]
    x0, y0, x1, y1 = box.T
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
    triangles = np.empty((total, 3), np.uint32)
    centre = mids[:, 4]
    base = start.copy()
    for (lo, n), (_, sorted_ids, _, _) in zip(spans, edges, strict=True):
        leaf = np.repeat(np.arange(len(n)), n)
        k = np.arange(len(leaf)) - np.repeat(np.cumsum(n) - n, n)
        at = base[leaf] + k
        i = lo[leaf] + k
        triangles[at, 0] = centre[leaf]
        triangles[at, 1] = sorted_ids[i]
        triangles[at, 2] = sorted_ids[i + 1]
        base += n
    return triangles
