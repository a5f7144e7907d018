"""The window's interaction logic, free of any window: events in, state and commands out.

Positions are image pixels, (x, y) = (column, row), pixel centres at integers; the window
converts the cursor (see :mod:`glmls.app.layout`), and a replay file gives them directly.
The controller changes its own state (handles, reference points, settings, overlays, zoom)
and returns *commands* for what only the window can do (save files, load handles, quit). The
editing of the handles is :class:`~glmls.app.editing.Editor`'s, zoom and pan
:mod:`glmls.app.zoom`'s.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from .controls import Controls, window_bindings
from .editing import UNDO_DEPTH, Editor, Handles, pick
from .events import Key, Move, Press, Release, Scroll
from .settings import CONSTRUCTIONS, GRIDS, TRANSFORM_ORDER, Settings
from .zoom import ZOOM_STEP, ViewLimits, Zoom, pan, zoom_at

__all__ = [
    "BINDINGS",
    "COMMANDS",
    "CONSTRUCTIONS",
    "GRIDS",
    "MODES",
    "OVERLAYS",
    "TRANSFORM_ORDER",
    "UNDO_DEPTH",
    "Controller",
    "Key",
    "Move",
    "Press",
    "Release",
    "Scroll",
    "Settings",
    "pick",
]

OVERLAYS = ("handles", "mesh", "error", "angle", "folds")
COMMANDS = ("save_image", "save_handles", "save_screenshot", "load_handles", "quit")
#: What a left click on empty space does: add a point handle, draw a segment handle, or
#: (reference mode) add a reference point.
MODES = ("points", "segments", "reference")
#: The arrow keys pan by this share of the view.
PAN_SHARE = 0.125
#: Mouse-wheel notches taken from one event at most (ZOOM_STEP ** 1000 is past any zoom).
MAX_NOTCHES = 1000.0

#: (keys, action, what it does): the key bindings. Printable keys are the characters typed;
#: others are named ("F1", "Escape", "Ctrl+Z", "Left"). The help screen (:mod:`.hud`) lists
#: them all, grouped.
BINDINGS: tuple[tuple[tuple[str, ...], str, str], ...] = window_bindings(
    (("c",), "construction", "cycle construction: quads nearest/linear, splat, backward"),
    ((("T",), "tolerance", "cycle the adaptive mesh (quads): off, 0.25 px, 0.05 px"),),
    (
        (("o",), "fit", "fit view: the whole deformed image / the input's frame"),
        (("]",), "zoom_in", "zoom in (about the view's centre)"),
        (("[",), "zoom_out", "zoom out"),
        (("0",), "zoom_reset", "reset zoom and pan"),
        (("Left",), "pan_left", "pan left"),
        (("Right",), "pan_right", "pan right"),
        (("Up",), "pan_up", "pan up"),
        (("Down",), "pan_down", "pan down"),
        (("h",), "overlay_handles", "overlay: handles (p -> q arrows, segments)"),
        (("m",), "overlay_mesh", "overlay: deformed mesh wireframe"),
        (("e",), "overlay_error", "overlay: MLS error field (eq. 7)"),
        (("a",), "overlay_angle", "overlay: triangle angular error (degrees)"),
        (("f",), "overlay_folds", "overlay: fold-overs"),
        (("d",), "segment_mode", "segment mode on / off: a drag on empty space draws one"),
        (("p",), "reference_mode", "reference-point mode on / off"),
    ),
    (
        (("s",), "save_image", "save the deformed image (full resolution)"),
        (("j",), "save_handles", "save the handles as JSON"),
    ),
)
ACTIONS = {key: action for keys, action, _ in BINDINGS for key in keys}


class Controller(Controls):
    """Handles (points and segments), reference points, settings, overlays and zoom, changed
    by :meth:`feed`.

    ``revision`` grows whenever the handles or the settings change (the window then
    re-uploads the handles); ``reference_revision`` when the reference points change.
    ``pick_radius`` (image pixels) is how near a click must be to grab a point or segment;
    the window keeps it at a fixed size on screen, and keeps ``view_limits`` (what zoom and
    pan may show) in step with its layout.
    """

    def __init__(
        self,
        src: object,
        dst: object,
        shape: tuple[int, int],
        *,
        reference: object = None,
        src_segments: object = None,
        dst_segments: object = None,
        settings: Settings | None = None,
        pick_radius: float = 8.0,
        overlays: dict[str, bool] | None = None,
        mode: str = "points",
        help_visible: bool = False,
    ) -> None:
        self.shape = (int(shape[0]), int(shape[1]))
        handles = Handles.of(src, dst, src_segments, dst_segments, reference)
        self.editor = Editor(handles, self.shape)
        self.settings = settings if settings is not None else Settings()
        if not isinstance(self.settings, Settings):
            raise TypeError(f"settings must be Settings, got {type(self.settings).__name__}")
        if mode not in MODES:
            raise ValueError(f"mode must be one of {', '.join(MODES)}, got {mode!r}")
        self.mode = mode
        self.pick_radius = float(pick_radius)
        wanted = {"handles": True} if overlays is None else overlays
        self.overlays = {name: bool(wanted.get(name, False)) for name in OVERLAYS}
        self.help_visible = help_visible
        self.message = ""
        self.zoom = Zoom()
        self.view_limits = ViewLimits.of_shape(self.shape)
        self._settings_revision = 0
        self._pan_anchor: tuple[float, float] | None = None

    # -- state --------------------------------------------------------------------------------

    @property
    def handles(self) -> Handles:
        """The current handles and reference points (replaced, never changed, by edits)."""
        return self.editor.state

    @property
    def src(self) -> np.ndarray:
        return self.editor.state.src

    @property
    def dst(self) -> np.ndarray:
        return self.editor.state.dst

    @property
    def src_segments(self) -> np.ndarray:
        return self.editor.state.src_segments

    @property
    def dst_segments(self) -> np.ndarray:
        return self.editor.state.dst_segments

    @property
    def reference(self) -> np.ndarray:
        return self.editor.state.reference

    @reference.setter
    def reference(self, points: object) -> None:
        s = self.editor.state
        self.editor.replace(Handles.of(s.src, s.dst, s.src_segments, s.dst_segments, points))

    @property
    def drawing(self) -> np.ndarray | None:
        """The segment being drawn (2, 2), if any: it becomes a handle on release."""
        return self.editor.drawing

    @property
    def revision(self) -> int:
        return self.editor.revision + self._settings_revision

    @property
    def reference_revision(self) -> int:
        return self.editor.reference_revision

    @property
    def reference_mode(self) -> bool:
        return self.mode == "reference"

    @property
    def segment_mode(self) -> bool:
        return self.mode == "segments"

    @property
    def dragging(self) -> bool:
        """Whether a button is down on something (a handle, a drawing, a pan)."""
        return self.editor.dragging or self._pan_anchor is not None

    @property
    def undo_depth(self) -> int:
        return self.editor.undo_depth

    @property
    def redo_depth(self) -> int:
        return self.editor.redo_depth

    def set_handles(
        self, src: object, dst: object, src_segments: object = None, dst_segments: object = None
    ) -> None:
        """Replace every handle (undoable; ``None`` segments: none), e.g. loaded from a file;
        the reference points stay."""
        reference = self.editor.state.reference
        self.editor.replace(Handles.of(src, dst, src_segments, dst_segments, reference))

    # -- events -------------------------------------------------------------------------------

    # feed (Controls): the commands it returns are names in COMMANDS

    def _scroll(self, event: Scroll) -> None:
        # past a few hundred notches every zoom is at a limit: a replay's dy of 1e6 would
        # overflow ZOOM_STEP ** dy
        notches = min(max(event.dy, -MAX_NOTCHES), MAX_NOTCHES)
        self._zoom(zoom_at(self.zoom, self.view_limits, event.x, event.y, ZOOM_STEP**notches))

    def _press(self, event: Press) -> None:
        self._release()  # a press while dragging (a lost release) ends the old drag
        x, y, r = event.x, event.y, self.pick_radius
        if event.button == "middle" or (event.button == "left" and "ctrl" in event.mods):
            self._pan_anchor = (x, y)
        elif event.button == "right":
            self.editor.delete(x, y, radius=r, reference=self.reference_mode)
        elif self.reference_mode:
            self.editor.press_reference(x, y, radius=r)
        else:
            source = "shift" in event.mods
            self.editor.press(x, y, source=source, segments=self.segment_mode, radius=r)

    def _move(self, x: float, y: float) -> None:
        if self._pan_anchor is not None:  # the anchor's image point back under the cursor
            ax, ay = self._pan_anchor
            self._zoom(pan(self.zoom, self.view_limits, ax - x, ay - y))
        else:
            self.editor.move(x, y, radius=self.pick_radius)

    def _release(self) -> None:
        self._pan_anchor = None
        self.editor.release(radius=self.pick_radius)

    def _zoom(self, zoom: Zoom) -> None:
        self.zoom = zoom

    def _key(self, key: str) -> list[str]:
        action = ACTIONS.get(key)
        if action is None:
            return []
        if action in COMMANDS:
            return [action]
        if action.startswith("overlay_"):
            name = action.removeprefix("overlay_")
            self.overlays[name] = not self.overlays[name]
        elif action.startswith("pan_"):
            self._pan_key(action.removeprefix("pan_"))
        else:
            try:
                getattr(self, f"_do_{action}")()
            except ValueError as error:  # e.g. a grid the construction refuses: said
                self.message = str(error)
        return []

    # -- key actions --------------------------------------------------------------------------

    def _configure(self, settings: Settings) -> None:
        if settings == self.settings:  # e.g. g at the finest grid: nothing to redo
            return
        self.settings = settings
        self._settings_revision += 1

    def _do_raise(self) -> None:
        self._configure(self.settings.stepped(self.shape, up=True))

    def _do_lower(self) -> None:
        self._configure(self.settings.stepped(self.shape, up=False))

    def _do_construction(self) -> None:
        self._configure(self.settings.next_construction())

    def _do_grid_finer(self) -> None:
        self._configure(self.settings.next_grid(-1))

    def _do_grid_coarser(self) -> None:
        self._configure(self.settings.next_grid(+1))

    def _do_tolerance(self) -> None:
        self._configure(self.settings.next_tolerance())

    def _do_fit(self) -> None:
        self._configure(replace(self.settings, fit=not self.settings.fit))

    def _do_zoom_in(self) -> None:
        x, y = self.zoom.centre_in(self.view_limits)
        self._zoom(zoom_at(self.zoom, self.view_limits, x, y, ZOOM_STEP))

    def _do_zoom_out(self) -> None:
        x, y = self.zoom.centre_in(self.view_limits)
        self._zoom(zoom_at(self.zoom, self.view_limits, x, y, 1 / ZOOM_STEP))

    def _do_zoom_reset(self) -> None:
        self._zoom(Zoom())

    def _pan_key(self, direction: str) -> None:
        w, h = self.view_limits.visible
        step = PAN_SHARE / self.zoom.factor
        dx, dy = {"left": (-w, 0), "right": (w, 0), "up": (0, -h), "down": (0, h)}[direction]
        self._zoom(pan(self.zoom, self.view_limits, dx * step, dy * step))

    def _mode(self, mode: str) -> None:
        self._release()
        self.mode = "points" if self.mode == mode else mode

    def _do_segment_mode(self) -> None:
        self._mode("segments")

    def _do_reference_mode(self) -> None:
        self._mode("reference")

    def _do_reset(self) -> None:
        s = self.editor.state
        if not (np.array_equal(s.dst, s.src) and np.array_equal(s.dst_segments, s.src_segments)):
            self.set_handles(s.src, s.src, s.src_segments, s.src_segments)

    def _do_restore(self) -> None:
        self._release()  # a drag under way ends first, as its own edit
        loaded = self.editor.loaded
        if not loaded.same_handles(self.editor.state):  # as loaded: no edit to undo
            self.set_handles(loaded.src, loaded.dst, loaded.src_segments, loaded.dst_segments)

    def _do_undo(self) -> None:
        self._pan_anchor = None
        if not self.editor.undo():
            self.message = "nothing to undo"

    def _do_redo(self) -> None:
        self._pan_anchor = None
        if not self.editor.redo():
            self.message = "nothing to redo"
