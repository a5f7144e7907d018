"""Progress on stderr: a bar with the time left for batches (:class:`Progress`), and a line
every few seconds for one long step (:class:`Ticker`). No dependency."""

from __future__ import annotations

import sys
import threading
import time
from typing import TextIO


def format_seconds(seconds: float) -> str:
    seconds = max(0, round(seconds))
    minutes, seconds = divmod(seconds, 60)
    hours, minutes = divmod(minutes, 60)
    return f"{hours}:{minutes:02d}:{seconds:02d}" if hours else f"{minutes}:{seconds:02d}"


class Progress:
    """``with Progress(total, "tune") as bar: ... bar.advance()``; silent when ``quiet``.

    On a terminal it redraws one line; otherwise it prints a line every 10 % so that logs
    stay short.
    """

    def __init__(
        self, total: int, label: str, *, quiet: bool = False, stream: TextIO | None = None
    ) -> None:
        self.total = max(int(total), 0)
        self.label = label
        self.quiet = quiet
        self.stream = stream if stream is not None else sys.stderr
        self.done = 0
        self._start = time.perf_counter()
        self._last_decile = -1
        self._tty = bool(getattr(self.stream, "isatty", lambda: False)())

    def __enter__(self) -> Progress:
        self._start = time.perf_counter()
        return self

    def __exit__(self, *exc: object) -> None:
        if not self.quiet and self._tty:
            self.stream.write("\n")
            self.stream.flush()

    def line(self) -> str:
        elapsed = time.perf_counter() - self._start
        fraction = self.done / self.total if self.total else 1.0
        filled = int(fraction * 24)
        bar = "#" * filled + "-" * (24 - filled)
        left = elapsed / self.done * (self.total - self.done) if self.done else float("nan")
        eta = format_seconds(left) if self.done else "?"
        return (
            f"{self.label} [{bar}] {self.done}/{self.total} "
            f"elapsed {format_seconds(elapsed)} left {eta}"
        )

    def advance(self, steps: int = 1) -> None:
        self.done = min(self.done + steps, self.total)
        if self.quiet:
            return
        if self._tty:
            self.stream.write("\r" + self.line())
            self.stream.flush()
            return
        decile = int(10 * self.done / self.total) if self.total else 10
        if decile != self._last_decile:
            self._last_decile = decile
            self.stream.write(self.line() + "\n")
            self.stream.flush()


class Ticker:
    """``with Ticker("analyze") as ticker: ... ticker.stage("pictures")``: silent for the first
    ``after`` seconds, then a line every ``every`` seconds with the stage and the time spent
    (one redrawn line on a terminal), so that a long single step shows it is working."""

    def __init__(
        self,
        label: str,
        *,
        quiet: bool = False,
        after: float = 2.0,
        every: float = 5.0,
        stream: TextIO | None = None,
    ) -> None:
        self.label = label
        self.quiet = quiet
        self.after = after
        self.every = every
        self.stream = stream if stream is not None else sys.stderr
        self.current = ""
        self._start = time.perf_counter()
        self._done = threading.Event()
        self._thread: threading.Thread | None = None
        self._printed = False
        self._tty = bool(getattr(self.stream, "isatty", lambda: False)())

    def stage(self, name: str) -> None:
        self.current = name

    def __enter__(self) -> Ticker:
        self._start = time.perf_counter()
        if not self.quiet:
            self._thread = threading.Thread(target=self._run, daemon=True)
            self._thread.start()
        return self

    def _run(self) -> None:
        if self._done.wait(self.after):
            return
        while True:
            elapsed = format_seconds(time.perf_counter() - self._start)
            stage = f" {self.current}" if self.current else ""
            line = f"{self.label}:{stage} ... {elapsed}"
            self.stream.write(("\r" + line) if self._tty else line + "\n")
            self.stream.flush()
            self._printed = True
            if self._done.wait(self.every):
                return

    def __exit__(self, *exc: object) -> None:
        self._done.set()
        if self._thread is not None:
            self._thread.join()
        if self._printed and self._tty:
            self.stream.write("\n")
            self.stream.flush()
