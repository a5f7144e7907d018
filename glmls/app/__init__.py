"""The real-time window (the paper's interactive IDS), opened by ``glmls demo``.

:mod:`.controller` holds the interaction logic (no window; :mod:`.events` its events and
replays), :mod:`.session` what is computed (the MLS and the analysis), :mod:`.view` and
:mod:`.overlays` what is drawn, :mod:`.hud` the text, :mod:`.glfw_window` the operating-system
window, and :mod:`.window` the :class:`~glmls.app.window.App` that runs them. Importing this
package does not import glfw; opening a window does.
"""

from .controller import BINDINGS, Controller, Settings
from .events import Key, Move, Press, Release, Wait, read_events

__all__ = [
    "BINDINGS",
    "Controller",
    "Key",
    "Move",
    "Press",
    "Release",
    "Settings",
    "Wait",
    "read_events",
]
