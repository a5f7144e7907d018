"""On-screen text: a glyph atlas made with Pillow at start-up, drawn as textured quads.

:class:`GlyphAtlas` (no GL) rasterises printable ASCII (and the few other characters of
glmls's messages) once into a grey image and lays text
out as quads; :class:`TextRenderer` uploads the atlas and draws the quads in one call per
frame. Positions are framebuffer pixels from the top left.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Iterable, Sequence

import moderngl
import numpy as np
from PIL import Image, ImageDraw, ImageFont

from ..gl import bindings
from ..gl.context import GLContext
from ..gl.dispatch import set_uniforms
from .vertices import StreamingVertices

__all__ = ["GlyphAtlas", "TextRenderer", "glyph_atlas"]

FONTS = ("DejaVuSansMono.ttf", "LiberationMono-Regular.ttf", "DejaVuSans.ttf")
#: Printable ASCII, and the other characters that glmls's messages use (a range's ±, units'
#: powers, µm, the multiplication sign), which the readout shows as said: not as "?".
_CHARS = [chr(c) for c in range(32, 127)] + list(
    "\u00b1\u00b2\u00b3\u00b9\u207b\u00b5\u03bc\u03a3\u00d7\u00b0\u2264\u2265\u00f7\u2014\u2026\u00e9\u00c5"
)  # ± ² ³ ¹ ⁻ µ μ Σ, times, ° ≤ ≥ ÷, dash, ellipsis, é Å
_SOLID = "\x7f"  # a fully covered cell, for panels and bars
_COLUMNS = 16


def load_font(size: int) -> ImageFont.FreeTypeFont | ImageFont.ImageFont:
    """A monospaced TrueType font when the system has one, else Pillow's built-in font."""
    for name in FONTS:
        try:
            return ImageFont.truetype(name, size)
        except OSError:
            continue
    return ImageFont.load_default(size)


class GlyphAtlas:
    """Printable ASCII and the other characters of glmls's messages (``±``, ``²``, ``µ``,
    ...) in cells of ``cell`` = (width, height) pixels of a grey image; any other character
    is drawn as ``?``.

    ``image`` (H, W) uint8 holds coverage; each glyph is drawn at its cell's top left with
    its ascender there, so a line of text is ``line_height`` pixels tall.
    """

    def __init__(self, size: int = 14) -> None:
        if isinstance(size, bool) or not isinstance(size, int) or size < 4:
            raise ValueError(f"size must be an integer >= 4 (pixels), got {size!r}")
        self.size = size
        font = load_font(size)
        ascent, descent = font.getmetrics() if hasattr(font, "getmetrics") else (size, size // 4)
        self.line_height = int(ascent + descent) + 2
        self.advance = {c: float(font.getlength(c)) for c in _CHARS}
        self.cell = (math.ceil(max(self.advance.values())) + 2, self.line_height)
        chars = [*_CHARS, _SOLID]
        rows = math.ceil(len(chars) / _COLUMNS)
        width, height = self.cell
        canvas = Image.new("L", (_COLUMNS * width, rows * height), 0)
        draw = ImageDraw.Draw(canvas)
        self.origin: dict[str, tuple[int, int]] = {}
        for index, char in enumerate(chars):
            x, y = (index % _COLUMNS) * width, (index // _COLUMNS) * height
            self.origin[char] = (x, y)
            if char == _SOLID:
                draw.rectangle((x, y, x + width - 1, y + height - 1), fill=255)
            else:
                draw.text((x + 1, y + 1), char, font=font, fill=255)
        self.image = np.asarray(canvas, dtype=np.uint8).copy()

    def width(self, text: str) -> float:
        """Width of one line of ``text`` in pixels."""
        return sum(self.advance.get(c, self.advance["?"]) for c in text)

    def quads(
        self, text: str, x: float, y: float, color: Sequence[float] = (1, 1, 1, 1)
    ) -> np.ndarray:
        """Vertices (6 per glyph) of ``text`` with its top left at (x, y); ``\\n`` breaks
        lines. Rows: x, y, atlas u, v (texels), r, g, b, a."""
        out = []
        width, height = self.cell
        for row, line in enumerate(text.split("\n")):
            pen = float(x)
            top = round(y + row * self.line_height)
            for char in line:
                if char not in self.advance:
                    char = "?"
                if char != " ":
                    out.append((round(pen) - 1, top, *self.origin[char]))
                pen += self.advance[char]
        if not out:
            return np.zeros((0, 8), np.float32)
        cells = np.array(out, np.float32)
        return _rectangles(cells[:, :2], cells[:, 2:], (width, height), color)

    def rectangle(
        self, x: float, y: float, width: float, height: float, color: Sequence[float]
    ) -> np.ndarray:
        """Vertices of a filled rectangle (drawn with the atlas's solid cell)."""
        u, v = self.origin[_SOLID]
        centre = np.array([[u + self.cell[0] / 2, v + self.cell[1] / 2]], np.float32)
        corners = _corners(np.array([[x, y]], np.float32), (width, height))
        uv = np.repeat(centre, 6, axis=0)
        rgba = np.tile(np.asarray(color, np.float32), (6, 1))
        return np.concatenate([corners, uv, rgba], axis=1)


@functools.lru_cache(maxsize=16)
def glyph_atlas(size: int) -> GlyphAtlas:
    """The :class:`GlyphAtlas` of ``size`` pixels, made once (atlases are not changed)."""
    return GlyphAtlas(size)


def _corners(origins: np.ndarray, size: tuple[float, float]) -> np.ndarray:
    w, h = size
    offsets = np.array([[0, 0], [w, 0], [w, h], [0, 0], [w, h], [0, h]], np.float32)
    return (origins[:, None, :] + offsets[None]).reshape(-1, 2)


def _rectangles(positions, texels, size, color) -> np.ndarray:
    xy = _corners(positions, size)
    uv = _corners(texels, size)
    rgba = np.tile(np.asarray(color, np.float32), (len(xy), 1))
    return np.concatenate([xy, uv, rgba], axis=1)


class TextRenderer:
    """Draws :class:`GlyphAtlas` quads into the bound framebuffer (blending on)."""

    def __init__(self, gl: GLContext, atlas: GlyphAtlas) -> None:
        self._gl = gl
        self.atlas = atlas
        mgl = gl.mgl
        height, width = atlas.image.shape
        self._texture = mgl.texture((width, height), 1, atlas.image.tobytes(), alignment=1)
        self._texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self._program = gl.program("draw/text.vert.glsl", "draw/text.frag.glsl")
        self._vertices = StreamingVertices(
            gl, self._program, "2f 2f 4f", "in_position", "in_uv", "in_color"
        )

    def draw(self, parts: Iterable[np.ndarray], screen: tuple[int, int]) -> None:
        """Draw the vertex arrays ``parts`` (from :meth:`GlyphAtlas.quads` / ``rectangle``)
        in order; ``screen`` is the framebuffer's (width, height)."""
        data = np.concatenate([np.zeros((0, 8), np.float32), *parts]).astype(np.float32)
        set_uniforms(self._program, {"u_screen": screen})
        self._texture.use(bindings.GLYPHS.index)
        self._vertices.draw(data)

    def release(self) -> None:
        self._vertices.release()
        self._texture.release()
