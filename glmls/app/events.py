"""The window's events (mouse and keys, in image pixels) and their recording for ``--replay``
(the format is in :doc:`/window`).

A JSON object ``{"events": [...]}`` (or the bare list). Each entry is one of::

    {"type": "press", "x": 226, "y": 40, "button": "left", "mods": ["shift"]}
    {"type": "move", "x": 250, "y": 52}
    {"type": "release", "x": 250, "y": 52, "button": "left"}
    {"type": "scroll", "x": 250, "y": 52, "dy": 1}
    {"type": "key", "key": "e"}
    {"type": "wait", "frames": 5}

Positions are image pixels (x, y) = (column, row), so a replay does not depend on the window's
size or pixel density. ``button`` (left, right, middle) defaults to left, ``mods`` to none;
``dy`` is mouse-wheel notches (> 0 zooms in). The window feeds one entry per frame; ``wait``
renders that many frames without an event. :class:`Recorder` writes what a live session fed
(``glmls demo --record``) in the same format.
"""

from __future__ import annotations

import json
import math
import os
import re
from dataclasses import dataclass
from pathlib import Path

from ..core.config import check_integer, check_real
from ..errors import InputFileError
from ..files.atomic import atomic_write

__all__ = [
    "BUTTONS",
    "KEY_NAMES",
    "MAX_WAIT_FRAMES",
    "MODIFIERS",
    "Event",
    "Key",
    "Move",
    "Press",
    "Recorder",
    "Release",
    "Scroll",
    "Wait",
    "event_entry",
    "read_events",
    "write_events",
]

BUTTONS = ("left", "right", "middle")
MODIFIERS = ("shift", "ctrl", "alt")
#: The keys a window feeds by name (the others: the character typed, or ``Ctrl+`` and
#: ``Ctrl+Shift+`` with a letter A-Z).
KEY_NAMES = (
    "F1",
    "Escape",
    "Backspace",
    "Left",
    "Right",
    "Up",
    "Down",
    "PageUp",
    "PageDown",
    "Tab",
)
#: The most frames one ``wait`` renders (about 4.6 hours at 60 frames a second).
MAX_WAIT_FRAMES = 1_000_000
_CTRL_KEY = re.compile(r"Ctrl\+(Shift\+)?[A-Z]")


def _check_point(event: object, *names: str) -> None:
    """``TypeError``/``ValueError`` naming the event's field that is no finite number."""
    for name in names:
        check_real(f"{type(event).__name__}.{name}", getattr(event, name))


@dataclass(frozen=True)
class Press:
    """A mouse button pressed at image point (x, y).

    Parameters
    ----------
    x, y : float
        The point, in image pixels (x, y) = (column, row) (montage pixels in the volume
        window).
    button : {"left", "right", "middle"}, default "left"
        The button (``BUTTONS``); a controller refuses another with a ``ValueError``.
    mods : frozenset of str, default none
        The modifier keys held down: any of "shift", "ctrl" and "alt" (``MODIFIERS``).

    See Also
    --------
    Move, Release : the drag that follows.
    glmls.app.Controller.feed : what the image window does with it.

    Examples
    --------
    >>> from glmls.app import Press
    >>> Press(226, 40)
    Press(x=226, y=40, button='left', mods=frozenset())
    >>> Press(226, 40, mods=frozenset({"shift"})).mods  # shift + press: move a source
    frozenset({'shift'})
    """

    x: float
    y: float
    button: str = "left"
    mods: frozenset[str] = frozenset()

    def __post_init__(self) -> None:
        _check_point(self, "x", "y")


@dataclass(frozen=True)
class Move:
    """The cursor moved to image point (x, y).

    Parameters
    ----------
    x, y : float
        The point, in image pixels (montage pixels in the volume window).

    Examples
    --------
    >>> from glmls.app import Move
    >>> Move(250.0, 52.0)
    Move(x=250.0, y=52.0)
    """

    x: float
    y: float

    def __post_init__(self) -> None:
        _check_point(self, "x", "y")


