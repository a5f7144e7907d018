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

from typing import NamedTuple, Protocol

import moderngl
import numpy as np

from ..core.config import check_choice
from ..core.mesh import MeshLattice, as_shape
from ..engine.kernel import MLSKernel
from ..gl import bindings
from ..gl.context import GLContext, current, get_context
from ..gl.dispatch import set_uniforms
from ..gl.dropped import release_when_dropped
from ..gl.resources import Resources, can_fill, keep_framebuffer
from .adaptive import ROOT_STEP, AdaptiveScan
from .bands import MeshBands
from .frame import (
    Bounds,
    Frame,
    border_margin,
    covering_frame,
    deformed_bounds,
    make_frame,
)
from .inverse import IDENTITY_FOUND, InverseSolver
from .options import PipelineOptions, WarpOptions
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

__all__ = ["Deformation", "FillChoices", "WarpPipeline"]


#: f's inverse at points: the first guess's mesh, extended past the image, has at most this
#: many points (at grid 1) or 4 per pixel of the image and per point, whichever is more.
#: Points beyond its reach start Newton from themselves, where f is close to its far-field
#: affine map.
GUESS_MESH_POINTS = 1 << 20


class FillChoices(NamedTuple):
    """What the fill passes take of a :class:`~glmls.imaging.options.WarpOptions` (and of
    the target): the interpolation as a flag, the border as its ``WARP_BORDER`` code."""

    linear: bool
    flip_y: bool
    border: int  # the index in BORDERS: WARP_BORDER
    tolerance: float | None  # the adaptive mesh's (quads), None: the regular one

    @classmethod
    def of(cls, options: WarpOptions, flip_y: bool) -> FillChoices:
        linear = options.interpolation == "linear"
        return cls(linear, flip_y, BORDERS.index(options.border), options.tolerance)


class Deformation(Protocol):
    """What the pipeline deforms by (an :class:`~glmls.MLS` is one): the kernel of f, and the
    kernel of the swapped-handles map for ``backward-swap``."""

    @property
    def kernel(self) -> MLSKernel: ...

    def swapped_kernel(self) -> MLSKernel: ...


