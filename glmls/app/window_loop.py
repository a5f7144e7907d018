"""The frame loop both windows share: replayed events, scripted frames and screenshots.

:class:`WindowLoop` runs a window (:class:`~glmls.app.window.App` and
:class:`~glmls.app.volume_window.VolumeApp`) until it closes or for a number of frames; each
window says how to open, lay out, feed an event, draw a frame (``_frame``) and close.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..files.atomic import atomic_write
from ..files.images import imwrite
from .events import Wait

__all__ = ["WindowLoop"]


class WindowLoop:
    """The replay and frame loop of a window; subclasses provide the window itself."""

    window: Any
    view: Any
    recorder: Any
    record_path: Path | None
    frames: int
    _quit: bool
    _last_view: tuple | None
    _want_screenshot: Path | None

    def run(
        self,
        *,
        events: Sequence | None = None,
        frames: int | None = None,
        screenshot: str | Path | None = None,
        on_frame: Callable[[Any], None] | None = None,
    ) -> None:
        """Open the window and run until closed, or for ``frames`` frames when given.

        ``events`` (replay) are fed one per frame before it is drawn (``Wait(n)`` skips n
        frames); ``screenshot`` saves the last frame drawn. Raises :class:`NoDisplayError`.
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
        raise NotImplementedError

    def screenshot(self) -> np.ndarray:
        """What the window shows (the back buffer just drawn), (H, W, 3) uint8, top row first."""
        return self.view.screenshot(self.window.framebuffer_size)  # type: ignore[union-attr]

    def _save_screenshot(self, path: Path, *, quiet: bool) -> None:
        self._want_screenshot = None
        try:
            with atomic_write(path) as tmp:
                imwrite(tmp, self.screenshot())
            if not quiet:
                self.say(f"saved {path}")
        except (OSError, ValueError) as error:
            if quiet:
                raise
            self.say(f"screenshot failed: {error}")