@dataclass(frozen=True)
class Release:
    """A mouse button released at image point (x, y).

    Parameters
    ----------
    x, y : float
        The point, in image pixels (montage pixels in the volume window).
    button : {"left", "right", "middle"}, default "left"
        The button.

    Examples
    --------
    >>> from glmls.app import Release
    >>> Release(250, 52, button="middle")
    Release(x=250, y=52, button='middle')
    """

    x: float
    y: float
    button: str = "left"

    def __post_init__(self) -> None:
        _check_point(self, "x", "y")


@dataclass(frozen=True)
class Scroll:
    """The mouse wheel turned ``dy`` notches with the cursor at image point (x, y).

    Parameters
    ----------
    x, y : float
        The cursor, in image pixels (montage pixels in the volume window).
    dy : float
        Notches turned: > 0 away from the user (the image window zooms in about the cursor,
        the volume window moves the slice point up), < 0 towards; a touchpad gives fractions.

    Examples
    --------
    >>> from glmls.app import Controller, Scroll
    >>> c = Controller([[10.0, 10]], [[10.0, 10]], (100, 100))
    >>> _ = c.feed(Scroll(50, 50, 1))
    >>> c.zoom.factor > 1
    True
    """

    x: float
    y: float
    dy: float

    def __post_init__(self) -> None:
        _check_point(self, "x", "y", "dy")


@dataclass(frozen=True)
class Key:
    """A key: the character typed ("t", "G", "?") or a name ("F1", "Escape", "Ctrl+Z").

    Parameters
    ----------
    key : str
        The character typed, or the key's name with its modifiers (``Ctrl+Shift+Z``), as
        :data:`~glmls.app.BINDINGS` lists them; a key bound to nothing does nothing.

    Examples
    --------
    >>> from glmls.app import Controller, Key
    >>> c = Controller([[10.0, 10]], [[12.0, 10]], (100, 100))
    >>> c.feed(Key("t")), c.settings.config.transform  # the next transform
    ([], 'similarity')
    >>> c.feed(Key("s"))  # a file key: a command for the window
    ['save_image']
    """

    key: str


Event = Press | Move | Release | Scroll | Key


@dataclass(frozen=True)
class Wait:
    """Render ``frames`` frames without an event (replays only).

    Parameters
    ----------
    frames : int
        Frames to render (>= 0) before the next event is fed.

    Examples
    --------
    >>> from glmls.app import Key, Wait
    >>> replay = [Key("e"), Wait(5), Key("e")]  # the error overlay on for five frames
    >>> replay[1].frames
    5
    """

    frames: int

    def __post_init__(self) -> None:
        check_integer("Wait.frames", self.frames, 0, MAX_WAIT_FRAMES)


_FIELDS = {
    "press": {"type", "x", "y", "button", "mods"},
    "move": {"type", "x", "y"},
    "release": {"type", "x", "y", "button"},
    "scroll": {"type", "x", "y", "dy"},
    "key": {"type", "key"},
    "wait": {"type", "frames"},
}


def _number(path: Path, where: str, entry: dict, name: str) -> float:
    if name not in entry:
        raise InputFileError(f'{path}: {where}: missing "{name}"')
    value = entry[name]
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise InputFileError(f'{path}: {where}: "{name}" must be a finite number, got {value!r}')
    return float(value)


