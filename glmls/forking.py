"""An MLS in a process forked from one that used GL (a data loader's worker), where GL would
hang (:mod:`glmls.gl.context`): its GPU work runs in the process's helper process
(:mod:`glmls.gl.helper`) on an MLS made there from the same handles and settings
(``glmls.served.serve_forked``), whether the MLS was made before the fork or after it.

:func:`on_gpu` and :func:`forwarded` decorate the MLS methods that use the GPU;
:class:`ForkSafe` is the MLS's side of it: its state for the helper, its liveness, its GL
objects (which a forked process does not have).
"""

from __future__ import annotations

import contextlib
import functools
import importlib
import weakref
from collections.abc import Callable
from typing import Any, TypeVar

from .core.config import MLSConfig
from .errors import GLUnavailableError, ReleasedError
from .gl import helper
from .gl.context import current, forked_from_gl, get_context

__all__ = ["ForkSafe", "forwarded", "in_helper", "on_gpu", "remade", "renderer"]

_R = TypeVar("_R")
_SERVER = "glmls.served"  # serve_forked: makes and keeps the helper's MLS objects


def forwarded(method: Callable[..., _R]) -> Callable[..., _R]:
    """``method`` of an MLS, or, in a process forked from one that used GL, the same method of
    the helper process's MLS made from the same handles and settings."""

    @functools.wraps(method)
    def wrapper(self, *args, **kwargs):
        if forked_from_gl():
            return self._served(method.__name__, args, kwargs)
        return method(self, *args, **kwargs)

    return wrapper


def on_gpu(method: Callable[..., _R]) -> Callable[..., _R]:
    """Check the MLS is alive, then run ``method`` with its GL context current; in a process
    forked from one that used GL, run it in the helper process instead (:func:`forwarded`)."""
    inner = current(method)

    @functools.wraps(method)
    def wrapper(self, *args, **kwargs):
        self.kernel.check_alive()
        return inner(self, *args, **kwargs)

    return forwarded(wrapper)


def _give_back(gl: Any, kernels: list) -> None:
    for kernel in kernels:
        gl.release_later(kernel)


