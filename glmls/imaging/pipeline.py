"""The GPU pipeline that builds deformed images: f on the mesh, then the quads are filled.

One :class:`WarpPipeline` per GL context (:meth:`WarpPipeline.of`) serves every
:class:`~glmls.MLS` on it, the command line and a window alike: the handles (a deformation's
kernel) are the only thing that changes between frames, every other GL object is cached by
size and reused. Stages never read back in between:

1. ``mls/points.comp.glsl`` writes f at the mesh vertices into a buffer (:mod:`.bands`);
2. ``quads``: the compute scan conversion (:mod:`.quads`) where the viewport has the image's
   size, else the GL rasterizer (:mod:`.raster`), which also draws ``splat``;
   ``paper-quads``: the paper's squares of pixel centres, scanned in a compute shader
   (:mod:`.paper`);
3. ``backward``: the quads' source points as a first guess of f's inverse, refined by
   Newton's method (:mod:`.inverse`), then ``warp/backward.frag.glsl`` samples the source.

:meth:`WarpPipeline.render` draws into any framebuffer (a window's, without read-back);
:meth:`WarpPipeline.warp` and :meth:`WarpPipeline.coordinate_map` are the numpy front ends.
Fold-overs: where deformed quads overlap, the FIRST cell in row-major scan order of the
source (smaller row, then column) shows, as a pixel the paper marks keeps its colour: in every
path of ``quads`` (see :mod:`.quads` and :mod:`.raster`), in ``paper-quads`` (its squares),
``splat`` (its pixels) and ``backward`` (whose first guess is the quads').
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from typing import NamedTuple, Protocol

import moderngl
import numpy as np

from ..core.mesh import MeshLattice, as_shape
from ..engine.kernel import MLSKernel
from ..gl import bindings
from ..gl.context import GLContext, current, get_context
from ..gl.dispatch import set_uniforms
from ..gl.resources import Resources, can_fill
from .adaptive import ROOT_STEP, AdaptiveScan, check_adaptive
from .bands import MeshBands
from .frame import Bounds, Frame, border_margin, deformed_bounds, make_frame
from .inverse import InverseSolver
from .options import PipelineOptions
from .paper import PaperQuads
from .quads import CellScan
from .raster import MeshRaster
from .readback import read_rgba8
from .source import (
    BORDERS,
    SourceImage,
    background_color,
    check_options,
    prepare_image,
    texture_data,
    texture_form,
)

__all__ = ["Deformation", "WarpPipeline"]


class _How(NamedTuple):
    """One construction's choices, as the passes take them."""

    method: str
    linear: bool
    grid: int
    border: int  # the index in BORDERS: WARP_BORDER
    flip_y: bool
    tolerance: float | None = None  # the adaptive mesh's (quads), None: the regular one


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
    to the :class:`~glmls.gl.GLContext` and are shared.
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
        self.paper = PaperQuads(self._gl, self._resources, self._bands)
        self.adaptive = AdaptiveScan(self._gl, self._resources)
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
    def clear(
        self,
        framebuffer: moderngl.Framebuffer,
        color: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0),
    ) -> None:
        """Set ``framebuffer``'s colour to ``color`` (RGBA, 0..1 for 8 bits), as before
        :meth:`render`: an RGBA8 or RGBA32F texture's texels copied from a buffer of the
        colour (:meth:`~glmls.gl.resources.Resources.fill`, several times a GL clear's speed
        on llvmpipe), any other attachment by GL's clear."""
        target = framebuffer.color_attachments[0] if framebuffer.color_attachments else None
        if can_fill(target):
            self._resources.fill(target, color)  # type: ignore[arg-type]
        else:
            with _keep_framebuffer(self._gl.mgl):
                framebuffer.clear(*color)

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
        border: str = "constant",
        frame: Frame | None = None,
        tolerance: float | None = None,
    ) -> None:
        """Draw the deformed ``source`` into ``framebuffer`` (its current viewport), no read-back.

        The caller clears the framebuffer to the background first (:meth:`clear`). The output
        is ``frame`` (default: the source's size and place, see
        :func:`~glmls.imaging.frame.make_frame`);
        ``quads`` and ``splat`` scale it to any viewport, ``backward`` needs a viewport of
        its size, and so does ``paper-quads`` (``ValueError`` otherwise). ``border``: one
        of :data:`~glmls.imaging.source.BORDERS`. ``flip_y`` for a window, whose row 0 is at
        the bottom. ``tolerance``: the adaptive mesh of ``quads`` (:mod:`.adaptive`; a
        viewport of the output's size). The bound framebuffer is left as found.
        """
        self._resources.check_alive()
        check_options(method, interpolation, grid, border)
        tolerance = check_adaptive(method, grid, tolerance)
        width, height = source.size
        if frame is None:
            frame = Frame((height, width))
        how = _How(
            method, interpolation == "linear", grid, BORDERS.index(border), flip_y, tolerance
        )
        with _keep_framebuffer(self._gl.mgl):
            self._render(mls, source, framebuffer, how, frame)

    def _render(self, mls, source, framebuffer, how: _How, frame: Frame) -> None:
        width, height = source.size
        shape = (height, width)
        kernel = mls.kernel
        if how.tolerance is not None:
            lattice = self._lattice(kernel, shape, ROOT_STEP, how.border, frame)
            self.adaptive.render(kernel, lattice, source, framebuffer, frame, how)
            return
        if how.method == "paper-quads":
            if tuple(framebuffer.viewport) != (0, 0, *frame.size):
                raise ValueError(
                    f"method 'paper-quads' needs a viewport of the output's size {frame.size}, "
                    f"got {tuple(framebuffer.viewport)}"
                )
            # the centres one pixel past the corners' margin: their deformed border then
            # encloses what the corners' does (a border mode covers the whole canvas)
            margin = self._lattice(kernel, shape, 1, how.border, frame).margin
            lattice = MeshLattice.centres(shape, margin=margin + 1 if how.border else 0)
            fill = {"linear": how.linear, "flip_y": how.flip_y, "border": how.border}
            self.paper.draw(kernel, source, lattice, frame, framebuffer, **fill)
            return
        if how.method in ("quads", "splat"):
            framebuffer.use()
            splat = how.method == "splat"
            lattice = self._lattice(kernel, shape, 1 if splat else how.grid, how.border, frame)
            fill = {"linear": how.linear, "coords": False, "flip_y": how.flip_y}
            fill["border"] = how.border
            if splat:
                lattice = MeshLattice.centres(shape, margin=lattice.margin)
            elif (
                self.options.compute_quads
                and tuple(framebuffer.viewport) == (0, 0, *frame.size)
                and self.cells.draw(
                    kernel, source, lattice, frame, **fill, target=framebuffer.color_attachments[0]
                )
            ):
                return
            self.raster.draw(kernel, source, lattice, frame, **fill)
            return
        swap = how.method == "backward-swap"
        coords = self._solve(mls, shape, frame, swap=swap, grid=how.grid, border=how.border)
        program = self._gl.program(
            "common/fullscreen.vert.glsl",
            "warp/backward.frag.glsl",
            {"WARP_LINEAR": how.linear, "WARP_BORDER": how.border},
        )
        set_uniforms(
            program,
            {"u_target_size": frame.size, "u_flip_y": how.flip_y, "u_source_size": (width, height)},
        )
        mode = moderngl.LINEAR if how.linear else moderngl.NEAREST
        source.filter = (mode, mode)
        source.use(bindings.SOURCE.index)
        coords.use(bindings.COORDS.index)
        framebuffer.use()
        self._resources.vertex_array(program).render(moderngl.TRIANGLES, vertices=3)

    def _lattice(self, kernel, shape, grid, border, frame, *, forward=True) -> MeshLattice:
        """The corner lattice of the quads: with a border mode, extended past the image as
        far as ``frame`` needs (:func:`~glmls.imaging.frame.border_margin`)."""
        lattice = MeshLattice.corners(shape, grid)
        if border == 0:
            return lattice
        return lattice.with_margin(border_margin(kernel, lattice, frame, warn=forward))

    def _solve(self, mls, shape, frame: Frame, *, swap: bool, grid: int, border: int):
        kernel = mls.swapped_kernel() if swap else mls.kernel
        lattice = (
            MeshLattice.corners(shape, grid)
            if swap
            else self._lattice(kernel, shape, grid, border, frame, forward=False)
        )
        return self._inverse.solve(kernel, lattice, frame, swap=swap, border=border)

    @current
    def solve_inverse(
        self,
        mls: Deformation,
        shape: tuple[int, int],
        *,
        swap: bool = False,
        grid: int = 1,
        border: str = "constant",
        frame: Frame | None = None,
    ) -> moderngl.Texture:
        """The RGBA32F texture (s.x, s.y, residual, covered) of the backward map of an image
        of ``shape``, output pixels of ``frame`` (default: the image's). ``border``
        ``constant``: pixels whose source point is outside the image are not covered."""
        self._resources.check_alive()
        check_options("backward", "nearest", grid, border)
        shape = as_shape(shape)
        frame = Frame(shape) if frame is None else frame
        with _keep_framebuffer(self._gl.mgl):
            return self._solve(
                mls, shape, frame, swap=swap, grid=grid, border=BORDERS.index(border)
            )

    @current
    def bounds(self, mls: Deformation, shape: object, *, grid: int = 1) -> Bounds:
        """The :class:`~glmls.imaging.frame.Bounds` of the deformed image of ``shape``: its
        quads' corners at ``grid`` under f, evaluated band by band on the GPU."""
        self._resources.check_alive()
        lattice = MeshLattice.corners(_within_limit(shape, self.max_image_size), grid)
        kernel = mls.kernel

        def bands():
            for _, (nx, rows) in self._bands(kernel, lattice):
                raw = self._bands.buffer.read(size=nx * rows * 8)
                yield np.frombuffer(raw, np.float32).reshape(-1, 2)

        return deformed_bounds(bands(), kernel)

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
        border: str = "constant",
        output_shape: object = None,
        origin: object = None,
        tolerance: float | None = None,
    ) -> np.ndarray:
        """The deformed image as a new array of ``image``'s dtype and channels, of
        ``output_shape`` (default: the image's); see :meth:`glmls.MLS.warp`."""
        self._resources.check_alive()
        check_options(method, interpolation, grid, border)
        tolerance = check_adaptive(method, grid, tolerance)
        source = prepare_image(image, self.max_image_size, normalized=True)
        frame = make_frame(output_shape, origin, source.shape, self.max_image_size)
        clear = background_color(background, source)
        texture = self.upload(source)
        dtype = "f1" if source.normalized else "f4"
        how = _How(method, interpolation == "linear", grid, BORDERS.index(border), False, tolerance)
        with _keep_framebuffer(self._gl.mgl):
            framebuffer = self._resources.framebuffer("target", frame.size, dtype)
            framebuffer.use()
            framebuffer.viewport = (0, 0, *frame.size)
            self.clear(framebuffer, clear)
            self._render(mls, texture, framebuffer, how, frame)
        if source.normalized:
            return source.restore(read_rgba8(framebuffer, frame.size, source.channels))
        values = np.empty((*frame.shape, 4), np.float32)
        # into an array of its own, writable (read()'s bytes are read-only)
        framebuffer.read_into(values, (0, 0, *frame.size), 4, dtype=dtype)
        return source.restore(values[..., : source.channels])

    @current
    def coordinate_map(
        self,
        mls: Deformation,
        shape: object,
        *,
        method: str = "backward",
        grid: int = 1,
        border: str = "constant",
        output_shape: object = None,
        origin: object = None,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(map (H, W, 2) float32, residual (H, W) float32, covered (H, W) bool) over the
        output canvas (``output_shape``, ``origin``; default: the image's)."""
        self._resources.check_alive()
        if method not in ("backward", "backward-swap"):
            raise ValueError(f"unknown method {method!r}; choose backward or backward-swap")
        check_options(method, "nearest", grid, border)
        shape = _within_limit(shape, self.max_image_size)
        frame = make_frame(output_shape, origin, shape, self.max_image_size)
        texture = self.solve_inverse(
            mls, shape, swap=method == "backward-swap", grid=grid, border=border, frame=frame
        )
        values = np.frombuffer(texture.read(), dtype=np.float32).reshape(*frame.shape, 4)
        residual = values[..., 2].copy()
        if method == "backward-swap":
            residual[:] = np.nan
        return values[..., :2].copy(), residual, values[..., 3] > 0.5

    def release(self) -> None:
        """Free every cached texture, framebuffer, buffer and vertex array. Idempotent."""
        self._resources.release()


@contextlib.contextmanager
def _keep_framebuffer(mgl: moderngl.Context) -> Iterator[None]:
    """Leave the bound framebuffer as found: moderngl re-binds the bound one when it creates
    another, and binding one of ours after we released it is a GL error."""
    bound = mgl.fbo
    if bound is None:  # a standalone context starts with none: framebuffer 0
        bound = mgl.detect_framebuffer(0)
    try:
        yield
    finally:
        bound.use()


def _within_limit(shape: object, limit: int) -> tuple[int, int]:
    """``shape`` as (H, W) if the GL limit (``limit`` pixels a side) takes an image of it;
    ``ValueError`` if not."""
    height, width = as_shape(shape)
    if max(height, width) > limit:
        raise ValueError(
            f"shape {(height, width)} exceeds the GL texture size limit of {limit} pixels"
        )
    return height, width
