"""What a thread holds of glmls's GL contexts: each context's lock (:class:`ContextLock`,
reentrant, its holder and count its own) and the thread's bindings (:class:`ThreadBindings`)."""

from __future__ import annotations

import collections
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
    lock taken then would otherwise stay held for ever.

    Fair: a release hands the lock to the thread that has waited longest. A thread that
    calls glmls back to back would otherwise take it again before the woken waiter ran,
    and keep every other thread (and a ``release()`` of the context) waiting as long as it
    loops."""

    __slots__ = ("_count", "_free", "_owner", "_waiting")

    def __init__(self) -> None:
        self._free = threading.Condition(threading.Lock())
        self._owner: int | None = None
        self._count = 0
        self._waiting: collections.deque[int] = collections.deque()

    def acquire(self) -> bool:
        me = threading.get_ident()
        with self._free:  # holder and count change together, before any handler runs
            if self._owner == me:
                self._count += 1
                return True
            if self._owner is None and not self._waiting:
                self._owner, self._count = me, 1
                return True
            self._waiting.append(me)
            try:
                while self._owner != me:  # release() names the next holder
                    self._free.wait()
            except BaseException:  # a signal's handler, in the wait
                if self._owner == me:
                    self._hand_over()  # named as it came: the next in line takes it
                else:
                    self._waiting.remove(me)
                raise
            self._count = 1
        return True

    def release(self) -> None:
        with self._free:
            if self._owner != threading.get_ident():
                raise RuntimeError("cannot release un-acquired lock")
            self._count -= 1
            if not self._count:
                self._hand_over()

    def _hand_over(self) -> None:
        """The lock to the longest waiting thread, or free (the condition held)."""
        self._count = 0
        self._owner = self._waiting.popleft() if self._waiting else None
        if self._owner is not None:
            self._free.notify_all()

    @property
    def waiting(self) -> int:
        """How many threads wait for the lock."""
        with self._free:
            return len(self._waiting)

    def count(self) -> int:
        """How many times the calling thread holds the lock (0: it does not)."""
        return self._count if self._owner == threading.get_ident() else 0

    def __enter__(self) -> bool:
        return self.acquire()

    def __exit__(self, *exc: object) -> None:
        self.release()