def _event(path: Path, where: str, entry: object):
    if not isinstance(entry, dict):
        raise InputFileError(f"{path}: {where}: expected an object, got {entry!r}")
    kind = entry.get("type")
    if kind not in _FIELDS:
        raise InputFileError(
            f'{path}: {where}: "type" must be one of {", ".join(_FIELDS)}, got {kind!r}'
        )
    unknown = sorted(set(entry) - _FIELDS[kind])
    if unknown:
        raise InputFileError(f"{path}: {where}: unknown field(s) {', '.join(unknown)} for {kind}")
    if kind == "key":
        key = entry.get("key")
        if not isinstance(key, str) or not (
            len(key) == 1 or key in KEY_NAMES or _CTRL_KEY.fullmatch(key)
        ):
            raise InputFileError(
                f'{path}: {where}: "key" must be a character typed, one of '
                f'{", ".join(KEY_NAMES)}, or "Ctrl+" or "Ctrl+Shift+" and a letter A-Z, '
                f"got {key!r}"
            )
        return Key(key)
    if kind == "wait":
        frames = entry.get("frames")
        if (
            isinstance(frames, bool)
            or not isinstance(frames, int)
            or not 0 <= frames <= MAX_WAIT_FRAMES
        ):
            raise InputFileError(
                f'{path}: {where}: "frames" must be an integer in 0..{MAX_WAIT_FRAMES}, '
                f"got {frames!r}"
            )
        return Wait(frames)
    x, y = _number(path, where, entry, "x"), _number(path, where, entry, "y")
    if kind == "move":
        return Move(x, y)
    if kind == "scroll":
        return Scroll(x, y, _number(path, where, entry, "dy"))
    button = entry.get("button", "left")
    if button not in BUTTONS:
        raise InputFileError(
            f'{path}: {where}: "button" must be one of {", ".join(BUTTONS)}, got {button!r}'
        )
    if kind == "release":
        return Release(x, y, button)
    mods = entry.get("mods", [])
    if not isinstance(mods, list) or any(m not in MODIFIERS for m in mods):
        raise InputFileError(
            f'{path}: {where}: "mods" must be a list of {", ".join(MODIFIERS)}, got {mods!r}'
        )
    return Press(x, y, button, frozenset(mods))


