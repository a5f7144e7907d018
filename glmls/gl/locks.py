"""What a thread holds of glmls's GL contexts: each context's lock (:class:`ContextLock`,
reentrant, its holder and count its own) and the thread's bindings (:class:`ThreadBindings`)."""

from __future__ import annotations

import contextlib
import threading

__all__ = ["ContextLock", "ThreadBindings"]


class ThreadBindings(threading.local):
    """The calling thread's state of glmls's contexts (one instance, per thread by
    ``threading.local``)."""

    def __init__(self) -> None:
        #: The GLContext glmls has bound in this thread (None: none of glmls's).
        self.current: object | None = None
        #: Open ``with context:`` blocks of this thread, innermost last.
        self.blocks: list[contextlib.AbstractContextManager] = []
        #: The contexts this thread keeps current (make_current()), unbound when it ends,
        #: each with the object that unbinds it.
        self.unbinders: dict[object, object] = {}
        #: Open bindings of this thread (GLContext.use() blocks), each holding its lock.
        self.held = 0


class ContextLock:
    """A context's reentrant lock, with its holder and count its own (:meth:`count`), so
    that an acquire that a signal's handler interrupts as it returns can be undone: Python
    runs a handler (Ctrl-C's KeyboardInterrupt) after a call returns, in the caller, and a
    lock taken then would otherwise stay held for ever."""

    __slots__ = ("_count", "_free", "_owner")

    def __init__(self) -> None:
        self._free = threading.Condition(threading.Lock())
        self._owner: int | None = None
        self._count = 0

    def acquire(self) -> bool:
        me = threading.get_ident()
        with self._free:  # holder and count change together, before any handler runs
            while self._owner is not None and self._owner != me:
                self._free.wait()
            self._owner = me
            self._count += 1
        return True

    def release(self) -> None:
        with self._free:
            if self._owner != threading.get_ident():
                raise RuntimeError("cannot release un-acquired lock")
            self._count -= 1
            if not self._count:
                self._owner = None
                self._free.notify()

    def count(self) -> int:
        """How many times the calling thread holds the lock (0: it does not)."""
        return self._count if self._owner == threading.get_ident() else 0

    def __enter__(self) -> bool:
        return self.acquire()

    def __exit__(self, *exc: object) -> None:
        self.release()
