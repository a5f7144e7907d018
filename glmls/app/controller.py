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

from ..core.mesh import as_shape
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
    """The image window's interaction, without a window: events in, state and commands out.

    It holds the handles (points and segments), the reference points, the :class:`Settings`,
    the overlays and the zoom, and :meth:`feed` changes them: one event at a time, in image
    pixels (x, y) = (column, row), as :data:`BINDINGS` and :doc:`/window` say. What only a
    window can do (save or load files, quit) comes back as commands. :class:`App` keeps one;
    on its own it tests, scripts or replays an interaction headless.

    Parameters
    ----------
    src, dst : array_like
        The point handles p and q, (N, 2) (x, y) in image pixels (N may be 0).
    shape : tuple of int
        (H, W) of the image.
    reference : array_like, optional
        Reference points (M, 2), whose angle errors the window reports; none by default.
    src_segments, dst_segments : array_like, optional
        Segment handles (S, 2, 2), each two end points (x, y); none by default.
    settings : Settings, optional
        What is shown: the MLS configuration and the image construction; ``Settings()`` by
        default.
    pick_radius : float, default 8
        How near (image pixels) a click must be to grab a point or a segment; the window
        keeps it at a fixed size on screen.
    overlays : dict of str to bool, optional
        Which of the overlays (``handles``, ``mesh``, ``error``, ``angle``, ``folds``) are
        on; by default the handles only.
    mode : {"points", "segments", "reference"}, default "points"
        What a left click on empty space does: add a point handle, draw a segment handle,
        or add a reference point.
    help_visible : bool, default False
        Whether the help screen shows.

    Attributes
    ----------
    settings : Settings
        What is shown now (replaced, never changed, by the keys).
    overlays : dict of str to bool
        Which overlays are on.
    mode : str
        One of "points", "segments" and "reference".
    zoom : glmls.app.zoom.Zoom
        The zoom factor (``zoom.factor``) and the pan.
    message : str
        A line for the readout, set by an action ("nothing to undo"); the window clears it.
    view_limits : glmls.app.zoom.ViewLimits
        What zoom and pan may show; the window keeps it in step with its layout.

    Raises
    ------
    ValueError
        For handles of the wrong shape or not finite, or an unknown ``mode``.
    TypeError
        For ``settings`` that are not :class:`Settings`.

    See Also
    --------
    App : the window around it.
    VolumeController : the volume window's.

    Examples
    --------
    Drag the target of a handle, cycle the transform, then undo the drag:

    >>> from glmls.app import Controller, Key, Move, Press, Release
    >>> c = Controller([[20.0, 20], [80, 80]], [[20.0, 20], [80, 80]], (100, 120))
    >>> for event in (Press(20, 20), Move(30, 25), Release(30, 25)):
    ...     _ = c.feed(event)  # no command
    >>> c.dst.tolist(), c.undo_depth
    ([[30.0, 25.0], [80.0, 80.0]], 1)
    >>> c.feed(Key("t")), c.settings.config.transform
    ([], 'similarity')
    >>> c.feed(Key("u")), c.dst.tolist()
    ([], [[20.0, 20.0], [80.0, 80.0]])

    The file keys are commands for the window:

    >>> c.feed(Key("j")), c.feed(Key("q"))
    (['save_handles'], ['quit'])
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
        self.shape = as_shape(shape)  # (H, W) of integers >= 1, or an error naming shape
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
        """The current handles and reference points (replaced, never changed, by edits).

        Examples
        --------
        >>> from glmls.app import Controller, Key
        >>> c = Controller([[10.0, 10]], [[12.0, 10]], (64, 64), reference=[[30.0, 30]])
        >>> before = c.handles
        >>> before.dst.tolist(), before.reference.tolist()
        ([[12.0, 10.0]], [[30.0, 30.0]])
        >>> _ = c.feed(Key("r"))  # every target back to its source: a new state
        >>> c.handles.dst.tolist(), before.dst.tolist()
        ([[10.0, 10.0]], [[12.0, 10.0]])
        """
        return self.editor.state

    @property
    def src(self) -> np.ndarray:
        """The point handles' sources p, (N, 2).

        Examples
        --------
        >>> from glmls.app import Controller, Press, Release
        >>> c = Controller([[10.0, 10]], [[12.0, 10]], (64, 64))
        >>> for event in (Press(40.0, 20.0), Release(40.0, 20.0)):  # a click adds p = q
        ...     _ = c.feed(event)
        >>> c.src.tolist()
        [[10.0, 10.0], [40.0, 20.0]]
        """
        return self.editor.state.src

    @property
    def dst(self) -> np.ndarray:
        """The point handles' targets q, (N, 2).

        Examples
        --------
        >>> from glmls.app import Controller, Move, Press, Release
        >>> c = Controller([[10.0, 10]], [[12.0, 10]], (64, 64))
        >>> for event in (Press(12.0, 10.0), Move(20.0, 15.0), Release(20.0, 15.0)):
        ...     _ = c.feed(event)  # drag q_0
        >>> c.dst.tolist(), c.src.tolist()
        ([[20.0, 15.0]], [[10.0, 10.0]])
        """
        return self.editor.state.dst

    @property
    def src_segments(self) -> np.ndarray:
        """The segment handles' sources, (S, 2, 2).

        Examples
        --------
        >>> from glmls.app import Controller, Key, Move, Press, Release
        >>> c = Controller([[10.0, 10]], [[12.0, 10]], (64, 64))
        >>> c.src_segments.shape
        (0, 2, 2)
        >>> _ = c.feed(Key("d"))  # segment mode: a drag on empty space draws one
        >>> for event in (Press(30.0, 20.0), Move(50.0, 40.0), Release(50.0, 40.0)):
        ...     _ = c.feed(event)
        >>> c.src_segments.tolist()
        [[[30.0, 20.0], [50.0, 40.0]]]
        """
        return self.editor.state.src_segments

    @property
    def dst_segments(self) -> np.ndarray:
        """The segment handles' targets, (S, 2, 2).

        Examples
        --------
        >>> from glmls.app import Controller, Key, Move, Press, Release
        >>> c = Controller([[10.0, 10]], [[12.0, 10]], (64, 64))
        >>> c.dst_segments.shape
        (0, 2, 2)
        >>> _ = c.feed(Key("d"))  # segment mode: a drag on empty space draws one
        >>> for event in (Press(30.0, 20.0), Move(50.0, 40.0), Release(50.0, 40.0)):
        ...     _ = c.feed(event)
        >>> c.dst_segments.tolist()
        [[[30.0, 20.0], [50.0, 40.0]]]
        """
        return self.editor.state.dst_segments

    @property
    def reference(self) -> np.ndarray:
        """The reference points, (M, 2); set it to replace them (one edit, undoable).

        Examples
        --------
        >>> from glmls.app import Controller, Key
        >>> c = Controller([[10.0, 10]], [[12.0, 10]], (64, 64))
        >>> c.reference.shape
        (0, 2)
        >>> c.reference = [[30.0, 30.0], [40.0, 20.0]]
        >>> c.reference.tolist(), c.undo_depth
        ([[30.0, 30.0], [40.0, 20.0]], 1)
        >>> _ = c.feed(Key("u"))
        >>> c.reference.shape, c.dst.tolist()
        ((0, 2), [[12.0, 10.0]])
        """
        return self.editor.state.reference

    @reference.setter
    def reference(self, points: object) -> None:
        s = self.editor.state
        self.editor.replace(Handles.of(s.src, s.dst, s.src_segments, s.dst_segments, points))

    @property
    def drawing(self) -> np.ndarray | None:
        """The segment being drawn (2, 2), if any: it becomes a handle on release.

        Examples
        --------
        >>> from glmls.app import Controller, Key, Move, Press, Release
        >>> c = Controller([[10.0, 10]], [[12.0, 10]], (64, 64))
        >>> _ = c.feed(Key("d"))  # segment mode
        >>> for event in (Press(30.0, 20.0), Move(50.0, 40.0)):
        ...     _ = c.feed(event)
        >>> c.drawing.tolist()
        [[30.0, 20.0], [50.0, 40.0]]
        >>> _ = c.feed(Release(50.0, 40.0))
        >>> c.drawing is None, len(c.src_segments)
        (True, 1)
        """
        return self.editor.drawing

    @property
    def revision(self) -> int:
        """A count that grows whenever the handles or the settings change.

        The window uploads the handles again when it does.

        Examples
        --------
        >>> from glmls.app import Controller, Key, Move, Press, Release
        >>> c = Controller([[10.0, 10]], [[12.0, 10]], (64, 64))
        >>> start = c.revision
        >>> _ = c.feed(Key("t"))  # the next transform
        >>> c.revision - start
        1
        >>> for event in (Press(12.0, 10.0), Move(20.0, 15.0), Release(20.0, 15.0)):
        ...     _ = c.feed(event)
        >>> c.revision > start + 1
        True
        """
        return self.editor.revision + self._settings_revision

    @property
    def reference_revision(self) -> int:
        """A count that grows whenever the reference points change.

        Examples
        --------
        >>> from glmls.app import Controller, Key
        >>> c = Controller([[10.0, 10]], [[12.0, 10]], (64, 64))
        >>> start = c.reference_revision
        >>> _ = c.feed(Key("t"))  # the settings: not the reference points
        >>> c.reference_revision == start
        True
        >>> c.reference = [[30.0, 30.0]]
        >>> c.reference_revision > start
        True
        """
        return self.editor.reference_revision

    @property
    def reference_mode(self) -> bool:
        """Whether a left click adds or moves a reference point (``p``).

        Examples
        --------
        >>> from glmls.app import Controller, Key, Press, Release
        >>> c = Controller([[10.0, 10]], [[12.0, 10]], (64, 64))
        >>> _ = c.feed(Key("p"))
        >>> c.reference_mode, c.mode
        (True, 'reference')
        >>> for event in (Press(30.0, 30.0), Release(30.0, 30.0)):
        ...     _ = c.feed(event)
        >>> c.reference.tolist(), len(c.src)
        ([[30.0, 30.0]], 1)
        """
        return self.mode == "reference"

    @property
    def segment_mode(self) -> bool:
        """Whether a drag on empty space draws a segment handle (``d``).

        Examples
        --------
        >>> from glmls.app import Controller, Key
        >>> c = Controller([[10.0, 10]], [[12.0, 10]], (64, 64))
        >>> c.segment_mode
        False
        >>> _ = c.feed(Key("d"))
        >>> c.segment_mode, c.mode
        (True, 'segments')
        >>> _ = c.feed(Key("d"))  # off again
        >>> c.segment_mode
        False
        """
        return self.mode == "segments"

    @property
    def dragging(self) -> bool:
        """Whether a button is down on something (a handle, a drawing, a pan).

        Examples
        --------
        >>> from glmls.app import Controller, Press, Release
        >>> c = Controller([[10.0, 10]], [[12.0, 10]], (64, 64))
        >>> _ = c.feed(Press(12.0, 10.0))  # on q_0
        >>> c.dragging
        True
        >>> _ = c.feed(Release(12.0, 10.0))
        >>> c.dragging
        False
        """
        return self.editor.dragging or self._pan_anchor is not None

    @property
    def undo_depth(self) -> int:
        """How many handle edits ``u`` can undo.

        Examples
        --------
        >>> from glmls.app import Controller, Key
        >>> c = Controller([[10.0, 10]], [[12.0, 10]], (64, 64))
        >>> c.undo_depth
        0
        >>> _ = c.feed(Key("r"))  # reset: one edit
        >>> c.undo_depth
        1
        >>> _ = c.feed(Key("u"))
        >>> c.undo_depth, c.dst.tolist()
        (0, [[12.0, 10.0]])
        """
        return self.editor.undo_depth

    @property
    def redo_depth(self) -> int:
        """How many undone edits ``U`` can redo.

        Examples
        --------
        >>> from glmls.app import Controller, Key
        >>> c = Controller([[10.0, 10]], [[12.0, 10]], (64, 64))
        >>> _ = c.feed(Key("r")), c.feed(Key("u"))  # reset, then undo it
        >>> c.redo_depth, c.dst.tolist()
        (1, [[12.0, 10.0]])
        >>> _ = c.feed(Key("U"))
        >>> c.redo_depth, c.dst.tolist()
        (0, [[10.0, 10.0]])
        """
        return self.editor.redo_depth

    def set_handles(
        self,
        src: object,
        dst: object,
        *,
        src_segments: object = None,
        dst_segments: object = None,
    ) -> None:
        """Replace every handle (undoable), e.g. loaded from a file; the reference points stay.

        Parameters
        ----------
        src, dst : array_like
            The point handles (N, 2).
        src_segments, dst_segments : array_like, optional
            The segment handles (S, 2, 2); ``None``: none.

        Examples
        --------
        >>> from glmls.app import Controller, Key
        >>> c = Controller([[10.0, 10]], [[12.0, 10]], (64, 64), reference=[[30.0, 30]])
        >>> c.set_handles([[5.0, 5], [50, 50]], [[6.0, 5], [48, 50]])
        >>> c.dst.tolist(), c.reference.tolist()
        ([[6.0, 5.0], [48.0, 50.0]], [[30.0, 30.0]])
        >>> _ = c.feed(Key("u"))  # undone as one edit
        >>> c.dst.tolist()
        [[12.0, 10.0]]
        """
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
        self._release()  # a drag under way ends first, as its own edit (a drawn segment kept)
        s = self.editor.state
        if not (np.array_equal(s.dst, s.src) and np.array_equal(s.dst_segments, s.src_segments)):
            self.set_handles(s.src, s.src, src_segments=s.src_segments, dst_segments=s.src_segments)

    def _do_restore(self) -> None:
        self._release()  # a drag under way ends first, as its own edit
        loaded = self.editor.loaded
        if not loaded.same_handles(self.editor.state):  # as loaded: no edit to undo
            self.set_handles(
                loaded.src,
                loaded.dst,
                src_segments=loaded.src_segments,
                dst_segments=loaded.dst_segments,
            )

    def _do_undo(self) -> None:
        self._pan_anchor = None
        if not self.editor.undo():
            self.message = "nothing to undo"

    def _do_redo(self) -> None:
        self._pan_anchor = None
        if not self.editor.redo():
            self.message = "nothing to redo"
