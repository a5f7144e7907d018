"""Where the image sits in the window: a text panel on the left, the image letterboxed.

Framebuffer pixels may outnumber window (cursor) units on high-DPI screens; everything here
is in framebuffer pixels, and :meth:`Layout.to_image` takes the cursor's window units with
the ratio between the two.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Layout", "layout"]

#: The panel is dropped (text drawn over the image) when it would leave the image less than
#: this share of the framebuffer's width.
MIN_IMAGE_SHARE = 0.5


@dataclass(frozen=True)
class Layout:
    """The image's viewport ``(x, y, width, height)`` in framebuffer pixels (GL's origin,
    bottom left) for a canvas of ``shape`` (H, W) whose pixel (0, 0) is image point
    ``origin`` (the input's frame: (0, 0); the fit view: the deformed image's bounds), and
    the panel's width."""

    framebuffer: tuple[int, int]
    viewport: tuple[int, int, int, int]
    panel: int
    shape: tuple[int, int]
    origin: tuple[float, float] = (0.0, 0.0)

    @property
    def scale(self) -> float:
        """Framebuffer pixels per image pixel (the smaller of x and y, which differ by
        rounding only)."""
        return min(self.viewport[2] / self.shape[1], self.viewport[3] / self.shape[0])

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


def layout(
    framebuffer: tuple[int, int],
    shape: tuple[int, int],
    panel: int,
    origin: tuple[float, float] = (0.0, 0.0),
) -> Layout:
    """Fit a canvas of ``shape`` (H, W) from image point ``origin`` beside a ``panel``
    pixels wide, keeping its aspect."""
    fb_width, fb_height = max(int(framebuffer[0]), 1), max(int(framebuffer[1]), 1)
    height, width = shape
    if fb_width - panel < MIN_IMAGE_SHARE * fb_width:
        panel = 0
    area = max(fb_width - panel, 1)
    scale = min(area / width, fb_height / height)
    vw, vh = max(round(width * scale), 1), max(round(height * scale), 1)
    vx = panel + (area - vw) // 2
    vy = (fb_height - vh) // 2
    return Layout((fb_width, fb_height), (vx, vy, vw, vh), panel, (height, width), origin)
