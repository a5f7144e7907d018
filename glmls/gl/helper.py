"""GL work for a process forked from one that made a GL context: a clean helper process.

GL drivers do not survive ``fork()`` (see :mod:`glmls.gl.context`), so a forked child of a GL
process cannot make a context of its own. :func:`call` runs a function in a helper process
started fresh (``python -c ...``, not forked: it works in daemonic workers too, such as a
``multiprocessing.Pool``'s or a PyTorch ``DataLoader``'s), one per process, started on first use
and kept for the next calls; the threads of a process take turns.

Arguments and results travel through two pipes, as messages of known length: a pickle with
its arrays out of band (protocol 5: the arrays' bytes are written as they are, not copied into
the pickle), read whole before they are unpickled. An exception or a warning raised in the
helper is raised or warned again in the caller; an answer that cannot be pickled there, or
unpickled here, becomes a :class:`RuntimeError` that says so, and the next call works.

The helper's life:

- it ignores ``SIGINT`` (Ctrl-C in a terminal signals the whole process group): its caller
  decides. A call interrupted in the caller (``KeyboardInterrupt``, an exception raised by a
  signal handler) ends the helper at once, since its answer would be read as the next call's;
  the next call starts another.
- a helper that dies (killed, out of memory) makes the call raise
  :class:`~glmls.GLUnavailableError` saying how it ended; the next call starts another.
- it ends when its caller does: at exit (:func:`stop`), or when it reads end of input or
  finds no one to answer (its caller killed); it never outlives its caller's call by more
  than the call's own time.
- a process forked from the caller has none (it starts its own on first use); the pipes it
  inherited are closed there without a byte written, and it never waits for its parent's.
"""

from __future__ import annotations

import functools
import importlib
import os
import pickle
import signal
import struct
import subprocess
import sys
import threading
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

from ..errors import GLUnavailableError
from . import exiting
from .context import forked_from_gl

__all__ = ["call", "process_id", "stop", "when_forked"]

_ROOT = str(Path(__file__).resolve().parents[2])  # the folder holding the glmls package
_SIZE = struct.Struct("<Q")
_JOINED = 1 << 16  # parts smaller than this are joined into one write
_STARTUP = (
    "import signal; signal.signal(signal.SIGINT, signal.SIG_IGN); "
    "from glmls.gl.helper import serve; serve()"
)


class _Process(subprocess.Popen):
    """The helper's process; in a process forked from its owner it is not ours: never waited
    for, and no warning when it goes."""

    owner = 0

    def __del__(self) -> None:
        if os.getpid() == self.owner:
            super().__del__()


class _Helper:
    """One helper process: its process and the two ends of the pipes we hold."""

    def __init__(self) -> None:
        env = dict(os.environ)
        env["PYTHONPATH"] = os.pathsep.join(p for p in (_ROOT, env.get("PYTHONPATH")) if p)
        requests_in, self.requests = os.pipe()
        self.answers, answers_out = os.pipe()
        try:
            self.process = _Process(
                [sys.executable, "-c", _STARTUP],
                stdin=requests_in,
                stdout=answers_out,
                env=env,
                close_fds=True,
            )
        except BaseException:
            for fd in (self.requests, self.answers):
                os.close(fd)
            raise
        finally:
            os.close(requests_in)
            os.close(answers_out)
        self.process.owner = self.pid = os.getpid()

    @property
    def alive(self) -> bool:
        return self.process.poll() is None

    def ask(self, request: tuple) -> tuple:
        """Send a request, return the answer's message (unpickled by the caller)."""
        _write(self.requests, _dumps(request))
        return _read(self.answers)

    def close(self) -> None:
        """Our ends of the pipes closed (no byte written): the helper reads end of input."""
        for fd in (self.requests, self.answers):
            try:
                os.close(fd)
            except OSError:
                pass

    def end(self, *, wait: float = 0.0) -> str:
        """Close the pipes, let the helper end within ``wait`` seconds (or kill it) and reap
        it; how it ended, in words."""
        self.close()
        if wait:
            try:
                self.process.wait(timeout=wait)
            except subprocess.TimeoutExpired:
                pass
        if self.process.poll() is None:
            self.process.kill()
        code = self.process.wait()
        if code < 0:
            try:
                return f"killed by signal {-code} ({signal.Signals(-code).name})"
            except ValueError:
                return f"killed by signal {-code}"
        return f"exited with status {code}"


_lock = threading.Lock()
_helper: _Helper | None = None
#: Helpers of the processes this one was forked from: not ours, kept from the garbage
#: collector (whose Popen would warn about a process still running).
_inherited: list[_Helper] = []


