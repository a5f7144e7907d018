"""The help screen (``F1`` or ``?``): the mouse and every key binding, in groups, laid out to
fit beside the readout: in one to three columns, at the readout's text size or smaller, and
only if nothing fits there, over the whole window. No GL: lines and where they go."""

from __future__ import annotations

import itertools
import textwrap
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from ..core.weights import WEIGHTS
from ..imaging.source import BORDERS
from .settings import TRANSFORM_ORDER
from .text import GlyphAtlas

__all__ = ["HELP", "HelpLayout", "help_blocks", "help_layout"]

#: The help's groups: a title and entries (label, what it does, the BINDINGS actions it
#: covers; none for the mouse). Every action of :data:`glmls.app.controller.BINDINGS` is here.
HELP: tuple[tuple[str, tuple[tuple[str, str, tuple[str, ...]], ...]], ...] = (
    ("Mouse", (
        ("click", "add a point (p = q)", ()),
        ("drag", "move a target", ()),
        ("shift+drag", "move a source", ()),
        ("right-click", "delete a handle", ()),
        ("wheel", "zoom at the cursor", ()),
        ("middle-drag", "pan (or ctrl+drag)", ()),
    )),
    ("Segments: mode d", (
        ("drag on empty", "draw one (p = q)", ()),
        ("drag an end", "move that end", ()),
        ("drag between", "move it whole", ()),
    )),
    ("Reference points: mode p", (
        ("click, drag", "add, move one", ()),
        ("right-click", "delete one", ()),
    )),
    ("Edit", (
        ("d", "segment mode on / off", ("segment_mode",)),
        ("p", "reference-point mode", ("reference_mode",)),
        ("u ^Z Bksp", "undo", ("undo",)),
        ("U ^Y", "redo", ("redo",)),
        ("r", "targets to sources", ("reset",)),
        ("R", "restore as loaded", ("restore",)),
    )),
    ("View", (
        ("] [", "zoom in / out", ("zoom_in", "zoom_out")),
        ("arrows", "pan", ("pan_left", "pan_right", "pan_up", "pan_down")),
        ("0", "reset zoom and pan", ("zoom_reset",)),
        ("o", "fit the deformed image", ("fit",)),
        ("F1 ?", "this help", ("help",)),
    )),
    ("MLS", (
        ("t", f"transform: {', '.join(TRANSFORM_ORDER)}", ("transform",)),
        ("w", f"weight: {', '.join(WEIGHTS)}", ("weight",)),
        ("+ -", "weight's alpha or radius", ("raise", "lower")),
        ("c", "construction: quads nearest, quads linear, splat, backward", ("construction",)),
        ("g G", "finer / coarser grid", ("grid_finer", "grid_coarser")),
        ("T", "adaptive mesh: off, 0.25, 0.05 px", ("tolerance",)),
        ("b", f"border: {', '.join(BORDERS)}", ("border",)),
    )),
    ("Overlays", (
        ("h", "handles", ("overlay_handles",)),
        ("m", "deformed mesh", ("overlay_mesh",)),
        ("e", "error field (eq. 7)", ("overlay_error",)),
        ("a", "angle error (degrees)", ("overlay_angle",)),
        ("f", "fold-overs", ("overlay_folds",)),
    )),
    ("Files", (
        ("s", "save the deformed image", ("save_image",)),
        ("j", "save the handles", ("save_handles",)),
        ("S", "save a screenshot", ("save_screenshot",)),
        ("l", "load the handles", ("load_handles",)),
        ("q Esc", "quit", ("quit",)),
    )),
)  # fmt: skip
#: Blank pixels between columns (in character widths).
COLUMN_GAP = 3
#: Entries longer than this (characters, label included) go on over more lines.
LINE_CHARS = 38


def help_blocks(
    groups: Sequence[tuple[str, Sequence[tuple[str, str, tuple[str, ...]]]]] = HELP,
) -> list[list[str]]:
    """The help as blocks of lines: a title, then its entries, labels aligned per block, long
    ones wrapped under their text; ``groups`` as :data:`HELP` (the image window's)."""
    blocks: list[list[str]] = []
    for title, entries in groups:
        width = max(len(label) for label, _, _ in entries)
        lines = [title]
        for label, text, _ in entries:
            indent = 2 + width + 2
            wrapped = textwrap.wrap(text, max(LINE_CHARS - indent, 12))
            lines.append(f"  {label:<{width}}  {wrapped[0]}")
            lines += [" " * indent + more for more in wrapped[1:]]
        blocks.append(lines)
    return blocks


@dataclass(frozen=True)
class HelpLayout:
    """The help at text ``size``: its box ``(x, y, width, height)`` (framebuffer pixels, y
    down), and each column's left edge and lines."""

    size: int
    box: tuple[float, float, float, float]
    columns: tuple[tuple[float, tuple[str, ...]], ...]

    @property
    def lines(self) -> list[str]:
        return [line for _, lines in self.columns for line in lines]


def _columns(blocks: list[list[str]], count: int) -> list[list[str]]:
    """``blocks`` in ``count`` columns (in order, a blank line between blocks), the tallest
    as short as can be."""
    best: list[list[str]] | None = None
    for cuts in itertools.combinations(range(1, len(blocks)), count - 1):
        edges = (0, *cuts, len(blocks))
        columns = [
            [line for k, block in enumerate(blocks[a:b]) for line in ([""] if k else []) + block]
            for a, b in itertools.pairwise(edges)
        ]
        if best is None or max(map(len, columns)) < max(map(len, best)):
            best = columns
    return best or [[line for block in blocks for line in block]]


def help_layout(
    areas: Sequence[tuple[float, float, float, float]],
    sizes: Sequence[int],
    atlas_of: Callable[[int], GlyphAtlas],
    blocks: list[list[str]] | None = None,
) -> HelpLayout:
    """Where the help goes: in the first of ``areas`` (x, y, width, height; framebuffer
    pixels, y down) that takes it, at the largest of ``sizes`` (text pixels, largest first)
    and the fewest columns (1 to 3) that fit there, centred. Where none fits, the last area
    at the smallest size in 3 columns, from its top left."""
    blocks = help_blocks() if blocks is None else blocks
    for area, size, count in itertools.product(areas, sizes, (1, 2, 3)):
        if count > len(blocks):
            continue
        found = _place(area, atlas_of(size), size, _columns(blocks, count))
        if found is not None:
            return found
    size = sizes[-1]
    columns = _columns(blocks, min(3, len(blocks)))
    return _place(areas[-1], atlas_of(size), size, columns, force=True)  # type: ignore[return-value]


def _place(area, atlas: GlyphAtlas, size: int, columns, *, force: bool = False):
    x, y, width, height = area
    pad = atlas.line_height / 2
    gap = COLUMN_GAP * atlas.advance["M"]
    widths = [max(atlas.width(line) for line in column) for column in columns]
    box_w = sum(widths) + gap * (len(columns) - 1) + 2 * pad
    box_h = max(map(len, columns)) * atlas.line_height + 2 * pad
    if not force and (box_w > width or box_h > height):
        return None
    left = x + max((width - box_w) / 2, 0)
    top = y + max((height - box_h) / 2, 0)
    placed, pen = [], left + pad
    for column, column_width in zip(columns, widths, strict=True):
        placed.append((pen, tuple(column)))
        pen += column_width + gap
    return HelpLayout(size, (left, top, box_w, box_h), tuple(placed))
