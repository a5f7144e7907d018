"""What the window draws each frame: the deformed image straight into the window's framebuffer
with the context's shared :class:`~glmls.gl.WarpPipeline`, the overlays and the text. The view
owns its textures (the displayed image, the error field's colours) and drawers."""

from __future__ import annotations

from collections.abc import Sequence

import moderngl
import numpy as np

from ..analysis.canvas import as_rgb8
from ..errors import DtypeError
from ..gl.context import GLContext
from ..imaging.pipeline import WarpPipeline
from ..imaging.source import prepare_image, texture_data, texture_form
from .controller import Controller, Settings
from .layout import Layout
from .overlays import (
    GeometryDrawer,
    PictureDrawer,
    handle_geometry,
    read_screen,
    reference_geometry,
    segment_geometry,
)
from .session import Analysis, Session
from .text import TextRenderer, glyph_atlas

__all__ = ["BACKGROUND", "FIELD_OPACITY", "TEXT_SIZE", "View", "display_image", "shown_reference"]

#: Text size (points at a content scale of 1).
TEXT_SIZE = 13
#: Text renderers kept (one per size: the readout's, the help's).
TEXT_SIZES_KEPT = 3
FIELD_OPACITY = 0.7
BACKGROUND = (0.13, 0.13, 0.14)
_STAGES = ("warp", "overlays", "text")


def display_image(image: np.ndarray) -> np.ndarray:
    """An image as float32 RGB in [0, 1] for the window's 8-bit framebuffer: the pipeline
    writes the texture's raw values, so 0-255 values would all show white. Integers are
    divided by their dtype's maximum where that is the scale of their values (uint8,
    uint16); floats within [0, 1] stay, and others, like the other integers (int16 CT slices,
    int32 labels, which their dtype's maximum would show black), are stretched from the lower
    of 0 and their minimum (black) to the higher of 1 and their maximum (white), of the finite
    values: NaN is black, infinities at the ends."""
    array = np.asarray(image)
    if array.ndim == 2:
        array = array[:, :, None]
    if array.ndim != 3 or not 1 <= array.shape[2] <= 4:
        raise ValueError(f"image must be H x W or H x W x C with C in 1..4, got {array.shape}")
    if array.size == 0:
        raise ValueError(f"image must not be empty, got shape {np.asarray(image).shape}")
    if array.dtype in (np.uint8, np.uint16):
        values = array.astype(np.float32) / float(np.iinfo(array.dtype).max)
    elif np.issubdtype(array.dtype, np.integer) or np.issubdtype(array.dtype, np.floating):
        values = array.astype(np.float64)  # float32 would overflow: 1e300s, -3e38..3e38
        finite = values[np.isfinite(values)]  # a NaN (a depth map's hole) makes no range
        low, high = float(finite.min(initial=0.0)), float(finite.max(initial=1.0))
        if low < 0.0 or high > 1.0:  # e.g. 0..255 or -1..1: its range, not all white
            values = (values - low) / (high - low)
        values = np.clip(np.nan_to_num(values, nan=0.0), 0.0, 1.0).astype(np.float32)
    else:
        raise DtypeError(f"image dtype must be integer or float, got {array.dtype}")
    colour = values[..., :3] if values.shape[2] >= 3 else np.repeat(values[..., :1], 3, axis=2)
    return np.ascontiguousarray(colour)


def shown_reference(c: Controller, session: Session) -> np.ndarray | None:
    """The reference points to draw, or None: in reference mode where they are (where a
    click picks them, as the sources p are drawn at p), else with the angle overlay at f(r),
    the corners of the deformed triangles."""
    if not len(c.reference):
        return None
    if c.reference_mode:
        return c.reference
    return session.deformed_reference() if c.overlays["angle"] else None


