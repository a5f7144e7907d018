"""Fold-overs: the mesh cells that f turns over (where deformed cells overlap, the deformed image
shows the first of them in row-major scan order of the source, as the paper's marked pixels
keep their colour). One rule, used by :func:`foldovers` and the window's overlay alike."""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple, Protocol

import numpy as np

from ..core.config import check_result_bytes
from ..core.mesh import MeshLattice
from ..mls import MLS
from .field import check_deformation, target_offset
from .volume_lattice import flat_areas

__all__ = ["Foldovers", "folded_cells", "foldovers"]


class HasMesh(Protocol):
    def mesh(self, shape: Sequence[int], *, grid: int = 1) -> tuple[np.ndarray, np.ndarray]: ...


class Foldovers(NamedTuple):
    """Mesh cells that f turns over, as :func:`foldovers` finds them (a named tuple).

    Attributes
    ----------
    count : int
        The number of folded cells.
    mask : numpy.ndarray
        (H, W) bool: the source pixels of those cells.

    Examples
    --------
    >>> folds = glmls.analysis.Foldovers(0, np.zeros((4, 4), bool))
    >>> folds.count, folds.mask.any().item()
    (0, False)
    """

    count: int
    mask: np.ndarray


def _cross(o: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    return (x[..., 0] - o[..., 0]) * (y[..., 1] - o[..., 1]) - (x[..., 1] - o[..., 1]) * (
        y[..., 0] - o[..., 0]
    )


def folded_cells(
    deformed: np.ndarray, *, rounding: float = float(np.finfo(np.float32).eps)
) -> np.ndarray:
    """(rows - 1, columns - 1) bool for a deformed mesh (rows, columns, 2): cells of which
    either drawn triangle, (00, 10, 11) or (00, 11, 01), has zero or negative signed area
    after deformation (this includes every cell whose deformed quad has negative area, and
    every cell that f crushes flat). ``rounding``: that of the mesh's points (float32's for
    a :class:`glmls.MLS`'s mesh): a triangle whose area is within :data:`FLAT_ULPS` times
    that rounding's effect of zero is flat (its sign is rounding, not orientation), as in
    the reference triangles' analysis (:func:`glmls.analysis.triangle_errors`)."""
    a, b = deformed[:-1, :-1], deformed[:-1, 1:]
    c, d = deformed[1:, 1:], deformed[1:, :-1]
    # each point may be off by rounding x its magnitude (f's scale over the mesh)
    noise = float(np.abs(deformed).max()) if deformed.size else 0.0

    def folds(o: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        area = _cross(o, x, y)
        p = np.hypot(*np.moveaxis(x - o, -1, 0))
        q = np.hypot(*np.moveaxis(y - o, -1, 0))
        return (area <= 0) | flat_areas(area, p, q, rounding, noise)

    return folds(a, b, c) | folds(a, c, d)


def foldovers(m: HasMesh, shape: object, *, grid: int = 1) -> Foldovers:
    """The cells of an image's mesh that fold over under ``m``'s f.

    A cell folds where either of its two drawn triangles has zero or negative signed area
    after deformation (``folded_cells``). Where cells fold, the deformed image shows the first
    of the overlapping cells in scan order (smaller source row, then column; see
    :meth:`glmls.MLS.warp`).

    Parameters
    ----------
    m : MLS
        The deformation (anything with a ``mesh(shape, grid=)`` method).
    shape : tuple of int
        (H, W) of the image.
    grid : int, optional
        The mesh's step in pixels.

    Returns
    -------
    Foldovers
        The number of folded cells and the mask of their source pixels.

    Raises
    ------
    ValueError
        For a shape that is not (H, W) with H, W >= 1, a grid that is not an integer from
        1 on, or a mesh and mask that need more than this machine's physical memory (41
        bytes a mesh vertex and a pixel; the message says both, in bytes).
    TypeError
        For an ``m`` without a ``mesh`` method, or a shape that is not integers.

    Examples
    --------
    >>> src = np.array([[2.0, 2.0], [13.0, 2.0], [2.0, 13.0]])
    >>> mirrored = np.array([[13.0, 2.0], [2.0, 2.0], [13.0, 13.0]])
    >>> with glmls.MLS(src, mirrored, transform="affine") as m:  # a reflection: all fold
    ...     folds = glmls.analysis.foldovers(m, (16, 16), grid=4)
    >>> folds.count, folds.mask.shape, folds.mask.all().item()
    (16, (16, 16), True)
    >>> with glmls.MLS(src, src + 1.0) as m:
    ...     glmls.analysis.foldovers(m, (16, 16)).count
    0
    """
    check_deformation(m, "mesh")
    lattice = MeshLattice.corners(shape, grid)  # validates shape and grid
    height, width = lattice.shape
    # the mesh's vertices and f (float64, and f in float32 from the GPU), and the mask
    check_result_bytes(
        f"foldovers of shape {lattice.shape} at grid {lattice.grid}",
        lattice.count * 40 + height * width,
    )
    # far targets: the folds of f - t (a whole-pixel t; the same cells, as f - t turns the
    # same triangles), whose float32 rounding is that of a map near its sources
    _, deformed = m.mesh(lattice.shape, grid=lattice.grid)
    rounding = np.finfo(np.float32 if isinstance(m, MLS) else np.float64).eps  # the GPU's
    folded = folded_cells(deformed - target_offset(m), rounding=float(rounding))
    return Foldovers(int(folded.sum()), lattice.cell_mask(folded))
