"""The real-time window (the paper's interactive IDS): one image, its handles and reference
points, a :class:`~glmls.app.controller.Controller` that events change, a
:class:`~glmls.app.session.Session` that keeps the MLS and the analysis in step with it, and a
:class:`~glmls.app.view.View` that draws each frame with the same pipeline as headless use,
straight into the window.

Per frame: events -> (if the handles or settings changed) one handle upload -> the deformed
image, the overlays and the text -> swap. Nothing is read back except what the analysis
overlays need on the CPU (their statistics) and screenshots.
"""

from __future__ import annotations

import time
from collections import deque
from collections.abc import Callable
from pathlib import Path

import numpy as np

from ..gl.context import get_context
from .commands import load_handles, save_handles, save_image
from .controller import Controller, Settings
from .events import Event, Recorder
from .glfw_window import GlfwWindow, NoDisplayError
from .hud import PANEL_CHARS, readout, text_quads
from .layout import Layout, layout
from .session import Session
from .text import TextRenderer
from .view import TEXT_SIZE, View, display_image
from .window_loop import WindowLoop

__all__ = ["PANEL_CHARS", "TEXT_SIZE", "App", "NoDisplayError", "display_image"]

#: Pick radius (window units) and how long messages stay (seconds).
PICK_RADIUS = 10.0
MESSAGE_SECONDS = 5.0


