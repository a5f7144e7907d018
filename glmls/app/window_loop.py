"""What both windows share: their state, replayed events, the frame loop, the commands that
save and load files, messages and screenshots.

:class:`WindowLoop` runs a window (:class:`~glmls.app.window.App` and
:class:`~glmls.app.volume_window.VolumeApp`) until it closes or for a number of frames; each
window says how to open, lay out, draw a frame (``render``) and what its files hold.
"""

from __future__ import annotations

import time
from collections import deque
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..files.atomic import same_file
from ..files.images import imwrite
from ..gl.context import get_context
from .events import Event, Recorder, Wait
from .glfw_window import GlfwWindow
from .hud import PANEL_CHARS
from .layout import Layout, layout
from .view import TEXT_SIZE

__all__ = ["MESSAGE_SECONDS", "PICK_RADIUS", "WindowLoop"]

#: Pick radius (window units) and how long messages stay (seconds).
PICK_RADIUS = 10.0
MESSAGE_SECONDS = 5.0


class WindowLoop:
    """The state, replay, frame loop and commands of a window; subclasses provide the window
    itself (``_open``, ``_lay_out``, ``render``, ``_view_key``) and what its files hold
    (``_save_warped``, ``_save_handles``, ``_load_handles``)."""

    window: Any
    view: Any
    session: Any
    controller: Any
    gl: Any

    def _start(
        self,
        shape: tuple[int, int],
        *,
        name: str,
        out_dir: str | Path,
        handles_path: str | Path | None,
        targets_path: str | Path | None = None,
        window_size: tuple[int, int] | None,
        record: str | Path | None,
        read_files: Mapping[str | Path, str] | None = None,
    ) -> None:
        """The state of a window not yet opened, laid out for a canvas of ``shape``
        (``read_files``: the files its inputs came from, which no save replaces)."""
        self.name = name
        self.out_dir = Path(out_dir)
        self.handles_path = Path(handles_path) if handles_path is not None else None
        #: The targets' file of an elastix pair, ``handles_path`` the sources'.
        self.targets_path = Path(targets_path) if targets_path is not None else None
        self.window_size = window_size
        self.record_path = Path(record) if record is not None else None
        self.recorder = Recorder() if record is not None else None
        self.frame_times: deque[float] = deque(maxlen=240)
        self.frames = 0
        #: Seconds of the last frame's stages; kept after the window closes.
        self.timings: dict[str, float] = {}
        self.layout: Layout = layout((1, 1), shape, 0)
        self._panel = 0
        self._messages: list[tuple[float, str]] = []
        self._last_view: tuple = ()
        self._want_screenshot: Path | None = None
        self._read_files = {Path(path): what for path, what in (read_files or {}).items()}
        self._quit = False
        self.window: GlfwWindow | None = None

    def _open_window(self, size: tuple[int, int], *, vsync: bool) -> None:
        """The operating-system window, whose context glmls adopts."""
        self.window = GlfwWindow(size, f"glmls demo - {self.name}", vsync=vsync)
        self.gl = get_context(self.window.context())  # glmls adopts the window's context

    def _listen(self) -> None:
        """Feed the window's events, cursor positions through the layout."""
        self.window.listen(
            self.feed,
            lambda x, y: self.layout.to_image(x, y, self.window.pixel_ratio),  # type: ignore[union-attr]
            lambda: self.controller.dragging,
        )

    def _text_renderer(self) -> Any:
        """The text renderer for the window's scale, the panel's width to fit it, and the
        session in step with the controller."""
        window = self.window
        assert window is not None
        size = max(8, round(TEXT_SIZE * window.content_scale * window.pixel_ratio))
        text = self.view.text_renderer(size)
        self._panel = round(PANEL_CHARS * text.atlas.advance["M"]) + 24
        self.session.sync()
        return text

    # -- events and commands ----------------------------------------------------------------

    def feed(self, event: Event) -> None:
        """One event through the controller, then the commands it returned.

        With the window open the commands save or load files; a recording window keeps the
        event.

        Parameters
        ----------
        event : Press, Move, Release, Scroll or Key
            The event, at image pixels (montage pixels in the volume window).

        Examples
        --------
        >>> import pathlib, tempfile
        >>> from glmls.app import App, Key, read_events
        >>> path = pathlib.Path(tempfile.mkdtemp()) / "keys.json"
        >>> app = App(np.zeros((32, 48)), [[10.0, 10]], [[12.0, 10]], record=path)
        >>> app.feed(Key("t"))
        >>> app.controller.settings.config.transform, app.recorder.events
        ('similarity', [Key(key='t')])
        """
        if self.recorder is not None:
            self.recorder.record(event)
        c = self.controller
        if self.window is not None:
            c.pick_radius = PICK_RADIUS * self.window.pixel_ratio / self.layout.scale
        self._feed(event)
        self._take_message()

    def _take_message(self) -> None:
        """Say what the controller was told to say (by an event, or while a frame was
        drawn: the adaptive mesh giving up)."""
        c = self.controller
        if c.message:
            self.say(c.message)
            c.message = ""

    def _feed(self, event: Event) -> None:
        for command in self.controller.feed(event):
            self._command(command)

    def say(self, text: str) -> None:
        """Show ``text`` in the readout for a few seconds.

        Parameters
        ----------
        text : str
            The message.

        Examples
        --------
        >>> from glmls.app import App
        >>> app = App(np.zeros((32, 48)), [[10.0, 10]], [[12.0, 10]])
        >>> "hello" in app.readout()
        False
        >>> app.say("hello")
        >>> "hello" in app.readout()
        True
        """
        self._messages.append((time.perf_counter(), text))
        del self._messages[:-4]

    def _shown_messages(self) -> list[str]:
        """The messages said within :data:`MESSAGE_SECONDS`."""
        return [m for _, m in self._shown()]

    def _shown(self) -> tuple[tuple[float, str], ...]:
        """(when, what) of the messages shown: part of a window's view key, so that a frame
        is drawn when one is said (the fifth too, though only four are kept) or expires."""
        now = time.perf_counter()
        return tuple((stamp, m) for stamp, m in self._messages if now - stamp < MESSAGE_SECONDS)

    def _path(self, suffix: str) -> Path:
        return self.out_dir / f"{self.name}-{suffix}"

    def _command(self, command: str) -> None:
        try:
            if command == "quit":
                self._quit = True
            elif command in ("save_image", "save_volume"):
                path = self._save_warped()
                # refused handles or settings: what the window shows, not what it names
                kept = " (the last valid f)" if self.window and self.session.error else ""
                self.say(f"saved {path}{kept}")
            elif command == "save_handles":
                path = self._writable(self._path("handles.json"))
                self._save_handles(path)
                self.handles_path = self.handles_path or path
                self.say(f"saved {path}")
            elif command == "save_screenshot":
                self._want_screenshot = self._writable(self._path("screenshot.png"))
            elif command == "load_handles":
                path = self.handles_path or self._path("handles.json")
                targets = self.targets_path if self.handles_path is not None else None
                self.say(self._load_handles(path, targets))
        except (OSError, ValueError) as error:
            self.say(f"{command.replace('_', ' ')} failed: {error}")

    def _writable(self, path: Path) -> Path:
        """``path``, where saving there replaces none of the files read; else ``ValueError``
        (said in the window as the save's failure)."""
        for read, what in self._read_files.items():
            if same_file(path, read):
                raise ValueError(f"{path} is {what}, which saving would replace")
        return path

    def _save_warped(self) -> Path:
        """Save the deformed image or volume (at a path :meth:`_writable` let through); its
        path."""
        raise NotImplementedError

    def _save_handles(self, path: Path) -> None:
        raise NotImplementedError

    def _load_handles(self, path: Path, targets: Path | None) -> str:
        """Load the handles (``targets``: an elastix pair's targets' file); what to say."""
        raise NotImplementedError

    # -- frames -----------------------------------------------------------------------------

    def run(
        self,
        *,
        events: Sequence | None = None,
        frames: int | None = None,
        screenshot: str | Path | None = None,
        on_frame: Callable[[Any], None] | None = None,
    ) -> None:
        """Open the window and run until closed, or for ``frames`` frames when given.

        The window closes (and a recording is saved) however the run ends.

        Parameters
        ----------
        events : sequence of events, optional
            A replay: fed one per frame before it is drawn (``Wait(n)`` skips n frames).
        frames : int, optional
            Draw this many frames and close; by default run until the window is closed
            (``q``, ``Escape`` or the window's close button).
        screenshot : str or os.PathLike, optional
            Save the last frame drawn there (with ``frames``).
        on_frame : callable, optional
            Called with the window after each frame.

        Raises
        ------
        glmls.NoDisplayError
            (a ``RuntimeError``) where no window can be opened: no display, no glfw, or no
            OpenGL 4.3 core context on it.

        Examples
        --------
        >>> from glmls.app import App, Key
        >>> app = App(np.zeros((32, 48)), [[10.0, 10]], [[12.0, 10]])
        >>> app.frames, app.window is None
        (0, True)

        With a display (so these lines are not run here): three frames, the key ``t`` fed
        before the first, and the window closed after the last:

        >>> app.run(events=[Key("t")], frames=3)  # doctest: +SKIP
        >>> app.frames, app.window is None  # doctest: +SKIP
        (3, True)
        >>> app.controller.settings.config.transform  # doctest: +SKIP
        'similarity'
        """
        scripted = frames is not None
        self._open(vsync=not scripted)
        window = self.window
        assert window is not None
        queue = deque(events or ())
        waiting = 0
        try:
            self._lay_out()
            while not window.should_close and not self._quit:
                busy = scripted or self._view_key() != self._last_view or self._want_screenshot
                window.poll(wait=None if busy else 0.5)
                if waiting:
                    waiting -= 1
                elif queue:
                    event = queue.popleft()
                    if isinstance(event, Wait):
                        waiting = max(event.frames - 1, 0)
                    else:
                        self.feed(event)
                idle = self._view_key() == self._last_view and self._want_screenshot is None
                if not scripted and idle:
                    continue
                self._frame(on_frame)
                if self.window is not window:
                    break  # on_frame closed it: nothing left to swap
                last = scripted and self.frames >= frames  # type: ignore[operator]
                if last and screenshot is not None:
                    self._want_screenshot = Path(screenshot)
                if self._want_screenshot is not None:
                    self._save_screenshot(self._want_screenshot, quiet=last)
                window.swap()
                if last:
                    break
        finally:
            self.close()
            if self.recorder is not None and self.record_path is not None:
                self.recorder.save(self.record_path)

    def _frame(self, on_frame: Callable[[Any], None] | None) -> None:
        self._last_view = self._view_key()
        self.render()
        self._take_message()  # a new view key: the next frame shows it
        self.frames += 1
        self.frame_times.append(time.perf_counter())
        self._framed()
        if on_frame is not None:
            on_frame(self)

    def _framed(self) -> None:
        """After a frame: keep its timings."""
        raise NotImplementedError

    def close(self) -> None:
        """Release every GL object, glmls's programs for this context, and the window.

        :meth:`run` closes the window however it ends; closing one not open does nothing.

        Examples
        --------
        >>> from glmls.app import App, Key
        >>> app = App(np.zeros((32, 48)), [[10.0, 10]], [[12.0, 10]])
        >>> app.close()  # not open: nothing to release
        >>> app.window is None
        True

        With a display (so these lines are not run here): the run closed the window, and
        closing it again does nothing:

        >>> app.run(frames=1)  # doctest: +SKIP
        >>> app.close()  # doctest: +SKIP
        >>> app.frames, app.window is None  # doctest: +SKIP
        (1, True)
        """
        if self.window is None:
            return
        self.session.release()
        self.view.release()
        self.gl.release()  # shared pipeline and programs, before the context goes
        self.window.close()
        self.window = None

    def screenshot(self) -> np.ndarray:
        """What the window shows (the back buffer just drawn), top row first.

        Returns
        -------
        numpy.ndarray
            (H, W, 3) uint8, H and W the framebuffer's.

        Examples
        --------
        With a display (so these lines are not run here), the last frame of a run:

        >>> from glmls.app import App
        >>> app = App(np.zeros((32, 48)), [[10.0, 10]], [[12.0, 10]], window_size=(400, 300))
        >>> shots = []
        >>> app.run(frames=1, on_frame=lambda a: shots.append(a.screenshot()))  # doctest: +SKIP
        >>> shots[0].shape, shots[0].dtype  # doctest: +SKIP
        ((300, 400, 3), dtype('uint8'))
        """
        return self.view.screenshot(self.window.framebuffer_size)  # type: ignore[union-attr]

    def _save_screenshot(self, path: Path, *, quiet: bool) -> None:
        self._want_screenshot = None
        try:
            imwrite(path, self.screenshot())  # whole file or none
            if not quiet:
                self.say(f"saved {path}")
        except (OSError, ValueError) as error:
            if quiet:
                raise
            self.say(f"screenshot failed: {error}")