class WarpPipeline:
    """The GPU passes that turn a deformation and a source image into the deformed image.

    Their GL objects are cached for the next call.

    One per GL context serves every :class:`~glmls.MLS` on it, the command line and a window
    alike: use the context's shared one, :meth:`of`. A pipeline of one's own (other
    ``options``, e.g. in tests) is released with :meth:`release`; one let go unreleased is
    released by its context at its next use, as an MLS is. Textures and framebuffers are kept
    for the last size of each role and replaced when the size changes; buffers only grow (up
    to ``options.band_bytes``). Compiled programs belong to the :class:`~glmls.gl.GLContext`
    and are shared.

    Parameters
    ----------
    ctx : moderngl.Context or GLContext or None
        The context to render with (default: glmls's shared headless one).
    options : PipelineOptions or None
        Which of the equivalent internal paths to take (default: the fastest).

    Raises
    ------
    glmls.GLUnavailableError
        Where no OpenGL 4.3 context can be made.

    Examples
    --------
    >>> import numpy as np
    >>> import glmls
    >>> pipe = glmls.gl.WarpPipeline.of()
    >>> image = np.arange(24, dtype=np.uint8).reshape(4, 6)
    >>> with glmls.MLS([[0, 0], [5, 3]], [[1, 0], [6, 3]]) as m:
    ...     out = pipe.warp(m, image, glmls.WarpOptions(method="backward"))
    >>> out.tolist()[0]
    [0, 0, 1, 2, 3, 4]
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
        #: Gives the objects of a pipeline let go unreleased back to the context.
        self._when_dropped = release_when_dropped(self._gl, self, self._resources)
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
        """The pipeline shared by everything that renders with ``ctx``.

        Parameters
        ----------
        ctx : moderngl.Context or GLContext or None
            The context (default: glmls's headless one).

        Returns
        -------
        WarpPipeline
            Made on first use, released with the context.
        """
        gl = get_context(ctx)

        def make() -> WarpPipeline:
            pipeline = cls(gl)
            pipeline._when_dropped.detach()  # the context's own, released with it
            return pipeline

        return gl.shared(WarpPipeline, make)

    @property
    def ctx(self) -> GLContext:
        """The :class:`~glmls.gl.GLContext` this pipeline renders with."""
        return self._gl

    @property
    def max_image_size(self) -> int:
        """Largest image side this context can warp (the GL texture and viewport limit)."""
        limits = self._gl.limits
        return min(limits["max_texture_size"], limits["max_viewport"])

    @current
    def upload(self, image: SourceImage, role: str = "source") -> moderngl.Texture:
        """The pipeline's texture of ``role`` holding ``image``.

        Parameters
        ----------
        image : SourceImage
            An image prepared by ``prepare_image`` (the form of
            its texture: ``texture_form``).
        role : str
            The texture's name; the next upload of that role replaces it.

        Returns
        -------
        moderngl.Texture
            The pipeline's texture (do not release it).
        """
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
        """Set ``framebuffer``'s colour to ``color``, as before :meth:`render`.

        An RGBA8 or RGBA32F texture's texels are copied from a buffer of the colour
        (``fill``, several times a GL clear's speed on
        llvmpipe), any other attachment is cleared by GL.

        Parameters
        ----------
        framebuffer : moderngl.Framebuffer
            The target.
        color : tuple of 4 float
            RGBA (0..1 for 8 bits).
        """
        target = framebuffer.color_attachments[0] if framebuffer.color_attachments else None
        if can_fill(target):
            self._resources.fill(target, color)  # type: ignore[arg-type]
        else:
            with keep_framebuffer(self._gl.mgl):
                framebuffer.clear(*color)

    @current
    def render(
        self,
        mls: Deformation,
        source: moderngl.Texture,
        framebuffer: moderngl.Framebuffer,
        options: WarpOptions | None = None,
        *,
        flip_y: bool = False,
        frame: Frame | None = None,
        **keywords: object,
    ) -> None:
        """Draw the deformed ``source`` into ``framebuffer`` (its current viewport), no
        read-back.

        The caller clears the framebuffer to the background first (:meth:`clear`; the
        options' ``background`` is not drawn). ``quads`` and ``splat`` scale the output
        canvas to any viewport; ``backward``, ``paper-quads`` and a ``tolerance`` need a
        viewport of its size. The bound framebuffer is left as found.

        Parameters
        ----------
        mls : Deformation
            What deforms: an :class:`~glmls.MLS`.
        source : moderngl.Texture
            The source image (e.g. from :meth:`upload`).
        framebuffer : moderngl.Framebuffer
            The target.
        options : WarpOptions or None
            The construction (default: ``WarpOptions()``); its ``output_shape`` and
            ``origin`` give the canvas unless ``frame`` does.
        flip_y : bool
            Row 0 at the bottom, as a window's.
        frame : Frame or None
            The output canvas (default: from ``options``, else the source's size and place,
            see ``make_frame``).
        **keywords
            Fields of :class:`~glmls.WarpOptions` replacing those of ``options``.

        Raises
        ------
        ValueError
            For bad options, or a viewport that the construction cannot fill.
        TypeError
            For a keyword that is no field of :class:`~glmls.WarpOptions`.
        """
        self._resources.check_alive()
        options = WarpOptions.of(options, **keywords)
        width, height = source.size
        if frame is None:
            frame = make_frame(
                options.output_shape, options.origin, (height, width), self.max_image_size
            )
        with keep_framebuffer(self._gl.mgl):
            self._render(mls, source, framebuffer, options, frame, flip_y=flip_y)

    def _render(
        self, mls, source, framebuffer, options: WarpOptions, frame: Frame, *, flip_y: bool
    ) -> None:
        width, height = source.size
        shape = (height, width)
        kernel = mls.kernel
        fill = FillChoices.of(options, flip_y)
        method, border = options.method, fill.border
        if fill.tolerance is not None:
            lattice = self._lattice(kernel, shape, ROOT_STEP, border, frame)
            self.adaptive.render(kernel, lattice, source, framebuffer, frame, fill)
            return
        if method == "paper-quads":
            if tuple(framebuffer.viewport) != (0, 0, *frame.size):
                raise ValueError(
                    f"method 'paper-quads' needs a viewport of the output's size {frame.size}, "
                    f"got {tuple(framebuffer.viewport)}"
                )
            # the centres one pixel past the corners' margin: their deformed border then
            # encloses what the corners' does (a border mode covers the whole canvas)
            margin = self._lattice(kernel, shape, 1, border, frame).margin
            lattice = MeshLattice.centres(shape, margin=margin + 1 if border else 0)
            paper = {"linear": fill.linear, "flip_y": flip_y, "border": border}
            self.paper.draw(kernel, source, lattice, frame, framebuffer, **paper)
            return
        if method in ("quads", "splat"):
            framebuffer.use()
            splat = method == "splat"
            lattice = self._lattice(kernel, shape, 1 if splat else options.grid, border, frame)
            quads = {"linear": fill.linear, "coords": False, "flip_y": flip_y, "border": border}
            if splat:
                lattice = MeshLattice.centres(shape, margin=lattice.margin)
            elif (
                self.options.compute_quads
                and tuple(framebuffer.viewport) == (0, 0, *frame.size)
                and self.cells.draw(
                    kernel, source, lattice, frame, **quads, target=framebuffer.color_attachments[0]
                )
            ):
                return
            self.raster.draw(kernel, source, lattice, frame, **quads)
            return
        swap = method == "backward-swap"
        coords = self._solve(mls, shape, frame, swap=swap, grid=options.grid, border=border)
        program = self._gl.program(
            "common/fullscreen.vert.glsl",
            "warp/backward.frag.glsl",
            {"WARP_LINEAR": fill.linear, "WARP_BORDER": border},
        )
        set_uniforms(
            program,
            {"u_target_size": frame.size, "u_flip_y": flip_y, "u_source_size": (width, height)},
        )
        mode = moderngl.LINEAR if fill.linear else moderngl.NEAREST
        source.filter = (mode, mode)
        source.use(bindings.SOURCE.index)
        coords.use(bindings.COORDS.index)
        framebuffer.use()
        self._resources.vertex_array(program).render(moderngl.TRIANGLES, vertices=3)

    def _lattice(self, kernel, shape, grid, border, frame, *, forward=True) -> MeshLattice:
        """The corner lattice of the quads: with a border mode, extended past the image as
        far as ``frame`` needs (``border_margin``)."""
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
        """The backward map of an image of ``shape`` as a texture, left on the GPU.

        Parameters
        ----------
        mls : Deformation
            What deforms.
        shape : (int, int)
            (H, W) of the source image.
        swap : bool
            The swapped-handles map (``backward-swap``) instead of f's inverse.
        grid : int
            The first guess's mesh step, pixels.
        border : str
            ``"constant"``: pixels whose source point is outside the image are not covered;
            the other :data:`~glmls.BORDERS` keep them.
        frame : Frame or None
            The output pixels (default: the image's).

        Returns
        -------
        moderngl.Texture
            The pipeline's RGBA32F texture (s.x, s.y, residual, covered) per output pixel.
        """
        self._resources.check_alive()
        check_options("backward", "nearest", grid, border)
        shape = as_shape(shape)
        frame = Frame(shape) if frame is None else frame
        with keep_framebuffer(self._gl.mgl):
            return self._solve(
                mls, shape, frame, swap=swap, grid=grid, border=BORDERS.index(border)
            )

    @current
    def inverse_points(
        self, mls: Deformation, points: np.ndarray, shape: tuple[int, int], *, grid: int = 1
    ) -> tuple[np.ndarray, np.ndarray]:
        """f's inverse at ``points``: for each point u the source point s with f(s) = u,
        found anywhere in the plane by Newton's method on f (as the ``backward`` method's).

        The first guess is the rasterized inverse of the mesh of an image of ``shape`` (step
        ``grid``), extended past the image until its deformed border encloses the points
        (``border_margin``, within ``GUESS_MESH_POINTS``),
        drawn over a canvas that holds the points
        (``guess_size`` texels). f is the deformation's own, as
        its ``__call__`` evaluates it.

        Parameters
        ----------
        mls : Deformation
            What deforms.
        points : numpy.ndarray
            (K, 2) float64 pixels, finite.
        shape : (int, int)
            (H, W) of the image whose mesh gives the first guess.
        grid : int
            That mesh's step, pixels.

        Returns
        -------
        s : numpy.ndarray
            (K, 2) float64, Newton's last iterate (whether or not it converged).
        residual : numpy.ndarray
            (K,) float64 |f(s) - u| in pixels, as the GPU computed it: s is f's inverse at u
            where it is at most ``NEWTON_ACCEPT``.
        """
        self._resources.check_alive()
        kernel = mls.kernel
        kernel.check_alive()
        shape = as_shape(shape)
        count = len(points)
        if count == 0:
            return np.zeros((0, 2)), np.zeros(0)
        frame = covering_frame(points)
        lattice = MeshLattice.corners(shape, grid)
        budget = max(GUESS_MESH_POINTS, 4 * (shape[0] * shape[1] + count))
        margin = border_margin(kernel, lattice, frame, warn=False, max_points=budget)
        with keep_framebuffer(self._gl.mgl):
            out = self._inverse.solve_points(
                kernel,
                lattice.with_margin(margin),
                frame,
                points,
                shape=kernel.shape,
                limit=self.max_image_size,
            )
        found = kernel.scaling.from_gpu(out[:, :2])
        identity = out[:, 3] == IDENTITY_FOUND  # f leaves u in place: u exactly
        found[identity] = points[identity] - kernel.offset
        return found, out[:, 2].astype(np.float64)

    @current
    def bounds(self, mls: Deformation, shape: object, *, grid: int = 1) -> Bounds:
        """The bounding box of the deformed image of an image of ``shape``.

        Parameters
        ----------
        mls : Deformation
            What deforms.
        shape : (int, int)
            (H, W) of the image.
        grid : int
            The step of the mesh whose corners are deformed, pixels.

        Returns
        -------
        Bounds
            The box of f at the mesh's corners, evaluated band by band on the GPU.

        Raises
        ------
        ValueError
            For a bad ``shape`` or ``grid``, or a shape beyond the GL limit.
        """
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
        options: WarpOptions | None = None,
        **keywords: object,
    ) -> np.ndarray:
        """The deformed image, read back (see :meth:`glmls.MLS.warp`).

        Parameters
        ----------
        mls : Deformation
            What deforms.
        image : array_like
            H x W or H x W x C (C in 1..4), uint8, uint16, float32 or float64.
        options : WarpOptions or None
            The construction and the canvas (default: ``WarpOptions()``).
        **keywords
            Fields of :class:`~glmls.WarpOptions` replacing those of ``options``.

        Returns
        -------
        numpy.ndarray
            A new array of ``image``'s dtype and channels, of ``options.output_shape``
            (default: the image's).

        Raises
        ------
        ValueError, TypeError
            For a bad image or options (named).
        """
        self._resources.check_alive()
        options = WarpOptions.of(options, **keywords)
        source = prepare_image(image, self.max_image_size, normalized=True)
        frame = make_frame(options.output_shape, options.origin, source.shape, self.max_image_size)
        clear = background_color(options.background, source)
        texture = self.upload(source)
        dtype = "f1" if source.normalized else "f4"
        with keep_framebuffer(self._gl.mgl):
            framebuffer = self._resources.framebuffer("target", frame.size, dtype)
            framebuffer.use()
            framebuffer.viewport = (0, 0, *frame.size)
            self.clear(framebuffer, clear)
            self._render(mls, texture, framebuffer, options, frame, flip_y=False)
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
        options: WarpOptions | None = None,
        **keywords: object,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The backward map over the output canvas, read back (see
        :meth:`glmls.MLS.coordinate_map`).

        Parameters
        ----------
        mls : Deformation
            What deforms.
        shape : (int, int)
            (H, W) of the source image.
        options : WarpOptions or None
            Its ``method`` (``"backward"``, the default here, or ``"backward-swap"``),
            ``grid``, ``border``, ``output_shape`` and ``origin`` (the others do not apply).
        **keywords
            Fields of :class:`~glmls.WarpOptions` replacing those of ``options``.

        Returns
        -------
        map : numpy.ndarray
            (H, W, 2) float32 source points (x, y).
        residual : numpy.ndarray
            (H, W) float32 |f(s) - u|, pixels (NaN for ``backward-swap``).
        covered : numpy.ndarray
            (H, W) bool: a source point was found (inside the image, for ``constant``).

        Raises
        ------
        ValueError
            For another method, or bad options.
        """
        self._resources.check_alive()
        options = WarpOptions.of(options or WarpOptions(method="backward"), **keywords)
        method = options.method
        check_choice("method", method, ("backward", "backward-swap"))
        shape = _within_limit(shape, self.max_image_size)
        frame = make_frame(options.output_shape, options.origin, shape, self.max_image_size)
        texture = self.solve_inverse(
            mls,
            shape,
            swap=method == "backward-swap",
            grid=options.grid,
            border=options.border,
            frame=frame,
        )
        values = np.frombuffer(texture.read(), dtype=np.float32).reshape(*frame.shape, 4)
        residual = values[..., 2].copy()
        if method == "backward-swap":
            residual[:] = np.nan
        return values[..., :2].copy(), residual, values[..., 3] > 0.5

    def release(self) -> None:
        """Free every cached texture, framebuffer, buffer and vertex array. Idempotent."""
        self._resources.release()


def _within_limit(shape: object, limit: int) -> tuple[int, int]:
    """``shape`` as (H, W) if the GL limit (``limit`` pixels a side) takes an image of it;
    ``ValueError`` if not."""
    height, width = as_shape(shape)
    if max(height, width) > limit:
        raise ValueError(
            f"shape {(height, width)} exceeds the GL texture size limit of {limit} pixels"
        )
    return height, width
