"""f on the lattice of an image, evaluated band by band into the pipeline's mesh buffer (a
buffer that stays on the GPU: the image passes read it there)."""

from __future__ import annotations

from collections.abc import Iterator

import moderngl

from ..core.mesh import MeshLattice
from ..engine.kernel import MLSKernel
from ..engine.passes import lattice_bands
from ..gl.resources import Resources
from .options import PipelineOptions

__all__ = ["MeshBands"]


class MeshBands:
    """The mesh buffer of a pipeline (``resources``) and the bands it is filled in."""

    def __init__(self, resources: Resources, options: PipelineOptions) -> None:
        self._resources = resources
        self._options = options

    def rows_per_band(self, lattice: MeshLattice, *, indexed: bool = False) -> int:
        """Rows of a band: the mesh buffer within ``band_bytes`` and, where ``indexed`` (the
        GL rasterizer's quads), the index buffer too."""
        return lattice.rows_per_band(self._options.band_bytes, indexed=indexed)

    def one_band(self, lattice: MeshLattice) -> bool:
        """Is ``lattice`` evaluated in a single band (not indexed)?"""
        return lattice.one_band(self.rows_per_band(lattice))

    @property
    def buffer(self) -> moderngl.Buffer:
        """The mesh buffer (after a band was evaluated)."""
        return self._resources.cached("mesh")

    def __call__(
        self,
        kernel: MLSKernel,
        lattice: MeshLattice,
        *,
        indexed: bool = False,
        reverse: bool = False,
        squares: bool = False,
    ) -> Iterator[tuple[int, tuple[int, int]]]:
        """Evaluate f on ``lattice`` band by band; yields (first row, (points per row, rows))
        with each band in :attr:`buffer`. ``reverse``: the last band first (the rasterizer
        draws the cells in reverse scan order). ``squares``: consecutive bands share a row
        even for the pixel centres (the squares of ``paper-quads`` need both their rows);
        cells of the corner lattice always do."""
        rows = self.rows_per_band(lattice, indexed=indexed)
        buffer = self._resources.buffer("mesh", min(lattice.count, rows * lattice.dims[0]) * 8)
        overlap = 1 if squares else None
        yield from lattice_bands(kernel, lattice, buffer, rows, overlap=overlap, reverse=reverse)
