"""The real-time windows (the paper's interactive IDS), opened by ``glmls demo``, and their
interaction without a window.

:class:`App` is the image window, :class:`VolumeApp` the volume window (three orthogonal
slices of a volume, 3D handles). Each keeps a controller, :class:`Controller` (with its
:class:`Settings`) or :class:`VolumeController` (with its :class:`VolumeSettings`), that
takes the events (:class:`Press`, :class:`Move`, :class:`Release`, :class:`Scroll`,
:class:`Key`), changes its state and returns commands for the window. A controller needs no
window, no display and no GPU: an interaction can be scripted, tested or replayed headless.
:func:`read_events` and :func:`write_events` read and write the replay files of ``glmls demo
--replay`` and ``--record`` (:class:`Recorder` keeps a session's events, :class:`Wait`
pauses a replay).

Importing this package does not import glfw; opening a window does.

The code: ``controller.py`` holds the interaction logic (no window; ``editing.py`` the
handle edits, ``zoom.py`` zoom and pan, ``settings.py`` what is shown, ``events.py`` the
events, replays and recordings), ``session.py`` what is computed (the MLS and the analysis),
``view.py`` and ``overlays.py`` what is drawn, ``hud.py`` and ``helpscreen.py`` the text,
``glfw_window.py`` the operating-system window, ``commands.py`` the file keys,
``window_loop.py`` the frame loop both windows share and ``window.py`` the :class:`App` that
runs them. The volume window has its own ``volume_controller.py``, ``volume_session.py``,
``volume_view.py`` and ``volume_window.py``, with the same events, operating-system window,
layout and text.
"""

from .controller import BINDINGS, Controller, Settings
from .events import Key, Move, Press, Recorder, Release, Scroll, Wait, read_events, write_events
from .volume_controller import VolumeController, VolumeSettings
from .volume_window import VolumeApp
from .window import App

__all__ = [
    "BINDINGS",
    "App",
    "Controller",
    "Key",
    "Move",
    "Press",
    "Recorder",
    "Release",
    "Scroll",
    "Settings",
    "VolumeApp",
    "VolumeController",
    "VolumeSettings",
    "Wait",
    "read_events",
    "write_events",
]
