"""The quadratic patch of an adaptive mesh's cell (:mod:`.mesh`) and the cell's error
test: the Lagrange basis through the 3 x 3 nodes (corners, edge mid-points, centre) of the
cell's 5 x 5 grid in quarters of its sides, the 16 other points of that grid where the test
compares the patch with f, and the test itself in float64 (:func:`estimate_cells`, the
reference of the GPU's ``adaptive/test.comp.glsl``); and the prediction of a split
cell's four children from its grid (:func:`predict_cells`, the reference of
``adaptive/quartic.glsl``, through ``adaptive/test.comp.glsl``).
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

__all__ = [
    "GRID_PLACE",
    "KNOWN_REACH",
    "MEASURED",
    "MISS_MEASURED",
    "NODES",
    "PATCH_AT_GRID",
    "PATCH_AT_TESTS",
    "PATCH_POWERS",
    "PATCH_SLOPES",
    "POWERS",
    "PRODUCT_BLOCK",
    "QUARTIC_AT_EIGHTHS",
    "SAFETY",
    "SLOPE_X",
    "SLOPE_Y",
    "TESTS",
    "TEST_INDEX",
    "Leaves",
    "error_bound",
    "estimate_cells",
    "interpolate",
    "known_errors",
    "lagrange",
    "lagrange_slope",
    "leaf_powers",
    "matmul_in_blocks",
    "monomials",
    "patches_fold",
    "predict_cells",
    "singular_squares",
]

#: The factor between a cell's miss (:func:`estimate_cells`, taken where the patch's error
#: peaks: its sampling misses the peak by at most ~3 %) and its error bound, for what the
#: first-order bound leaves out (the Jacobian between the 25 points where its smallest
#: singular value is taken, f's orders above the quartic, the scan's one Newton step). Over
#: 5 weights x 5 maps x 2 tolerances, every leaf erring by more than 0.3 of the tolerance
#: erred by at most 1.10 x its miss over that singular value (by up to 1.57 x with the miss
#: taken at the 16 test points alone, past this factor: a quartic error peaks 4/3 above its
#: values there).
SAFETY = 1.25

#: Positions (row, column) on a cell's 5 x 5 grid, in quarters of its sides: the patch's
#: 3 x 3 nodes, row by row, and the 16 test points, row by row.
NODES = tuple((r, c) for r in (0, 2, 4) for c in (0, 2, 4))
TESTS = tuple((r, c) for r in range(5) for c in range(5) if r % 2 or c % 2)
#: The test points' places in the 5 x 5 grid, row-major.
TEST_INDEX = np.array([5 * r + c for r, c in TESTS])


def lagrange(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The quadratic Lagrange basis of the nodes at 0, 1/2 and 1, at ``t``."""
    return 2 * (t - 0.5) * (t - 1), -4 * t * (t - 1), 2 * t * (t - 0.5)


