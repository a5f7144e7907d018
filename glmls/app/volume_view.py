"""What the volume window draws each frame: the three deformed slices on the montage (each a
picture scaled onto its part of the viewport), the overlay pictures over them, the slice
point's crosshairs, the active view's frame, the handles near each plane, and the text."""

from __future__ import annotations

import math
from collections.abc import Sequence

import moderngl
import numpy as np

from ..analysis.canvas import HANDLE_SOURCE_COLOR, HANDLE_TARGET_COLOR
from ..analysis.shapes import arrow_triangles, disk_triangles
from ..gl.context import GLContext
from .helpscreen import help_blocks
from .hud import HELP_MIN_SHARE, MIN_WINDOW_HEIGHT, TextGroups, text_quads
from .layout import Layout, layout
from .overlays import GeometryDrawer, PictureDrawer, read_screen
from .text import GlyphAtlas, TextRenderer, glyph_atlas
from .volume_controller import AXES, VIEWS, VOLUME_BINDINGS, VolumeController

__all__ = [
    "MARGIN",
    "VolumeView",
    "frame_lines",
    "handle_triangles",
    "help_groups",
    "help_text",
    "label_quads",
    "montage_layout",
    "scene_geometry",
    "text_groups",
    "view_labels",
    "view_viewport",
    "window_size",
]

BACKGROUND = (0.13, 0.13, 0.14)
CROSSHAIR_RGBA = (0.2, 0.9, 1.0, 0.5)
ACTIVE_RGBA = (1.0, 0.85, 0.2, 1.0)
FRAME_RGBA = (0.5, 0.5, 0.55, 1.0)
LABEL_RGBA = (0.9, 0.9, 0.9, 1.0)
#: Framebuffer pixels of a view label's dark box on each side of its text.
LABEL_PAD = 3
#: The mouse's part of the help (the keys come from :data:`VOLUME_BINDINGS`).
MOUSE_HELP = (
    ("click", "active view; slice point there"),
    ("drag a target", "move it within the plane"),
    ("shift+click", "add a handle (p = q) there"),
    ("right-click", "delete the handle there"),
    ("wheel", "slice point along the normal"),
)


#: Montage pixels of background around the three views, in which their frame lines lie (at
#: the window's very edge a line would fall outside the framebuffer).
MARGIN = 1


def window_size(grid, panel: int) -> tuple[int, int]:
    """The window's default (width, height) for the montage of ``grid`` and its margin beside
    a panel ``panel`` pixels wide: a small montage scaled up to about 560 rows or 900
    columns, a large one down to 1000 rows and 1600 columns at most (a screen's), rounded up
    so that the views fit whole; the montage's area at least the panel's width, the height
    at least :data:`~glmls.app.hud.MIN_WINDOW_HEIGHT` (the readout's)."""
    rows, columns = grid.montage_shape
    rows, columns = rows + 2 * MARGIN, columns + 2 * MARGIN
    scale = max(1.0, min(560 / rows, 900 / columns))
    scale = min(scale, 1000 / rows, 1600 / columns)
    # a narrower area would drop the panel and put the readout over the views
    # (layout.MIN_IMAGE_SHARE)
    height = max(math.ceil(rows * scale), MIN_WINDOW_HEIGHT)  # the readout's, for a flat one
    return panel + max(math.ceil(columns * scale), panel), height


def montage_layout(framebuffer: tuple[int, int], grid, panel: int) -> Layout:
    """The montage of ``grid``, with :data:`MARGIN` montage pixels all round, fitted into
    ``framebuffer`` beside the panel."""
    rows, columns = grid.montage_shape
    shape = (rows + 2 * MARGIN, columns + 2 * MARGIN)
    return layout(framebuffer, shape, panel, origin=(-MARGIN, -MARGIN))


def view_viewport(layout: Layout, grid, view: int) -> tuple[int, int, int, int]:
    """The framebuffer rectangle (GL's origin, bottom left) of ``view`` on the montage."""
    (ox, oy), (columns, rows) = grid.offset(view), grid.size(view)
    left, top = layout.to_framebuffer(ox - 0.5, oy - 0.5)
    right, bottom = layout.to_framebuffer(ox + columns - 0.5, oy + rows - 0.5)
    x0, x1 = round(left), round(right)
    y0 = layout.framebuffer[1] - round(bottom)
    return x0, y0, max(x1 - x0, 1), max(round(bottom) - round(top), 1)


