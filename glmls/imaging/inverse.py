"""The backward construction: for each output pixel u the source point s with f(s) = u
(``glmls/shaders/warp/inverse.comp.glsl``).

The first guess is the rasterized piecewise linear inverse of the deformed mesh (the quads,
drawn with their source points instead of colours), then Newton's method on f refines it.
``backward-swap`` instead evaluates the MLS map with p and q swapped, the shortcut of other
MLS tools: the caller passes that map's kernel.
"""

from __future__ import annotations

import moderngl

from ..core.mesh import MeshLattice
from ..engine.kernel import MLSKernel
from ..gl import bindings
from ..gl.context import GLContext, current
from ..gl.dispatch import run_2d, set_uniforms
from ..gl.resources import Resources
from .frame import Frame
from .options import PipelineOptions
from .quads import CellScan
from .raster import MeshRaster

__all__ = ["NEWTON_ACCEPT", "NEWTON_STEPS", "NEWTON_TOLERANCE", "InverseSolver"]

#: Newton on f stops below this residual |f(s) - u| (pixels) ...
NEWTON_TOLERANCE = 1e-3
#: ... or after this many steps; a pixel whose residual stays above NEWTON_ACCEPT (pixels) is
#: left uncovered (no source point found).
NEWTON_STEPS = 8
NEWTON_ACCEPT = 0.05


class InverseSolver:
    """The backward map of a pipeline (its GL objects are the pipeline's)."""

    def __init__(
        self,
        gl: GLContext,
        resources: Resources,
        options: PipelineOptions,
        cells: CellScan,
        raster: MeshRaster,
    ) -> None:
        self._gl = gl
        self._resources = resources
        self._options = options
        self._cells = cells
        self._raster = raster

    @current
    def solve(
        self,
        kernel: MLSKernel,
        lattice: MeshLattice,
        frame: Frame,
        *,
        swap: bool = False,
        border: int = 0,
    ) -> moderngl.Texture:
        """The RGBA32F texture (s.x, s.y, residual in pixels, covered) of the output pixels of
        ``frame`` for ``lattice``'s image (``lattice`` is the first guess's mesh: its grid,
        and its margin past the image for a border mode). ``swap``: ``kernel`` is the
        swapped-handles map, evaluated once per pixel (residual -1). ``border`` 0
        (constant): pixels whose source point lies outside the image are not covered; other
        modes keep them. Leaves the texture's framebuffer bound."""
        height, width = lattice.shape
        framebuffer = self._resources.framebuffer("coords", frame.size)
        texture = self._resources.texture("coords", frame.size, 4, "f4")
        if not swap:
            framebuffer.use()
            framebuffer.viewport = (0, 0, *frame.size)
            self._resources.fill(texture, (0.0, 0.0, 0.0, 0.0))
            drawn = self._options.compute_quads and self._cells.draw(
                kernel, None, lattice, frame, linear=False, coords=True, flip_y=False
            )
            if not drawn:
                self._raster.draw(
                    kernel, None, lattice, frame, linear=False, coords=True, flip_y=False
                )
        program = kernel.program(
            "warp/inverse.comp.glsl",
            {"WARP_SWAP": swap, "WARP_NEWTON_STEPS": NEWTON_STEPS, "WARP_BORDER": border},
        )
        kernel.bind(program, lattice.shape)
        sc = kernel.scaling
        set_uniforms(
            program,
            {
                **frame.uniforms(),
                "u_source_size": (width, height),
                "u_center": sc.center,
                "u_scale": sc.scale,
                "u_tolerance": NEWTON_TOLERANCE,
                "u_accept": NEWTON_ACCEPT,
            },
        )
        self._gl.mgl.memory_barrier()
        texture.bind_to_image(bindings.INVERSE_MAP.index, read=True, write=True)
        run_2d(program, frame.size, max_groups=self._gl.limits["max_work_groups_x"])
        self._gl.mgl.memory_barrier()
        return texture
