"""The adaptive mesh on the GPU: f evaluated level by level (``mls/points.comp.glsl``, one
batched call per level), the quadtree built on the CPU (:mod:`.mesh`), its triangles
scan-converted by ``adaptive/scan.comp.glsl``: each covered pixel's source point is the
triangle's linear guess refined by a Newton step on its leaf's quadratic patch
(``adaptive/patch.glsl``). One pass where the mesh is an embedding; keys (the first
triangle in scan order wins) only near reversed triangles where its boundary is simple
(:mod:`.folds`), else everywhere. The pass colours RGBA8 targets itself; other
targets get the points, which ``adaptive/fill.frag.glsl`` samples."""

from __future__ import annotations

from typing import Protocol

import moderngl
import numpy as np

from ...core.mesh import MeshLattice
from ...engine.kernel import MLSKernel
from ...gl import bindings
from ...gl.context import GLContext
from ...gl.dispatch import ScanPieces, fill_buffer, run_1d, set_uniforms
from ...gl.resources import Resources
from ..frame import Frame
from .cells import GPUCells, known_points
from .folds import boundary_turns
from .mesh import ROOT_STEP, AdaptiveMesh, build_adaptive, check_adaptive
from .patch import SLOPE_X, SLOPE_Y

__all__ = ["NONE", "AdaptiveScan", "Fill"]

#: The source point of a pixel no triangle covers (ADAPTIVE_NONE in the shaders).
NONE = 3.0e38


class Fill(Protocol):
    """A construction's choices, as the pipeline passes them."""

    linear: bool
    flip_y: bool
    border: int  # WARP_BORDER
    tolerance: float


