"""``method="paper-quads"``: the paper's "forward with polygon interpolation" exactly as its
pseudo-code says (:mod:`glmls.core.paper_quads` is the float64 reference, and says the rules),
on the GPU (``glmls/shaders/warp/paper_quads.comp.glsl``).

The squares are those of four adjacent pixel centres (the lattice of pixel centres, possibly
with a margin past the image for a border mode), coloured by the vertex nearest to each pixel;
where quadrilaterals overlap the first square in row-major scan order keeps the pixel. The
scan records per output pixel the winning square and vertex in one atomic key, then a
full-viewport draw (``warp/paper_quads.frag.glsl``) copies that vertex's source pixel.
``interpolation="linear"`` (the paper's "it can be extended to use more complex interpolation
methods"): a second scan writes, at each pixel its square won, the source point of the pixel
centre under the inverse of Q's bilinear map, sampled bilinearly by
``warp/backward.frag.glsl``: the bilinear blend of the square's four vertex colours.
"""

from __future__ import annotations

import moderngl

from ..core.mesh import MeshLattice
from ..core.paper_quads import EDGE_TOLERANCE
from ..engine.kernel import MLSKernel
from ..gl import bindings
from ..gl.context import GLContext, current
from ..gl.dispatch import ScanPieces, fill_buffer, set_uniforms
from ..gl.resources import Resources
from .bands import MeshBands
from .frame import Frame

__all__ = ["MAX_SQUARES", "PaperQuads"]

#: The most squares a lattice may have: a key ~(4 k + v) must stay nonzero in 32 bits.
MAX_SQUARES = (1 << 30) - 1


class PaperQuads:
    """The ``paper-quads`` construction of a pipeline (its GL objects are the pipeline's)."""

    def __init__(self, gl: GLContext, resources: Resources, bands: MeshBands) -> None:
        self._gl = gl
        self._resources = resources
        self._bands = bands

    @current
    def draw(
        self,
        kernel: MLSKernel,
        source: moderngl.Texture,
        lattice: MeshLattice,
        frame: Frame,
        framebuffer: moderngl.Framebuffer,
        *,
        linear: bool,
        flip_y: bool,
        border: int = 0,
    ) -> None:
        """The squares of ``lattice`` (pixel centres of the source image, possibly with a
        margin) into ``framebuffer``, whose viewport has the size of ``frame`` (the output
        canvas). ``border``: the code of the rule for source pixels past the image."""
        if lattice.kind != "centres":
            raise ValueError(f"paper-quads draws squares of pixel centres, got {lattice.kind}")
        columns, rows = lattice.dims
        if columns < 2 or rows < 2:
            # no square of four pixel centres: every pixel would keep the background
            raise ValueError(
                f"method 'paper-quads' fills squares of four adjacent pixel centres, and an "
                f"image {lattice.shape[1]} pixel{'s' * (lattice.shape[1] != 1)} wide and "
                f"{lattice.shape[0]} high has none; use "
                f"method 'quads', or a border mode other than 'constant'"
            )
        if (columns - 1) * (rows - 1) > MAX_SQUARES:
            raise ValueError(
                f"paper-quads handles at most {MAX_SQUARES} squares of pixel centres; the "
                f"lattice of {columns} x {rows} points (margin {lattice.margin}) has more"
            )
        height, width = lattice.shape
        sc = kernel.scaling
        values = {
            "u_center": sc.center,
            "u_scale": sc.scale,
            **frame.uniforms(kernel),
            "u_source_size": (width, height),
            **lattice.pixel_uniforms(),
            "u_squares_x": columns - 1,
            "u_flip_y": flip_y,
        }
        pixels = frame.pixels
        winner = self._resources.buffer("winner", (pixels + 3) // 4 * 16)
        fill_buffer(self._gl, winner, pixels * 4)
        one_band = self._scan(kernel, lattice, values, stage=0, whole_mesh=None)
        self._gl.mgl.memory_barrier()
        mgl = self._gl.mgl
        mgl.disable(moderngl.DEPTH_TEST | moderngl.BLEND | moderngl.CULL_FACE)
        vertex = "common/fullscreen.vert.glsl"
        if linear:
            map_framebuffer = self._resources.framebuffer("coords", frame.size)
            map_framebuffer.use()
            map_framebuffer.viewport = (0, 0, *frame.size)
            coords = self._resources.texture("coords", frame.size, 4, "f4")
            self._resources.fill(coords, (0.0, 0.0, 0.0, 0.0))  # covered = 0
            coords.bind_to_image(bindings.INVERSE_MAP.index, read=False, write=True)
            self._scan(kernel, lattice, values, stage=1, whole_mesh=one_band)
            mgl.memory_barrier()
            program = self._gl.program(
                vertex, "warp/backward.frag.glsl", {"WARP_LINEAR": True, "WARP_BORDER": border}
            )
            coords.use(bindings.COORDS.index)
        else:
            program = self._gl.program(
                vertex, "warp/paper_quads.frag.glsl", {"WARP_LINEAR": False, "WARP_BORDER": border}
            )
            winner_texture = self._resources.texture("winner", frame.size, 1, "u4")
            winner_texture.write(winner)  # a copy on the GPU side
            winner_texture.use(bindings.WINNER_TEXTURE.index)
        set_uniforms(program, values)
        mode = moderngl.LINEAR if linear else moderngl.NEAREST
        source.filter = (mode, mode)
        source.use(bindings.SOURCE.index)
        framebuffer.use()
        self._resources.vertex_array(program).render(moderngl.TRIANGLES, vertices=3)

    def _scan(self, kernel, lattice, values, *, stage: int, whole_mesh):
        """``warp/paper_quads.comp.glsl`` stage ``stage`` over every band; ``whole_mesh``:
        the dims of a lattice evaluated in one band and still in the mesh buffer (else it is
        evaluated again). Returns the dims if the lattice was one band, else None."""
        program = self._gl.compute(
            "warp/paper_quads.comp.glsl",
            {"WARP_PAPER_STAGE": stage, "PAPER_TOLERANCE": EDGE_TOLERANCE},
        )
        set_uniforms(program, values)
        winner = self._resources.cached("winner")
        bands = (
            iter([(0, whole_mesh)])
            if whole_mesh is not None
            else self._bands(kernel, lattice, squares=True)
        )
        count = 0
        dims = None
        for first, dims in bands:
            set_uniforms(program, {"u_mesh_dims": dims, "u_first_row": first})
            self._bands.buffer.bind_to_storage_buffer(bindings.DEFORMED.index)
            winner.bind_to_storage_buffer(bindings.WINNER.index)
            squares = (dims[0] - 1) * (dims[1] - 1)
            if squares > 0:
                # with the pieces of large squares on llvmpipe (common/pieces.glsl)
                pieces = ScanPieces(self._gl)
                pieces.run_1d(program, squares, max_groups=self._gl.limits["max_work_groups_x"])
            count += 1
        return dims if count == 1 else None