def _rgba(colour, alpha: float = 1.0) -> np.ndarray:
    rgb = np.asarray(colour, np.float32)[:3]
    return np.array([*(rgb / 255.0 if rgb.max() > 1 else rgb), alpha], np.float32)


def _coloured(positions: np.ndarray, rgba) -> np.ndarray:
    colours = np.tile(np.asarray(rgba, np.float32), (len(positions), 1))
    return np.concatenate([positions.astype(np.float32), colours], axis=1)


def _box(x0: float, y0: float, x1: float, y1: float) -> np.ndarray:
    corners = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])
    return np.stack([corners, np.roll(corners, -1, axis=0)], axis=1).reshape(-1, 2)


def frame_lines(c: VolumeController) -> np.ndarray:
    """Line vertex rows x, y, r, g, b, a in montage pixels: each view's frame (the active
    one highlighted, in the margin round the view) and the crosshairs of the other two planes
    (within the view)."""
    grid, lines = c.grid, []
    for view in range(3):
        (ox, oy), (columns, rows) = grid.offset(view), grid.size(view)
        box = _box(ox - 0.5, oy - 0.5, ox + columns - 0.5, oy + rows - 0.5)
        lines.append(_coloured(box, ACTIVE_RGBA if view == c.active else FRAME_RGBA))
        u, v = grid.to_montage(view, grid.to_units(c.point))[0]
        bottom, end = oy + rows - 0.5, ox + columns - 0.5
        cross = np.array([[u, oy - 0.5], [u, bottom], [ox - 0.5, v], [end, v]])
        lines.append(_coloured(cross, CROSSHAIR_RGBA))
    return np.concatenate(lines)


def handle_triangles(c: VolumeController, scale: float, view: int) -> np.ndarray:
    """Triangle vertex rows x, y, r, g, b, a in montage pixels of the handles within
    :attr:`~VolumeController.near` voxels of ``view``'s plane: an arrow from p to q, a disk
    at each, at their physical in-plane positions, wherever those are (a handle outside the
    volume lies outside the view: :meth:`VolumeView.draw` cuts each view's to its own
    rectangle)."""
    grid, unit = c.grid, 1.0 / scale
    shown = c.near_plane(view) if c.show_handles else np.zeros(0, int)
    if not len(shown):
        return np.zeros((0, 6), np.float32)
    p, q = grid.to_montage(view, c.src[shown]), grid.to_montage(view, c.dst[shown])
    target = _rgba(HANDLE_TARGET_COLOR)
    return np.concatenate(
        [
            _coloured(arrow_triangles(p, q, 1.5 * unit, 7.0 * unit), target),
            _coloured(disk_triangles(p, 3.0 * unit), _rgba(HANDLE_SOURCE_COLOR)),
            _coloured(disk_triangles(q, 5.0 * unit), (0.0, 0.0, 0.0, 0.8)),
            _coloured(disk_triangles(q, 3.8 * unit), target),
        ]
    )


def scene_geometry(c: VolumeController, scale: float) -> tuple[np.ndarray, np.ndarray]:
    """(triangles, lines): :func:`handle_triangles` of the three views and
    :func:`frame_lines`, vertex rows x, y, r, g, b, a in montage pixels."""
    triangles = [handle_triangles(c, scale, view) for view in range(3)]
    return np.concatenate(triangles), frame_lines(c)


