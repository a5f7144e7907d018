"""The quads of the paper's forward method scan-converted in a compute shader
(``glmls/shaders/warp/cells.comp.glsl``): the GL rasterizer's job without its per-triangle setup
(~0.25 us per triangle on llvmpipe: 0.5 s for the 2 million triangles of a 1024^2 image at
grid 1). It needs a viewport of the output canvas's size; other viewports, and keys too long for
31 bits, take the rasterizer (:mod:`glmls.imaging.raster`). A mesh wider than a GL texture
(the corners of an image as wide as the GL limit) is read from the mesh buffer
(:meth:`~glmls.imaging.bands.MeshBands.bind_mesh`).

Fold-overs: each covered pixel keeps, with atomicMax, the key 2^31 - (cell row, cell column,
triangle) of the FIRST triangle in row-major cell order that covers it, so the result does not
depend on the order the invocations run in and is the paper's rule (a marked pixel keeps its
colour), the one the GL rasterizer gets by drawing the cells in reverse order.

Three ways to fill the pixels, fastest first:

- nearest, into an RGBA8 texture from an RGBA8 source ("fused"): the scan conversion writes
  the colours itself and ``warp/cells_fixup.comp.glsl`` corrects fold-overs; a mesh in one
  band is first drawn without keys or atomics and redrawn with them only where
  ``warp/cells_check.comp.glsl`` cannot show it is an embedding ("fast"): only the cells
  that reach a tile near a folded cell, or every cell where the boundary bends too much;
- nearest otherwise: the scan picks each pixel's source pixel, and a draw
  (``warp/cells_nearest.frag.glsl``) copies it;
- linear or source points: ``warp/cells.frag.glsl`` interpolates the winning triangle; a mesh
  too big for one band is evaluated twice (coverage, then each band's pixels).
"""

from __future__ import annotations

import math

import moderngl
import numpy as np

from ..core.mesh import MeshLattice
from ..engine.kernel import MLSKernel
from ..gl import bindings
from ..gl.context import GLContext, current
from ..gl.dispatch import ScanPieces, fill_buffer, set_uniforms
from ..gl.resources import Resources
from .bands import MeshBands
from .frame import Frame
from .options import PipelineOptions

__all__ = ["PATHS", "CellScan", "key_layout"]

_BLOCK = 8  # cells on a side of the blocks of warp/cells_hot.glsl
_MARK_GROUPS = 8  # where warp_check_data holds the marking's work groups (warp/cells_hot.glsl)
_BLOCK_GROUPS = 5  # ... the listing of the blocks' (stage 3's)
_HOT_HEADER = 12  # uints in warp_check_data before the hot tiles (warp/cells_hot.glsl)
#: The fix-up list's header before a scan (warp/cells_packed.glsl): no pixel listed, and its
#: indirect dispatch (x, y, z) of no work groups.
_NO_FIXUPS = np.array([0, 0, 0, 1], np.uint32).tobytes()

#: The ways :meth:`CellScan.draw` filled the pixels (:attr:`CellScan.last_path`).
PATHS = ("fused fast", "fused", "nearest", "interpolated")


def key_layout(lattice: MeshLattice, *, source_pixel: bool) -> tuple[int, int, int] | None:
    """Bit layout of ``warp/cells.comp.glsl``'s triangle keys, (sub bits, column shift, row
    shift), or None where a key would not fit in 31 bits (the rasterizer draws those meshes).

    A key is 2^31 minus the bit fields cell row, cell column, triangle and, with
    ``source_pixel``, the chosen source pixel's column and row inside the cell (``sub bits``
    each), most significant first: the largest key is the first triangle in row-major cell
    order, the one shown where cells fold.
    """
    columns, rows = lattice.cells
    sub_bits = (lattice.grid - 1).bit_length() if source_pixel else 0
    col_shift = 1 + 2 * sub_bits
    row_shift = col_shift + (columns - 1).bit_length()
    if row_shift + (rows - 1).bit_length() > 31:
        return None
    return sub_bits, col_shift, row_shift


def _packable(source: moderngl.Texture | None, target: object) -> bool:
    """Can the fused nearest path write ``target`` from ``source``: single-sample RGBA8
    textures (bound as r32ui images, warp/texels.glsl)."""
    return bindings.holds_texels(source) and bindings.holds_texels(target)


