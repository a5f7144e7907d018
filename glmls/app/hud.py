"""The window's text: the readout panel (settings, timings, statistics, messages) and the help
overlay, as lines and then as glyph quads. No GL: :class:`~glmls.app.text.TextRenderer`
draws the quads."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .controller import OVERLAYS, Controller
from .helpscreen import HelpLayout, help_blocks, help_layout
from .text import GlyphAtlas, glyph_atlas

__all__ = [
    "MIN_WINDOW_HEIGHT",
    "PANEL_CHARS",
    "TextGroups",
    "frame_rate",
    "help_lines",
    "place_help",
    "readout",
    "readout_quads",
    "text_quads",
    "wrap",
]

#: Panel width in characters.
PANEL_CHARS = 44
#: The least height (pixels) of a window's default size: the readout's lines at their size.
MIN_WINDOW_HEIGHT = 480
#: The help's text may shrink to this share of the readout's (and 8 pixels at least).
HELP_MIN_SHARE = 0.6
#: Glyph quads to draw, by text size (pixels): each group with that size's atlas.
TextGroups = list[tuple[int, list[np.ndarray]]]
MODE_NAMES = {"points": "points", "segments": "SEGMENTS", "reference": "REFERENCE POINTS"}


def wrap(text: str, width: int) -> list[str]:
    """Lines of at most ``width`` characters (long words, e.g. paths, are cut)."""
    words, lines, line = [], [], ""
    for word in text.split():
        words += [word[i : i + width - 2] for i in range(0, len(word), width - 2)]
    for word in words:
        if line and len(line) + 1 + len(word) > width:
            lines.append(line)
            line = "  " + word
        else:
            line = f"{line} {word}" if line else word
    return [*lines, line] if line else lines


def frame_rate(frame_times: Sequence[float]) -> tuple[float, float]:
    """(frames per second over the last second, the last frame's milliseconds) from the
    frames' times in seconds."""
    times = list(frame_times)
    recent = [t for t in times if t >= times[-1] - 1.0] if times else []
    fps = (len(recent) - 1) / (recent[-1] - recent[0]) if len(recent) > 2 else 0.0
    frame_ms = 1000 * (recent[-1] - recent[-2]) if len(recent) > 1 else 0.0
    return fps, frame_ms


def readout(
    *,
    name: str,
    shape: tuple[int, int],
    controller: Controller,
    frame_times: Sequence[float],
    timings: dict[str, float],
    error: str,
    analysis_lines: Sequence[str],
    messages: Sequence[str],
    showing: str = "the last valid f",
) -> list[str]:
    """The lines of the readout panel; ``showing``: what the window draws while ``error``
    says why the handles or settings give no f."""
    c, s = controller, controller.settings
    fps, frame_ms = frame_rate(frame_times)
    ms = {k: 1000 * v for k, v in timings.items()}
    on = [overlay for overlay in OVERLAYS if c.overlays[overlay]]
    height, width = shape
    lines = [
        f"glmls  {name}  {width}x{height}",
        f"fps {fps:5.1f}   frame {frame_ms:5.1f} ms",
        f"ms: handles {ms.get('handles', 0):.2f}  warp {ms.get('warp', 0):.2f}",
        f"    analysis {ms.get('analysis', 0):.1f}  overlays {ms.get('overlays', 0):.2f}"
        f"  text {ms.get('text', 0):.2f}",
        "",
        f"transform  {s.config.transform}   (t)",
        f"weight     {s.config.weight}, {s.parameter(shape)}   (w, +/-)",
        f"construct  {s.method} {s.interpolation}   (c)",
        f"grid       {s.grid} px   (g/G)"
        if s.tolerance is None
        else f"mesh       adaptive {s.tolerance:g} px{'' if s.adaptive else ' (quads)'}   (T)",
        f"border     {s.border}   (b)",
        f"view       {'fit: whole deformed image' if s.fit else 'input frame'}   (o)",
        f"zoom       {c.zoom.factor:.2f}x   (wheel, [ ], 0)",
        f"handles    {len(c.src)} points, {len(c.src_segments)} segments",
        f"reference  {len(c.reference)} points",
        f"mode       {MODE_NAMES[c.mode]}   (d, p)",
        f"overlays   {' '.join(on) or 'none'}",
        "",
    ]
    if error:
        lines += wrap(f"! {error}", PANEL_CHARS) + [f"  (showing {showing})"]
    for line in analysis_lines:  # a long one (why an analysis failed) wrapped, whole
        lines += [line] if len(line) <= PANEL_CHARS else wrap(line, PANEL_CHARS)
    if not any(c.overlays[n] for n in ("error", "angle", "folds")):
        lines.append("errors: e field, a angles, f folds")
    lines += ["", "F1 or ?: help"]
    for message in messages:
        lines += wrap(message, PANEL_CHARS)
    return lines


def help_lines() -> list[str]:
    """The help screen's lines, in order (blocks separated by a blank line)."""
    return [line for k, block in enumerate(help_blocks()) for line in ([""] if k else []) + block]


def place_help(
    atlas: GlyphAtlas,
    readout_width: float,
    framebuffer: tuple[int, int],
    blocks: list[list[str]] | None = None,
) -> HelpLayout:
    """Where the help (``blocks`` of lines, default the image window's) goes: beside the
    readout (right of ``readout_width`` framebuffer pixels) at the readout's text size or
    smaller, else over the whole window."""
    fb_w, fb_h = framebuffer
    margin = atlas.line_height / 2
    beside = (readout_width + margin, margin, fb_w - readout_width - 2 * margin, fb_h - 2 * margin)
    whole = (margin, margin, fb_w - 2 * margin, fb_h - 2 * margin)
    smallest = max(8, round(HELP_MIN_SHARE * atlas.size))
    sizes = list(range(atlas.size, smallest - 1, -1)) or [atlas.size]
    return help_layout([beside, whole], sizes, glyph_atlas, blocks)


def readout_quads(
    atlas: GlyphAtlas, lines: Sequence[str], height: float
) -> tuple[int, list[np.ndarray], float]:
    """(text size, glyph quads on a dark panel, the panel's width) of the readout at the top
    left: at ``atlas``'s size, or smaller (down to :data:`HELP_MIN_SHARE` of it, 8 pixels at
    least) where its lines would run past the ``height`` of the framebuffer, so that the
    last ones (what a key did) stay in view. A line longer than :data:`PANEL_CHARS` (a long
    file name, a huge radius) is wrapped: the panel keeps the width the layout gave it,
    beside the image, not over it."""
    lines = [part for line in lines for part in _fitted(line)]
    smallest = min(atlas.size, max(8, round(HELP_MIN_SHARE * atlas.size)))
    for size in range(atlas.size, smallest - 1, -1):
        sized = glyph_atlas(size) if size != atlas.size else atlas
        pad = sized.cell[1] // 2
        panel_height = len(lines) * sized.line_height + 2 * pad
        if panel_height <= height:
            break
    width = max(sized.width(line) for line in lines) + 2 * pad
    parts = [
        sized.rectangle(0, 0, width, panel_height, (0.0, 0.0, 0.0, 0.55)),
        sized.quads("\n".join(lines), pad, pad, (0.95, 0.95, 0.95, 1.0)),
    ]
    return sized.size, parts, width


def _fitted(line: str) -> list[str]:
    """``line`` as it is where it fits the panel, else wrapped to it."""
    return [line] if len(line) <= PANEL_CHARS else wrap(line, PANEL_CHARS)


def text_quads(
    atlas: GlyphAtlas,
    lines: Sequence[str],
    *,
    help_visible: bool,
    panel: int,
    framebuffer: tuple[int, int],
    blocks: list[list[str]] | None = None,
) -> TextGroups:
    """Glyph quads of the readout (top left, on a dark panel) and, if shown, the help
    (:func:`place_help`; ``blocks`` of lines, default the image window's), grouped by text
    size."""
    size, readout_parts, width = readout_quads(atlas, lines, framebuffer[1])
    groups: TextGroups = [(size, readout_parts)]
    if help_visible:
        placed = place_help(atlas, max(width, panel), framebuffer, blocks)
        help_atlas = glyph_atlas(placed.size)
        x, y, w, h = placed.box
        parts = [help_atlas.rectangle(x, y, w, h, (0.05, 0.05, 0.08, 0.92))]
        top = y + help_atlas.line_height / 2
        for left, column in placed.columns:
            parts.append(help_atlas.quads("\n".join(column), left, top, (1.0, 0.92, 0.6, 1.0)))
        groups.append((placed.size, parts))
    return groups