class ForkSafe:
    """What an MLS needs to work in a process forked from one that used GL. The MLS has the
    handles (``src``, ``dst``, ``src_segments``, ``dst_segments``), ``_config``, ``_shape``,
    ``_spacing`` (read here as :attr:`config`, :attr:`shape` and :attr:`spacing`),
    ``_options`` (``storage`` and ``bins``), ``_kernel`` and ``_gl`` (None where it was made
    in such a process) and ``released``."""

    _dropped = False  # released, for an MLS made in a forked process

    # Read-only: the GPU's f was made from them; a value assigned later would reach the repr,
    # the inverse's first guess and a forked process's f, but not this process's f.
    @property
    def config(self) -> MLSConfig:
        """The :class:`~glmls.MLSConfig` f was made with (read-only).

        Examples
        --------
        >>> with glmls.MLS([[0, 0]], [[1, 0]], transform="similarity") as m:
        ...     print(m.config.transform, m.config.weight)
        similarity idw
        """
        return self._config  # type: ignore[attr-defined]

    @property
    def shape(self) -> tuple[int, ...] | None:
        """(H, W) of the image (a volume's (D, H, W)) given when it was made, or None.

        Read-only.

        Examples
        --------
        >>> with glmls.MLS([[0, 0]], [[1, 0]], shape=(32, 48)) as m:
        ...     print(m.shape)
        (32, 48)
        >>> with glmls.MLS([[0, 0]], [[1, 0]]) as m:
        ...     print(m.shape)
        None
        """
        return self._shape  # type: ignore[attr-defined]

    @property
    def spacing(self) -> tuple[float, float, float] | None:
        """3D: (dz, dy, dx) of the volume's voxels given when it was made, or None.

        Read-only; always None in 2D.

        Examples
        --------
        >>> src = [[0, 0, 0], [4, 0, 0]]
        >>> with glmls.MLS(src, src, shape=(8, 8, 8), spacing=(2.0, 1.0, 1.0)) as m:
        ...     print(m.spacing)
        (2.0, 1.0, 1.0)
        >>> with glmls.MLS([[0, 0]], [[1, 0]]) as m:
        ...     print(m.spacing)
        None
        """
        return self._spacing  # type: ignore[attr-defined]

    def _release_when_dropped(self, kernel: Any) -> None:
        """Give ``kernel`` (and the swapped handles' kernel, :meth:`_owns`) back to its context
        when this object is collected without :meth:`release` (an MLS used as scikit-image
        uses a transform, made and dropped in a loop): the context releases them at its next
        use (:meth:`~glmls.gl.context.GLContext.release_later`)."""
        self._owned = [kernel]
        finalizer = weakref.finalize(self, _give_back, kernel.gl, self._owned)
        finalizer.atexit = False  # at exit the process's GL goes as a whole

    def _drop_swapped(self) -> None:
        """Release the swapped handles' kernel, made again when next needed."""
        swapped = getattr(self, "_swapped", None)
        if swapped is not None:
            swapped.release()
            self._swapped = None

    def _owns(self, kernel: Any) -> None:
        """``kernel``, made later, is given back with the first (:meth:`_release_when_dropped`)."""
        self._owned.append(kernel)

    def _forked_state(self) -> tuple:
        """What ``glmls.served.serve_forked`` makes the helper's MLS from."""
        m: Any = self
        segments = (m.src_segments, m.dst_segments) if len(m.src_segments) else (None, None)
        o = self._options  # type: ignore[attr-defined]
        state = (m.config, m.shape, m.spacing, o["storage"], o["bins"])
        return (m.src, m.dst, *segments, *state)

    # Pickled and copied as what it is made from, as the helper's MLS is: its GPU objects
    # cannot travel, and a copy sharing them would be released with the original.
    def __reduce__(self) -> tuple:
        self._check_alive()
        return remade, (self._forked_state(),)

    def __copy__(self) -> Any:
        self._check_alive()
        return remade(self._forked_state(), None if forked_from_gl() else self._gl)  # type: ignore[attr-defined]

    def __deepcopy__(self, memo: dict) -> Any:
        return self.__copy__()

    def _made_forked(self, **handles: object) -> None:
        """Made in a process forked from one that used GL: no GL objects here. The helper's
        MLS, made now, raises what the kernel would (a radius weight without one, ...)."""
        self._gl = self._kernel = None
        for name, value in handles.items():
            setattr(self, "_" + name, value)
        helper.call(_SERVER, "serve_forked", (self._forked_state(), None, None, (), {}))

    def _served(self, name: str, args: tuple, kwargs: dict, grid: int | None = None) -> Any:
        """``name`` (of the inverse of ``grid`` if given) run by the helper process's MLS."""
        self._check_alive()
        state = (self._forked_state(), name, grid, args, kwargs)
        return helper.call(_SERVER, "serve_forked", state)

    def _check_alive(self) -> None:
        if self.released:  # type: ignore[attr-defined]
            raise ReleasedError("this MLS has been released; create a new one")
        if not forked_from_gl():
            self._kernel.check_alive()

    def _current(self) -> contextlib.AbstractContextManager:
        """The GL context made current, or nothing in a forked process (no GL work there)."""
        return contextlib.nullcontext() if forked_from_gl() else self._gl.use()

    def _here(self, value: Any) -> Any:
        """A GL internal (``kernel``, ``ctx``), which a process forked from one that used GL
        does not have: the MLS's GL objects there are the helper's (or, for an MLS made
        before the fork, its parent's, which GL cannot use here)."""
        if value is None or forked_from_gl():
            raise GLUnavailableError(
                "this process was forked from one that used GL: an MLS's GPU work runs in a "
                "helper process here, and its GL objects (kernel, ctx) live there"
            )
        return value


def remade(state: tuple, ctx: Any = None) -> Any:
    """An unpickled or copied MLS: a new one made from ``state`` (``ForkSafe._forked_state``),
    on ``ctx`` (None: the process's shared context)."""
    return importlib.import_module(_SERVER).made_from(state, ctx)


def in_helper(m: ForkSafe, name: str, args: tuple, kwargs: dict, *, grid: int | None) -> Any:
    """``name`` of the inverse of ``grid`` of the MLS ``m``, run by the helper process."""
    return m._served(name, args, kwargs, grid)


def renderer(m: object = None) -> str | None:
    """The GL renderer (``GL_RENDERER``) that does the GPU work of ``m`` (an MLS; None: of the
    shared headless context), the helper process's in a process forked from one that used GL;
    None where ``m`` has no GL context (a CPU reference)."""
    if isinstance(m, ForkSafe) and forked_from_gl():
        return helper.call(__name__, "renderer")
    ctx = get_context() if m is None else getattr(m, "ctx", None)
    return None if ctx is None else str(ctx.mgl.info.get("GL_RENDERER"))
