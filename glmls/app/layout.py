"""Where the image sits in the window: a text panel on the left, the image letterboxed in the
area beside it, magnified and moved by a :class:`~glmls.app.zoom.Zoom`.

Framebuffer pixels may outnumber window (cursor) units on high-DPI screens; everything here
is in framebuffer pixels, and :meth:`Layout.to_image` takes the cursor's window units with
the ratio between the two. Zoomed in, only the canvas pixels in view are drawn: the layout's
:attr:`~Layout.frame` is that part of the canvas (whole pixels), its viewport where it lands on
screen (reaching a little past the area), and :attr:`~Layout.clip` the area it is cut to.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from ..imaging.frame import Frame
from .zoom import MAX_PIXEL, ViewLimits, Zoom, clamp

__all__ = ["Layout", "layout"]

#: The panel is dropped (text drawn over the image) when it would leave the image less than
#: this share of the framebuffer's width.
MIN_IMAGE_SHARE = 0.5


@dataclass(frozen=True)
class Layout:
    """The image's viewport ``(x, y, width, height)`` in framebuffer pixels (GL's origin,
    bottom left) showing a canvas part of ``shape`` (H, W) whose pixel (0, 0) is image point
    ``origin``, the panel's width, the rectangle the image is cut to (``clip``, GL's origin),
    the zoom in effect and the limits it was clamped to."""

    framebuffer: tuple[int, int]
    viewport: tuple[int, int, int, int]
    panel: int
    shape: tuple[int, int]
    origin: tuple[float, float] = (0.0, 0.0)
    clip: tuple[int, int, int, int] | None = None
    zoom: Zoom = field(default_factory=Zoom)
    limits: ViewLimits | None = None

    @property
    def frame(self) -> Frame:
        """The part of the canvas in view: what the pipeline renders into the viewport."""
        return Frame(self.shape, self.origin)

    @property
    def scale(self) -> float:
        """Framebuffer pixels per image pixel (the smaller of x and y, which differ by
        rounding only)."""
        return min(self.viewport[2] / self.shape[1], self.viewport[3] / self.shape[0])

    @property
    def scissor(self) -> tuple[int, int, int, int]:
        """The rectangle to draw the image and overlays in (GL's origin, bottom left)."""
        return self.viewport if self.clip is None else self.clip

    @property
    def _scales(self) -> tuple[float, float]:
        return self.viewport[2] / self.shape[1], self.viewport[3] / self.shape[0]

    def to_image(self, x: float, y: float, pixel_ratio: float = 1.0) -> tuple[float, float]:
        """Image point (column, row) under the cursor at window units (x, y), y down."""
        fx, fy = x * pixel_ratio, y * pixel_ratio
        vx, vy, _, vh = self.viewport
        top = self.framebuffer[1] - (vy + vh)  # the viewport's top row, counted from the top
        sx, sy = self._scales
        ox, oy = self.origin
        return (fx - vx) / sx - 0.5 + ox, (fy - top) / sy - 0.5 + oy

    def to_framebuffer(self, x: float, y: float) -> tuple[float, float]:
        """Framebuffer position (y down) of image point (x, y)."""
        vx, vy, _, vh = self.viewport
        top = self.framebuffer[1] - (vy + vh)
        sx, sy = self._scales
        ox, oy = self.origin
        return vx + (x - ox + 0.5) * sx, top + (y - oy + 0.5) * sy


def _span(centre: float, half: float, origin: float, size: int) -> tuple[int, int]:
    """Canvas pixels [first, last) that the view [centre - half, centre + half] touches."""
    first = math.floor(centre - half - origin + 0.5)
    last = math.ceil(centre + half - origin + 0.5)
    return max(first, 0), max(min(last, size), max(first, 0) + 1)


def layout(
    framebuffer: tuple[int, int],
    shape: tuple[int, int],
    panel: int,
    origin: tuple[float, float] = (0.0, 0.0),
    zoom: Zoom | None = None,
) -> Layout:
    """Fit a canvas of ``shape`` (H, W) from image point ``origin`` beside a ``panel``
    pixels wide, keeping its aspect; with ``zoom``, magnified about its centre (clamped so
    that the view stays on the canvas)."""
    fb_width, fb_height = max(int(framebuffer[0]), 1), max(int(framebuffer[1]), 1)
    height, width = shape
    if fb_width - panel < MIN_IMAGE_SHARE * fb_width:
        panel = 0
    area = max(fb_width - panel, 1)
    base = min(area / width, fb_height / height)
    ox, oy = origin
    limits = ViewLimits(
        (ox - 0.5, oy - 0.5, ox + width - 0.5, oy + height - 0.5),
        (area / base, fb_height / base),
        max(1.0, MAX_PIXEL / base),
    )
    zoom = clamp(zoom or Zoom(), limits)
    if zoom.factor <= 1.0:
        vw, vh = max(round(width * base), 1), max(round(height * base), 1)
        vx = panel + (area - vw) // 2
        vy = (fb_height - vh) // 2
        return Layout(
            (fb_width, fb_height), (vx, vy, vw, vh), panel, (height, width), origin,
            None, zoom, limits,
        )  # fmt: skip
    scale = base * zoom.factor
    cx, cy = zoom.centre_in(limits)
    c0, c1 = _span(cx, area / (2 * scale), ox, width)
    r0, r1 = _span(cy, fb_height / (2 * scale), oy, height)
    # the part's left and top edges on screen (y down), from the area's middle
    left = panel + area / 2 + (ox + c0 - 0.5 - cx) * scale
    top = fb_height / 2 + (oy + r0 - 0.5 - cy) * scale
    vw, vh = max(round((c1 - c0) * scale), 1), max(round((r1 - r0) * scale), 1)
    vx, vy = round(left), fb_height - (round(top) + vh)
    clip_x0, clip_x1 = max(vx, panel), min(vx + vw, fb_width)
    clip_y0, clip_y1 = max(vy, 0), min(vy + vh, fb_height)
    clip = (clip_x0, clip_y0, max(clip_x1 - clip_x0, 0), max(clip_y1 - clip_y0, 0))
    return Layout(
        (fb_width, fb_height), (vx, vy, vw, vh), panel, (r1 - r0, c1 - c0),
        (ox + c0, oy + r0), clip, zoom, limits,
    )  # fmt: skip