class App(WindowLoop):
    """The window: one image, its handles and reference points, and a :class:`Controller`.

    ``out_dir``: where ``s``/``j``/``S`` save; ``handles_path``: the file ``l`` loads (else
    the last one saved); ``src_segments``/``dst_segments``: segment handles (S, 2, 2);
    ``record``: write every event fed (mouse, keys, replayed ones) there as a replay file
    when the window closes. Open with :meth:`run`.
    """

    def __init__(
        self,
        image: np.ndarray,
        src: np.ndarray,
        dst: np.ndarray,
        *,
        reference: np.ndarray | None = None,
        src_segments: np.ndarray | None = None,
        dst_segments: np.ndarray | None = None,
        settings: Settings | None = None,
        name: str = "image",
        out_dir: str | Path = ".",
        handles_path: str | Path | None = None,
        window_size: tuple[int, int] | None = None,
        record: str | Path | None = None,
    ) -> None:
        self.image = np.asarray(image)
        self.display = display_image(self.image)
        self.shape = (self.display.shape[0], self.display.shape[1])
        self.name = name
        self.out_dir = Path(out_dir)
        self.handles_path = Path(handles_path) if handles_path is not None else None
        self.window_size = window_size
        self.controller = Controller(
            src,
            dst,
            self.shape,
            reference=reference,
            src_segments=src_segments,
            dst_segments=dst_segments,
            settings=settings or Settings(),
        )
        self.record_path = Path(record) if record is not None else None
        self.recorder = Recorder() if record is not None else None
        self.frame_times: deque[float] = deque(maxlen=240)
        self.frames = 0
        #: Seconds of the last frame's stages: CPU (handles, analysis) and GPU (warp,
        #: overlays, text); kept after the window closes.
        self.timings: dict[str, float] = {}
        self.layout: Layout = layout((1, 1), self.shape, 0)
        self._panel = 0
        self._messages: list[tuple[float, str]] = []
        self._last_view: tuple = ()
        self._want_screenshot: Path | None = None
        self._quit = False
        self.window: GlfwWindow | None = None

    # -- window set-up ----------------------------------------------------------------------

    def _default_size(self) -> tuple[int, int]:
        height, width = self.shape
        scale = min(1.0, 1000 / width, 760 / height)
        panel = PANEL_CHARS * 8 + 24
        return panel + round(width * scale), max(round(height * scale), 480)

    def _open(self, *, vsync: bool) -> None:
        size = self.window_size or self._default_size()
        self.window = GlfwWindow(size, f"glmls demo - {self.name}", vsync=vsync)
        self.gl = get_context(self.window.context())  # glmls adopts the window's context
        self.session = Session(self.gl, self.controller, self.shape)
        self.view = View(self.gl, self.display)
        self.window.listen(
            self.feed,
            lambda x, y: self.layout.to_image(x, y, self.window.pixel_ratio),  # type: ignore[union-attr]
            lambda: self.controller.dragging,
        )

    # -- events and commands ----------------------------------------------------------------

    def feed(self, event: Event) -> None:
        """One event through the controller, then the commands it returned; the layout
        follows a change of zoom at once (the next cursor position is read through it)."""
        if self.recorder is not None:
            self.recorder.record(event)
        c = self.controller
        if self.window is not None:
            pixels = PICK_RADIUS * self.window.pixel_ratio
            c.pick_radius = pixels / self.layout.scale
            if self.layout.limits is not None:
                c.view_limits = self.layout.limits
        zoom = c.zoom
        for command in c.feed(event):
            self._command(command)
        if c.zoom != zoom:
            self._relayout()
        if c.message:
            self.say(c.message)
            c.message = ""

    def say(self, text: str) -> None:
        self._messages.append((time.perf_counter(), text))
        del self._messages[:-4]

    def _path(self, suffix: str) -> Path:
        return self.out_dir / f"{self.name}-{suffix}"

    def _command(self, command: str) -> None:
        c = self.controller
        try:
            if command == "quit":
                self._quit = True
            elif command == "save_image":
                path = self._path("warped.png")
                mls = self.session.mls if self.window is not None else None
                canvas = self.session.canvas
                save_image(path, mls, self.image, self.display, c.settings, canvas)
                self.say(f"saved {path}")
            elif command == "save_handles":
                path = self._path("handles.json")
                save_handles(path, c)
                self.handles_path = self.handles_path or path
                self.say(f"saved {path}")
            elif command == "save_screenshot":
                self._want_screenshot = self._path("screenshot.png")
            elif command == "load_handles":
                path = self.handles_path or self._path("handles.json")
                loaded = load_handles(path, c)
                self.say(f"loaded {loaded.points} points, {loaded.segments} segments from {path}")
        except (OSError, ValueError) as error:
            self.say(f"{command.replace('_', ' ')} failed: {error}")

    # -- frames -----------------------------------------------------------------------------

    def readout(self) -> list[str]:
        """The lines of the on-screen readout."""
        now = time.perf_counter()
        return readout(
            name=self.name,
            shape=self.shape,
            controller=self.controller,
            frame_times=self.frame_times,
            timings=self.timings,
            error=self.session.error if self.window is not None else "",
            analysis_lines=self.session.analysis.lines if self.window is not None else [],
            messages=[m for stamp, m in self._messages if now - stamp < MESSAGE_SECONDS],
        )

    def _view_key(self) -> tuple:
        c = self.controller
        return (
            c.revision,
            c.reference_revision,
            tuple(c.overlays.values()),
            c.help_visible,
            c.mode,
            c.zoom,
            None if c.drawing is None else c.drawing.tobytes(),
            self.window.framebuffer_size,  # type: ignore[union-attr]
            len(self._messages),
        )

    def render(self) -> None:
        """Draw one frame into the window's back buffer."""
        window = self.window
        assert window is not None, "open the window with run() first"
        framebuffer = window.framebuffer_size
        text = self._lay_out()
        analysis = self.session.analyse(self.layout.scale)
        quads = text_quads(
            text.atlas,
            self.readout(),
            help_visible=self.controller.help_visible,
            panel=self.layout.panel,
            framebuffer=framebuffer,
        )
        self.view.draw(self.layout, self.controller, self.session, analysis, quads)

    def _lay_out(self) -> TextRenderer:
        """The text renderer for the window's scale, and the layout with its panel (before
        the first frame too, so that the first event goes through the right layout)."""
        window = self.window
        assert window is not None
        size = max(8, round(TEXT_SIZE * window.content_scale * window.pixel_ratio))
        text = self.view.text_renderer(size)
        self._panel = round(PANEL_CHARS * text.atlas.advance["M"]) + 24
        self.session.sync()
        self._relayout()
        return text

    def _relayout(self) -> None:
        """The layout for the framebuffer, the session's canvas and the controller's zoom."""
        if self.window is None:
            return
        canvas, c = self.session.canvas, self.controller
        self.layout = layout(
            self.window.framebuffer_size, canvas.shape, self._panel, canvas.origin, c.zoom
        )
        if self.layout.limits is not None:
            c.view_limits = self.layout.limits

    def _frame(self, on_frame: Callable[[App], None] | None) -> None:
        self._last_view = self._view_key()
        self.render()
        self.frames += 1
        self.frame_times.append(time.perf_counter())
        self.view.next_frame(self.frames)
        self.timings = self.session.timings | self.view.timings
        if on_frame is not None:
            on_frame(self)

    def close(self) -> None:
        """Release every GL object, glmls's programs for this context, and the window."""
        if self.window is None:
            return
        self.session.release()
        self.view.release()
        self.gl.release()  # shared pipeline and programs, before the context goes
        self.window.close()
        self.window = None
