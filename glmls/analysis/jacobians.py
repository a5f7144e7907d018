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
  stretch is).
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
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .stats import error_stats
from .volume_field import Deformation3D, precision, volume_deformation
from .volume_lattice import (
    FLAT_ULPS,
    as_volume_shape,
    axis_corners,
    check_grid3,
    deformation_spacing,
    evaluate,
    flat_triples,
    lattice_points,
    spacing_scale,
)

__all__ = ["CellJacobians", "cell_jacobians"]

#: Corner points per slab of cells (f, J and the SVD of a slab stay within ~1 GB).
SLAB_POINTS = 1 << 21

#: (permutation of the axes (x, y, z) = (0, 1, 2), its sign) for the six Kuhn tetrahedra.
KUHN = tuple(
    (order, 1 if sum(a > b for a, b in itertools.combinations(order, 2)) % 2 == 0 else -1)
    for order in itertools.permutations(range(3))
)


@dataclass(frozen=True, eq=False)
class CellJacobians:
    """The Jacobian of a deformation per cell of a volume's lattice, and its folds.

    Made by :func:`cell_jacobians` (see :mod:`glmls.analysis.jacobians` for the
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


def _triple(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """a . (b x c) over the last axis."""
    return (a * np.cross(b, c)).sum(-1)


def _corner_max(values: np.ndarray) -> np.ndarray:
    """The largest of ``values`` (cz + 1, cy + 1, cx + 1) over each cell's eight corners."""
    cz, cy, cx = (n - 1 for n in values.shape)
    out = values[:cz, :cy, :cx].copy()
    for dz, dy, dx in itertools.product((0, 1), repeat=3):
        np.maximum(out, values[dz : dz + cz, dy : dy + cy, dx : dx + cx], out=out)
    return out


def cell_quantities(
    corners: np.ndarray, axes: Sequence[np.ndarray], rounding: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(det, ratio, min_det) per cell from f at the corners (cz + 1, cy + 1, cx + 1, 3), the
    corners' coordinates along (x, y, z) and the rounding of f (``precision``)."""
    x, y, z = (np.asarray(a, dtype=np.float64) for a in axes)
    hx, hy, hz = np.diff(x), np.diff(y), np.diff(z)
    f = corners
    hx3, hy3, hz3 = hx[None, None, :, None], hy[None, :, None, None], hz[:, None, None, None]
    # edges along x of every cell (4 per cell), likewise y and z
    ex = f[:, :, 1:] - f[:, :, :-1]  # (cz+1, cy+1, cx, 3)
    ey = f[:, 1:] - f[:, :-1]  # (cz+1, cy, cx+1, 3)
    ez = f[1:] - f[:-1]  # (cz, cy+1, cx+1, 3)
    jx = (ex[:-1, :-1] + ex[1:, :-1] + ex[:-1, 1:] + ex[1:, 1:]) / (4 * hx3)
    jy = (ey[:-1, :, :-1] + ey[1:, :, :-1] + ey[:-1, :, 1:] + ey[1:, :, 1:]) / (4 * hy3)
    jz = (ez[:, :-1, :-1] + ez[:, 1:, :-1] + ez[:, :-1, 1:] + ez[:, 1:, 1:]) / (4 * hz3)
    jacobian = np.stack([jx, jy, jz], axis=-1)  # column a: df/dv_a
    det = np.linalg.det(jacobian)
    singular = np.linalg.svd(jacobian, compute_uv=False)
    # rounding moves f by about rounding x (|f| + |J| |v|) at each corner, and so J by that
    # over a side: a smallest singular value within it is 0, whatever its sign in det J
    zz, yy, xx = np.meshgrid(np.abs(z), np.abs(y), np.abs(x), indexing="ij")
    reach = _corner_max(np.maximum(np.maximum(zz, yy), xx))
    side = np.minimum(np.minimum(hz3[..., 0], hy3[..., 0]), hx3[..., 0])
    noise = _corner_max(np.abs(f).max(axis=-1)) + singular[..., 0] * reach
    flat = singular[..., 2] <= FLAT_ULPS * rounding * (singular[..., 0] + noise / side)
    det[flat] = 0.0
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(flat, np.nan, singular[..., 0] / singular[..., 2])
    volume = hx3[..., 0] * hy3[..., 0] * hz3[..., 0]
    cz, cy, cx = det.shape
    min_det = np.full(det.shape, np.inf)
    for order, sign in KUHN:
        at = np.zeros(3, int)  # the path's corner offset along (x, y, z)
        edges = []
        for axis in order:
            start = f[at[2] : at[2] + cz, at[1] : at[1] + cy, at[0] : at[0] + cx]
            at[axis] += 1
            end = f[at[2] : at[2] + cz, at[1] : at[1] + cy, at[0] : at[0] + cx]
            edges.append(end - start)
        value = np.where(flat_triples(edges, rounding, noise), 0.0, sign * _triple(*edges))
        np.minimum(min_det, value / volume, out=min_det)
    return det, ratio, min_det


def cell_jacobians(
    m: Deformation3D, shape: Sequence[int], *, grid: int = 1, spacing: object = None
) -> CellJacobians:
    """det J, the singular value ratio of J and the folds of ``m`` per cell of a volume.

    f is evaluated at the cell corners every ``grid`` voxels (``m(points)``, in blocks) and
    differentiated per cell (:mod:`glmls.analysis.jacobians`). A cell folds where det J <= 0
    at its centre or on any of its six Kuhn tetrahedra, as the 2D fold-overs test both
    triangles of a cell; a det J within rounding of 0 (f flattens the cell, J singular to
    f's precision: float64, or float32 on the GPU) is 0, a fold, with the ratio NaN. f is
    that of the volume's warp: a radius weight given no radius takes the diagonal of this
    volume in the handles' units (``volume_deformation`` of
    :mod:`glmls.analysis.volume_field`).

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
        from 1 on, ``m`` returning the wrong shape or values that are not finite, or a
        ``spacing`` of another length than 3, with a value that is not a finite number > 0, or
        other than ``m``'s.
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
    dims = as_volume_shape(shape)
    step = check_grid3(grid)
    steps = deformation_spacing(m, spacing)
    dx, dy, dz = spacing_scale(steps)
    m = volume_deformation(m, dims, steps)  # f as the volume's warp has it
    z, y, x = (axis_corners(n, step) * d for n, d in zip(dims, (dz, dy, dx), strict=True))
    cells = (len(z) - 1, len(y) - 1, len(x) - 1)
    det, ratio, min_det = np.empty(cells), np.empty(cells), np.empty(cells)
    # slabs of cells along z, each with its two planes of corners: bounded memory
    slab = max(1, SLAB_POINTS // (len(y) * len(x)))
    for start in range(0, cells[0], slab):
        planes = z[start : start + slab + 1]
        values = evaluate(m, lattice_points(planes, y, x), 3)
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
