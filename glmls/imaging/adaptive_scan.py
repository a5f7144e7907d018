"""The adaptive mesh on the GPU: f evaluated level by level (``mls/points.comp.glsl``, one
batched call per level), the quadtree built on the CPU (:mod:`.adaptive`), its triangles
scan-converted by ``warp/adaptive.comp.glsl`` (first triangle in scan order wins) and the
image filled by ``warp/adaptive.frag.glsl``."""

from __future__ import annotations

from typing import Protocol

import moderngl
import numpy as np

from ..core.mesh import MeshLattice
from ..engine.kernel import MLSKernel
from ..engine.passes import evaluate_points
from ..gl import bindings
from ..gl.context import GLContext
from ..gl.dispatch import run_1d, set_uniforms
from ..gl.resources import Resources
from .adaptive import ROOT_STEP, AdaptiveMesh, build_adaptive, check_adaptive
from .frame import Frame

__all__ = ["AdaptiveScan", "Fill"]


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

    def build(self, kernel: MLSKernel, lattice: MeshLattice, tolerance: float) -> AdaptiveMesh:
        """The adaptive mesh over ``lattice``'s cells (the roots), f from ``kernel``."""

        def evaluate(points: np.ndarray) -> np.ndarray:
            f, _ = evaluate_points(kernel, points, with_matrix=False, shape=lattice.shape)
            return f

        return build_adaptive(evaluate, lattice, tolerance)

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
        vertices = np.empty((len(mesh.source), 4), np.float32)
        vertices[:, :2] = mesh.deformed - np.asarray(frame.origin)
        vertices[:, 2:] = mesh.source
        vertex_buffer = self._resources.buffer("adaptive-vertices", vertices.nbytes)
        vertex_buffer.write(vertices.tobytes())
        index_buffer = self._resources.buffer("adaptive-triangles", mesh.triangles.nbytes)
        index_buffer.write(mesh.triangles.tobytes())
        winner = self._resources.buffer("adaptive-winner", frame.pixels * 4)
        winner.clear(size=frame.pixels * 4)
        vertex_buffer.bind_to_storage_buffer(bindings.DEFORMED.index)
        index_buffer.bind_to_storage_buffer(bindings.POINTS.index)
        winner.bind_to_storage_buffer(bindings.WINNER.index)
        values = {**frame.uniforms(), "u_triangles": count, "u_flip_y": flip_y}
        scan = gl.compute("warp/adaptive.comp.glsl")
        set_uniforms(scan, values)
        run_1d(scan, count, max_groups=gl.limits["max_work_groups_x"])
        gl.mgl.memory_barrier()
        fill = gl.program(
            "common/fullscreen.vert.glsl",
            "warp/adaptive.frag.glsl",
            {"WARP_LINEAR": linear, "WARP_OUTPUT_COORDS": coords, "WARP_BORDER": border},
        )
        height, width = (0, 0) if source is None else (source.size[1], source.size[0])
        set_uniforms(fill, values | {"u_source_size": (width, height)})
        if source is not None and not coords:
            mode = moderngl.LINEAR if linear else moderngl.NEAREST
            source.filter = (mode, mode)
            source.use(bindings.SOURCE.index)
        framebuffer.use()
        gl.mgl.disable(moderngl.DEPTH_TEST | moderngl.BLEND | moderngl.CULL_FACE)
        self._resources.vertex_array(fill).render(moderngl.TRIANGLES, vertices=3)
