"""The real-time window (the paper's interactive IDS), opened by ``glmls demo``.

:mod:`.controller` holds the interaction logic (no window; :mod:`.editing` the handle edits,
:mod:`.zoom` zoom and pan, :mod:`.settings` what is shown, :mod:`.events` the events, replays
and recordings), :mod:`.session` what is computed (the MLS and the analysis), :mod:`.view` and
:mod:`.overlays` what is drawn, :mod:`.hud` and :mod:`.helpscreen` the text,
:mod:`.glfw_window` the operating-system window, :mod:`.commands` the file keys, and
:mod:`.window` the :class:`~glmls.app.window.App` that runs them. The volume window (three
orthogonal slices of a volume, 3D handles) has its own :mod:`.volume_controller`,
:mod:`.volume_session`, :mod:`.volume_view` and :mod:`.volume_window` (the
:class:`~glmls.app.volume_window.VolumeApp`), with the same events, operating-system window,
layout and text. Importing this package does not import glfw; opening a window does.
"""

from .controller import BINDINGS, Controller, Settings
from .events import Key, Move, Press, Recorder, Release, Scroll, Wait, read_events, write_events

__all__ = [
    "BINDINGS",
    "Controller",
    "Key",
    "Move",
    "Press",
    "Recorder",
    "Release",
    "Scroll",
    "Settings",
    "Wait",
    "read_events",
    "write_events",
]
