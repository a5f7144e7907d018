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

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from .commands import load_handles, save_handles, save_image, warped_suffix
from .controller import Controller, Settings
from .events import Event
from .glfw_window import NoDisplayError
from .hud import MIN_WINDOW_HEIGHT, PANEL_CHARS, readout, text_quads
from .layout import layout
from .session import Session
from .text import TextRenderer
from .view import TEXT_SIZE, View, display_image
from .window_loop import WindowLoop

__all__ = ["PANEL_CHARS", "TEXT_SIZE", "App", "NoDisplayError", "display_image"]


class App(WindowLoop):
    """The real-time window (``glmls demo``): one image, its handles and a :class:`Controller`.

    The image is deformed live as the handles are dragged, with the same pipeline as
    headless use; :doc:`/window` lists the mouse actions and the keys. Constructing it opens
    nothing: :meth:`run` opens the window (it needs a display: a desktop, or Xvfb with
    ``xvfb-run``) and returns when it closes, or after ``frames`` frames.

    Parameters
    ----------
    image : numpy.ndarray
        (H, W) or (H, W, C), of any dtype :func:`glmls.warp` takes; shown as 8-bit RGB.
    src, dst : array_like
        The point handles p and q, (N, 2) (x, y) in image pixels.
    reference : array_like, optional
        Reference points (M, 2), whose angle errors the window reports.
    src_segments, dst_segments : array_like, optional
        Segment handles (S, 2, 2).
    settings : Settings, optional
        The MLS configuration and the image construction at first; ``Settings()`` by
        default.
    name : str, default "image"
        The image's name: the title and the saved files' names (``NAME-warped.png``).
    out_dir : str or os.PathLike, default "."
        Where ``s``, ``j`` and ``S`` save.
    handles_path : str or os.PathLike, optional
        The file ``l`` loads (else the last one saved).
    targets_path : str or os.PathLike, optional
        The targets' file where ``handles_path`` is an elastix pair's sources'.
    window_size : tuple of int, optional
        (width, height) of the window in screen units; by default the image fits in about
        1000 x 760 beside the text panel.
    record : str or os.PathLike, optional
        Write every event fed (mouse, keys, replayed ones) there as a replay file
        (:func:`write_events`) when the window closes.
    read_files : mapping of str or os.PathLike to str, optional
        Files the window's inputs came from, each with what it is ("the --reference
        file"): a save (``s``, ``j``, ``S``) that would replace one of them is refused, and
        the window says so.

    Attributes
    ----------
    controller : Controller
        The handles, the settings and the view's state; :meth:`feed` changes it.
    frames : int
        Frames drawn so far.

    Raises
    ------
    ValueError
        For handles of the wrong shape or not finite.

    See Also
    --------
    VolumeApp : the volume window.

    Examples
    --------
    Construction opens nothing, and the controller takes events at once:

    >>> from glmls.app import App, Key, Settings
    >>> image = glmls.data.astronaut()
    >>> src, dst = glmls.data.astronaut_handles()
    >>> settings = Settings(config=glmls.MLSConfig(weight="gaussian", radius=200.0), grid=8)
    >>> app = App(image, src, dst, settings=settings, name="astronaut")
    >>> app.feed(Key("t"))
    >>> app.controller.settings.config.transform
    'similarity'

    Running the window needs a display (so these lines are not run here); with ``frames``
    it draws that many frames, feeding the ``events`` one per frame, saves the last one as
    ``screenshot`` and closes:

    >>> app.run(events=[Key("e")], frames=5, screenshot="window.png")  # doctest: +SKIP
    >>> app.run()  # until the window is closed  # doctest: +SKIP
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
        targets_path: str | Path | None = None,
        window_size: tuple[int, int] | None = None,
        record: str | Path | None = None,
        read_files: Mapping[str | Path, str] | None = None,
    ) -> None:
        self.image = np.asarray(image)
        self.display = display_image(self.image)
        self.shape = (self.display.shape[0], self.display.shape[1])
        self._start(
            self.shape,
            name=name,
            out_dir=out_dir,
            handles_path=handles_path,
            targets_path=targets_path,
            window_size=window_size,
            record=record,
            read_files=read_files,
        )
        self.controller = Controller(
            src,
            dst,
            self.shape,
            reference=reference,
            src_segments=src_segments,
            dst_segments=dst_segments,
            settings=settings or Settings(),
        )

    # -- window set-up ----------------------------------------------------------------------

    def _default_size(self) -> tuple[int, int]:
        height, width = self.shape
        scale = min(1.0, 1000 / width, 760 / height)
        panel = PANEL_CHARS * 8 + 24
        # an image area at least the panel's width: a narrower one would drop the panel and
        # put the readout over the image (layout.MIN_IMAGE_SHARE)
        return panel + max(round(width * scale), panel), max(
            round(height * scale), MIN_WINDOW_HEIGHT
        )

    def _open(self, *, vsync: bool) -> None:
        size = self.window_size or self._default_size()
        self._open_window(size, vsync=vsync)
        self.session = Session(self.gl, self.controller, self.shape)
        self.view = View(self.gl, self.display)
        self._listen()

    # -- events and commands ----------------------------------------------------------------

    def _feed(self, event: Event) -> None:
        """The controller's commands for ``event``; the layout follows a change of zoom at
        once (the next cursor position is read through it)."""
        c = self.controller
        if self.window is not None and self.layout.limits is not None:
            c.view_limits = self.layout.limits
        zoom = c.zoom
        super()._feed(event)
        if c.zoom != zoom:
            self._relayout()

    def _save_warped(self) -> Path:
        path = self._writable(self._path(f"warped{warped_suffix(self.image)}"))
        mls = self.session.mls if self.window is not None else None
        canvas = self.session.canvas
        save_image(path, mls, self.image, self.display, self.controller.settings, canvas)
        return path

    def _save_handles(self, path: Path) -> None:
        save_handles(path, self.controller)

    def _load_handles(self, path: Path, targets: Path | None) -> str:
        loaded = load_handles(path, self.controller, targets=targets)
        return f"loaded {loaded.points} points, {loaded.segments} segments from {path}"

    # -- frames -----------------------------------------------------------------------------

    def readout(self) -> list[str]:
        """The lines of the on-screen readout.

        Returns
        -------
        list of str
            The lines, top first; before the window opens, those of the state alone.

        Examples
        --------
        >>> from glmls.app import App, Key
        >>> app = App(np.zeros((32, 48)), [[10.0, 10]], [[12.0, 10]], name="square")
        >>> app.readout()[0]
        'glmls  square  48x32'
        >>> [line for line in app.readout() if line.startswith("transform")]
        ['transform  rigid   (t)']
        >>> app.feed(Key("t"))
        >>> [line for line in app.readout() if line.startswith("transform")]
        ['transform  similarity   (t)']
        """
        return readout(
            name=self.name,
            shape=self.shape,
            controller=self.controller,
            frame_times=self.frame_times,
            timings=self.timings,
            error=self.session.error if self.window is not None else "",
            analysis_lines=self.session.analysis.lines if self.window is not None else [],
            messages=self._shown_messages(),
            showing="the last valid f"
            if self.window is None or self.session.mls is not None
            else "the input: no valid f yet",
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
            self._shown(),
        )

    def render(self) -> None:
        """Draw one frame into the window's back buffer.

        :meth:`run` opens the window and calls it once a frame; ``on_frame`` sees each frame
        drawn, before it is shown.

        Examples
        --------
        >>> from glmls.app import App, Key
        >>> app = App(np.zeros((32, 48)), [[10.0, 10]], [[12.0, 10]], window_size=(400, 300))
        >>> app.window is None  # nothing to draw into before run
        True

        With a display (so these lines are not run here), the frames drawn and seen:

        >>> shots = []
        >>> def keep(window):
        ...     shots.append(window.screenshot())
        >>> app.run(events=[Key("m")], frames=2, on_frame=keep)  # doctest: +SKIP
        >>> len(shots), app.frames, shots[-1].shape  # doctest: +SKIP
        (2, 2, (300, 400, 3))
        """
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
        text = self._text_renderer()
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

    def _framed(self) -> None:
        # the stages: CPU (handles, analysis) and GPU (warp, overlays, text)
        self.view.next_frame(self.frames)
        self.timings = self.session.timings | self.view.timings
