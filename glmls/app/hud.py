"""The window's text: the readout panel (settings, timings, statistics, messages) and the help
overlay, as lines and then as glyph quads. No GL: :class:`~glmls.app.text.TextRenderer`
draws the quads."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .controller import BINDINGS, OVERLAYS, Controller
from .text import GlyphAtlas

__all__ = ["HELP_MOUSE", "PANEL_CHARS", "help_lines", "readout", "text_quads", "wrap"]

#: Panel width in characters.
PANEL_CHARS = 44
HELP_MOUSE = (
    "Mouse",
    "  click empty space    add a handle (p = q)",
    "  drag a handle        move its target q",
    "  shift + drag         move its source p",
    "  right-click          delete a handle",
    "  in reference mode (p): click adds, drag moves,",
    "  right-click deletes reference points",
)


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
) -> list[str]:
    """The lines of the readout panel."""
    c, s = controller, controller.settings
    times = list(frame_times)
    recent = [t for t in times if t >= times[-1] - 1.0] if times else []
    fps = (len(recent) - 1) / (recent[-1] - recent[0]) if len(recent) > 2 else 0.0
    frame_ms = 1000 * (recent[-1] - recent[-2]) if len(recent) > 1 else 0.0
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
        f"grid       {s.grid} px   (g/G)",
        f"border     {s.border}   (b)",
        f"view       {'fit: whole deformed image' if s.fit else 'input frame'}   (o)",
        f"handles    {len(c.src)}   reference {len(c.reference)}",
        f"mode       {'REFERENCE POINTS' if c.reference_mode else 'handles'}   (p)",
        f"overlays   {' '.join(on) or 'none'}",
        "",
    ]
    if error:
        lines += wrap(f"! {error}", PANEL_CHARS) + ["  (showing the last valid f)"]
    lines += analysis_lines
    if not any(c.overlays[n] for n in ("error", "angle", "folds")):
        lines.append("errors: e field, a angles, f folds")
    lines += ["", "F1 or ?: help"]
    for message in messages:
        lines += wrap(message, PANEL_CHARS)
    return lines


def help_lines() -> list[str]:
    """The help overlay: the mouse, then every key binding."""
    column = max(len(", ".join(keys)) for keys, _, _ in BINDINGS)
    keys = [f"  {', '.join(keys):<{column}} {text}" for keys, _, text in BINDINGS]
    return [*HELP_MOUSE, "Keys", *keys]


def text_quads(
    atlas: GlyphAtlas,
    lines: Sequence[str],
    *,
    help_visible: bool,
    panel: int,
    framebuffer: tuple[int, int],
) -> list[np.ndarray]:
    """Glyph quads of the readout (top left, on a dark panel) and, if shown, the help beside
    the readout where there is room (else centred over everything)."""
    pad = atlas.cell[1] // 2
    width = max(atlas.width(line) for line in lines) + 2 * pad
    height = len(lines) * atlas.line_height + 2 * pad
    parts = [
        atlas.rectangle(0, 0, width, height, (0.0, 0.0, 0.0, 0.55)),
        atlas.quads("\n".join(lines), pad, pad, (0.95, 0.95, 0.95, 1.0)),
    ]
    if not help_visible:
        return parts
    text = help_lines()
    fb_w, fb_h = framebuffer
    pad = atlas.cell[1]
    width = max(atlas.width(line) for line in text) + 2 * pad
    height = len(text) * atlas.line_height + 2 * pad
    left = panel if panel + width <= fb_w else (fb_w - width) / 2
    x, y = max(left, 0), max((fb_h - height) / 2, 0)
    return [
        *parts,
        atlas.rectangle(x, y, width, height, (0.05, 0.05, 0.08, 0.88)),
        atlas.quads("\n".join(text), x + pad, y + pad, (1.0, 0.92, 0.6, 1.0)),
    ]