class CellScan:
    """The compute scan conversion of a pipeline (its GL objects are the pipeline's)."""

    #: The fast scan lists up to max(folded_min, cells / 16) folded cells; with more, its
    #: keyed pass redraws every cell (tests lower it to take that way).
    folded_min = 4096

    def __init__(
        self, gl: GLContext, resources: Resources, options: PipelineOptions, bands: MeshBands
    ) -> None:
        self._gl = gl
        self._resources = resources
        self._options = options
        self._bands = bands
        #: How the last :meth:`draw` filled the pixels: one of :data:`PATHS`, or None.
        self.last_path: str | None = None
        self._fast_dims = (1, 1)  # the mesh of the last fast scan
        self._fold_capacity = 0  # and the length of its list of folded cells
        self._pieces = ScanPieces(gl)  # large cells on llvmpipe (common/pieces.glsl)

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
        target: object = None,
    ) -> bool:
        """The quads of ``lattice`` (corners of the source image, possibly with a margin)
        into the bound framebuffer, whose viewport has the size of ``frame`` (the output
        canvas); ``target`` is its colour texture. False (nothing drawn) where the triangle
        keys do not fit in 31 bits; a mesh whose rows do not fit the mesh texture is read
        from the mesh buffer (:meth:`MeshBands.bind_mesh`).
        ``coords``: write the source points instead of colours (the backward method's first
        guess; ``source`` unused). ``border``: the code of the rule for source pixels past
        the image (``WARP_BORDER``)."""
        height, width = lattice.shape
        nearest = not linear and not coords
        layout = key_layout(lattice, source_pixel=nearest)
        if layout is None:
            return False
        mesh = self._bands.mesh_defines(lattice)  # how the passes read the mesh
        sub_bits, col_shift, row_shift = layout
        fused = nearest and not flip_y and _packable(source, target)
        sc = kernel.scaling
        values = {
            "u_center": sc.center,
            "u_scale": sc.scale,
            **frame.uniforms(kernel),
            "u_source_size": (width, height),
            **lattice.pixel_uniforms(),
            "u_sub_bits": sub_bits,
            "u_col_shift": col_shift,
            "u_row_shift": row_shift,
            "u_fixup_capacity": self._options.fixup_capacity(frame.pixels),
        }
        border = 0 if coords else border
        pixels = frame.pixels
        # padded to whole uvec4s for the clear of warp/cells_check.comp.glsl
        winner = self._resources.buffer("winner", (pixels + 3) // 4 * 16)
        fast = fused and self._options.fast_embedded and self._bands.one_band(lattice)
        if not fast:  # the fast path clears it on the GPU if and when it needs it
            fill_buffer(self._gl, winner, pixels * 4)
        if fused:
            self._prepare_fused(values["u_fixup_capacity"])  # type: ignore[arg-type]
        if fast:
            values.update(self._hot_tiles(lattice, frame))
        cells = self._program(
            mesh, nearest=nearest, fused=fused, fast=False, border=border, hot=fast
        )
        set_uniforms(cells, values)
        bands = 0
        for first, dims in self._bands(kernel, lattice):
            set_uniforms(cells, {"u_mesh_dims": dims, "u_first_row": first})
            self._bands.bind_mesh(lattice, dims)
            winner.bind_to_storage_buffer(bindings.WINNER.index)
            if fused:
                self._bind_fused(source, target)  # type: ignore[arg-type]
            if fast:
                band = values | {"u_mesh_dims": dims, "u_first_row": first}
                self._scan_fast(cells, band, border, mesh)
            else:
                self._pieces.run_1d(
                    cells, (dims[0] - 1) * (dims[1] - 1), max_groups=self._max_groups
                )
            bands += 1
        self._gl.mgl.memory_barrier()
        if fused:
            self._fix_up(values, source, target, border)  # type: ignore[arg-type]
            self.last_path = "fused fast" if fast else "fused"
        else:
            whole_mesh = dims if bands == 1 else None
            self._resolve(
                kernel, source, lattice, values, (linear, coords, flip_y, border), whole_mesh
            )
            self.last_path = "nearest" if nearest else "interpolated"
        return True

    @property
    def _max_groups(self) -> int:
        return self._gl.limits["max_work_groups_x"]

    @current
    def embedding_counts(self) -> tuple[int, int]:
        """(cells not strictly positive plus boundary edges not turning, boundary crossings)
        that the last fast scan counted (``warp/cells_check.comp.glsl``; (0, 1) means an
        embedding). Reads back: for tests and diagnostics, not frames."""
        self._gl.mgl.memory_barrier()
        counts = np.frombuffer(self._resources.cached("check").read(size=12), np.uint32)
        return int(counts[0] + counts[2]), int(counts[1])

    @current
    def redrawn_cells(self) -> int:
        """How many cells the keyed pass of the last fast scan redrew (0 where the mesh was
        an embedding): those reaching a hot tile (on llvmpipe each piece of a cell walked
        in pieces counts, ``common/pieces.glsl``), or all where the boundary failed its test
        or more cells folded than it lists. Reads back: for tests and diagnostics, not
        frames."""
        self._gl.mgl.memory_barrier()
        bad, crossings, folded, redrawn = np.frombuffer(
            self._resources.cached("check").read(size=16), np.uint32
        )
        if bad == 0 and crossings == 1 and folded <= self._fold_capacity:
            return int(redrawn)
        nx, ny = self._fast_dims
        return (nx - 1) * (ny - 1)

    def _hot_tiles(self, lattice: MeshLattice, frame: Frame) -> dict[str, int]:
        """The uniforms of the hot-tile map of the fast scan (warp/cells_hot.glsl): tiles of
        2 px at grid 1, 4 px otherwise, each row of tiles in whole uints."""
        shift = 1 if lattice.grid == 1 else 2
        width, _ = frame.size
        words = ((width - 1 >> shift) + 32) // 32
        return {"u_hot_shift": shift, "u_hot_words": words}

    def _program(
        self,
        mesh: dict[str, bool],
        *,
        nearest: bool,
        fused: bool,
        fast: bool,
        border: int,
        hot: bool = False,
    ) -> moderngl.ComputeShader:
        """The scan's program; ``mesh``: how it reads the mesh (:meth:`MeshBands.mesh_defines`)."""
        return self._gl.compute(
            "warp/cells.comp.glsl",
            {
                "WARP_CELLS_SOURCE": nearest,
                "WARP_CELLS_FUSED": fused,
                "WARP_CELLS_FAST": fast,
                "WARP_CELLS_HOT": hot,
                "WARP_BORDER": border if fused else 0,
                **mesh,
            },
        )

    def _scan_fast(
        self,
        keyed: moderngl.ComputeShader,
        values: dict[str, object],
        border: int,
        mesh: dict[str, bool],
    ) -> None:
        """The fused scan of a whole mesh (one band): the pass without keys, which lists the
        folded cells; the embedding test, which marks the tiles near them and lists the
        blocks of cells that reach those (warp/cells_hot.glsl); the clear of the winner
        buffer and the keyed redraw, dispatched indirectly with sizes the test wrote
        (warp/cells_check.comp.glsl): nothing where the mesh is an embedding, the cells of
        the listed blocks that reach a hot tile (``keyed``, ``WARP_CELLS_HOT``) where cells
        fold inside a simple boundary, every cell (a keyed pass without it) where the
        boundary fails or more cells fold than the list holds (one in 16). ``mesh``: as
        :meth:`_program` takes it."""
        gl = self._gl
        stages = {
            stage: gl.compute("warp/cells_check.comp.glsl", {"WARP_CHECK_STAGE": stage, **mesh})
            for stage in (1, 2, 3, 6)
        }
        fast = self._program(mesh, nearest=True, fused=True, fast=True, border=border)
        every = self._program(mesh, nearest=True, fused=True, fast=False, border=border)
        nx, ny = self._fast_dims = values["u_mesh_dims"]  # type: ignore[misc]
        cells = (nx - 1) * (ny - 1)
        blocks = math.ceil((nx - 1) / _BLOCK) * math.ceil((ny - 1) / _BLOCK)
        _, height = values["u_target_size"]  # type: ignore[misc]
        shift, words = values["u_hot_shift"], values["u_hot_words"]
        # warp_check_data: a header, the hot tiles, the folded blocks' bits, the folded cells,
        # the listed blocks (warp/cells_hot.glsl)
        folded_blocks = _HOT_HEADER + words * ((height - 1 >> shift) + 1)  # type: ignore[operator]
        folded_list = folded_blocks + (blocks + 31) // 32
        capacity = self._fold_capacity = max(self.folded_min, cells // 16)
        block_list = folded_list + capacity
        values = values | {
            "u_folded_blocks": folded_blocks,
            "u_folded_list": folded_list,
            "u_folded_capacity": capacity,
            "u_block_list": block_list,
        }
        for program in (fast, every, keyed, *stages.values()):
            set_uniforms(program, values)
        check = self._resources.buffer("check", 48 + 4 * (block_list + blocks))
        check.clear(size=48 + 4 * folded_list)
        check.bind_to_storage_buffer(bindings.CHECK.index)
        pieces = self._pieces
        pieces.run_1d(fast, cells, max_groups=self._max_groups)
        gl.mgl.memory_barrier()
        stages[1].run(group_x=1)  # the boundary's test, then the sizes of what follows
        gl.mgl.memory_barrier()
        # indirect from here, sized by stage 1 (and the keyed scan of the blocks by stage 3):
        # an embedding runs none of them
        stages[6].run_indirect(check, offset=48 + 4 * _MARK_GROUPS)
        gl.mgl.memory_barrier()
        stages[3].run_indirect(check, offset=48 + 4 * _BLOCK_GROUPS)
        stages[2].run_indirect(check, offset=16)
        gl.mgl.memory_barrier()
        set_uniforms(every, {"u_offset": 0})
        for program, offset in ((every, 32), (keyed, 48)):
            pieces.start(program)
            program.run_indirect(check, offset=offset)
            pieces.finish(program)

    def _prepare_fused(self, capacity: int) -> None:
        """An empty fix-up list, its dispatch of no work groups (the textures need no
        preparing: warp/texels.glsl reads and writes them as r32ui images, with no copies)."""
        self._resources.buffer("fixups", 16 + 4 * capacity).write(_NO_FIXUPS)

    def _bind_fused(self, source: moderngl.Texture, target: moderngl.Texture) -> None:
        bindings.bind_texels(source, bindings.TEXEL_SOURCE, write=False)
        bindings.bind_texels(target, bindings.TEXEL_TARGET, write=True)
        self._resources.cached("fixups").bind_to_storage_buffer(bindings.FIXUPS.index)

    def _fix_up(
        self,
        values: dict[str, object],
        source: moderngl.Texture,
        target: moderngl.Texture,
        border: int,
    ) -> None:
        """warp/cells_fixup.comp.glsl over the listed pixels: an indirect dispatch whose
        size the scan set as it listed them (no read-back; no work where none was listed)."""
        fixup = self._gl.compute("warp/cells_fixup.comp.glsl", {"WARP_BORDER": border})
        self._bind_fused(source, target)
        self._resources.cached("winner").bind_to_storage_buffer(bindings.WINNER.index)
        set_uniforms(fixup, values)
        fixup.run_indirect(self._resources.cached("fixups"), offset=4)
        self._gl.mgl.memory_barrier()  # the image stores before the target is read or drawn

    def _resolve(self, kernel, source, lattice, values, how, whole_mesh):
        """Fill the bound framebuffer from the winner buffer with full-viewport draws;
        ``how``: (linear, coords, flip_y, border). ``whole_mesh``: the dims of the mesh
        still in the mesh buffer, None if it was done in bands (it is then evaluated
        again, band by band)."""
        linear, coords, flip_y, border = how
        nearest = not linear and not coords
        vertex = "common/fullscreen.vert.glsl"
        if nearest:
            program = self._gl.program(
                vertex,
                "warp/cells_nearest.frag.glsl",
                {"WARP_LINEAR": False, "WARP_BORDER": border},
            )
        else:
            defines = {"WARP_LINEAR": linear, "WARP_OUTPUT_COORDS": coords, "WARP_BORDER": border}
            mesh = self._bands.mesh_defines(lattice)
            program = self._gl.program(vertex, "warp/cells.frag.glsl", defines | mesh)
        set_uniforms(program, values | {"u_flip_y": flip_y})
        if source is not None and not coords:
            mode = moderngl.LINEAR if linear else moderngl.NEAREST
            source.filter = (mode, mode)
            source.use(bindings.SOURCE.index)
        self._gl.mgl.disable(moderngl.DEPTH_TEST | moderngl.BLEND | moderngl.CULL_FACE)
        width, height = values["u_target_size"]
        winner_texture = self._resources.texture("winner", (width, height), 1, "u4")
        winner_texture.write(self._resources.cached("winner"))  # a copy on the GPU side
        winner_texture.use(bindings.WINNER_TEXTURE.index)
        vao = self._resources.vertex_array(program)
        if nearest:
            vao.render(moderngl.TRIANGLES, vertices=3)
            return
        if whole_mesh is not None:
            bands = iter([(0, whole_mesh)])
        else:
            bands = self._bands(kernel, lattice)
        for first, dims in bands:
            set_uniforms(program, {"u_mesh_dims": dims, "u_first_row": first})
            self._bands.bind_mesh(lattice, dims)
            vao.render(moderngl.TRIANGLES, vertices=3)
