"""Zoom and pan, in image pixels: how much of the canvas the window shows and where.

:class:`Zoom` is the state (a factor over the letterboxed view, and the image point at the
centre of the image area); :class:`ViewLimits` what bounds it (the canvas, how much of it the
area shows at factor 1, the largest factor). Every step is exact in image coordinates: zooming
about a point keeps that point where it is on screen, panning by (dx, dy) moves the image
point under the cursor by exactly that, so a replay of image-pixel events gives the same view.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["MAX_PIXEL", "ZOOM_STEP", "ViewLimits", "Zoom", "clamp", "pan", "zoom_at"]

#: One mouse-wheel notch (or ``[`` / ``]``) zooms by this factor.
ZOOM_STEP = 1.25
#: The largest zoom shows one image pixel this many framebuffer pixels wide.
MAX_PIXEL = 64.0


@dataclass(frozen=True)
class ViewLimits:
    """The canvas's extent in image points ``(x0, y0, x1, y1)`` (pixel edges: the input's
    frame is ``(-0.5, -0.5, W - 0.5, H - 0.5)``), the image area's size in image pixels at
    factor 1 ``visible`` (w, h; at least the canvas's, the view being letterboxed), and the
    largest factor."""

    bounds: tuple[float, float, float, float]
    visible: tuple[float, float]
    max_zoom: float = 32.0

    @classmethod
    def of_shape(cls, shape: tuple[int, int]) -> ViewLimits:
        """The limits before a window has laid anything out: the input's frame, all of it
        visible at factor 1."""
        height, width = shape
        return cls((-0.5, -0.5, width - 0.5, height - 0.5), (float(width), float(height)))

    @property
    def middle(self) -> tuple[float, float]:
        x0, y0, x1, y1 = self.bounds
        return (x0 + x1) / 2, (y0 + y1) / 2


@dataclass(frozen=True)
class Zoom:
    """``factor`` >= 1 over the letterboxed view; ``center`` the image point in the middle of
    the image area (``None``: the canvas's middle, as at factor 1)."""

    factor: float = 1.0
    center: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        if not (math.isfinite(self.factor) and self.factor >= 1.0):
            raise ValueError(f"zoom factor must be finite and >= 1, got {self.factor!r}")

    def centre_in(self, limits: ViewLimits) -> tuple[float, float]:
        """The centre, ``None`` resolved to the canvas's middle."""
        return limits.middle if self.center is None else self.center


def _axis(centre: float, low: float, high: float, half: float) -> float:
    """Keep the view [centre - half, centre + half] on the canvas [low, high]: no empty
    margin where the canvas is larger than the view, centred where it is smaller."""
    if 2 * half >= high - low:
        return (low + high) / 2
    return min(max(centre, low + half), high - half)


def clamp(zoom: Zoom, limits: ViewLimits) -> Zoom:
    """``zoom`` within ``limits``: the factor in [1, max_zoom], the centre so that the view
    stays on the canvas. Factor 1 is the letterboxed view (centre ``None``)."""
    factor = min(max(zoom.factor, 1.0), max(limits.max_zoom, 1.0))
    if factor <= 1.0:
        return Zoom()
    x, y = zoom.centre_in(limits)
    x0, y0, x1, y1 = limits.bounds
    w, h = limits.visible
    centre = (_axis(x, x0, x1, w / (2 * factor)), _axis(y, y0, y1, h / (2 * factor)))
    return Zoom(factor, centre)


def zoom_at(zoom: Zoom, limits: ViewLimits, x: float, y: float, times: float) -> Zoom:
    """Zoom by ``times`` about image point (x, y), which stays where it is on screen (unless
    the view would leave the canvas)."""
    factor = min(max(zoom.factor * times, 1.0), max(limits.max_zoom, 1.0))
    cx, cy = zoom.centre_in(limits)
    keep = zoom.factor / factor
    return clamp(Zoom(factor, (x + (cx - x) * keep, y + (cy - y) * keep)), limits)


def pan(zoom: Zoom, limits: ViewLimits, dx: float, dy: float) -> Zoom:
    """Move the view's centre by (dx, dy) image pixels (within the canvas)."""
    cx, cy = zoom.centre_in(limits)
    return clamp(Zoom(zoom.factor, (cx + dx, cy + dy)), limits)