def view_labels(
    layout: Layout, c: VolumeController, atlas: GlyphAtlas
) -> list[tuple[int, str, GlyphAtlas, tuple[int, int]]]:
    """(view, text, atlas, its top left corner in framebuffer pixels, y down: the view's) of
    each view's label that fits inside the view with its box:
    its name and plane (``axial z = 12``) at ``atlas``'s size or smaller (down to
    :data:`~glmls.app.hud.HELP_MIN_SHARE` of it, 8 pixels at least), else the plane alone
    (``z = 12``, ``z=12``) as large as it fits; a view too small for any (one voxel thin)
    has none."""
    smallest = min(atlas.size, max(8, round(HELP_MIN_SHARE * atlas.size)))
    sizes = range(atlas.size, smallest - 1, -1)
    labels = []
    for view in range(3):
        left, bottom, width, height = view_viewport(layout, c.grid, view)
        corner = (left, layout.framebuffer[1] - bottom - height)
        normal = "xyz"[AXES[view][2]]
        at = c.point[AXES[view][2]]
        full, short = f"{VIEWS[view]} {normal} = {at}", (f"{normal} = {at}", f"{normal}={at}")
        atlases = [atlas if size == atlas.size else glyph_atlas(size) for size in sizes]
        # the whole label at any size first; the plane alone as large as it fits
        candidates = [(full, a) for a in atlases] + [(t, a) for a in atlases for t in short]
        fitting = (
            (text, sized)
            for text, sized in candidates
            if sized.width(text) + 2 * LABEL_PAD <= width and sized.line_height <= height
        )
        found = next(fitting, None)
        if found is not None:
            labels.append((view, *found, corner))
    return labels


def label_quads(layout: Layout, c: VolumeController, atlas: GlyphAtlas) -> TextGroups:
    """Glyph quads of :func:`view_labels` at each view's top left corner, on a dark box,
    the active view's in its frame's colour; grouped by text size."""
    groups: dict[int, list[np.ndarray]] = {}
    for view, text, sized, (x, y) in view_labels(layout, c, atlas):
        colour = ACTIVE_RGBA if view == c.active else LABEL_RGBA
        box = sized.width(text) + 2 * LABEL_PAD
        groups.setdefault(sized.size, []).extend(
            [
                sized.rectangle(x, y, box, sized.line_height, (0, 0, 0, 0.6)),
                sized.quads(text, x + LABEL_PAD, y, colour),
            ]
        )
    return list(groups.items())


#: The help's groups of keys: a title and the actions of :data:`VOLUME_BINDINGS` it lists.
KEY_GROUPS = (
    ("MLS", ("help", "transform", "weight", "raise", "lower", "method", "grid_finer",
             "grid_coarser", "border")),
    ("Overlays", ("overlay_error", "overlay_folds", "handles")),
    ("Views", ("view_axial", "view_coronal", "view_sagittal", "view_next")),
    ("Slice point", ("slice_up", "slice_down", "slice_up8", "slice_down8", "centre")),
    ("Edit", ("reset", "restore", "undo", "redo")),
    ("Files", ("save_volume", "save_handles", "save_screenshot", "load_handles", "quit")),
)  # fmt: skip
#: Shorter key names for the help's labels.
SHORT_KEYS = {"Ctrl+Shift+": "^S-", "Ctrl+": "^", "Backspace": "Bksp", "Escape": "Esc",
              "PageUp": "PgUp", "PageDown": "PgDn"}  # fmt: skip


def _label(keys: tuple[str, ...]) -> str:
    label = " ".join(keys)
    for name, short in SHORT_KEYS.items():
        label = label.replace(name, short)
    return label


def help_groups() -> list[tuple[str, tuple[tuple[str, str, tuple[str, ...]], ...]]]:
    """The help's groups, as :data:`~glmls.app.helpscreen.HELP` has them: the mouse, then
    every key binding in :data:`KEY_GROUPS`."""
    bindings = {action: (keys, what) for keys, action, what in VOLUME_BINDINGS}
    groups = [("Mouse", tuple((action, what, ()) for action, what in MOUSE_HELP))]
    for title, actions in KEY_GROUPS:
        entries = tuple((_label(bindings[a][0]), bindings[a][1], (a,)) for a in actions)
        groups.append((title, entries))
    return groups


def help_text() -> list[str]:
    """The help screen's lines, in order (blocks separated by a blank line)."""
    blocks = help_blocks(help_groups())
    return [line for k, block in enumerate(blocks) for line in ([""] if k else []) + block]


