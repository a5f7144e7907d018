"""An offscreen picture rasterised by OpenGL: a :class:`Canvas` is an RGBA8 framebuffer (4x
multisampled where the driver allows) of an image's size; layers are drawn in order (an image,
a colour-mapped field, filled triangles, lines, disks, arrows) and :meth:`Canvas.read` returns
the picture top-down as (H, W, 3) uint8. Geometry is given in image pixel coordinates,
(x, y) = (column, row), pixel centres at integers.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import moderngl
import numpy as np

from ..core.config import check_integer, check_real
from ..core.handles import COORDINATE_LIMIT, as_points
from ..core.mesh import as_shape
from ..errors import DtypeError, ReleasedError
from ..gl import bindings
from ..gl.context import GLContext, current, get_context
from ..gl.dispatch import set_uniforms
from ..gl.dropped import release_when_dropped
from .colormaps import NAN_COLOR, as_color, color_limits, colormap
from .shapes import arrow_triangles, disk_triangles, segment_triangles

__all__ = [
    "EDGE_COLOR",
    "HANDLE_SOURCE_COLOR",
    "HANDLE_TARGET_COLOR",
    "Canvas",
    "as_rgb8",
    "check_size",
    "float_intensities",
    "rgb8_intensities",
]

_FULLSCREEN = "common/fullscreen.vert.glsl"

#: Default drawing colours (RGB 0-255).
HANDLE_SOURCE_COLOR = (30, 144, 255)
HANDLE_TARGET_COLOR = (255, 200, 0)
EDGE_COLOR = (255, 255, 0)


class _CanvasObjects:
    """A canvas's framebuffers and renderbuffers, freed by its :meth:`Canvas.release`, or by
    its context at its next use once the canvas is let go unreleased
    (:func:`~glmls.gl.dropped.release_when_dropped`)."""

    def __init__(self, gl: GLContext, previous: moderngl.Framebuffer) -> None:
        self.gl = gl
        self.previous = previous  # bound again if one of ours is bound
        self.objects: list = []
        self.released = False

    def release(self) -> None:
        if self.released:
            return
        if self.gl.usable:
            with self.gl.use():
                if self.gl.mgl.fbo in self.objects:
                    previous = self.previous
                    if isinstance(previous.mglo, moderngl.InvalidObject):
                        # another canvas's, released since: the default framebuffer
                        previous = self.gl.mgl.detect_framebuffer(0)
                    previous.use()
                for obj in reversed(self.objects):
                    obj.release()
        self.objects.clear()
        self.released = True


def float_intensities(values: np.ndarray) -> tuple[float, float]:
    """The intensities that :func:`as_rgb8` maps to 0 and 255 for float ``values`` (finite):
    (0, 1) where every value lies in [0, 1]; else the values' least and greatest (from 0 to
    the value where they are all one), so that an image of any range (a float TIFF of 0 to
    255, say, or of -1 to 1) is pictured and measured whole, not clipped."""
    lo, hi = float(values.min()), float(values.max())
    if lo >= 0.0 and hi <= 1.0:
        return 0.0, 1.0
    if hi <= lo:  # one value: the scale from 0 to it
        lo, hi = min(lo, 0.0), max(hi, 0.0)
    return lo, hi


def as_rgb8(image: object, name: str = "image") -> np.ndarray:
    """An image as (H, W, 3) uint8, from any image :func:`glmls.imread` gives: grey (H, W)
    or (H, W, 1), grey and alpha (H, W, 2), RGB or RGBA (alpha dropped); uint8, uint16
    (scaled by 255 / 65535), or floats: those in [0, 1] scaled by 255, others from their
    least to their greatest value (:func:`float_intensities`)."""
    return rgb8_intensities(image, name)[0]


def rgb8_intensities(image: object, name: str = "image") -> tuple[np.ndarray, tuple | None]:
    """:func:`as_rgb8`'s picture, and for a float image whose values leave [0, 1] the
    intensities it mapped to 0 and 255 (:func:`float_intensities`), else None."""
    array = np.asarray(image)
    if array.ndim == 2:
        array = array[:, :, None]
    if array.ndim != 3 or not 1 <= array.shape[2] <= 4 or min(array.shape[:2]) < 1:
        raise ValueError(f"{name} must be (H, W) or (H, W, C) with C in 1..4, got {array.shape}")
    colour = array[:, :, :3] if array.shape[2] >= 3 else array[:, :, :1]
    limits = None
    if array.dtype == np.uint8:
        rgb = colour
    elif array.dtype == np.uint16:
        rgb = np.round(colour / 257.0).astype(np.uint8)
    elif np.issubdtype(array.dtype, np.floating):
        if not np.isfinite(colour).all():
            raise ValueError(f"{name} holds NaN or infinite values")
        colour = colour.astype(np.float64)
        lo, hi = float_intensities(colour)
        limits = None if (lo, hi) == (0.0, 1.0) else (lo, hi)
        rgb = np.round(np.clip((colour - lo) / (hi - lo), 0.0, 1.0) * 255).astype(np.uint8)
    else:
        raise DtypeError(f"{name} must be uint8, uint16 or float, got dtype {array.dtype}")
    return np.ascontiguousarray(np.broadcast_to(rgb, (*rgb.shape[:2], 3))), limits


def _opacity(opacity: object) -> float:
    return check_real("opacity", opacity, low=0, high=1)


def _rgba(color: object, opacity: object, name: str) -> tuple[float, float, float, float]:
    alpha = _opacity(opacity)
    r, g, b = as_color(color, name)
    return (r / 255, g / 255, b / 255, alpha)


def check_size(name: str, value: object) -> float:
    """A drawn size in pixels (a width, a radius, an arrow head): a real option
    (:func:`~glmls.core.config.check_real`) > 0 and within the coordinate range."""
    what = f"a finite number of pixels > 0 and <= {COORDINATE_LIMIT:g}"
    return check_real(name, value, low=0, high=COORDINATE_LIMIT, low_open=True, what=what)


def _ends(a: object, b: object, names: tuple[str, str]) -> tuple[np.ndarray, np.ndarray]:
    """Two (K, 2) point arrays of one shape: the ends of segments or arrows."""
    a, b = as_points(a, names[0]), as_points(b, names[1])
    if a.shape != b.shape:
        raise ValueError(
            f"{' and '.join(names)} must have the same shape, got {a.shape} and {b.shape}"
        )
    return a, b


class Canvas:
    """An offscreen picture of an image's size, drawn in layers by OpenGL, read back top-down.

    An RGBA8 framebuffer; layers (an image, a colour-mapped field, filled triangles, lines,
    disks, arrows) are drawn in order, each over the ones before. Geometry is given in image
    pixel coordinates, (x, y) = (column, row), pixel centres at integers. The drawing methods
    return the canvas, so that calls chain. Release with :meth:`release` or a ``with`` block.

    Parameters
    ----------
    shape : sequence of int
        (H, W) of the picture.
    background : sequence of float, optional
        The (r, g, b) colour, 0-255, it starts with.
    samples : int, optional
        Multisampling (antialiased edges) when the driver offers it: the largest power of
        two up to it and the driver's limit; 0 or 1 for none.
    ctx : moderngl.Context or GLContext, optional
        The context to draw with (default: glmls's shared headless one).

    Attributes
    ----------
    shape : tuple of int
        (H, W).

    Raises
    ------
    ValueError
        For a shape that is not (H, W) with H, W >= 1, or larger than the GL texture limit;
        for ``samples`` below 0.
    TypeError
        For ``samples`` that is not an integer (a float, a bool, a string).

    See Also
    --------
    render_field, render_handles : pictures made with a canvas.

    Examples
    --------
    >>> with glmls.analysis.Canvas((16, 24), background=(255, 255, 255)) as canvas:
    ...     limits = canvas.field(np.tile(np.arange(24.0), (16, 1)))  # viridis, 0 to 23
    ...     picture = (
    ...         canvas.disks([[12, 8]], color=(255, 0, 0), radius=3)
    ...         .lines([[0, 0]], [[23, 0]], color=(0, 0, 255), width=2)
    ...         .read()
    ...     )
    >>> limits, picture.shape, picture.dtype.name
    ((0.0, 23.0), (16, 24, 3), 'uint8')
    >>> picture[8, 12].tolist(), picture[0, 10].tolist(), picture[8, 0].tolist()
    ([255, 0, 0], [0, 0, 255], [68, 1, 84])
    """

    def __init__(
        self,
        shape: Sequence[int],
        *,
        background: Sequence[float] = (0, 0, 0),
        samples: int = 4,
        ctx: moderngl.Context | GLContext | None = None,
    ) -> None:
        self.shape = as_shape(shape)
        samples = check_integer("samples", samples, low=0)
        self._gl = get_context(ctx)
        with self._gl.use():
            self._setup(background, samples)

    def _setup(self, background: Sequence[float], samples: int) -> None:
        mgl = self._gl.mgl
        height, width = self.shape
        # its layers: textures of its size, drawn into renderbuffers through a viewport
        limits = self._gl.limits
        limit = min(
            limits["max_texture_size"], limits["max_renderbuffer_size"], limits["max_viewport"]
        )
        if max(height, width) > limit:
            raise ValueError(f"shape {self.shape} exceeds the GL size limit {limit}")
        # moderngl takes powers of two up to the driver's limit (3 is its error)
        most = min(samples, mgl.max_samples)
        self._samples = 1 << (most.bit_length() - 1) if most > 1 else 0
        # Bound again on release: moderngl rebinds "the current framebuffer" after creating
        # one, and a released one would be a GL error (and a window wants its own back).
        # A headless context has none bound yet: then framebuffer 0.
        previous = mgl.fbo if mgl.fbo is not None else mgl.detect_framebuffer(0)
        self._owned = _CanvasObjects(self._gl, previous)
        self._objects = self._owned.objects
        release_when_dropped(self._gl, self, self._owned)  # a canvas let go unreleased
        size = (width, height)
        # Colour only (2-D layers need no depth); moderngl's simple_framebuffer would add a
        # multisampled depth buffer, which some drivers refuse.
        self._resolved = self._framebuffer(size, 0)
        self._fbo = self._framebuffer(size, self._samples) if self._samples else self._resolved
        self._released = False
        r, g, b = as_color(background, "background")
        self._fbo.use()
        self._fbo.clear(r / 255, g / 255, b / 255, 1.0)

    def _framebuffer(self, size: tuple[int, int], samples: int) -> moderngl.Framebuffer:
        mgl = self._gl.mgl
        color = self._keep(mgl.renderbuffer(size, 4, samples=samples))
        return self._keep(mgl.framebuffer(color_attachments=[color]))

    def _keep(self, obj):
        self._objects.append(obj)
        return obj

    def _begin(self) -> moderngl.Context:
        if self._released:
            raise ReleasedError("this Canvas has been released")
        mgl = self._gl.mgl
        self._fbo.use()
        mgl.enable(moderngl.BLEND)
        mgl.blend_func = moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA
        return mgl

    def _fullscreen(self, program: moderngl.Program) -> None:
        vao = self._gl.mgl.vertex_array(program, [])
        try:
            vao.render(moderngl.TRIANGLES, vertices=3)
        finally:
            vao.release()

    # -- layers -----------------------------------------------------------------------------

    @current
    def image(self, image: object) -> Canvas:
        """Draw an image of this canvas's shape over everything (opaque).

        Parameters
        ----------
        image : array_like
            (H, W) or (H, W, C) with C in 1..4 (alpha dropped): uint8, uint16, or floats
            in [0, 1].

        Returns
        -------
        Canvas
            This canvas.

        Examples
        --------
        >>> image = np.zeros((4, 6, 3), np.uint8)
        >>> image[:, 3:] = (200, 100, 50)
        >>> with glmls.analysis.Canvas((4, 6)) as canvas:
        ...     picture = canvas.image(image).read()
        >>> picture[2, 4].tolist(), picture[2, 0].tolist()
        ([200, 100, 50], [0, 0, 0])
        """
        rgb = as_rgb8(image)
        if rgb.shape[:2] != self.shape:
            raise ValueError(f"image is {rgb.shape[:2]}, the canvas {self.shape}")
        mgl = self._begin()
        program = self._gl.program(_FULLSCREEN, "draw/image.frag.glsl")
        texture = mgl.texture(self.shape[::-1], 3, rgb.tobytes(), alignment=1)
        try:
            texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
            texture.use(bindings.PICTURE.index)
            self._fullscreen(program)
        finally:
            texture.release()
        return self

    @current
    def field(
        self,
        values: object,
        *,
        cmap: object = "viridis",
        vmin: float | None = None,
        vmax: float | None = None,
        percentile: float | None = None,
        nan_color: Sequence[float] = NAN_COLOR,
        opacity: float = 1.0,
    ) -> tuple[float, float]:
        """Draw an (H, W) scalar field through a colour map.

        Parameters
        ----------
        values : array_like
            (H, W), finite or NaN.
        cmap : str or array_like, optional
            A colour map, as :func:`glmls.analysis.apply_colormap` takes it.
        vmin, vmax, percentile : float, optional
            The colour limits, as :func:`glmls.analysis.color_limits` takes them.
        nan_color : sequence of float, optional
            The (r, g, b) colour of NaN values.
        opacity : float, optional
            In [0, 1].

        Returns
        -------
        lo, hi : float
            The colour limits used.

        Examples
        --------
        >>> values = np.tile(np.arange(6.0), (4, 1))
        >>> with glmls.analysis.Canvas((4, 6)) as canvas:
        ...     limits = canvas.field(values, cmap=[[0, 0, 0], [255, 255, 255]])
        ...     picture = canvas.read()
        >>> limits, picture[0, 0].tolist(), picture[0, 5].tolist()
        ((0.0, 5.0), [0, 0, 0], [255, 255, 255])
        """
        array = np.asarray(values, dtype=np.float64)
        if array.shape != self.shape:
            raise ValueError(f"values must have the canvas shape {self.shape}, got {array.shape}")
        if np.isinf(array).any():
            raise ValueError("values must be finite or NaN")
        lo, hi = color_limits(array, vmin=vmin, vmax=vmax, percentile=percentile)
        table = colormap(cmap)
        defined = ~np.isnan(array)
        # the colours need the values clipped to the limits only, and those by a power of
        # two (exact) to a largest magnitude about 1: float32 holds finite float64 values
        # beyond its range (1e39) and below it (1e-40) so, and the span of limits near
        # float64's largest too
        largest = max(abs(lo), abs(hi))
        unit = math.ldexp(1.0, -math.frexp(largest)[1]) if largest > 0 else 1.0
        shown = np.where(defined, np.clip(array, lo, hi), 0.0) * unit
        packed = np.stack([shown, defined], axis=-1).astype(np.float32)
        lut = np.concatenate([table, np.full((len(table), 1), 255, np.uint8)], axis=1)
        mgl = self._begin()
        program = self._gl.program(_FULLSCREEN, "draw/colormap.frag.glsl")
        texture = mgl.texture(self.shape[::-1], 2, packed.tobytes(), dtype="f4")
        lut_texture = mgl.texture((len(lut), 1), 4, lut.tobytes())
        try:
            for binding, tex in ((bindings.VALUES, texture), (bindings.COLOR_TABLE, lut_texture)):
                tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
                tex.use(binding.index)
            uniforms = {
                "u_table_size": len(table),
                "u_limits": (lo * unit, hi * unit),
                "u_nan_color": _rgba(nan_color, 1.0, "nan_color"),
                "u_opacity": _opacity(opacity),
            }
            set_uniforms(program, uniforms)
            self._fullscreen(program)
        finally:
            texture.release()
            lut_texture.release()
        return lo, hi

    def triangles(self, vertices: object, colors: object, *, opacity: float = 1.0) -> Canvas:
        """Fill triangles with one colour each.

        Parameters
        ----------
        vertices : array_like
            (T, 3, 2) corners.
        colors : array_like
            (T, 3) colours, 0-255, or a single (r, g, b) for all.
        opacity : float, optional
            In [0, 1].

        Returns
        -------
        Canvas
            This canvas.

        Examples
        --------
        >>> with glmls.analysis.Canvas((8, 8)) as canvas:
        ...     picture = canvas.triangles([[[0, 0], [8, 0], [0, 8]]], (255, 0, 0)).read()
        >>> picture[1, 1].tolist(), picture[7, 7].tolist()  # inside, outside
        ([255, 0, 0], [0, 0, 0])
        """
        tris = np.asarray(vertices, dtype=np.float64)
        if tris.ndim != 3 or tris.shape[1:] != (3, 2):
            raise ValueError(f"vertices must have shape (T, 3, 2), got {tris.shape}")
        rgb = np.asarray(colors, dtype=np.float64)
        if rgb.shape == (3,):
            rgb = np.broadcast_to(rgb, (len(tris), 3))
        if rgb.shape != (len(tris), 3) or rgb.min(initial=0) < 0 or rgb.max(initial=0) > 255:
            raise ValueError(f"colors must be (r, g, b) or ({len(tris)}, 3) in 0-255")
        rgba = np.concatenate([rgb / 255, np.full((len(tris), 1), _opacity(opacity))], axis=1)
        self._draw(tris.reshape(-1, 2), np.repeat(rgba, 3, axis=0))
        return self

    def _solid(self, positions: np.ndarray, color, opacity: float, name: str) -> None:
        rgba = np.tile(_rgba(color, opacity, name), (len(positions), 1))
        self._draw(positions, rgba)

    def lines(
        self,
        a: object,
        b: object,
        *,
        color: Sequence[float] = EDGE_COLOR,
        width: float = 1.5,
        opacity: float = 1.0,
    ) -> Canvas:
        """Draw segments a[k] -> b[k].

        Parameters
        ----------
        a, b : array_like
            The ends, (K, 2) each.
        color : sequence of float, optional
            (r, g, b), 0-255.
        width : float, optional
            In pixels.
        opacity : float, optional
            In [0, 1].

        Returns
        -------
        Canvas
            This canvas.

        Examples
        --------
        >>> with glmls.analysis.Canvas((8, 8)) as canvas:
        ...     picture = canvas.lines([[0, 4]], [[7, 4]], color=(0, 255, 0), width=2).read()
        >>> picture[4, 3].tolist(), picture[0, 3].tolist()
        ([0, 255, 0], [0, 0, 0])
        """
        a, b = _ends(a, b, ("a", "b"))
        self._solid(segment_triangles(a, b, check_size("width", width)), color, opacity, "color")
        return self

    def disks(
        self,
        centres: object,
        *,
        color: Sequence[float] = EDGE_COLOR,
        radius: float = 3.0,
        opacity: float = 1.0,
    ) -> Canvas:
        """Draw filled disks.

        Parameters
        ----------
        centres : array_like
            (K, 2).
        color : sequence of float, optional
            (r, g, b), 0-255.
        radius : float, optional
            In pixels.
        opacity : float, optional
            In [0, 1].

        Returns
        -------
        Canvas
            This canvas.

        Examples
        --------
        >>> with glmls.analysis.Canvas((9, 9)) as canvas:
        ...     picture = canvas.disks([[4, 4]], color=(0, 0, 255), radius=2).read()
        >>> picture[4, 4].tolist(), picture[0, 0].tolist()
        ([0, 0, 255], [0, 0, 0])
        """
        centres = as_points(centres, "centres")
        triangles = disk_triangles(centres, check_size("radius", radius))
        self._solid(triangles, color, opacity, "color")
        return self

    def arrows(
        self,
        src: object,
        dst: object,
        *,
        color: Sequence[float] = HANDLE_TARGET_COLOR,
        width: float = 2.0,
        head: float = 10.0,
        opacity: float = 1.0,
    ) -> Canvas:
        """Draw arrows src[k] -> dst[k].

        Parameters
        ----------
        src, dst : array_like
            Tails and tips, (K, 2) each.
        color : sequence of float, optional
            (r, g, b), 0-255.
        width : float, optional
            The shaft's width in pixels.
        head : float, optional
            The head's length in pixels.
        opacity : float, optional
            In [0, 1].

        Returns
        -------
        Canvas
            This canvas.

        Examples
        --------
        >>> with glmls.analysis.Canvas((9, 16)) as canvas:
        ...     picture = canvas.arrows([[1, 4]], [[14, 4]], color=(255, 255, 0), head=4).read()
        >>> picture[4, 6].tolist(), picture[0, 6].tolist()  # on the shaft, off it
        ([255, 255, 0], [0, 0, 0])
        """
        src, dst = _ends(src, dst, ("src", "dst"))
        triangles = arrow_triangles(src, dst, check_size("width", width), check_size("head", head))
        self._solid(triangles, color, opacity, "color")
        return self

    @current
    def _draw(self, positions: np.ndarray, rgba: np.ndarray) -> None:
        if len(positions) == 0:
            self._begin()
            return
        data = np.concatenate([positions, rgba], axis=1).astype(np.float32)
        mgl = self._begin()
        program = self._gl.program("draw/geometry.vert.glsl", "draw/color.frag.glsl")
        # the program is shared (a window's overlays set another origin): set every uniform
        uniforms = {
            "u_size": (self.shape[1], self.shape[0]),
            "u_origin": (0.0, 0.0),
            "u_flip_y": False,
        }
        set_uniforms(program, uniforms)
        buffer = mgl.buffer(data.tobytes())
        vao = mgl.vertex_array(program, [(buffer, "2f 4f", "in_position", "in_color")])
        try:
            vao.render(moderngl.TRIANGLES)
        finally:
            vao.release()
            buffer.release()

    # -- result -----------------------------------------------------------------------------

    @current
    def read(self) -> np.ndarray:
        """The picture so far.

        Returns
        -------
        numpy.ndarray
            (H, W, 3) uint8, row 0 at the top.

        Raises
        ------
        ReleasedError
            Once the canvas is released.

        Examples
        --------
        >>> with glmls.analysis.Canvas((2, 3), background=(10, 20, 30)) as canvas:
        ...     picture = canvas.read()
        >>> picture.shape, picture.dtype.name, picture[0, 0].tolist()
        ((2, 3, 3), 'uint8', [10, 20, 30])
        """
        if self._released:
            raise ReleasedError("this Canvas has been released")
        if self._fbo is not self._resolved:
            self._gl.mgl.copy_framebuffer(self._resolved, self._fbo)
        height, width = self.shape
        data = self._resolved.read(components=3, alignment=1)
        return np.frombuffer(data, dtype=np.uint8).reshape(height, width, 3).copy()

    def release(self) -> None:
        """Free the canvas's GL objects (only the references where its context is gone).

        Examples
        --------
        >>> canvas = glmls.analysis.Canvas((2, 3))
        >>> canvas.release()
        >>> canvas.release()  # a second time does nothing
        >>> canvas.read()
        Traceback (most recent call last):
            ...
        glmls.errors.ReleasedError: this Canvas has been released
        """
        if self._released:
            return
        self._owned.release()
        self._released = True

    def __enter__(self) -> Canvas:
        return self

    def __exit__(self, *exc: object) -> None:
        self.release()
