"""The volume window: three orthogonal slices through a point of a volume, deformed live by a
3D MLS whose handles are dragged within the slice planes (``glmls demo VOLUME``).

A :class:`~glmls.app.volume_controller.VolumeController` takes the events (montage pixels,
as the 2D window's take image pixels: replays and recordings have the same format), a
:class:`~glmls.app.volume_session.VolumeSession` keeps the MLS, the three deformed slices
and the overlay in step with it, and a :class:`~glmls.app.volume_view.VolumeView` draws
them; the operating-system window, the layout and the text are the 2D window's.
"""

from __future__ import annotations

import time
from collections import deque
from collections.abc import Callable
from pathlib import Path

import numpy as np

from ..files.landmarks import read_handles, write_handles
from ..files.volumes import write_volume
from ..gl.context import get_context
from .events import Event, Recorder
from .glfw_window import GlfwWindow, NoDisplayError
from .hud import PANEL_CHARS, wrap
from .layout import Layout, layout
from .view import TEXT_SIZE
from .volume_controller import AXES, VIEWS, VolumeController, VolumeSettings
from .volume_session import VolumeSession, display_volume
from .volume_view import VolumeView, text_groups
from .window_loop import WindowLoop

__all__ = ["NoDisplayError", "VolumeApp"]

PICK_RADIUS = 10.0
MESSAGE_SECONDS = 5.0