def lagrange_slope(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Its derivative."""
    return 4 * t - 3, 4 - 8 * t, 4 * t - 1


# the basis and its derivative at 0, 1/4, ..., 1 (rows)
_QUARTERS = np.linspace(0.0, 1.0, 5)
_AT_QUARTERS = np.stack(lagrange(_QUARTERS), -1)
_SLOPE_AT_QUARTERS = np.stack(lagrange_slope(_QUARTERS), -1)
#: The patch on the 5 x 5 grid (25, 9), at the test points (16, 9), and its derivatives per
#: unit of u, then of v, on the grid (50, 9): rows of points, columns of the nodes.
PATCH_AT_GRID = np.kron(_AT_QUARTERS, _AT_QUARTERS)
PATCH_AT_TESTS = PATCH_AT_GRID[TEST_INDEX]
PATCH_SLOPES = np.concatenate(
    [np.kron(_AT_QUARTERS, _SLOPE_AT_QUARTERS), np.kron(_SLOPE_AT_QUARTERS, _AT_QUARTERS)]
)


def _quartic_at(t: np.ndarray) -> np.ndarray:
    """The quartic Lagrange basis through nodes 0 .. 4 (a cell's quarters) at ``t`` (in
    quarters), (len(t), 5)."""
    nodes = np.arange(5.0)
    basis = np.ones((len(t), 5))
    for k in range(5):
        for j in range(5):
            if j != k:
                basis[:, k] *= (t - nodes[j]) / (nodes[k] - nodes[j])
    return basis


#: The quartic Lagrange basis through a cell's quarters (nodes 0 .. 4) at its eighths (rows
#: e / 2, e = 0 .. 8), (9, 5): 0 and 1 at the quarters themselves, dyadic elsewhere.
QUARTIC_AT_EIGHTHS = _quartic_at(np.arange(9) / 2.0)
#: Where across a cell (a fraction of its side) its miss is measured: its quarters (its 5 x
#: 5 grid) and the lines 0.15 of a side in from its edges. Along a line, the patch's error
#: of f's third and fourth orders, u (u - 1/2) (u - 1) (a + b u), peaks 0.15 to 0.21 of the
#: way in from either end, up to 4/3 above its values at the quarters; these positions find
#: at least 95 % of its peak along a line, and 90 % over the cell for any mix of f's third
#: and fourth orders (the quarters alone: 3/4 and 70 %; measured on 3,000 random mixes).
MEASURED = np.array([0.0, 0.15, 0.25, 0.5, 0.75, 0.85, 1.0])
MISS_MEASURED = np.kron(_quartic_at(4 * MEASURED), _quartic_at(4 * MEASURED))[:, TEST_INDEX]

#: The exponents (i, j) of a patch's powers wx^i wy^j in the order of :func:`leaf_powers`
#: (a_00, f's value at the centre node, left out).
POWERS = tuple(divmod(m, 3) for m in range(1, 9))
#: Where a_10 and a_01 are among the powers: the patch's slopes at the centre, per unit of wx
#: and of wy.
SLOPE_X, SLOPE_Y = POWERS.index((1, 0)), POWERS.index((0, 1))


def monomials(wx: float, wy: float) -> np.ndarray:
    """(8,): wx^i wy^j for the exponents :data:`POWERS`: a patch's value (less the centre's)
    at (wx, wy) is its powers (:func:`leaf_powers`) times these."""
    return np.array([wx**i * wy**j for i, j in POWERS])


def _patch_powers() -> np.ndarray:
    """(9, 8): the powers of a patch (:func:`leaf_powers`) from its values at the 3 x 3
    nodes (row by row) less the centre's: the monomials at the nodes, w = (-1/2, 0, 1/2)
    along each axis, inverted (small integers, exact in float64)."""
    # NODES in quarters of the sides: w = (place - 2) / 4
    outer = [k for k in range(9) if k != 4]
    at_nodes = np.array([monomials((c - 2) / 4, (r - 2) / 4) for r, c in np.take(NODES, outer, 0)])
    out = np.zeros((9, 8))
    out[outer] = np.rint(np.linalg.inv(at_nodes).T)
    return out


#: See :func:`_patch_powers`.
PATCH_POWERS = _patch_powers()


def leaf_powers(nodes: np.ndarray, deformed: np.ndarray) -> np.ndarray:
    """(2, L, 8) float64: each patch (``nodes`` (L, 9), the vertex ids of its 3 x 3 nodes row
    by row; ``deformed`` (V, 2), f at the vertices) less f at its centre node, in powers of
    its centred coordinates w = (s - centre) / size, in [-1/2, 1/2]^2: the coefficients
    a_ij of wx^i wy^j in the order of :data:`POWERS` (a_01 a_02 a_10 a_11 a_12 a_20 a_21
    a_22), of f's x, then of its y. Horner's rule evaluates a patch and its slopes from them
    in about a third of the operations of the Lagrange form (``adaptive/patch.glsl``
    does, at every pixel)."""
    nodes = nodes.astype(np.intp, copy=False)  # once: numpy converts other indices per gather
    out = np.empty((2, len(nodes), 8))
    for axis in (0, 1):
        f = np.take(np.ascontiguousarray(deformed[:, axis]), nodes)  # (L, 9)
        f -= f[:, 4:5]
        out[axis] = matmul_in_blocks(f, PATCH_POWERS)
    return out


#: The most multiply-adds (m n k) one matrix product of :func:`matmul_in_blocks` is given:
#: OpenBLAS computes a product of up to 2^18 on the calling thread; a larger one wakes its
#: threads, which spin on after it and take the cores from a software GPU driver (llvmpipe's
#: next pass ran 4 % slower after one (8,167 x 9) x (9 x 8) product).
PRODUCT_BLOCK = 1 << 17


def matmul_in_blocks(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a @ b`` (2-D) as products of at most :data:`PRODUCT_BLOCK` multiply-adds each, along
    the longer of ``a``'s rows and ``b``'s columns: BLAS's speed on the small matrices of the
    adaptive mesh (einsum's loops are 4-15x slower) without waking its threads."""
    (m, k), n = a.shape, b.shape[1]
    if m * n * k <= PRODUCT_BLOCK:
        return a @ b
    out = np.empty((m, n), np.result_type(a, b))
    if m >= n:
        rows = max(1, PRODUCT_BLOCK // (n * k))
        for first in range(0, m, rows):
            np.matmul(a[first : first + rows], b, out=out[first : first + rows])
    else:
        columns = max(1, PRODUCT_BLOCK // (m * k))
        for first in range(0, n, columns):
            out[:, first : first + columns] = a @ b[:, first : first + columns]
    return out


def estimate_cells(
    fx: np.ndarray,
    fy: np.ndarray,
    nodes: np.ndarray,
    tests: np.ndarray,
    width: np.ndarray,
    height: np.ndarray,
    *,
    inset: bool = True,
) -> tuple[np.ndarray, np.ndarray]:
    """(error, stretch) of each cell, (K,) float64: the source-space error of its quadratic
    patch, and its largest stretch. ``fx``, ``fy``: f at every vertex (V,); ``nodes`` (K, 9)
    and ``tests`` (K, 16) the vertex ids of each cell's 3 x 3 patch nodes and 16 test points
    (rows of its 5 x 5 grid, in quarters of its sides, row by row); ``width`` and ``height``
    (K,) its sides in pixels. The float64 reference of the GPU's test
    (``adaptive/test.comp.glsl``, through :mod:`.cells`).

    The patch (Lagrange, through the 3 x 3 ``nodes``) reproduces every x^a y^b with a, b <=
    2, so it errs by f's third and higher derivatives: along a line of the cell, by f's
    third and fourth orders, u (u - 1/2) (u - 1) (a + b u), which peaks 0.15 to 0.21 of the
    way in from either end: within 3 % of its values at u = 1/4 and 3/4 where the third
    order rules (b = 0), up to 4/3 above them where the fourth does. The patch's misses at
    the other 16 points of the 5 x 5 grid, ``tests`` (the quarter-centres, and the quarter
    points of its edges and mid-lines, where a handle just past the cell bends f most), and
    0 at the nodes, make the quartic through the grid; the cell's miss is its largest
    distance from 0 there and on the lines 0.15 of a side in from the cell's edges
    (:data:`MEASURED`, :data:`MISS_MEASURED`: at least 90 % of its peak; ``inset`` False: at
    the 16 points alone, as the children's prediction takes them, :func:`predict_cells`). That
    output-space miss times :data:`SAFETY`, over the smallest singular value of the patch's
    Jacobian on the 5 x 5 grid, bounds (to first order) the distance from a pixel's source
    point to f's inverse (:func:`error_bound`)."""
    nodes_t, tests_t = nodes.T.copy(), tests.T.copy()  # (9, K), (16, K)
    nx, ny = fx[nodes_t], fy[nodes_t]
    # in blocks: numpy's BLAS threads spin on after a large product, taking the cores from
    # the GPU driver when it is software (llvmpipe: its next passes ran up to 1.8x slower).
    # In place where it can be: these are (25, K) arrays, and fewer of them is faster.
    miss_x = matmul_in_blocks(PATCH_AT_TESTS, nx)
    miss_x -= fx[tests_t]
    miss_y = matmul_in_blocks(PATCH_AT_TESTS, ny)
    miss_y -= fy[tests_t]
    if inset:
        miss_x = matmul_in_blocks(MISS_MEASURED, miss_x)
        miss_y = matmul_in_blocks(MISS_MEASURED, miss_y)
    miss_x *= miss_x
    miss_y *= miss_y
    miss_x += miss_y
    miss = np.sqrt(miss_x.max(axis=0))
    a, b, c, d = _patch_jacobian(nx, ny)
    inv_w, inv_h = 1.0 / width, 1.0 / height
    a *= inv_w
    c *= inv_w
    b *= inv_h
    d *= inv_h
    det = a * d
    det -= b * c
    high, low = singular_squares(a, b, c, d, det)
    smallest = np.where(_turns_over(det), 0.0, np.sqrt(low.min(axis=0)))
    return error_bound(miss, smallest), np.sqrt(high.max(axis=0))


#: How far past a cell (a fraction of its side) :func:`known_errors` measures its patch at
#: a known point: a cusp just outside bends f inside (an idw alpha 0.6 map erred by 1.04x
#: the tolerance 0.6 px from a handle 0.3 px past its leaf's edge).
KNOWN_REACH = 0.25


def known_errors(
    fx: np.ndarray,
    fy: np.ndarray,
    nodes: np.ndarray,
    box: np.ndarray,
    points: np.ndarray,
    values: np.ndarray,
) -> np.ndarray:
    """Each cell's error bound at the points where f is known (``values``) and may bend more
    sharply than :func:`estimate_cells`' 16 samples show (along the segment handles, at the
    point handles or between close ones: :func:`.cells.known_points`), inside the
    cell or within :data:`KNOWN_REACH` of its sides past it; (K,) float64, 0 where it has
    none. :data:`SAFETY` x the patch's miss there over the smallest singular value of its
    Jacobian there; infinite where that Jacobian's orientation is not the one at the cell's
    centre (or f is not finite). ``fx``, ``fy``: f at every vertex; ``nodes`` (K, 9) each
    cell's patch nodes; ``box`` (K, 4) its x0, y0, x1, y1; ``points`` (N, 2), sorted by x,
    and ``values`` (N, 2), f at them, in the coordinates of ``box`` and of f."""
    out = np.zeros(len(box))
    if len(box) == 0 or len(points) == 0:
        return out
    x0, y0, x1, y1 = (np.ascontiguousarray(box[:, k], dtype=np.float64) for k in range(4))
    reach_x, reach_y = KNOWN_REACH * (x1 - x0), KNOWN_REACH * (y1 - y0)
    # the points in each cell's column (a search of the x-sorted points), then its rows
    first = np.searchsorted(points[:, 0], x0 - reach_x, "left")
    counts = np.searchsorted(points[:, 0], x1 + reach_x, "right") - first
    cell = np.repeat(np.arange(len(box)), counts)
    point = np.arange(len(cell)) - np.repeat(np.cumsum(counts) - counts, counts) + first[cell]
    py = points[point, 1]
    inside = (py >= (y0 - reach_y)[cell]) & (py <= (y1 + reach_y)[cell])
    cell, point = cell[inside], point[inside]
    if len(cell) == 0:
        return out
    width, height = (x1 - x0)[cell], (y1 - y0)[cell]
    u, v = (points[point, 0] - x0[cell]) / width, (points[point, 1] - y0[cell]) / height
    # node 3 a + b: row a of the grid (v), column b (u)
    at_u, at_v = np.stack(lagrange(u), -1), np.stack(lagrange(v), -1)
    slope_u, slope_v = np.stack(lagrange_slope(u), -1), np.stack(lagrange_slope(v), -1)
    basis = (at_v[:, :, None] * at_u[:, None, :]).reshape(-1, 9)
    along_u = (at_v[:, :, None] * slope_u[:, None, :]).reshape(-1, 9)
    along_v = (slope_v[:, :, None] * at_u[:, None, :]).reshape(-1, 9)
    ids = nodes[cell]
    nx, ny = fx[ids], fy[ids]
    miss = np.hypot((basis * nx).sum(1) - values[point, 0], (basis * ny).sum(1) - values[point, 1])
    a, c = (along_u * nx).sum(1) / width, (along_u * ny).sum(1) / width
    b, d = (along_v * nx).sum(1) / height, (along_v * ny).sum(1) / height
    det = a * d - b * c
    _, low = singular_squares(a, b, c, d, det)
    # the orientation at the centre (grid point 12), from the slopes per unit of u and v
    centre_u, centre_v = PATCH_SLOPES[12], PATCH_SLOPES[37]
    turn = (nx @ centre_u) * (ny @ centre_v) - (nx @ centre_v) * (ny @ centre_u)
    bound = error_bound(miss, np.sqrt(low))
    bound[~(det * turn > 0)] = np.inf
    np.maximum.at(out, cell, bound)
    return out


def singular_squares(
    a: np.ndarray, b: np.ndarray, c: np.ndarray, d: np.ndarray, det: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The squares of the largest and smallest singular values of the 2 x 2 matrices [[a,
    b], [c, d]] (elementwise), ``det`` = a d - b c: the sum of the squares is the Frobenius
    norm's square, their product det^2; s_max^2 from the quadratic's larger root, s_min^2 =
    det^2 / s_max^2 (no cancellation where they are far apart; NaN where both are 0)."""
    high = a * a
    high += b * b
    high += c * c
    high += d * d
    root = high * high
    low = det * det
    root -= 4 * low
    np.maximum(root, 0, out=root)
    np.sqrt(root, out=root)
    high += root
    high *= 0.5
    with np.errstate(divide="ignore", invalid="ignore"):
        low /= high
    return high, low


def _patch_jacobian(nx: np.ndarray, ny: np.ndarray) -> tuple[np.ndarray, ...]:
    """The Jacobian [[a, b], [c, d]] of the patches through nodes ``nx``, ``ny`` (9, K) on
    their 5 x 5 grids, per unit of u and v (columns d/du, d/dv): four (25, K) arrays."""
    jx = matmul_in_blocks(PATCH_SLOPES, nx)
    jy = matmul_in_blocks(PATCH_SLOPES, ny)
    return jx[:25], jx[25:], jy[:25], jy[25:]


def _turns_over(det: np.ndarray) -> np.ndarray:
    """(K,) bool: the determinants ``det`` (25, K) are not of one orientation over the
    cell (a mirror keeps one too), or are 0 or not a number somewhere: the patch folds."""
    return ~((det > 0).all(axis=0) | (det < 0).all(axis=0))


def patches_fold(fx: np.ndarray, fy: np.ndarray, nodes: np.ndarray) -> np.ndarray:
    """Whether each cell's quadratic patch turns over, (K,) bool: its Jacobian's determinant
    is not of one sign (or is 0, or not a number) on the cell's 5 x 5 grid, exactly the cells
    :func:`estimate_cells` bounds by infinity whatever f is at their test points. ``fx``,
    ``fy``: f at every vertex; ``nodes`` (K, 9) each cell's patch nodes."""
    nodes_t = nodes.T.copy()
    a, b, c, d = _patch_jacobian(fx[nodes_t], fy[nodes_t])
    det = a * d
    det -= b * c
    return _turns_over(det)


#: The places of a cell's nodes, then its tests, on its 5 x 5 grid, row by row.
GRID_PLACE = np.array([5 * r + c for r, c in NODES + TESTS])


def predict_cells(
    fx: np.ndarray,
    fy: np.ndarray,
    nodes: np.ndarray,
    tests: np.ndarray,
    width: np.ndarray,
    height: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """(error, stretch) of the four children of each cell, (K, 4) float64 each (children
    (0, 0), (0, 1), (1, 0), (1, 1): row, then column), as :func:`estimate_cells` would find
    them from f at their 5 x 5 grids, but with f there predicted: the quartic through the
    cell's own 5 x 5 grid (arguments as :func:`estimate_cells`'s). The children's nodes are
    the cell's grid points, so their Jacobians (and stretches, and whether they fold) are
    exactly their patches'; only the miss is predicted. Where f is smooth over the cell the
    quartic errs by f's fifth derivatives, the children's patches by their third: the
    prediction is close. The float64 reference of ``adaptive/quartic.glsl``."""
    count = len(nodes)
    ids = np.concatenate([nodes, tests], axis=1)
    grids = []
    for f in (fx, fy):
        grid = np.empty((count, 5, 5))
        grid.reshape(count, 25)[:, GRID_PLACE] = f[ids]
        # (9 x 9) eighths = Q grid Q^T, per cell
        grids.append(np.einsum("ea,kab,fb->kef", QUARTIC_AT_EIGHTHS, grid, QUARTIC_AT_EIGHTHS))
    errors, stretches = [], []
    place_nodes, place_tests = GRID_PLACE[:9], GRID_PLACE[9:]
    base = 25 * np.arange(count)[:, None]
    for i in (0, 1):
        for j in (0, 1):
            rows, cols = slice(4 * i, 4 * i + 5), slice(4 * j, 4 * j + 5)
            values = [np.ascontiguousarray(g[:, rows, cols]).reshape(-1) for g in grids]
            error, stretch = estimate_cells(
                *values,
                base + place_nodes,
                base + place_tests,
                width / 2,
                height / 2,
                inset=False,
            )
            errors.append(error)
            stretches.append(stretch)
    return np.stack(errors, axis=1), np.stack(stretches, axis=1)


def error_bound(miss: np.ndarray, smallest: np.ndarray) -> np.ndarray:
    """A cell's source-space error bound from its patch's ``miss`` (output pixels) and the
    smallest singular value of its Jacobian: :data:`SAFETY` x miss / smallest; infinite where
    the cell folds (``smallest`` 0: the Jacobian's orientation is not the same throughout)
    or the miss is not finite."""
    with np.errstate(divide="ignore", invalid="ignore"):
        error = np.where(smallest > 0, SAFETY * miss / smallest, np.inf)
    error[~np.isfinite(miss)] = np.inf
    return error


class Leaves(Protocol):
    """What :func:`interpolate` reads of a :class:`~glmls.imaging.adaptive.AdaptiveMesh`."""

    leaves: np.ndarray  # (L, 4) x0, y0, x1, y1
    nodes: np.ndarray  # (L, 9) each leaf's 3 x 3 patch nodes


def interpolate(mesh: Leaves, values: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
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
