"""The Jacobian of a 3D deformation per cell of a lattice, and its folds.

The lattice is that of the 2D fold-overs (:mod:`.folding`) in 3D: cell corners every
``grid`` voxels from -0.5 to n - 0.5 along each axis (the last step may be shorter), f
evaluated at the corners. Per cell:

- J = df/dv at the cell's centre, by finite differences: column a of J is the mean of the
  cell's four edges along axis a (x, y, z), each f(end) - f(start), over the cell's side.
  That is the Jacobian of the trilinear interpolation of f at the cell's centre, and exactly
  M^T for an affine f(v) = v M + T (J is the column-vector Jacobian; det J = det M).
- ``det``: det J, 1 for the identity (a volume ratio); ``ratio``: the ratio of J's largest
  to its smallest singular value, 1 for any similarity (how anisotropic the cell's
  stretch is), both in closed form (:mod:`glmls.analysis.singular3`: float64 rounding, not
  a LAPACK call per cell).
- ``min_det``: the smallest det J of the six tetrahedra of the cell's Kuhn decomposition
  (each a path 000 -> 100 -> 110 -> 111 through the cube's corners, one per order of the
  axes, all sharing the diagonal 000-111), where the piecewise linear interpolation of f at
  the corners has an exact Jacobian: as the 2D code's two triangles per cell.
- a fold: ``det`` <= 0 or ``min_det`` <= 0 (f turns the cell, or part of it, inside out, or
  flattens it).

**Flattened cells.** Rounding leaves a determinant that should be 0 (f projects onto a plane
not along the axes) at +-1e-16 or so, of either sign. So J counts as singular where its
smallest singular value is within 32 (``FLAT_ULPS``) times f's precision (float64's,
float32's where f comes from the GPU) of J's largest plus the rounding of f at the corners
over the cell's side: ``det`` is then 0 and ``ratio`` NaN, and the cell folds. A Kuhn
tetrahedron whose image has volume 0 to that rounding has det 0 alike. Thin cells far above
the rounding (det J = 1e-9 in float64) keep their values.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..core.config import check_result_bytes
from .singular3 import cross3, det_and_extremes, dot3
from .stats import error_stats
from .volume_field import Deformation3D, precision, target_offset, volume_deformation
from .volume_lattice import (
    FLAT_ULPS,
    as_volume_shape,
    axis_corners,
    check_grid3,
    deformation_spacing,
    evaluate,
    lattice_points,
    spacing_scale,
)

__all__ = ["CellJacobians", "cell_jacobians"]

#: Corner points per slab of cells: f at them and their (x, y, z) take some 40 MB.
SLAB_POINTS = 1 << 19

#: (permutation of the axes (x, y, z) = (0, 1, 2), its sign) for the six Kuhn tetrahedra.
KUHN = tuple(
    (order, 1 if sum(a > b for a, b in itertools.combinations(order, 2)) % 2 == 0 else -1)
    for order in itertools.permutations(range(3))
)


@dataclass(frozen=True, eq=False)
class CellJacobians:
    """The Jacobian of a deformation per cell of a volume's lattice, and its folds.

    Made by :func:`cell_jacobians` (see ``glmls.analysis.jacobians`` for the
    definitions); the arrays are read-only, the per-cell ones (cz, cy, cx) in the order
    (z, y, x) of the cells.

    Attributes
    ----------
    shape : tuple of int
        The volume's (D, H, W).
    grid : int
        The lattice's step in voxels.
    det : numpy.ndarray
        (cz, cy, cx): det J at each cell's centre; 0 where J is singular to rounding (f
        flattens the cell).
    ratio : numpy.ndarray
        (cz, cy, cx): J's largest singular value over its smallest, >= 1; NaN where J is
        singular to rounding (left out of :meth:`stats`, counted as its ``nan_count``).
    min_det : numpy.ndarray
        (cz, cy, cx): the smallest det J of the cell's six Kuhn tetrahedra (0 for one that f
        flattens to rounding).
    folded : numpy.ndarray
        (cz, cy, cx) bool: ``det`` <= 0 or ``min_det`` <= 0: f folds or flattens the cell.
    mask : numpy.ndarray
        (D, H, W) bool: the voxels of the folded cells.

    Examples
    --------
    >>> src = [[0, 0, 0], [10, 0, 0], [0, 10, 0], [0, 0, 10]]
    >>> m = glmls.analysis.ReferenceDeformation(src, np.multiply(src, 2.0), transform="affine")
    >>> cells = glmls.analysis.cell_jacobians(m, (8, 8, 8), grid=4)
    >>> cells.det.shape, cells.det.round(9).min().item(), cells.ratio.round(9).max().item()
    ((2, 2, 2), 8.0, 1.0)
    >>> stats = cells.stats()
    >>> stats["cells"], stats["folds"], round(stats["det"]["median"], 9)
    (8, 0, 8.0)
    """

    shape: tuple[int, int, int]
    grid: int
    det: np.ndarray
    ratio: np.ndarray
    min_det: np.ndarray
    folded: np.ndarray
    mask: np.ndarray

    @property
    def count(self) -> int:
        """The number of folded cells.

        Examples
        --------
        >>> mirror = np.diag([-1.0, 1.0, 1.0])
        >>> cells = glmls.analysis.cell_jacobians(lambda v: v @ mirror, (4, 4, 4), grid=2)
        >>> cells.count  # a mirror folds every cell
        8
        >>> glmls.analysis.cell_jacobians(lambda v: v * 2.0, (4, 4, 4), grid=2).count
        0
        """
        return int(self.folded.sum())

    def stats(self) -> dict[str, object]:
        """JSON-ready statistics of the cells.

        Returns
        -------
        dict
            ``grid``, ``cells``, ``folds`` (folded cells), ``folded_voxels``, and the
            :func:`error_stats` of ``det``, ``ratio`` and ``min_det``.

        Examples
        --------
        >>> mirror = np.diag([-1.0, 1.0, 1.0])
        >>> cells = glmls.analysis.cell_jacobians(lambda v: v @ mirror, (4, 4, 4), grid=2)
        >>> stats = cells.stats()
        >>> stats["cells"], stats["folds"], stats["folded_voxels"], stats["det"]["max"]
        (8, 8, 64, -1.0)
        """
        return {
            "grid": self.grid,
            "cells": int(self.det.size),
            "folds": self.count,
            "folded_voxels": int(self.mask.sum()),
            "det": error_stats(self.det),
            "ratio": error_stats(self.ratio),
            "min_det": error_stats(self.min_det),
        }


#: Cells per block of :func:`cell_quantities` (whole z layers, else rows of one layer, at
#: least one row): its hundred-odd float64 temporaries of 128 kB each stay in a core's
#: cache, which makes the numpy passes over them about twice as fast as blocks 4x larger.
BLOCK_CELLS = 1 << 14


def _components(f: np.ndarray) -> list[np.ndarray]:
    """The x, y and z of f (..., 3) as three contiguous arrays."""
    return [np.ascontiguousarray(f[..., i]) for i in range(3)]


def _corner_max(values: np.ndarray) -> np.ndarray:
    """The largest of ``values`` (cz + 1, cy + 1, cx + 1) over each cell's eight corners."""
    cz, cy, cx = (n - 1 for n in values.shape)
    out = values[:cz, :cy, :cx].copy()
    for dz, dy, dx in itertools.product((0, 1), repeat=3):
        np.maximum(out, values[dz : dz + cz, dy : dy + cy, dx : dx + cx], out=out)
    return out


