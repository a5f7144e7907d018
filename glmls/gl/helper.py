"""GL work for a process forked from one that made a GL context: a clean helper process.

GL drivers do not survive ``fork()`` (see :mod:`glmls.gl.context`), so a forked child of a GL
process cannot make a context of its own. :func:`call` runs a function in a helper process
started fresh (``python -c ...``, not forked: it works in daemonic workers too, such as a
``multiprocessing.Pool``'s or a PyTorch ``DataLoader``'s), one per process, started on first use
and kept for the next calls. Arguments and results travel pickled through pipes; an exception or
a warning raised in the helper is raised or warned again in the caller. The helper exits when
its caller does (it reads end of file).
"""

from __future__ import annotations

import atexit
import importlib
import os
import pickle
import subprocess
import sys
import threading
import warnings
from pathlib import Path
from typing import Any

from ..errors import GLUnavailableError

_ROOT = str(Path(__file__).resolve().parents[2])  # the folder holding the glmls package
_lock = threading.Lock()
_helper: subprocess.Popen | None = None
_pid: int | None = None  # the process that started _helper


def _start() -> subprocess.Popen:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (_ROOT, env.get("PYTHONPATH")) if p)
    return subprocess.Popen(
        [sys.executable, "-c", "from glmls.gl.helper import serve; serve()"],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        env=env,
        close_fds=True,
    )


def call(module: str, name: str, args: tuple = (), kwargs: dict | None = None) -> Any:
    """``module.name(*args, **kwargs)`` in this process's helper process (started on first use).

    Raises what the function raised; a :class:`~glmls.GLUnavailableError` when the helper
    cannot be started or dies.
    """
    global _helper, _pid
    request = pickle.dumps((module, name, args, kwargs or {}), pickle.HIGHEST_PROTOCOL)
    with _lock:
        try:
            if _helper is None or _pid != os.getpid() or _helper.poll() is not None:
                _helper, _pid = _start(), os.getpid()
            helper = _helper
            pickle.dump(request, helper.stdin)
            helper.stdin.flush()
            ok, value, caught = pickle.load(helper.stdout)
        except (OSError, EOFError, pickle.UnpicklingError) as error:
            _helper = None
            raise GLUnavailableError(
                "OpenGL unavailable: the helper process that does glmls's GL work for this "
                f"forked process failed ({error!r}); use the 'spawn' start method"
            ) from error
    for message, category in caught:
        warnings.warn(message, category, stacklevel=3)
    if not ok:
        raise value
    return value


def stop() -> None:
    """End this process's helper process, if it has one (done at exit)."""
    global _helper
    with _lock:
        helper, _helper = _helper, None
        if helper is None:
            return
        for stream in (helper.stdin, helper.stdout):
            stream.close()
        try:
            helper.wait(timeout=10)
        except subprocess.TimeoutExpired:
            helper.kill()
            helper.wait()


def _after_fork_in_child() -> None:
    """A forked child starts a helper of its own (its parent's answers its parent)."""
    global _helper, _lock
    _helper, _lock = None, threading.Lock()


atexit.register(stop)
os.register_at_fork(after_in_child=_after_fork_in_child)


def serve() -> None:
    """The helper's loop: read a request, run it, answer; stop at end of input."""
    answers = os.fdopen(os.dup(1), "wb")
    os.dup2(2, 1)  # anything printed goes to stderr, not into the answers
    requests = sys.stdin.buffer
    while True:
        try:
            request = pickle.load(requests)
        except (EOFError, KeyboardInterrupt):  # the caller ended (or Ctrl-C reached us too)
            return
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                module, name, args, kwargs = pickle.loads(request)
                ok, value = True, getattr(importlib.import_module(module), name)(*args, **kwargs)
            except Exception as error:  # raised again in the caller
                ok, value = False, error
        answer = (ok, value, [(str(w.message), w.category) for w in caught])
        try:
            pickle.dump(answer, answers, pickle.HIGHEST_PROTOCOL)
        except Exception as error:  # e.g. an exception that does not pickle
            pickle.dump((False, RuntimeError(repr(error)), []), answers)
        answers.flush()
