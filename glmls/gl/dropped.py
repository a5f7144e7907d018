"""GL objects let go without ``release()``: freed later, where GL may be used, never in the
garbage collector, which runs anywhere (in any thread, even inside a GL call).

- :func:`release_when_dropped`: the GL objects of an object collected unreleased (a
  canvas's framebuffers, a warp pipeline's textures and buffers) go back to their context,
  which releases them at the start of its next use
  (:meth:`~glmls.gl.context.GLContext.release_later`).
- :func:`free_when_dropped`: a moderngl context that glmls made
  (:func:`~glmls.gl.context.create_headless`), whose :class:`~glmls.gl.GLContext` is
  collected unreleased, is freed by the next :func:`free_dropped` (the next
  ``create_headless``) of the process that made it: no thread has it current then (a
  binding, ``make_current()`` or a thread's state would have kept the ``GLContext``), and
  destroying an EGL context frees every object made on it.
"""

from __future__ import annotations

import contextlib
import os
import weakref
from collections.abc import Callable
from typing import Any

import moderngl

__all__ = ["free_dropped", "free_when_dropped", "release_when_dropped"]

#: (process id, moderngl context) of the contexts collected unreleased, to be freed.
_pending: list[tuple[int, moderngl.Context]] = []


def release_when_dropped(gl: Any, owner: object, obj: Any) -> weakref.finalize:
    """Release ``obj`` (``owner``'s GL objects on the :class:`~glmls.gl.GLContext` ``gl``) at
    ``gl``'s next use once the garbage collector takes ``owner``.

    ``obj`` must ignore a second ``release()`` (``owner``'s own), and must not refer to
    ``owner``, which it would keep alive. The finalizer keeps ``gl`` alive as long as
    ``owner`` is: an object that ``gl`` itself holds (:meth:`GLContext.shared
    <glmls.gl.context.GLContext.shared>`) is released with ``gl`` instead (``detach()`` the
    finalizer).

    Parameters
    ----------
    gl : GLContext
        The context of ``obj``'s GL objects.
    owner : object
        The object whose collection releases ``obj`` (weakly referenced).
    obj : object
        Has a ``release()`` method that frees its GL objects on ``gl``.

    Returns
    -------
    weakref.finalize
        The finalizer.
    """
    finalizer = weakref.finalize(owner, gl.release_later, obj)
    finalizer.atexit = False  # at exit the process's GL goes as a whole
    return finalizer


def free_when_dropped(context: object, mgl: moderngl.Context) -> weakref.finalize:
    """Free ``mgl`` at the next :func:`free_dropped` once the garbage collector takes
    ``context`` (its :class:`~glmls.gl.GLContext`); ``detach()`` the finalizer returned
    when the context is released."""
    finalizer = weakref.finalize(context, _pending.append, (os.getpid(), mgl))
    finalizer.atexit = False
    return finalizer


def free_dropped(in_use: Callable[[moderngl.Context], bool]) -> None:
    """Free the moderngl contexts collected unreleased in this process (a forked child
    leaves its parent's alone), but those for which ``in_use`` is true."""
    while _pending:
        pid, mgl = _pending.pop()
        if pid == os.getpid() and not in_use(mgl):
            with contextlib.suppress(Exception):  # a leftover must not fail the user's call
                mgl.release()