class View:
    """The window's GL objects on context ``gl`` for a displayed image ``display`` (H, W, 3
    float RGB in [0, 1], :func:`display_image`)."""

    def __init__(self, gl: GLContext, display: np.ndarray) -> None:
        self.gl = gl
        self.shape = (display.shape[0], display.shape[1])
        self.pipeline = WarpPipeline.of(gl)
        # 8-bit, as the framebuffer: nearest quads then take the pipeline's fused path
        self.source = self._texture(as_rgb8(display))
        self._field: moderngl.Texture | None = None
        self._field_key: tuple = ()
        self.geometry = GeometryDrawer(gl, self.shape)
        self.picture = PictureDrawer(gl, self.shape)
        self.field_picture = PictureDrawer(gl, self.shape)
        self.texts: dict[int, TextRenderer] = {}
        # Two sets of timer queries, used in turn: a frame reads the set of the frame before,
        # whose GPU work is done by then, so reading never stalls the frame being drawn.
        self._query_sets = [{name: gl.mgl.query(time=True) for name in _STAGES} for _ in (0, 1)]
        self._queries = self._query_sets[0]
        #: GPU seconds of each stage of the frame before last.
        self.timings: dict[str, float] = {}

    def _texture(self, rgb: np.ndarray, texture: moderngl.Texture | None = None):
        """``rgb`` (H, W, 3 uint8) in an RGBA8 texture of the view's own (``texture`` reused
        where it has that size)."""
        image = prepare_image(rgb, self.pipeline.max_image_size, normalized=True)
        form = texture_form(image)
        if texture is None or (texture.size, texture.components, texture.dtype) != form:
            if texture is not None:
                texture.release()
            texture = self.gl.mgl.texture(form[0], form[1], dtype=form[2])
            texture.repeat_x = texture.repeat_y = False
        texture.write(texture_data(image))
        return texture

    def text_renderer(self, size: int) -> TextRenderer:
        """The text renderer with a glyph atlas of ``size`` pixels (the last few sizes are
        kept, others released)."""
        if size not in self.texts:
            while len(self.texts) >= TEXT_SIZES_KEPT:
                self.texts.pop(next(iter(self.texts))).release()
            self.texts[size] = TextRenderer(self.gl, glyph_atlas(size))
        return self.texts[size]

    def draw(
        self,
        layout: Layout,
        controller: Controller,
        session: Session,
        analysis: Analysis,
        text: Sequence[tuple[int, list[np.ndarray]]],
    ) -> None:
        """One frame into the window's back buffer; ``text``: glyph quads by text size."""
        with self.gl.use():
            self._draw(layout, controller, session, analysis, text)

    def _draw(self, layout, controller, session, analysis, text) -> None:
        mgl = self.gl.mgl
        c, s = controller, controller.settings
        framebuffer = layout.framebuffer
        screen = mgl.screen
        screen.use()
        screen.viewport = (0, 0, *framebuffer)
        screen.clear(*BACKGROUND, 1.0)
        screen.clear(0.0, 0.0, 0.0, 1.0, viewport=layout.scissor)
        frame = layout.frame  # the part of the canvas in view
        self.geometry.frame = frame  # the overlays' coordinates
        screen.scissor = layout.scissor  # zoomed in, the viewport reaches past the area
        s = session.construction(s)
        try:
            with self._queries["warp"]:
                try:
                    self._draw_image(screen, layout, session, s)
                except ValueError as error:  # the adaptive mesh's budget: the grid
                    if s.adaptive is None:
                        raise
                    c.message = session.adaptive_failed(s, error)
                    s = session.construction(s)
                    self._draw_image(screen, layout, session, s)
            with self._queries["overlays"]:
                screen.viewport = layout.viewport
                self._overlays(screen, layout, c, s, session, analysis)
        finally:
            screen.scissor = None
        with self._queries["text"]:
            screen.viewport = (0, 0, *framebuffer)
            for size, parts in text:
                self.text_renderer(size).draw(parts, framebuffer)

    def _overlays(self, screen, layout: Layout, c: Controller, s, session: Session, analysis):
        if session.mls is not None and c.overlays["error"] and analysis.field_colours is not None:
            if analysis.key != self._field_key:  # upload once per analysis
                self._field = self._texture(analysis.field_colours, self._field)
                self._field_key = analysis.key
            # the field is f's on the image only: nothing past its border
            self._offscreen(self.field_picture, self._field, session, layout, s, "constant")
            screen.use()
            screen.viewport = layout.viewport
            self.field_picture.draw(opacity=FIELD_OPACITY, linear=True)
        for vertices, mode in analysis.geometry:
            self.geometry.draw(vertices, mode)
        shown = c.overlays["handles"] or c.reference_mode or c.segment_mode
        none = np.zeros((0, 2, 2))
        a, b = (c.src_segments, c.dst_segments) if shown else (none, none)
        self.geometry.draw(segment_geometry(a, b, layout.scale, c.drawing))  # and the drawing
        if shown:
            self.geometry.draw(handle_geometry(c.src, c.dst, layout.scale))
        points = shown_reference(c, session)
        if points is not None:
            self.geometry.draw(reference_geometry(points, layout.scale))

    def _draw_image(self, screen, layout: Layout, session: Session, s: Settings) -> None:
        if s.method == "quads" and s.interpolation == "linear" and s.adaptive is None:
            # drawn at the screen's resolution: bilinear detail where the window magnifies.
            # Nearest quads go through the picture: the compute scan conversion writes it
            # directly (an image-sized RGBA8 target), 2-3x faster than the rasterizer here.
            screen.viewport = layout.viewport
            self.pipeline.render(
                session.drawn,
                self.source,
                screen,
                s.warp_options(),
                flip_y=True,
                frame=layout.frame,
            )
            return
        self._offscreen(self.picture, self.source, session, layout, s, s.border)
        screen.use()
        screen.viewport = layout.viewport
        self.picture.draw(opacity=1.0, linear=False)

    def _offscreen(
        self, picture: PictureDrawer, source, session: Session, layout: Layout, s, border
    ) -> None:
        picture.resize(layout.shape)
        picture.framebuffer.use()
        self.pipeline.clear(picture.framebuffer)
        self.pipeline.render(
            session.drawn,
            source,
            picture.framebuffer,
            s.warp_options(border=border),
            flip_y=False,
            frame=layout.frame,
        )

    def next_frame(self, frames: int) -> None:
        """After frame number ``frames``: switch query sets and read the other one's times
        (the frame before this one's, done by now)."""
        self._queries = self._query_sets[frames % 2]
        if frames >= 2:
            for name, query in self._queries.items():
                self.timings[name] = query.elapsed / 1e9

    def screenshot(self, framebuffer: tuple[int, int]) -> np.ndarray:
        """The back buffer just drawn, (H, W, 3) uint8, top row first."""
        return read_screen(self.gl, framebuffer)

    def release(self) -> None:
        if self.gl.usable:
            with self.gl.use():
                for obj in (self.geometry, self.picture, self.field_picture, *self.texts.values()):
                    obj.release()
                self.texts.clear()
                for texture in (self.source, self._field):
                    if texture is not None:
                        texture.release()
        self._query_sets.clear()  # moderngl's Query has no release(); the context frees them
