"""The deformed mesh drawn by the GL rasterizer (``glmls/shaders/warp/mesh.vert.glsl`` and
``mesh.frag.glsl``): two triangles per cell for the quads of viewports other than the output
canvas's size (a window scaling the image) and of meshes whose keys are too long for the
compute scan, and one point per pixel for the simple forward method.

Fold-overs: OpenGL writes later primitives over earlier ones, so the cells are drawn in
reverse row-major order of their source cells (the last band first, one draw call per band,
each cell's triangle 1 before its triangle 0): where deformed quads overlap, the FIRST cell in
scan order (smaller source row, then column) is drawn last and shows, as with the compute scan
and the paper's marking of pixels. The points of ``splat`` likewise: the first source pixel in
scan order shows. Exact at any size (no depth buffer and its precision).
"""

from __future__ import annotations

import moderngl
import numpy as np

from ..core.mesh import MeshLattice
from ..engine.kernel import MLSKernel
from ..gl import bindings
from ..gl.context import GLContext, current
from ..gl.dispatch import set_uniforms
from ..gl.resources import Resources
from .bands import MeshBands
from .frame import Frame

__all__ = ["MeshRaster"]


class MeshRaster:
    """The rasterizer path of a pipeline (its GL objects are the pipeline's)."""

    def __init__(self, gl: GLContext, resources: Resources, bands: MeshBands) -> None:
        self._gl = gl
        self._resources = resources
        self._bands = bands

    @current
    def draw(
        self,
        kernel: MLSKernel,
        source: moderngl.Texture | None,
        lattice: MeshLattice,
        frame: Frame,
        *,
        linear: bool,
        coords: bool,
        flip_y: bool,
        border: int = 0,
    ) -> None:
        """Draw ``lattice`` (the corners every ``grid`` pixels: quads; the pixel centres:
        splat; either possibly with a margin past the image) of the source image into the
        bound framebuffer, the output canvas ``frame`` mapped onto its viewport. ``border``:
        the code of the rule for source pixels past the image (``WARP_BORDER``)."""
        splat = lattice.kind == "centres"
        program = self._gl.program(
            "warp/mesh.vert.glsl",
            "warp/mesh.frag.glsl",
            {
                "WARP_SPLAT": splat,
                "WARP_LINEAR": linear,
                "WARP_OUTPUT_COORDS": coords,
                "WARP_BORDER": 0 if coords else border,
            },
        )
        height, width = lattice.shape
        sc = kernel.scaling
        values = {
            "u_center": sc.center,
            "u_scale": sc.scale,
            **frame.uniforms(kernel),
            "u_flip_y": flip_y,
            "u_source_size": (width, height),
            **lattice.pixel_uniforms(),
        }
        set_uniforms(program, values)
        if source is not None and not coords:
            mode = moderngl.LINEAR if linear else moderngl.NEAREST
            source.filter = (mode, mode)
            source.use(bindings.SOURCE.index)
        mgl = self._gl.mgl
        mgl.disable(moderngl.DEPTH_TEST | moderngl.BLEND | moderngl.CULL_FACE)
        if splat:
            mgl.point_size = 1.0
        first_band = min(self._bands.rows_per_band(lattice, indexed=True), lattice.dims[1])
        most = (lattice.dims[0] - 1) * (first_band - 1)  # cells of the largest band
        for first, dims in self._bands(kernel, lattice, indexed=not splat, reverse=True):
            set_uniforms(program, {"u_mesh_dims": dims, "u_first_row": first})
            self._bands.buffer.bind_to_storage_buffer(bindings.DEFORMED.index)
            if splat:  # the vertex shader takes the points in reverse order
                vao = self._resources.vertex_array(program)
                vao.render(moderngl.POINTS, vertices=dims[0] * dims[1])
            else:
                # The first band has the most rows: its indices, in reverse, end with those
                # of any band with fewer rows, which draws that suffix.
                index = self._index_buffer(dims[0], first_band)
                cells = (dims[0] - 1) * (dims[1] - 1)
                vao = self._resources.vertex_array(program, index)
                vao.render(moderngl.TRIANGLES, vertices=6 * cells, first=6 * (most - cells))

    def _index_buffer(self, nx: int, rows: int) -> moderngl.Buffer:
        """Triangles (00, 11, 01), (00, 10, 11) of each cell of a band of ``rows`` rows of
        ``nx`` vertices, in reverse row-major order (the first cell last: it shows)."""

        def indices() -> bytes:
            i = np.arange(nx * rows, dtype=np.uint32).reshape(rows, nx)
            a, b, c, d = i[:-1, :-1], i[:-1, 1:], i[1:, 1:], i[1:, :-1]
            cells = np.stack([a, c, d, a, b, c], axis=-1).reshape(-1, 6)
            return np.ascontiguousarray(cells[::-1]).tobytes()

        return self._resources.keyed_buffer("index", (nx, rows), indices)
