"""What both controllers share (:class:`~glmls.app.controller.Controller` of the image window,
:class:`~glmls.app.volume_controller.VolumeController` of the volume window): the key
bindings they have in common, the dispatch of an event, and the keys that change the
settings' MLS configuration, border and help screen.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

from ..core.weights import WEIGHTS
from ..imaging.source import BORDERS
from .events import BUTTONS, Event, Key, Move, Press, Release, Scroll
from .settings import TRANSFORM_ORDER, cycle

__all__ = [
    "BORDER_BINDING",
    "CONFIG_BINDINGS",
    "EDIT_BINDINGS",
    "FILE_BINDINGS",
    "GRID_BINDINGS",
    "Controls",
    "window_bindings",
]

Binding = tuple[tuple[str, ...], str, str]

#: (keys, action, what it does) of both windows, in groups, each in the order the windows
#: list them: the configuration, the grid, the border, the handles' edits, the files.
CONFIG_BINDINGS: tuple[Binding, ...] = (
    (("F1", "?"), "help", "show / hide this help"),
    (("t",), "transform", "cycle transform: rigid, similarity, affine"),
    (("w",), "weight", f"cycle weight: {', '.join(WEIGHTS)}"),
    (("+", "="), "raise", "raise the weight's parameter (idw alpha, else radius)"),
    (("-",), "lower", "lower the weight's parameter"),
)
GRID_BINDINGS: tuple[Binding, ...] = (
    (("g",), "grid_finer", "finer grid (step / 2)"),
    (("G",), "grid_coarser", "coarser grid (step x 2)"),
)
BORDER_BINDING: Binding = (("b",), "border", f"cycle border: {', '.join(BORDERS)}")
EDIT_BINDINGS: tuple[Binding, ...] = (
    (("r",), "reset", "reset: every target back to its source"),
    (("R",), "restore", "restore the handles as loaded"),
    (("u", "Ctrl+Z", "Backspace"), "undo", "undo the last handle edit"),
    (("U", "Ctrl+Y", "Ctrl+Shift+Z"), "redo", "redo the last undone edit"),
)
#: After each window's own saves of the deformed image or volume and of the handles.
FILE_BINDINGS: tuple[Binding, ...] = (
    (("S",), "save_screenshot", "save a screenshot of the window"),
    (("l",), "load_handles", "load the handles file"),
    (("q", "Escape"), "quit", "quit"),
)


def window_bindings(
    construction: Binding,
    after_grid: tuple[Binding, ...],
    own: tuple[Binding, ...],
    saves: tuple[Binding, ...],
) -> tuple[Binding, ...]:
    """A window's key bindings, in the order its help lists them: the shared ones, with its
    ``construction`` key after the configuration's, its keys ``after_grid``, its ``own``
    after the border's, and its ``saves`` (the deformed image or volume, the handles)."""
    return (
        *CONFIG_BINDINGS,
        construction,
        *GRID_BINDINGS,
        *after_grid,
        BORDER_BINDING,
        *own,
        *EDIT_BINDINGS,
        *saves,
        *FILE_BINDINGS,
    )


class Controls:
    """Events to the handlers of a controller (``_press``, ``_move``, ``_release``,
    ``_scroll``, ``_key``), and the key actions on ``settings`` (its ``config`` an
    :class:`~glmls.MLSConfig`, its ``border``) both controllers take; each says how new
    settings take effect (``_configure``)."""

    settings: Any
    help_visible: bool

    def feed(self, event: Event) -> list[str]:
        """Apply one event: change the state, and return what only the window can do.

        Parameters
        ----------
        event : Press, Move, Release, Scroll or Key
            The event, its position in image pixels (montage pixels in the volume window).

        Returns
        -------
        list of str
            The commands for the window (``save_image`` or ``save_volume``,
            ``save_handles``, ``save_screenshot``, ``load_handles``, ``quit``); mostly none.

        Raises
        ------
        ValueError
            For a press of an unknown button.
        TypeError
            For something that is not an event.

        Examples
        --------
        >>> from glmls.app import Controller, Key, Press, Release, VolumeController
        >>> c = Controller([[10.0, 10]], [[12.0, 10]], (64, 64))
        >>> c.feed(Press(40.0, 20.0)), c.feed(Release(40.0, 20.0)), len(c.src)  # a new handle
        ([], [], 2)
        >>> c.feed(Key("s")), c.feed(Key("q"))
        (['save_image'], ['quit'])
        >>> VolumeController([[2.0, 2, 5]], [[2.0, 2, 5]], (10, 12, 12)).feed(Key("s"))
        ['save_volume']
        """
        if isinstance(event, Press):
            if event.button not in BUTTONS:
                raise ValueError(f"unknown mouse button {event.button!r}; use one of {BUTTONS}")
            self._press(event)
        elif isinstance(event, Move):
            self._move(event.x, event.y)
        elif isinstance(event, Release):
            self._release()
        elif isinstance(event, Scroll):
            self._scroll(event)
        elif isinstance(event, Key):
            return self._key(event.key)
        else:
            raise TypeError(f"unknown event {event!r}")
        return []

    def _press(self, event: Press) -> None:
        raise NotImplementedError

    def _move(self, x: float, y: float) -> None:
        raise NotImplementedError

    def _release(self) -> None:
        raise NotImplementedError

    def _scroll(self, event: Scroll) -> None:
        raise NotImplementedError

    def _key(self, key: str) -> list[str]:
        raise NotImplementedError

    def _configure(self, settings: Any) -> None:
        raise NotImplementedError

    def _reconfigure(self, **changes: object) -> None:
        self._configure(replace(self.settings, config=replace(self.settings.config, **changes)))

    def _do_help(self) -> None:
        self.help_visible = not self.help_visible

    def _do_transform(self) -> None:
        self._reconfigure(transform=cycle(TRANSFORM_ORDER, self.settings.config.transform))

    def _do_weight(self) -> None:
        self._reconfigure(weight=cycle(WEIGHTS, self.settings.config.weight))

    def _do_border(self) -> None:
        self._configure(replace(self.settings, border=cycle(BORDERS, self.settings.border)))