class AdaptiveScan:
    """The adaptive path of a pipeline (its GL objects are the pipeline's ``resources``)."""

    def __init__(self, gl: GLContext, resources: Resources) -> None:
        self._gl = gl
        self._resources = resources
        #: Triangles the last :meth:`draw` drew with keys: 0 for an embedding, those near
        #: reversed triangles where the boundary is simple, else all.
        self.last_keyed = 0

    def build(self, kernel: MLSKernel, lattice: MeshLattice, tolerance: float) -> AdaptiveMesh:
        """The adaptive mesh over ``lattice``'s cells (the roots), f from ``kernel``, the
        cells tested and their children predicted on the GPU, in one pass per level
        (:mod:`.cells`)."""
        cells = GPUCells(self._gl, self._resources, kernel, lattice.shape, tolerance)
        return build_adaptive(
            cells.evaluate,
            lattice,
            tolerance,
            test=cells.test,
            known=known_points(kernel, lattice.shape),
        )

    def mesh(self, kernel: MLSKernel, shape: tuple[int, int], tolerance: float) -> AdaptiveMesh:
        """The adaptive mesh that ``quads`` with ``tolerance`` draws for an image of ``shape``
        (border ``constant``: no margin)."""
        lattice = MeshLattice.corners(shape, ROOT_STEP)
        return self.build(kernel, lattice, check_adaptive("quads", 1, tolerance))  # type: ignore[arg-type]

    def render(
        self,
        kernel: MLSKernel,
        lattice: MeshLattice,
        source: moderngl.Texture,
        framebuffer: moderngl.Framebuffer,
        frame: Frame,
        how: Fill,
    ) -> None:
        """Build the mesh over ``lattice``'s cells (the roots) and fill ``framebuffer``, whose
        viewport must have the size of ``frame`` (``ValueError`` otherwise)."""
        linear, flip_y, border, tolerance = how.linear, how.flip_y, how.border, how.tolerance
        if tuple(framebuffer.viewport) != (0, 0, *frame.size):
            raise ValueError(
                f"tolerance= needs a viewport of the output's size {frame.size}, "
                f"got {tuple(framebuffer.viewport)}"
            )
        mesh = self.build(kernel, lattice, tolerance)
        fill = {"linear": linear, "coords": False, "flip_y": flip_y, "border": border}
        self.draw(mesh, source, frame, framebuffer, **fill)

    def draw(
        self,
        mesh: AdaptiveMesh,
        source: moderngl.Texture | None,
        frame: Frame,
        framebuffer: moderngl.Framebuffer,
        *,
        linear: bool,
        coords: bool,
        flip_y: bool,
        border: int,
    ) -> None:
        """Fill ``framebuffer`` (its viewport has ``frame``'s size) from ``mesh``: the colour
        of ``source`` at each pixel's source point, or (``coords``) the point itself."""
        gl = self._gl
        count = len(mesh.triangles)
        if count == 0:
            return
        self._upload(mesh, frame)
        target = framebuffer.color_attachments[0] if framebuffer.color_attachments else None
        # straight into an RGBA8 texture: the pass samples and stores the colours itself
        colour = source is not None and not coords and not flip_y and bindings.holds_texels(target)
        values = {
            **frame.uniforms(),
            "u_triangles": count,
            "u_flip_y": flip_y,
            "u_source_size": (0, 0) if source is None else tuple(source.size),
        }
        if source is not None and not coords:
            mode = moderngl.LINEAR if linear else moderngl.NEAREST
            source.filter = (mode, mode)
            source.use(bindings.SOURCE.index)
        # nearest from RGBA8 to RGBA8: texels copied whole through r32ui images
        texels = colour and not linear and bindings.holds_texels(source)
        if texels:
            bindings.bind_texels(source, bindings.TEXEL_SOURCE, write=False)  # type: ignore[arg-type]
            bindings.bind_texels(target, bindings.TEXEL_TARGET, write=True)  # type: ignore[arg-type]
        elif colour:
            target.bind_to_image(bindings.ADAPTIVE_TARGET.index, read=False, write=True)  # type: ignore[union-attr]
        else:
            self._clear_points(frame)
        self._scan(
            mesh,
            frame,
            values,
            {
                "ADAPTIVE_COLOUR": colour,
                "ADAPTIVE_TEXELS": texels,
                "WARP_LINEAR": linear,
                "WARP_BORDER": border,
            },
        )
        if colour:
            gl.mgl.memory_barrier()  # the image stores before the caller reads the texture
            return
        # a GPU-side copy: texel fetches are what a fragment shader reads fastest
        width, height = frame.size
        points_texture = self._resources.texture("adaptive-points", (width, height), 2, "f4")
        points_texture.write(self._resources.cached("adaptive-points"))
        points_texture.use(bindings.COORDS.index)
        fill = gl.program(
            "common/fullscreen.vert.glsl",
            "adaptive/fill.frag.glsl",
            {
                "WARP_LINEAR": linear,
                "WARP_OUTPUT_COORDS": coords,
                "WARP_BORDER": border,
                "ADAPTIVE_NONE": NONE,
            },
        )
        set_uniforms(fill, values)
        framebuffer.use()
        gl.mgl.disable(moderngl.DEPTH_TEST | moderngl.BLEND | moderngl.CULL_FACE)
        self._resources.vertex_array(fill).render(moderngl.TRIANGLES, vertices=3)

    def _upload(self, mesh: AdaptiveMesh, frame: Frame) -> None:
        """The mesh's vertices (in the output frame), triangles and leaf patches, in their
        tables (:mod:`glmls.gl.tables`: the scan reads them triangle by triangle), bound."""
        tables = self._resources.tables
        # column by column: numpy copies (N, 2) into strided (N, 4) columns ~5x slower
        vertices = np.empty((len(mesh.source), 4), np.float32)
        for axis in (0, 1):
            vertices[:, axis] = mesh.deformed[:, axis] - frame.origin[axis]
            vertices[:, 2 + axis] = mesh.source[:, axis]
        indices = np.empty((len(mesh.triangles), 4), np.uint32)
        for corner in (0, 1, 2):
            indices[:, corner] = mesh.triangles[:, corner]
        indices[:, 3] = mesh.triangle_leaf
        leaves = _leaf_patches(mesh, frame).reshape(-1, 4)
        tables.write("adaptive-vertices", vertices, bindings.ADAPTIVE_VERTICES.index)
        tables.write("adaptive-triangles", indices, bindings.ADAPTIVE_TRIANGLES.index)
        tables.write("adaptive-leaves", leaves, bindings.ADAPTIVE_LEAVES.index)

    def _clear_points(self, frame: Frame) -> None:
        """The per-pixel source points, all :data:`NONE` (and a spare element), bound."""
        gl = self._gl
        points = self._resources.buffer("adaptive-points", (frame.pixels + 1) * 8)
        points.bind_to_storage_buffer(bindings.ADAPTIVE_POINTS.index)
        clear = gl.compute("adaptive/clear.comp.glsl", {"ADAPTIVE_NONE": NONE})
        set_uniforms(clear, {"u_count": frame.pixels})
        run_1d(clear, frame.pixels, max_groups=gl.limits["max_work_groups_x"])

    def _scan(self, mesh: AdaptiveMesh, frame: Frame, values: dict, defines: dict) -> None:
        """The scan passes. An embedding: one pass, no keys. A simple boundary with reversed
        triangles: one pass for the triangles away from them, which lists the others, then
        keys and points for the listed ones. Otherwise keys, then points, for all. The
        boundary is checked here, the triangles on the GPU (:meth:`_reversed`), after the
        one pass where no leaf folds (:meth:`_one_pass_found_none`)."""
        count = len(mesh.triangles)
        simple, orientation = boundary_turns(mesh)
        values = values | {"u_orientation": orientation}
        self.last_keyed = 0
        if simple and self._likely_embedded(mesh):
            if self._one_pass_found_none(count, values, defines):
                return
        hot = None
        if simple:
            hot, layout, reversed_ = self._reversed(count, frame, orientation)
            if reversed_ == 0:
                self._run(count, values, defines | {"ADAPTIVE_FILL": 2})
                return
        winner = self._resources.buffer("adaptive-winner", frame.pixels * 4)
        fill_buffer(self._gl, winner, frame.pixels * 4)
        winner.bind_to_storage_buffer(bindings.WINNER.index)
        if hot is None:
            self.last_keyed = count
            for fill_pass in (0, 1):
                self._run(count, values, defines | {"ADAPTIVE_FILL": fill_pass})
            return
        self._run(count, values | layout, defines | {"ADAPTIVE_FILL": 2, "ADAPTIVE_HOT": True})
        listed = int(np.frombuffer(hot.read(size=4), np.uint32)[0])
        self.last_keyed = listed
        for fill_pass in (0, 1):
            keyed = defines | {"ADAPTIVE_FILL": fill_pass, "ADAPTIVE_LIST": True}
            self._run(listed, values | layout, keyed)

    @staticmethod
    def _likely_embedded(mesh: AdaptiveMesh) -> bool:
        """No leaf of ``mesh`` folds (every estimate finite): its triangles most likely all
        keep their orientation."""
        return bool(np.isfinite(mesh.estimate).all())

    def _one_pass_found_none(self, count: int, values: dict, defines: dict) -> bool:
        """Draw the mesh in the one pass of an embedding before any check (no leaf folds, so
        it most likely is one), counting the triangles the fold check would find; whether
        it found none. Where it found some, the checked passes draw the mesh again, and
        they write every pixel this pass wrote (a pixel it wrote is covered, and they write
        every covered pixel): the image is theirs. W1 saves the check (~1.2 ms)."""
        found = self._hot_buffer(16)
        self._run(count, values, defines | {"ADAPTIVE_FILL": 2})
        return _reversed_count(found) == 0

    def folds(self, mesh: AdaptiveMesh, frame: Frame) -> tuple[bool, int, np.ndarray]:
        """What the scan finds of ``mesh``'s folds, drawn into ``frame``: whether its
        boundary is simple, and where it is, how many triangles are reversed (or nearly
        degenerate) and the 8 x 8 px tiles they reach, (rows, words) uint32 bits as
        :func:`.folds.hot_tiles` (else 0 and no bits). It uploads the mesh."""
        if len(mesh.triangles) == 0:
            raise ValueError("the mesh has no triangles: nothing to check")
        simple, orientation = boundary_turns(mesh)
        if not simple:
            return False, 0, np.zeros((0, 0), np.uint32)
        count = len(mesh.triangles)
        rows, words = _tiles(frame)
        with self._gl.use():
            self._upload(mesh, frame)
            hot, _, reversed_ = self._reversed(count, frame, orientation)
            data = hot.read(size=4 * rows * words, offset=16 + 4 * count)
        return True, reversed_, np.frombuffer(data, np.uint32).reshape(rows, words)

    def _reversed(self, count: int, frame: Frame, orientation: float):
        """The triangles not of the mesh's ``orientation`` (or nearly degenerate), found on
        the GPU (``adaptive/folds.comp.glsl``; float64 reference
        :func:`.folds.check_folds`) with the 8 x 8 px tiles they reach
        (:func:`.folds.hot_tiles`): the buffer (bound) that holds the tiles' bits
        and the scan's list, the uniforms of its layout, and how many triangles."""
        gl = self._gl
        rows, words = _tiles(frame)
        bits = 16 + 4 * count
        size = bits + 4 * words * rows
        hot = self._hot_buffer(size)
        hot.clear(size=size - bits, offset=bits)
        layout = {"u_hot_bits": count, "u_hot_words": words}
        check = gl.compute("adaptive/folds.comp.glsl")
        set_uniforms(check, layout | {"u_target_size": frame.size, "u_orientation": orientation})
        run_1d(check, count, max_groups=gl.limits["max_work_groups_x"])
        gl.mgl.memory_barrier()
        return hot, layout, _reversed_count(hot)

    def _hot_buffer(self, size: int) -> moderngl.Buffer:
        """The buffer of adaptive/mesh.glsl's AdaptiveHot block (``size`` bytes at
        least), its counters (the listed and the reversed triangles) zero, bound."""
        hot = self._resources.buffer("adaptive-hot", size)
        hot.clear(size=16)
        hot.bind_to_storage_buffer(bindings.ADAPTIVE_HOT.index)
        return hot

    def _run(self, count: int, values: dict, defines: dict) -> None:
        """One scan pass over ``count`` triangles (or listed ones)."""
        gl = self._gl
        scan = gl.compute("adaptive/scan.comp.glsl", defines)
        set_uniforms(scan, values)
        # with the pieces of large triangles on llvmpipe (common/pieces.glsl)
        ScanPieces(gl).run_1d(scan, count, max_groups=gl.limits["max_work_groups_x"])
        gl.mgl.memory_barrier()


