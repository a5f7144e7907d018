"""The real-time window (the paper's interactive IDS): ``glmls demo`` / ``python -m glmls.app``.

:mod:`.controller` holds the interaction logic (no window), :mod:`.window` the glfw window that
runs :class:`glmls.WarpPipeline` in its own GL context, :mod:`.command` the command line.
Importing this package does not import glfw; opening a window does.
"""

from .command import configure_parser, run
from .controller import BINDINGS, Controller, Key, Move, Press, Release, Settings
from .events import Wait, read_events

__all__ = [
    "BINDINGS",
    "Controller",
    "Key",
    "Move",
    "Press",
    "Release",
    "Settings",
    "Wait",
    "configure_parser",
    "read_events",
    "run",
]