def _edges(f: list[np.ndarray]) -> list[list[np.ndarray]]:
    """The differences of f (x, y, z components, (cz + 1, cy + 1, cx + 1) each) along x, y
    and z: ``edges[axis][component]``, one longer than the cells along the other axes."""
    return [
        [c[:, :, 1:] - c[:, :, :-1] for c in f],
        [c[:, 1:] - c[:, :-1] for c in f],
        [c[1:] - c[:-1] for c in f],
    ]


def _edge(edges: list[list[np.ndarray]], axis: int, at: Sequence[int]) -> list[np.ndarray]:
    """The cells' edges along ``axis`` from the corner offset ``at`` (x, y, z) of 0 or 1,
    as contiguous arrays (``at[axis]`` is 0: an edge array holds as many along its axis)."""
    cz, cy, cx = edges[2][0].shape[0], edges[1][0].shape[1], edges[0][0].shape[2]
    dx, dy, dz = at
    return [np.ascontiguousarray(e[dz : dz + cz, dy : dy + cy, dx : dx + cx]) for e in edges[axis]]


def _kuhn_min(
    edges: list[list[np.ndarray]], volume: np.ndarray, rounding: float, noise: np.ndarray
) -> np.ndarray:
    """The smallest det J of each cell's six Kuhn tetrahedra, 0 for one flat to rounding
    (:func:`~glmls.analysis.volume_lattice.flat_triples`' test, edge by edge)."""
    lengths: dict[tuple[int, int, int, int], np.ndarray] = {}
    path_edges: dict[tuple[int, int, int, int], list[np.ndarray]] = {}
    low = np.full(noise.shape, np.inf)
    for order, sign in KUHN:
        at = [0, 0, 0]
        path = []
        for axis in order:
            key = (axis, *at)
            if key not in path_edges:
                e = path_edges[key] = _edge(edges, axis, at)
                lengths[key] = np.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])
            path.append(key)
            at[axis] += 1
        a, b, c = (path_edges[key] for key in path)
        la, lb, lc = (lengths[key] for key in path)
        triple = dot3(a, cross3(b, c))
        tolerance = FLAT_ULPS * rounding * (la * lb * lc + noise * (la * lb + lb * lc + la * lc))
        value = np.where(np.abs(triple) <= tolerance, 0.0, sign * triple) / volume
        np.minimum(low, value, out=low)
    return low