class VolumeView:
    """The volume window's GL objects on context ``gl`` for a controller's montage."""

    def __init__(self, gl: GLContext, c: VolumeController) -> None:
        self.gl = gl
        self.grid = c.grid
        self.slices = [PictureDrawer(gl, self._shape(view)) for view in range(3)]
        self.overlays = [PictureDrawer(gl, self._shape(view)) for view in range(3)]
        self.geometry = GeometryDrawer(gl, c.grid.montage_shape)
        self.texts: dict[int, TextRenderer] = {}
        self._keys: list[tuple] = [(), ()]

    def _shape(self, view: int) -> tuple[int, int]:
        """(rows, columns) of ``view``'s picture: voxels, stretched onto its viewport."""
        right, down, _ = AXES[view]
        return self.grid.extent(down), self.grid.extent(right)

    def text_renderer(self, size: int) -> TextRenderer:
        """The text renderer of ``size`` pixels (made once)."""
        if size not in self.texts:
            self.texts[size] = TextRenderer(self.gl, glyph_atlas(size))
        return self.texts[size]

    @staticmethod
    def _upload(drawers: list[PictureDrawer], pictures: Sequence[np.ndarray]) -> None:
        for drawer, picture in zip(drawers, pictures, strict=True):
            if picture.ndim == 2:
                grey = picture[:, :, None]
                picture = np.concatenate([grey, grey, grey, np.full_like(grey, 255)], axis=2)
            drawer.texture.write(np.ascontiguousarray(picture, np.uint8).tobytes())

    def draw(
        self,
        layout: Layout,
        c: VolumeController,
        slices: tuple[tuple, Sequence[np.ndarray]],
        overlays: tuple[tuple, Sequence[np.ndarray] | None],
        text: Sequence[tuple[int, list[np.ndarray]]],
    ) -> None:
        """One frame into the window's back buffer. ``slices`` and ``overlays``: (a key that
        changes with them, the pictures), uploaded only when their key changed."""
        with self.gl.use():
            mgl = self.gl.mgl
            screen = mgl.screen
            screen.use()
            width, height = layout.framebuffer
            screen.viewport = (0, 0, width, height)
            screen.clear(*BACKGROUND, 1.0)
            if slices[0] != self._keys[0]:
                self._upload(self.slices, slices[1])
                self._keys[0] = slices[0]
            shown = overlays[1] is not None
            if shown and overlays[0] != self._keys[1]:
                self._upload(self.overlays, overlays[1])  # type: ignore[arg-type]
                self._keys[1] = overlays[0]
            for view in range(3):
                screen.viewport = view_viewport(layout, self.grid, view)
                self.slices[view].draw(opacity=1.0, linear=False)
                if shown:
                    self.overlays[view].draw(opacity=1.0, linear=False)
            screen.viewport = layout.viewport
            self.geometry.frame = layout.frame  # the montage and its margin
            self.geometry.draw(frame_lines(c), moderngl.LINES)
            try:  # each view's handles cut to its rectangle, not drawn over the others
                for view in range(3):
                    screen.scissor = view_viewport(layout, self.grid, view)
                    self.geometry.draw(handle_triangles(c, layout.scale, view))
            finally:
                screen.scissor = None
            screen.viewport = (0, 0, width, height)
            for size, parts in text:
                self.text_renderer(size).draw(parts, (width, height))

    def screenshot(self, framebuffer: tuple[int, int]) -> np.ndarray:
        """The back buffer just drawn, (H, W, 3) uint8, top row first."""
        return read_screen(self.gl, framebuffer)

    def release(self) -> None:
        """Release the view's GL objects."""
        if self.gl.usable:
            with self.gl.use():
                for obj in (*self.slices, *self.overlays, self.geometry, *self.texts.values()):
                    obj.release()
        self.texts.clear()


def text_groups(
    atlas: GlyphAtlas, lines: Sequence[str], *, help_visible: bool, framebuffer: tuple[int, int]
) -> list[tuple[int, list[np.ndarray]]]:
    """Glyph quads of the readout (top left, on a dark panel, smaller where it would not fit
    the height, :func:`~glmls.app.hud.readout_quads`) and, if shown, the help laid out as
    the image window's (:func:`~glmls.app.hud.place_help`): beside the readout in one to
    three columns, at its text size or smaller, else over the whole window."""
    blocks = help_blocks(help_groups())
    return text_quads(
        atlas, lines, help_visible=help_visible, panel=0, framebuffer=framebuffer, blocks=blocks
    )