class VolumeApp(WindowLoop):
    """The volume window: a volume, its 3D handles and a :class:`VolumeController`.

    Parameters
    ----------
    volume : numpy.ndarray
        (D, H, W) or (D, H, W, C); shown grey (:func:`~glmls.app.volume_session.display_volume`).
    src, dst : array_like
        The handles (N, 3) (x, y, z).
    settings : VolumeSettings, optional
        The MLS configuration and the construction of the slices.
    name : str
        The volume's name (the title, the saved files' names).
    out_dir : str or os.PathLike
        Where ``s``, ``j`` and ``S`` save.
    handles_path : str or os.PathLike, optional
        The file ``l`` loads (else the last one saved).
    window_size : tuple of int, optional
        (width, height) of the window.
    record : str or os.PathLike, optional
        Write every event fed there as a replay file when the window closes.
    """

    def __init__(
        self,
        volume: np.ndarray,
        src: object,
        dst: object,
        *,
        settings: VolumeSettings | None = None,
        name: str = "volume",
        out_dir: str | Path = ".",
        handles_path: str | Path | None = None,
        window_size: tuple[int, int] | None = None,
        record: str | Path | None = None,
    ) -> None:
        self.volume = np.asarray(volume)
        self.display = display_volume(self.volume)
        self.controller = VolumeController(src, dst, self.display.shape, settings=settings)
        self.name = name
        self.out_dir = Path(out_dir)
        self.handles_path = Path(handles_path) if handles_path is not None else None
        self.window_size = window_size
        self.record_path = Path(record) if record is not None else None
        self.recorder = Recorder() if record is not None else None
        self.frame_times: deque[float] = deque(maxlen=240)
        self.frames = 0
        #: Seconds of the last frame's stages (handles, slices, analysis, draw).
        self.timings: dict[str, float] = {}
        self.layout: Layout = layout((1, 1), self.controller.grid.montage_shape, 0)
        self._panel = 0
        self._messages: list[tuple[float, str]] = []
        self._last_view: tuple = ()
        self._want_screenshot: Path | None = None
        self._quit = False
        self.window: GlfwWindow | None = None

    def _open(self, *, vsync: bool) -> None:
        rows, columns = self.controller.grid.montage_shape
        scale = max(1.0, min(560 / rows, 900 / columns))
        panel = PANEL_CHARS * 8 + 24
        size = self.window_size or (panel + round(columns * scale), round(rows * scale))
        self.window = GlfwWindow(size, f"glmls demo - {self.name}", vsync=vsync)
        self.gl = get_context(self.window.context())
        self.session = VolumeSession(self.gl, self.controller, self.display)
        self.view = VolumeView(self.gl, self.controller)
        self.window.listen(
            self.feed,
            lambda x, y: self.layout.to_image(x, y, self.window.pixel_ratio),  # type: ignore[union-attr]
            lambda: self.controller.dragging,
        )

    # -- events and commands ----------------------------------------------------------------

    def feed(self, event: Event) -> None:
        """One event through the controller, then the commands it returned."""
        if self.recorder is not None:
            self.recorder.record(event)
        c = self.controller
        if self.window is not None:
            c.pick_radius = PICK_RADIUS * self.window.pixel_ratio / self.layout.scale
        for command in c.feed(event):
            self._command(command)
        if c.message:
            self.say(c.message)
            c.message = ""

    def say(self, text: str) -> None:
        """Show ``text`` in the readout for a few seconds."""
        self._messages.append((time.perf_counter(), text))
        del self._messages[:-4]

    def _command(self, command: str) -> None:
        c = self.controller
        try:
            if command == "quit":
                self._quit = True
            elif command == "save_volume":
                path = self.out_dir / f"{self.name}-warped.npy"
                mls = self.session.mls if self.window is not None else None
                if mls is None:
                    raise ValueError("no valid deformation")
                s = c.settings
                warped = mls.warp(self.volume, method=s.method, interpolation="linear", grid=s.grid)
                write_volume(path, warped)
                self.say(f"saved {path}")
            elif command == "save_handles":
                path = self.out_dir / f"{self.name}-handles.json"
                write_handles(path, c.src, c.dst)
                self.handles_path = self.handles_path or path
                self.say(f"saved {path}")
            elif command == "save_screenshot":
                self._want_screenshot = self.out_dir / f"{self.name}-screenshot.png"
            elif command == "load_handles":
                path = self.handles_path or self.out_dir / f"{self.name}-handles.json"
                c.set_handles(*read_handles(path, ndim=3))
                self.say(f"loaded {len(c.src)} handles from {path}")
        except (OSError, ValueError) as error:
            self.say(f"{command.replace('_', ' ')} failed: {error}")

    # -- frames -----------------------------------------------------------------------------

    def readout(self) -> list[str]:
        """The lines of the on-screen readout."""
        c, s = self.controller, self.controller.settings
        times = list(self.frame_times)
        recent = [t for t in times if t >= times[-1] - 1.0] if times else []
        fps = (len(recent) - 1) / (recent[-1] - recent[0]) if len(recent) > 2 else 0.0
        frame_ms = 1000 * (recent[-1] - recent[-2]) if len(recent) > 1 else 0.0
        ms = {k: 1000 * v for k, v in self.timings.items()}
        depth, height, width = self.display.shape
        x, y, z = c.point
        normal = "xyz"[AXES[c.active][2]]
        lines = [
            f"glmls  {self.name}  {width}x{height}x{depth}",
            f"fps {fps:5.1f}   frame {frame_ms:5.1f} ms",
            f"ms: handles {ms.get('handles', 0):.2f}  slices {ms.get('slices', 0):.1f}",
            f"    analysis {ms.get('analysis', 0):.1f}  draw {ms.get('draw', 0):.1f}",
            "",
            f"transform  {s.config.transform}   (t)",
            f"weight     {s.config.weight}, {c.parameter()}   (w, +/-)",
            f"construct  {s.method} linear   (c)",
            f"grid       {s.grid} voxels   (g/G)",
            f"border     {s.border}   (b)",
            f"point      x {x}  y {y}  z {z}   (click)",
            f"active     {VIEWS[c.active]}: {normal} +/- (Up/Down)",
            f"handles    {len(c.src)} (shown within {c.near:g} voxels)",
            f"overlay    {c.overlay}   (e, f)",
            "",
        ]
        if self.window is not None and self.session.error:
            lines += wrap(f"! {self.session.error}", PANEL_CHARS) + ["  (the last valid f)"]
        lines += self.session.lines if self.window is not None else []
        lines += ["", "F1 or ?: help"]
        now = time.perf_counter()
        for stamp, message in self._messages:
            if now - stamp < MESSAGE_SECONDS:
                lines += wrap(message, PANEL_CHARS)
        return lines

    def _view_key(self) -> tuple:
        c = self.controller
        return (
            c.revision,
            c.point,
            c.active,
            c.overlay,
            c.show_handles,
            c.help_visible,
            self.window.framebuffer_size,  # type: ignore[union-attr]
            len(self._messages),
        )

    def render(self) -> None:
        """Draw one frame into the window's back buffer."""
        window = self.window
        assert window is not None, "open the window with run() first"
        text = self._lay_out()
        session = self.session
        slices = session.slices()
        overlays = session.overlays()
        start = time.perf_counter()
        c = self.controller
        groups = text_groups(
            text,
            self.readout(),
            help_visible=c.help_visible,
            framebuffer=window.framebuffer_size,
        )
        groups[0][1].extend(self._labels(text))
        self.view.draw(
            self.layout,
            c,
            ((session.revision, c.point, session.mls is None), slices),
            ((session.revision, c.point, c.overlay), overlays),
            groups,
        )
        session.timings["draw"] = time.perf_counter() - start

    def _labels(self, atlas) -> list[np.ndarray]:
        """Each view's name and plane at its top left corner."""
        c, parts = self.controller, []
        for view in range(3):
            normal = AXES[view][2]
            ox, oy = c.grid.offset(view)
            x, y = self.layout.to_framebuffer(ox - 0.5, oy - 0.5)
            label = f"{VIEWS[view]} {'xyz'[normal]} = {c.point[normal]}"
            colour = (1.0, 0.85, 0.2, 1.0) if view == c.active else (0.9, 0.9, 0.9, 1.0)
            parts.append(
                atlas.rectangle(x, y, atlas.width(label) + 6, atlas.line_height, (0, 0, 0, 0.6))
            )
            parts.append(atlas.quads(label, x + 3, y, colour))
        return parts

    def _lay_out(self):
        window = self.window
        assert window is not None
        size = max(8, round(TEXT_SIZE * window.content_scale * window.pixel_ratio))
        text = self.view.text_renderer(size).atlas
        self._panel = round(PANEL_CHARS * text.advance["M"]) + 24
        self.session.sync()
        self.layout = layout(
            window.framebuffer_size, self.controller.grid.montage_shape, self._panel
        )
        return text

    def _frame(self, on_frame: Callable[[VolumeApp], None] | None) -> None:
        self._last_view = self._view_key()
        self.render()
        self.frames += 1
        self.frame_times.append(time.perf_counter())
        self.timings = dict(self.session.timings)
        if on_frame is not None:
            on_frame(self)

    def close(self) -> None:
        """Release every GL object, glmls's programs for this context, and the window."""
        if self.window is None:
            return
        self.session.release()
        self.view.release()
        self.gl.release()
        self.window.close()
        self.window = None
