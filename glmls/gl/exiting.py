"""The interpreter's exit as glmls's GL sees it.

At exit glmls releases its contexts (:func:`glmls.gl.context.release_all`) and ends the helper
process of a forked process (:func:`glmls.gl.helper.stop`). Python runs those exit functions
after it has joined every non-daemon thread, but daemon threads still run: one that calls
glmls meanwhile would find its context released under it, or start a new context or helper
that nothing would release, and its exception would print a traceback over a clean exit.
So from the first of glmls's exit functions on, a thread other than the main thread that
enters glmls's GL work waits there, holding none of glmls's locks, until the process ends
(daemon threads end with it). The main thread keeps its errors: an exit function of the
program's own that runs after glmls's gets :class:`~glmls.ReleasedError` and can say so.
"""

from __future__ import annotations

import atexit
import threading
from collections.abc import Callable

__all__ = ["at_exit", "exiting", "halt_if_exiting"]

_exiting = threading.Event()


def exiting() -> bool:
    """Whether the interpreter has begun running glmls's exit functions."""
    return _exiting.is_set()


def halt_if_exiting(*, holding: bool = False) -> None:
    """Wait for the end of the process if it is exiting and this is not the main thread,
    unless ``holding``: a thread that holds one of glmls's locks goes on, since the exit
    functions of the main thread take them."""
    if holding or not _exiting.is_set():
        return
    if threading.current_thread() is not threading.main_thread():
        threading.Event().wait()


def at_exit(function: Callable[[], object]) -> None:
    """Run ``function`` at exit, after marking the exit (:func:`exiting`)."""

    def run() -> None:
        _exiting.set()
        function()

    atexit.register(run)
