"""The GPU path of a batch for ``paper-quads``: the paper's squares of pixel centres of many
images of one shape scanned in one submission per chunk (:mod:`.forward` runs the chunks).

Per chunk of images:

1. f at every image's pixel centres (the lattice of the single warp: past the image by its
   mesh's margin and one pixel more with a border mode) in one dispatch into the mesh table
   (:func:`~glmls.batch.drawer.upload_meshes`);
2. ONE dispatch of ``batch/paper_quads.comp.glsl`` scans every square of every image, an
   invocation per square, with the single scan's arithmetic (``warp/paper_scan.glsl``):
   per pixel of the atlas of the output canvases the key of the first square in scan order
   that contains it and of its vertex nearest to the pixel centre; ``linear``: a second
   dispatch writes, at the pixels each square won, the source point under the inverse of its
   bilinear map;
3. ONE draw (``batch/paper_quads.frag.glsl``) fills the atlas from the keys (nearest: the
   vertex's source pixel; linear: the source point sampled bilinearly), and in more
   attachments of the same draw the masks (nearest) and, for keypoints and maps, the numbers
   of the source pixels drawn;
4. ONE read-back.

Each image equals its :func:`glmls.warp`, bit for bit.
"""

from __future__ import annotations

import moderngl
import numpy as np

from ..core.mesh import MeshLattice
from ..core.paper_quads import EDGE_TOLERANCE
from ..gl import bindings
from ..gl.context import current
from ..gl.dispatch import ScanPieces, fill_buffer, set_uniforms
from ..gl.resources import keep_framebuffer
from ..imaging.frame import Frame
from ..imaging.options import WarpOptions
from ..imaging.paper import MAX_SQUARES
from ..imaging.source import BORDERS, SourceImage
from .canvases import ForwardTargets
from .drawer import BatchDrawer, mesh_stride, upload_meshes

__all__ = ["MAX_ITEMS", "BatchPaper", "chunk_squares", "paper_lattice"]

#: The most items (squares of all of a chunk's images) one scan takes: the shader's item
#: number is a signed 32-bit integer.
MAX_ITEMS = (1 << 31) - 1


def paper_lattice(shape: tuple[int, int], margin: int, border: str) -> MeshLattice | None:
    """The single warp's lattice of ``paper-quads`` for an image of ``shape`` (H, W) whose
    corner mesh has ``margin`` past the image (0 with the ``constant`` border): the pixel
    centres, one pixel past that margin with a border mode, so that their deformed border
    encloses the corners'. None where the single warp refuses it (no square of four pixel
    centres, or more than :data:`~glmls.imaging.paper.MAX_SQUARES`): the single path names
    the image."""
    lattice = MeshLattice.centres(shape, margin=margin + 1 if border != "constant" else 0)
    columns, rows = lattice.dims
    if columns < 2 or rows < 2 or (columns - 1) * (rows - 1) > MAX_SQUARES:
        return None
    return lattice


def chunk_squares(lattice: MeshLattice) -> int:
    """The most images whose squares on ``lattice`` one scan takes."""
    columns, rows = lattice.dims
    return max(1, MAX_ITEMS // ((columns - 1) * (rows - 1)))


class BatchPaper(BatchDrawer):
    """The batched ``paper-quads`` of a context (see the module docstring); one per
    context, :meth:`of`."""

    label = "the batch paper-quads"

    @current
    def warp(
        self,
        lattices,
        sources: list[SourceImage],
        options: WarpOptions,
        frame: Frame,
        background: tuple[float, float, float, float],
        lattice: MeshLattice,
        labels: tuple[list[SourceImage], tuple[float, float, float, float]] | None = None,
        *,
        drawn: bool = False,
    ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
        """The chunk's images filled by the squares of ``lattice`` (:func:`paper_lattice`):
        (N, H, W, C) in the sources' dtype, the label images (``labels``: the chunk's and
        their background) warped nearest alike or None, and where ``drawn`` the
        (N, H, W, 2) float32 numbers + 1 of the image pixels drawn (0 where none is) or
        None."""
        gl, mgl, resources = self._gl, self._gl.mgl, self._resources
        count = len(sources)
        height, width = sources[0].shape
        upload_meshes(gl, resources, lattices, lattice)  # 1.
        targets = ForwardTargets(
            resources, count, frame, sources[0], background, labels, drawn=drawn
        )
        atlas = targets.size
        pixels = atlas[0] * atlas[1]
        winner = resources.buffer("winner", (pixels + 3) // 4 * 16)
        fill_buffer(gl, winner, pixels * 4)
        linear = options.interpolation == "linear"
        columns, rows = lattice.dims
        values = {
            **lattice.pixel_uniforms(),
            "u_target_size": frame.size,
            "u_origin": frame.origin,
            "u_source_size": (width, height),
            "u_mesh_dims": lattice.dims,
            "u_mesh_stride": mesh_stride(lattice) // 8,
            "u_images": count,
            "u_squares_x": columns - 1,
        }
        items = count * (columns - 1) * (rows - 1)
        mgl.memory_barrier()
        self._scan(values, items, winner, stage=0)  # 2.
        mgl.memory_barrier()
        if linear:  # the source points of the pixels each square won (no fill: the draw
            # reads only the pixels with a key, every one of which the scan writes)
            coords = resources.texture("coords", atlas, 4, "f4", tall=True)
            coords.bind_to_image(bindings.INVERSE_MAP.index, read=False, write=True)
            self._scan(values, items, winner, stage=1)
            mgl.memory_barrier()
            coords.use(bindings.COORDS.index)
        keys = resources.texture("winner", atlas, 1, "u4", tall=True)
        keys.write(winner, viewport=(0, 0, *atlas))  # a copy on the GPU side
        keys.use(bindings.WINNER_TEXTURE.index)
        defines = {
            "WARP_LINEAR": linear,
            "WARP_BORDER": BORDERS.index(options.border),
            "BATCH_FORWARD_LABELS": labels is not None,
            "BATCH_FORWARD_DRAWN": drawn,
        }
        program = gl.program("common/fullscreen.vert.glsl", "batch/paper_quads.frag.glsl", defines)
        set_uniforms(program, values)
        self._sources.bind(sources, targets.label_sources, linear)
        with keep_framebuffer(mgl):  # 3.
            framebuffer = targets.framebuffer
            framebuffer.use()
            framebuffer.viewport = (0, 0, *atlas)
            mgl.disable(moderngl.DEPTH_TEST | moderngl.BLEND | moderngl.CULL_FACE)
            resources.vertex_array(program).render(moderngl.TRIANGLES, vertices=3)
        return targets.read(mgl)  # 4.

    def _scan(self, values, items: int, winner: moderngl.Buffer, *, stage: int) -> None:
        """``batch/paper_quads.comp.glsl`` stage ``stage`` over the chunk's ``items``
        squares, with the pieces of large squares (``common/pieces.glsl``)."""
        gl = self._gl
        defines = {"WARP_PAPER_STAGE": stage, "PAPER_TOLERANCE": EDGE_TOLERANCE}
        program = gl.compute("batch/paper_quads.comp.glsl", defines)
        set_uniforms(program, values)
        winner.bind_to_storage_buffer(bindings.WINNER.index)
        ScanPieces(gl).run_1d(program, items, max_groups=gl.limits["max_work_groups_x"])