def _reversed_count(hot: moderngl.Buffer) -> int:
    """The reversed (or nearly degenerate) triangles that a fold check or the one pass
    counted in ``hot`` (:meth:`AdaptiveScan._hot_buffer`)."""
    return int(np.frombuffer(hot.read(size=4, offset=4), np.uint32)[0])


def _tiles(frame: Frame) -> tuple[int, int]:
    """The 8 x 8 px tiles of ``frame`` as the fold check marks them: rows, and uint32 words
    of bits per row (as :func:`.folds.hot_tiles`)."""
    width, height = frame.size
    return (height + 7) // 8, ((width + 7) // 8 + 31) // 32


def _leaf_patches(mesh: AdaptiveMesh, frame: Frame) -> np.ndarray:
    """(L, 6, 4) float32: what ``adaptive/patch.glsl`` reads of each leaf: its centre
    and size, f at its centre node in the output frame and its orientation, and its patch in
    powers (:attr:`~.mesh.AdaptiveMesh.powers`, worked out in float64), the x's four
    and four, then the y's."""
    count = len(mesh.leaves)
    leaves = np.empty((count, 6, 4), np.float32)
    # column by column, 1-D: numpy copies a transposed or stacked array of short rows
    # several times slower
    x0, y0, x1, y1 = (np.ascontiguousarray(mesh.leaves[:, k]) for k in range(4))
    for k, value in enumerate(((x0 + x1) / 2, (y0 + y1) / 2, x1 - x0, y1 - y0)):
        leaves[:, 0, k] = value
    centres = np.ascontiguousarray(mesh.nodes[:, 4])
    for axis in (0, 1):
        leaves[:, 1, axis] = np.take(mesh.deformed[:, axis], centres) - frame.origin[axis]
    powers = mesh.powers
    leaves[:, 2:4] = powers[0].reshape(count, 2, 4)
    leaves[:, 4:6] = powers[1].reshape(count, 2, 4)
    # the Jacobian's orientation at the centre, from the slopes there (a_10 and a_01)
    (ax, ay), (bx, by) = ((powers[0][:, k], powers[1][:, k]) for k in (SLOPE_X, SLOPE_Y))
    turn = np.sign(ax * by - bx * ay)
    leaves[:, 1, 2] = np.where(np.isfinite(mesh.estimate), turn, 0.0)
    leaves[:, 1, 3] = 0.0
    return leaves