def read_events(path: str | os.PathLike) -> list:
    """The events of a replay file (``glmls demo --replay``), in order.

    Parameters
    ----------
    path : str or os.PathLike
        A JSON file of ``{"events": [...]}`` or the bare list, each entry an event in the
        format of ``glmls.app.events`` (:doc:`/window` has it in full).

    Returns
    -------
    list of Press, Move, Release, Scroll, Key or Wait
        The events, in the file's order.

    Raises
    ------
    glmls.files.InputFileError
        (a ``ValueError``) naming the file, the entry and the fault: a missing file, invalid
        JSON, an unknown type or field, a position that is not a finite number, an unknown
        button or modifier, a negative ``frames``.

    See Also
    --------
    write_events : writes them back.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from glmls.app import read_events
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "drag.json"
    >>> _ = path.write_text('{"events": [{"type": "press", "x": 226, "y": 40}, '
    ...                     '{"type": "key", "key": "e"}, {"type": "wait", "frames": 2}]}')
    >>> read_events(path)
    [Press(x=226.0, y=40.0, button='left', mods=frozenset()), Key(key='e'), Wait(frames=2)]
    >>> _ = path.write_text('[{"type": "press", "x": 1}]')
    >>> read_events(path)
    Traceback (most recent call last):
    ...
    glmls.errors.InputFileError: ...drag.json: events[0]: missing "y"
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise InputFileError(f"{path}: no such file") from None
    except (OSError, UnicodeDecodeError) as error:
        raise InputFileError(f"{path}: cannot read: {error}") from None
    try:
        data = json.loads(text)
    except json.JSONDecodeError as error:
        raise InputFileError(f"{path}: line {error.lineno}: invalid JSON: {error.msg}") from None
    except ValueError as error:  # an integer of more than 4,300 digits
        raise InputFileError(f"{path}: invalid JSON: {error}") from None
    except RecursionError:
        raise InputFileError(f"{path}: JSON nested too deeply to be events") from None
    if isinstance(data, dict):
        if "events" not in data:
            raise InputFileError(f'{path}: top level: missing the key "events"')
        data = data["events"]
    if not isinstance(data, list):
        raise InputFileError(f"{path}: expected a list of events, got {type(data).__name__}")
    return [_event(path, f"events[{i}]", entry) for i, entry in enumerate(data)]


def replay_frames(events: list) -> int:
    """Frames a replay takes: one per event, ``frames`` per wait."""
    return sum(e.frames if isinstance(e, Wait) else 1 for e in events)


def event_entry(event: Event | Wait) -> dict[str, object]:
    """The JSON entry of one event (what :func:`read_events` reads back as ``event``)."""
    if isinstance(event, Press):
        entry: dict[str, object] = {"type": "press", "x": event.x, "y": event.y}
        if event.button != "left":
            entry["button"] = event.button
        if event.mods:
            entry["mods"] = [m for m in MODIFIERS if m in event.mods]
        return entry
    if isinstance(event, Move):
        return {"type": "move", "x": event.x, "y": event.y}
    if isinstance(event, Release):
        entry = {"type": "release", "x": event.x, "y": event.y}
        if event.button != "left":
            entry["button"] = event.button
        return entry
    if isinstance(event, Scroll):
        return {"type": "scroll", "x": event.x, "y": event.y, "dy": event.dy}
    if isinstance(event, Key):
        return {"type": "key", "key": event.key}
    if isinstance(event, Wait):
        return {"type": "wait", "frames": event.frames}
    raise TypeError(f"unknown event {event!r}")


def write_events(path: str | os.PathLike, events: list) -> None:
    """Write ``events`` as a replay file (``{"events": [...]}``, one entry a line).

    The file is written whole or not at all (:func:`glmls.files.atomic_write`);
    :func:`read_events` reads it back as the same events.

    Parameters
    ----------
    path : str or os.PathLike
        The JSON file to write (replaced if it exists).
    events : list of Press, Move, Release, Scroll, Key or Wait
        The events, in order.

    Raises
    ------
    TypeError
        For an entry that is not an event.
    OSError
        Where the file cannot be written.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from glmls.app import Key, Move, Press, Release, read_events, write_events
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "drag.json"
    >>> events = [Press(226, 40), Move(250, 52), Release(250, 52), Key("e")]
    >>> write_events(path, events)
    >>> print(path.read_text())
    {"events": [
      {"type": "press", "x": 226, "y": 40},
      {"type": "move", "x": 250, "y": 52},
      {"type": "release", "x": 250, "y": 52},
      {"type": "key", "key": "e"}
    ]}
    <BLANKLINE>
    >>> read_events(path) == events
    True
    """
    lines = ",\n".join("  " + json.dumps(event_entry(e)) for e in events)
    text = '{"events": [\n' + lines + ("\n" if lines else "") + "]}\n"
    with atomic_write(Path(path)) as tmp:
        Path(tmp).write_text(text, encoding="utf-8")


class Recorder:
    """The events fed to a window, in order, to be saved as a replay file.

    A window given ``record=`` (``glmls demo --record``) keeps one and saves it when it
    closes. A replay feeds one event per frame: the session's pace is not kept, its outcome
    is.

    Attributes
    ----------
    events : list of Press, Move, Release, Scroll or Key
        The events recorded so far.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from glmls.app import Key, Press, Recorder, read_events
    >>> recorder = Recorder()
    >>> recorder.record(Press(10, 20))
    >>> recorder.record(Key("t"))
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "session.json"
    >>> recorder.save(path)
    >>> read_events(path)
    [Press(x=10.0, y=20.0, button='left', mods=frozenset()), Key(key='t')]
    """

    def __init__(self) -> None:
        self.events: list[Event] = []

    def record(self, event: Event) -> None:
        """Add ``event`` to ``events``.

        Parameters
        ----------
        event : Press, Move, Release, Scroll or Key
            The event fed.

        Examples
        --------
        >>> from glmls.app import Key, Move, Recorder
        >>> recorder = Recorder()
        >>> recorder.record(Move(3.0, 4.0))
        >>> recorder.record(Key("t"))
        >>> recorder.events
        [Move(x=3.0, y=4.0), Key(key='t')]
        """
        self.events.append(event)

    def save(self, path: str | os.PathLike) -> None:
        """Write ``events`` as a replay file (:func:`write_events`).

        Parameters
        ----------
        path : str or os.PathLike
            The JSON file to write.

        Examples
        --------
        >>> import pathlib, tempfile
        >>> from glmls.app import Key, Recorder, Wait, read_events
        >>> recorder = Recorder()
        >>> recorder.record(Key("g"))
        >>> recorder.record(Wait(5))
        >>> path = pathlib.Path(tempfile.mkdtemp()) / "replay.json"
        >>> recorder.save(path)
        >>> read_events(path) == recorder.events
        True
        """
        write_events(path, self.events)
