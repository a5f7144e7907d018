"""f on the lattice of an image, evaluated band by band into the pipeline's mesh buffer (a
buffer that stays on the GPU), which the image passes read copied into the mesh texture (a
cell's corners fetched as texels: on llvmpipe ~3x faster than a storage buffer's loads of a
different vertex in each lane).

The mesh of pixel corners has one vertex more per side than the image has pixels: at the GL
texture limit (an image exactly ``GL_MAX_TEXTURE_SIZE`` pixels wide or high, or less with a
border mode's margin) it no longer fits one texture's row or column. A band never has more
rows than a texture holds (:meth:`MeshBands.rows_per_band`); the passes read a mesh wider
than a texture (:meth:`MeshBands.fits_texture`) from the mesh buffer itself
(:meth:`MeshBands.bind_mesh`, ``warp/mesh_fetch.glsl``), so that such an image's pixels are
the compute scan's, as any other image's and a batch's.
"""

from __future__ import annotations

from collections.abc import Iterator

import moderngl

from ..core.mesh import MeshLattice
from ..engine.kernel import MLSKernel
from ..engine.passes import lattice_bands
from ..gl import bindings
from ..gl.resources import Resources
from .options import PipelineOptions

__all__ = ["MeshBands"]


class MeshBands:
    """The mesh buffer of a pipeline (``resources``) and the bands it is filled in."""

    def __init__(self, resources: Resources, options: PipelineOptions) -> None:
        self._resources = resources
        self._options = options
        self._texture_size = (1, 1)  # of the mesh texture: the largest band of the lattice

    @property
    def max_texture_size(self) -> int:
        """The GL limit on a side of the mesh texture (``GL_MAX_TEXTURE_SIZE``)."""
        return self._resources.limits["max_texture_size"]

    def rows_per_band(self, lattice: MeshLattice, *, indexed: bool = False) -> int:
        """Rows of a band: the mesh buffer within ``band_bytes`` and, where ``indexed`` (the
        GL rasterizer's quads), the index buffer too; no more than the mesh texture holds."""
        rows = lattice.rows_per_band(self._options.band_bytes, indexed=indexed)
        return min(rows, self.max_texture_size)

    def fits_texture(self, lattice: MeshLattice) -> bool:
        """Does a row of ``lattice`` fit a row of the mesh texture (:meth:`texture`)? The
        corners of an image as wide as the GL limit do not: one vertex more than pixels."""
        return lattice.dims[0] <= self.max_texture_size

    def one_band(self, lattice: MeshLattice) -> bool:
        """Is ``lattice`` evaluated in a single band (not indexed)?"""
        return lattice.one_band(self.rows_per_band(lattice))

    @property
    def buffer(self) -> moderngl.Buffer:
        """The mesh buffer (after a band was evaluated)."""
        return self._resources.cached("mesh")

    def bind_mesh(self, lattice: MeshLattice, dims: tuple[int, int]) -> None:
        """The band just evaluated (``dims`` as yielded) bound where the passes that read it
        at random find it (``warp/mesh_fetch.glsl``): copied into the mesh texture
        (:meth:`texture`), or, where a row of ``lattice`` does not fit a texture
        (:meth:`fits_texture`; their programs take :meth:`mesh_defines`), the mesh buffer
        itself, bound to ``DEFORMED``."""
        if self.fits_texture(lattice):
            self.texture(dims)
        else:
            self.buffer.bind_to_storage_buffer(bindings.DEFORMED.index)

    def mesh_defines(self, lattice: MeshLattice) -> dict[str, bool]:
        """The defines of the programs that read ``lattice``'s bands as :meth:`bind_mesh`
        binds them."""
        return {"WARP_MESH_BUFFER": not self.fits_texture(lattice)}

    def texture(self, dims: tuple[int, int]) -> moderngl.Texture:
        """The band just evaluated (``dims``: points per row, rows, as yielded) copied on the
        GPU into the mesh texture (RG32F, scaled: vertex (i, j) of the band is texel (i, j);
        one texture for all the lattice's bands), bound to ``MESH``. ``ValueError`` where the
        band is wider than a texture (:meth:`bind_mesh` binds the buffer for those)."""
        if dims[0] > self.max_texture_size:
            raise ValueError(
                f"a mesh band of {dims[0]} vertices per row does not fit a GL texture "
                f"({self.max_texture_size} texels per row)"
            )
        texture = self._resources.texture("mesh", self._texture_size, 2, "f4")
        texture.write(self.buffer, viewport=(0, 0, *dims))
        texture.use(bindings.MESH.index)
        return texture

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
        self._texture_size = (lattice.dims[0], min(rows, lattice.dims[1]))
        overlap = 1 if squares else None
        yield from lattice_bands(kernel, lattice, buffer, rows, overlap=overlap, reverse=reverse)