def _block_quantities(
    f: np.ndarray, axes: Sequence[np.ndarray], rounding: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`cell_quantities` of one block of cells."""
    x, y, z = axes
    hx, hy, hz = np.diff(x), np.diff(y), np.diff(z)
    hx3, hy3, hz3 = hx[None, None, :], hy[None, :, None], hz[:, None, None]
    comps = _components(f)
    edges = _edges(comps)
    ex, ey, ez = edges
    # column a of J: the mean of the cell's four edges along axis a over its side
    jx = [(e[:-1, :-1] + e[1:, :-1] + e[:-1, 1:] + e[1:, 1:]) / (4 * hx3) for e in ex]
    jy = [(e[:-1, :, :-1] + e[1:, :, :-1] + e[:-1, :, 1:] + e[1:, :, 1:]) / (4 * hy3) for e in ey]
    jz = [(e[:, :-1, :-1] + e[:, 1:, :-1] + e[:, :-1, 1:] + e[:, 1:, 1:]) / (4 * hz3) for e in ez]
    jacobian = [[jx[row], jy[row], jz[row]] for row in range(3)]
    det, s1, s3 = det_and_extremes(jacobian)
    # rounding moves f by about rounding x (|f| + |J| |v|) at each corner, and so J by that
    # over a side: a smallest singular value within it is 0, whatever its sign in det J
    rx, ry, rz = (np.maximum(np.abs(a[:-1]), np.abs(a[1:])) for a in (x, y, z))
    reach = np.maximum(np.maximum(rz[:, None, None], ry[:, None]), rx)  # |v| at the corners
    side = np.minimum(np.minimum(hz3, hy3), hx3)
    scale = np.maximum(np.maximum(np.abs(comps[0]), np.abs(comps[1])), np.abs(comps[2]))
    noise = _corner_max(scale) + s1 * reach
    flat = s3 <= FLAT_ULPS * rounding * (s1 + noise / side)
    det[flat] = 0.0
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(flat, np.nan, s1 / s3)
    min_det = _kuhn_min(edges, hx3 * hy3 * hz3, rounding, noise)
    return det, ratio, min_det


def cell_quantities(
    corners: np.ndarray, axes: Sequence[np.ndarray], rounding: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(det, ratio, min_det) per cell from f at the corners (cz + 1, cy + 1, cx + 1, 3), the
    corners' coordinates along (x, y, z) and the rounding of f (``precision``).

    The cells go in blocks of z layers, or of rows of a layer (:data:`BLOCK_CELLS`): every
    quantity is a cell's own, so the blocks give the same bits as one pass, in bounded
    memory."""
    x, y, z = (np.asarray(a, dtype=np.float64) for a in axes)
    cells = (len(z) - 1, len(y) - 1, len(x) - 1)
    det, ratio, min_det = np.empty(cells), np.empty(cells), np.empty(cells)
    layers = max(1, BLOCK_CELLS // (cells[1] * cells[2]))
    rows = cells[1] if layers > 1 else max(1, BLOCK_CELLS // cells[2])
    for k in range(0, cells[0], layers):
        for j in range(0, cells[1], rows):
            block = (slice(k, min(k + layers, cells[0])), slice(j, min(j + rows, cells[1])))
            ends = tuple(slice(b.start, b.stop + 1) for b in block)  # the blocks' corners
            det[block], ratio[block], min_det[block] = _block_quantities(
                corners[ends], (x, y[ends[1]], z[ends[0]]), rounding
            )
    return det, ratio, min_det


def cell_jacobians(
    m: Deformation3D, shape: Sequence[int], *, grid: int = 1, spacing: object = None
) -> CellJacobians:
    """det J, the singular value ratio of J and the folds of ``m`` per cell of a volume.

    f is evaluated at the cell corners every ``grid`` voxels (``m(points)``, in blocks) and
    differentiated per cell (``glmls.analysis.jacobians``). A cell folds where det J <= 0
    at its centre or on any of its six Kuhn tetrahedra, as the 2D fold-overs test both
    triangles of a cell; a det J within rounding of 0 (f flattens the cell, J singular to
    f's precision: float64, or float32 on the GPU) is 0, a fold, with the ratio NaN. f is
    that of the volume's warp: a radius weight given no radius takes the diagonal of this
    volume in the handles' units (``volume_deformation`` of
    ``glmls.analysis.volume_field``).

    Parameters
    ----------
    m : glmls.MLS or ReferenceDeformation
        A deformation of (N, 3) handles (anything mapping (K, 3) points to (K, 3)).
    shape : sequence of int
        (D, H, W), or (D, H, W, C), of the volume.
    grid : int, optional
        The lattice's step in voxels (1: a cell per voxel; (D + 1)(H + 1)(W + 1) points).
    spacing : (float, float, float), optional
        (dz, dy, dx): voxel (k, j, i) is the point (i dx, j dy, k dz) of the handles' units,
        as :meth:`glmls.MLS.warp` places it, and J is df/dv in those units (default:
        ``m.spacing`` where ``m`` has one, else 1 each; another than ``m.spacing`` is a
        ValueError).

    Returns
    -------
    CellJacobians
        det J, the singular value ratio, the Kuhn tetrahedra's smallest det J, the folds and
        their voxels.

    Raises
    ------
    ValueError
        For a shape that is not (D, H, W) with D, H, W >= 1, a grid that is not an integer
        from 1 on, cells that need more than this machine's physical memory (25 bytes a
        cell and 1 a voxel; the message says both, in bytes), ``m`` returning the wrong
        shape or values that are not finite, or a ``spacing`` of another length than 3, with
        a value that is not a finite number > 0, or other than ``m``'s.
    TypeError
        For a shape that is not integers, or a ``spacing`` that is not a sequence of real
        numbers.

    See Also
    --------
    foldovers : the same test in 2D.

    Examples
    --------
    >>> mirror = np.diag([-1.0, 1.0, 1.0])
    >>> cells = glmls.analysis.cell_jacobians(lambda v: v @ mirror, (4, 4, 4), grid=2)
    >>> cells.count, cells.det.ravel().tolist()[:2], cells.mask.all().item()
    (8, [-1.0, -1.0], True)
    >>> glmls.analysis.cell_jacobians(lambda v: v + 1.0, (4, 4, 4)).count
    0
    """
    if not callable(m):  # before any work, rather than at the first block of f
        raise TypeError(f"m must be a glmls.MLS or a function of points, got {type(m).__name__}")
    dims = as_volume_shape(shape)
    step = check_grid3(grid)
    # det, ratio and min det (float64) and the folds per cell, and the mask per voxel
    check_result_bytes(
        f"cell_jacobians of shape {dims} at grid {step}",
        math.prod(-(-n // step) for n in dims) * 25 + math.prod(dims),
    )
    steps = deformation_spacing(m, spacing)
    dx, dy, dz = spacing_scale(steps)
    m = volume_deformation(m, dims, steps)  # f as the volume's warp has it
    z, y, x = (axis_corners(n, step) * d for n, d in zip(dims, (dz, dy, dx), strict=True))
    cells = (len(z) - 1, len(y) - 1, len(x) - 1)
    det, ratio, min_det = np.empty(cells), np.empty(cells), np.empty(cells)
    # f less the GPU's offset of far targets (exact: the offset is whole units): its
    # rounding, and so the flatness tolerance, is that of the map near its sources
    offset = target_offset(m)
    # slabs of cells along z, each with its two planes of corners: bounded memory
    slab = max(1, SLAB_POINTS // (len(y) * len(x)))
    for start in range(0, cells[0], slab):
        planes = z[start : start + slab + 1]
        values = evaluate(m, lattice_points(planes, y, x), 3)
        if offset.any():
            values -= offset
        values = values.reshape(len(planes), len(y), len(x), 3)
        part = slice(start, start + len(planes) - 1)
        det[part], ratio[part], min_det[part] = cell_quantities(
            values, (x, y, planes), precision(m)
        )
    folded = (det <= 0) | (min_det <= 0)
    index = [np.arange(n) // step for n in dims]
    mask = folded[np.ix_(*index)]
    for array in (det, ratio, min_det, folded, mask):
        array.flags.writeable = False
    return CellJacobians(dims, step, det, ratio, min_det, folded, mask)
