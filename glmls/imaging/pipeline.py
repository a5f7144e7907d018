"""The GPU pipeline that builds deformed images: f on the mesh, then the quads are filled.

One :class:`WarpPipeline` per GL context (:meth:`WarpPipeline.of`) serves every
:class:`~glmls.MLS` on it, the command line and a window alike: the handles (a deformation's
kernel) are the only thing that changes between frames, every other GL object is cached by
size and reused. Stages never read back in between:

1. ``mls/points.comp.glsl`` writes f at the mesh vertices into a buffer (:mod:`.bands`);
2. ``quads``: the compute scan conversion (:mod:`.cells`) where the viewport has the image's
   size, else the GL rasterizer (:mod:`.raster`), which also draws ``splat``;
3. ``backward``: the quads' source points as a first guess of f's inverse, refined by
   Newton's method (:mod:`.inverse`), then ``warp/backward.frag.glsl`` samples the source.

:meth:`WarpPipeline.render` draws into any framebuffer (a window's, without read-back);
:meth:`WarpPipeline.warp` and :meth:`WarpPipeline.coordinate_map` are the numpy front ends.
Fold-overs: where deformed quads overlap, the cell with the larger source row (then column)
is on top, in every method (see :mod:`.cells`).
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from typing import Protocol

import moderngl
import numpy as np

from ..core.mesh import MeshLattice, as_shape
from ..engine.kernel import MLSKernel
from ..gl import bindings
from ..gl.context import GLContext, current, get_context
from ..gl.dispatch import set_uniforms
from ..gl.resources import Resources
from .bands import MeshBands
from .cells import CellScan
from .inverse import InverseSolver
from .options import PipelineOptions
from .raster import MeshRaster
from .source import (
    SourceImage,
    background_color,
    check_options,
    prepare_image,
    texture_data,
    texture_form,
)

__all__ = ["Deformation", "WarpPipeline"]


class Deformation(Protocol):
    """What the pipeline deforms by (an :class:`~glmls.MLS` is one): the kernel of f, and the
    kernel of the swapped-handles map for ``backward-swap``."""

    @property
    def kernel(self) -> MLSKernel: ...

    def swapped_kernel(self) -> MLSKernel: ...


class WarpPipeline:
    """Cached GL objects and the passes that turn a deformation and a source texture into an
    image. Use the context's shared one, :meth:`of`; a pipeline of one's own (other
    ``options``, e.g. in tests) is released with :meth:`release`.

    Textures and framebuffers are kept for the last size of each role and replaced when the
    size changes; buffers only grow (up to ``options.band_bytes``). Compiled programs belong
    to the :class:`~glmls.GLContext` and are shared.
    """

    def __init__(
        self,
        ctx: moderngl.Context | GLContext | None = None,
        *,
        options: PipelineOptions | None = None,
    ) -> None:
        self._gl = get_context(ctx)
        self.options = options if options is not None else PipelineOptions()
        self._resources = Resources(self._gl, "this warp pipeline")
        self._bands = MeshBands(self._resources, self.options)
        self.cells = CellScan(self._gl, self._resources, self.options, self._bands)
        self.raster = MeshRaster(self._gl, self._resources, self._bands)
        self._inverse = InverseSolver(
            self._gl, self._resources, self.options, self.cells, self.raster
        )

    @classmethod
    def of(cls, ctx: moderngl.Context | GLContext | None = None) -> WarpPipeline:
        """The pipeline shared by everything that renders with ``ctx`` (default: glmls's
        headless context), made on first use and released with the context."""
        gl = get_context(ctx)
        return gl.shared(WarpPipeline, lambda: cls(gl))

    @property
    def ctx(self) -> GLContext:
        return self._gl

    @property
    def max_image_size(self) -> int:
        """Largest image side this context can warp (the GL texture and viewport limit)."""
        limits = self._gl.limits
        return min(limits["max_texture_size"], limits["max_viewport"])

    @contextlib.contextmanager
    def _keep_framebuffer(self) -> Iterator[None]:
        """Leave the bound framebuffer as found: moderngl re-binds the bound one when it
        creates another, and binding one of ours after we released it is a GL error."""
        mgl = self._gl.mgl
        bound = mgl.fbo
        if bound is None:  # a standalone context starts with none: framebuffer 0
            bound = mgl.detect_framebuffer(0)
        try:
            yield
        finally:
            bound.use()

    @current
    def upload(self, image: SourceImage, role: str = "source") -> moderngl.Texture:
        """The pipeline's texture of ``role`` holding ``image`` (see
        :func:`~glmls.imaging.source.texture_form`); it stays the pipeline's, replaced by the
        next upload of that role."""
        texture = self._resources.texture(role, *texture_form(image))
        texture.write(texture_data(image))
        return texture

    # -- drawing -------------------------------------------------------------------------

    @current
    def render(
        self,
        mls: Deformation,
        source: moderngl.Texture,
        framebuffer: moderngl.Framebuffer,
        *,
        method: str = "quads",
        interpolation: str = "nearest",
        grid: int = 1,
        flip_y: bool = False,
    ) -> None:
        """Draw the deformed ``source`` into ``framebuffer`` (its current viewport), no read-back.

        The caller clears the framebuffer to the background first. The output has the
        source's size in pixels; ``quads`` and ``splat`` scale to any viewport, ``backward``
        needs a viewport of that size. ``flip_y`` for a window, whose row 0 is at the bottom.
        The bound framebuffer is left as found.
        """
        self._resources.check_alive()
        check_options(method, interpolation, grid)
        with self._keep_framebuffer():
            self._render(mls, source, framebuffer, method, interpolation == "linear", grid, flip_y)

    def _render(self, mls, source, framebuffer, method, linear, grid, flip_y) -> None:
        width, height = source.size
        shape = (height, width)
        kernel = mls.kernel
        if method in ("quads", "splat"):
            framebuffer.use()
            if method == "splat":
                lattice = MeshLattice.centres(shape)
            else:
                lattice = MeshLattice.corners(shape, grid)
                whole_viewport = tuple(framebuffer.viewport) == (0, 0, width, height)
                if (
                    self.options.compute_quads
                    and whole_viewport
                    and self.cells.draw(
                        kernel,
                        source,
                        lattice,
                        linear=linear,
                        coords=False,
                        flip_y=flip_y,
                        target=framebuffer.color_attachments[0],
                    )
                ):
                    return
            self.raster.draw(
                kernel, source, lattice, (width, height), linear=linear, coords=False, flip_y=flip_y
            )
            return
        swap = method == "backward-swap"
        coords = self._solve(mls, shape, swap=swap, grid=grid)
        program = self._gl.program(
            "common/fullscreen.vert.glsl", "warp/backward.frag.glsl", {"WARP_LINEAR": linear}
        )
        set_uniforms(program, {"u_target_size": (width, height), "u_flip_y": flip_y})
        mode = moderngl.LINEAR if linear else moderngl.NEAREST
        source.filter = (mode, mode)
        source.use(bindings.SOURCE.index)
        coords.use(bindings.COORDS.index)
        framebuffer.use()
        self._resources.vertex_array(program).render(moderngl.TRIANGLES, vertices=3)

    def _solve(self, mls: Deformation, shape, *, swap: bool, grid: int) -> moderngl.Texture:
        kernel = mls.swapped_kernel() if swap else mls.kernel
        return self._inverse.solve(kernel, MeshLattice.corners(shape, grid), swap=swap)

    @current
    def solve_inverse(
        self, mls: Deformation, shape: tuple[int, int], *, swap: bool = False, grid: int = 1
    ) -> moderngl.Texture:
        """The RGBA32F texture (s.x, s.y, residual, covered) of the backward map, output
        pixels of an image of ``shape`` (the output has the source's size)."""
        self._resources.check_alive()
        with self._keep_framebuffer():
            return self._solve(mls, as_shape(shape), swap=swap, grid=grid)

    # -- numpy front ends ----------------------------------------------------------------

    @current
    def warp(
        self,
        mls: Deformation,
        image: object,
        *,
        method: str = "quads",
        interpolation: str = "nearest",
        grid: int = 1,
        background: object = 0,
    ) -> np.ndarray:
        """The deformed image as a new array of ``image``'s shape and dtype."""
        self._resources.check_alive()
        check_options(method, interpolation, grid)
        source = prepare_image(image, self.max_image_size, normalized=True)
        clear = background_color(background, source)
        height, width = source.shape
        texture = self.upload(source)
        dtype = "f1" if source.normalized else "f4"
        with self._keep_framebuffer():
            framebuffer = self._resources.framebuffer("target", (width, height), dtype)
            framebuffer.use()
            framebuffer.viewport = (0, 0, width, height)
            framebuffer.clear(*clear)
            self._render(mls, texture, framebuffer, method, interpolation == "linear", grid, False)
        components = source.channels if source.normalized else 4
        raw = framebuffer.read(viewport=(0, 0, width, height), components=components, dtype=dtype)
        values = np.frombuffer(raw, dtype=np.uint8 if source.normalized else np.float32)
        values = values.reshape(height, width, components)
        return source.restore(values[..., : source.channels])

    @current
    def coordinate_map(
        self, mls: Deformation, shape: object, *, method: str = "backward", grid: int = 1
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(map (H, W, 2) float32, residual (H, W) float32, covered (H, W) bool)."""
        self._resources.check_alive()
        if method not in ("backward", "backward-swap"):
            raise ValueError(f"unknown method {method!r}; choose backward or backward-swap")
        check_options(method, "nearest", grid)
        height, width = as_shape(shape)
        if max(height, width) > self.max_image_size:
            raise ValueError(
                f"shape {(height, width)} exceeds the GL texture size limit of "
                f"{self.max_image_size} pixels"
            )
        texture = self.solve_inverse(
            mls, (height, width), swap=method == "backward-swap", grid=grid
        )
        values = np.frombuffer(texture.read(), dtype=np.float32).reshape(height, width, 4)
        residual = values[..., 2].copy()
        if method == "backward-swap":
            residual[:] = np.nan
        return values[..., :2].copy(), residual, values[..., 3] > 0.5

    def release(self) -> None:
        """Free every cached texture, framebuffer, buffer and vertex array. Idempotent."""
        self._resources.release()