def call(module: str, name: str, args: tuple = (), kwargs: dict | None = None) -> Any:
    """``module.name(*args, **kwargs)`` in this process's helper process (started on first use).

    Returns
    -------
    object
        What the function returned.

    Raises
    ------
    Exception
        What the function raised; a :class:`RuntimeError` for an answer that could not be
        sent or read.
    GLUnavailableError
        When the helper cannot be started or dies.
    """
    global _helper
    request = (module, name, args, kwargs or {})
    exiting.halt_if_exiting()  # a daemon thread at exit: no new helper (glmls.gl.exiting)
    failed: BaseException | None = None
    with _lock:
        helper = _helper
        try:
            if helper is None or not helper.alive:
                if helper is not None:
                    helper.end()
                _helper = helper = None
                _helper = helper = _Helper()
            message = helper.ask(request)
        except (OSError, EOFError) as error:
            _helper = None
            how = "did not start" if helper is None else helper.end()
            failed = GLUnavailableError(
                "OpenGL unavailable: the helper process that does glmls's GL work for this "
                f"process (forked from one that used GL) {how} ({error!r}); the next call "
                "starts another. Use the 'spawn' start method to avoid the helper"
            )
            failed.__cause__ = error
        except BaseException:  # interrupted: its answer would be read as the next call's
            _helper = None
            if helper is not None:
                helper.end()
            raise
    if failed is not None:
        exiting.halt_if_exiting()  # stop() at exit ended the helper under a daemon thread
        raise failed
    try:
        ok, value, caught = _loads(*message)
    except Exception as error:
        raise RuntimeError(
            f"the answer of {module}.{name} could not be read from glmls's helper process "
            f"({error!r})"
        ) from error
    for text, category in caught:
        warnings.warn(text, category, stacklevel=3)
    if not ok:
        raise value
    return value


_R = TypeVar("_R")


def when_forked(function: Callable[..., _R]) -> Callable[..., _R]:
    """``function`` (a module-level function of arrays that takes a ``ctx`` keyword), or, in a
    process forked from one that used GL and without a ``ctx``, the same function run by this
    process's helper (:func:`call`)."""

    @functools.wraps(function)
    def wrapper(*args, **kwargs):
        if kwargs.get("ctx") is None and forked_from_gl():
            return call(function.__module__, function.__name__, args, kwargs)
        return function(*args, **kwargs)

    return wrapper


def process_id() -> int | None:
    """The process id of this process's helper, None before the first :func:`call`."""
    helper = _helper
    return None if helper is None or helper.pid != os.getpid() else helper.process.pid


def stop() -> None:
    """End this process's helper process, if it has one (done at exit)."""
    global _helper
    if not _lock.acquire(timeout=5):  # another thread's call in the way (a daemon's, at exit)
        helper = _helper
        if helper is not None and helper.pid == os.getpid():
            helper.process.kill()
        return
    try:
        helper, _helper = _helper, None
        if helper is not None:
            helper.end(wait=10)
    finally:
        _lock.release()


def _after_fork_in_child() -> None:
    """A forked child starts a helper of its own (its parent's answers its parent): close the
    inherited pipes (no buffer to flush: they are bare descriptors) and keep the object."""
    global _helper, _lock
    if _helper is not None:
        _helper.close()
        _inherited.append(_helper)
    _helper, _lock = None, threading.Lock()


exiting.at_exit(stop)
os.register_at_fork(after_in_child=_after_fork_in_child)


# -- messages: a count of parts, their sizes, then the parts ---------------------------------


def _dumps(value: object) -> list:
    """``value`` as the parts of a message: the pickle, then its out-of-band buffers."""
    buffers: list[pickle.PickleBuffer] = []
    data = pickle.dumps(value, protocol=5, buffer_callback=buffers.append)
    return [data, *(buffer.raw() for buffer in buffers)]


def _loads(data: bytearray, buffers: list[bytearray]) -> Any:
    return pickle.loads(data, buffers=buffers)


def _write(fd: int, parts: list) -> None:
    """The message in as few writes as it takes: small parts joined (each write wakes the
    reader), large ones written from where they are."""
    views = [memoryview(part).cast("B") for part in parts]
    pending = bytearray(_SIZE.pack(len(views)))
    for view in views:
        pending += _SIZE.pack(view.nbytes)
    for view in [*views, None]:
        if view is not None and view.nbytes < _JOINED:
            pending += view
            continue
        for chunk in (memoryview(pending), view):
            while chunk:
                chunk = chunk[os.write(fd, chunk) :]
        pending = bytearray()


def _read_exact(fd: int, size: int) -> bytearray:
    buffer = bytearray(size)
    view = memoryview(buffer)
    while view:
        count = os.readv(fd, [view])
        if count == 0:
            raise EOFError("end of input")
        view = view[count:]
    return buffer


def _read(fd: int) -> tuple[bytearray, list[bytearray]]:
    (count,) = _SIZE.unpack(_read_exact(fd, _SIZE.size))
    sizes = struct.unpack(f"<{count}Q", _read_exact(fd, _SIZE.size * count))
    data, *buffers = (_read_exact(fd, size) for size in sizes)
    return data, buffers


# -- the helper's side -----------------------------------------------------------------------


def serve() -> None:
    """The helper's loop: read a request, run it, answer; stop at end of input, or when no
    one reads the answers (the caller ended)."""
    answers = os.dup(1)
    os.dup2(2, 1)  # anything printed goes to stderr, not into the answers
    while True:
        try:
            message = _read(0)
        except (EOFError, OSError):  # the caller ended or gave up on us
            return
        name = "the request"
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                module, function, args, kwargs = _loads(*message)
                del message  # its arrays are the arguments now
                name = f"{module}.{function}"
                target = getattr(importlib.import_module(module), function)
                ok, value = True, target(*args, **kwargs)
            except Exception as error:  # raised again in the caller
                ok, value = False, error
        answer = (ok, value, [(str(w.message), w.category) for w in caught])
        try:
            parts = _dumps(answer)
        except Exception as error:  # e.g. a result or an exception that does not pickle
            what = "result" if ok else "exception"
            failure = RuntimeError(
                f"the {what} of {name} could not be sent from glmls's helper process ({error!r})"
            )
            parts = _dumps((False, failure, []))
        try:
            _write(answers, parts)
        except OSError:  # the caller ended mid-call: no one to answer
            return
