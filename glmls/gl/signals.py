"""Signals held while moderngl builds a program.

moderngl's C code calls back into Python once per uniform of a program it links
(``_moderngl.make_uniform``) and does not survive an exception raised in that callback: the
process dies (SIGSEGV). Python runs a signal's handler in the main thread at its next
bytecode, which may be inside that callback, so Ctrl-C (``KeyboardInterrupt``) or a handler
that raises (a ``SIGALRM`` timeout) during a program's first compile killed the process.
While the main thread builds a program, the Python signal handlers are replaced by one that
notes the signal; the build done, they are restored and the noted signals raised again, so
that their handlers run there, outside moderngl. (Blocking the signals in the main thread
would not do: another thread would take them, and the handler still run in the main
thread.) A compile takes milliseconds on a GPU and up to seconds on a CPU renderer: that is
how long a Ctrl-C waits. In other threads Python runs no handler, and nothing is changed.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator

__all__ = ["signals_held"]


@contextlib.contextmanager
def signals_held() -> Iterator[None]:
    """Within the block (in the main thread), the signals with a Python handler are noted,
    and raised again when it ends, where their handlers run."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    handlers = {}
    for signum in signal.valid_signals():
        handler = _handler(signum)
        if callable(handler):
            handlers[signum] = handler
    noted: list[int] = []

    def note(signum: int, frame: object) -> None:
        noted.append(signum)

    for signum in handlers:
        signal.signal(signum, note)
    try:
        yield
    finally:
        for signum, handler in handlers.items():
            signal.signal(signum, handler)
        for signum in dict.fromkeys(noted):
            signal.raise_signal(signum)


def _handler(signum: int) -> object:
    try:
        return signal.getsignal(signum)
    except (ValueError, OSError):  # a signal Python cannot name here
        return None
