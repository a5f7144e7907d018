"""The one place where glmls creates or adopts OpenGL contexts.

By default glmls renders headless through EGL (``moderngl.create_context(standalone=True,
backend="egl", require=430)``); a window hands in its own context instead. Each context is
wrapped in a :class:`GLContext` that also caches the compiled programs for it.
"""

from __future__ import annotations

import atexit
import functools
from collections.abc import Callable, Iterable, Mapping
from typing import TypeVar

import moderngl

from .errors import GLUnavailableError
from .shaders import compose

REQUIRED_GL = 430

_PACKAGES_EGL = "libegl1"
_PACKAGES_DRIVER = "libegl-mesa0 libgl1-mesa-dri"
_FIX = (
    "On Debian/Ubuntu: apt-get install libegl1 libegl-mesa0 libgl1-mesa-dri "
    "(Mesa's llvmpipe runs GL 4.5 on the CPU); with an NVIDIA GPU, its driver's EGL "
    "library (libnvidia-egl) instead of Mesa's."
)


def _explain(error: Exception) -> GLUnavailableError:
    """Turn glcontext's terse errors into one that says what is missing and how to fix it."""
    text = str(error)
    if "not loaded" in text:
        what = f"the EGL or GL library could not be loaded ({text}); install {_PACKAGES_EGL}"
    elif "device" in text or "eglInitialize" in text or "eglGetDisplay" in text:
        what = f"no EGL driver answered ({text}); install {_PACKAGES_DRIVER}"
    elif "eglCreateContext" in text or "version" in text.lower():
        what = f"the driver offers no OpenGL 4.3 core context ({text})"
    else:
        what = f"creating a headless EGL context failed ({text})"
    return GLUnavailableError(f"OpenGL unavailable: {what}. {_FIX}")


class GLContext:
    """A moderngl context plus the glmls programs compiled for it.

    ``owned`` contexts (made by :func:`create_headless`) are released with :meth:`release`;
    borrowed ones (a window's) are left to their owner, only glmls's programs are released.
    """

    def __init__(self, mgl: moderngl.Context, *, owned: bool) -> None:
        if mgl.version_code < REQUIRED_GL:
            raise GLUnavailableError(
                f"OpenGL unavailable: glmls needs OpenGL {REQUIRED_GL // 100}.3 core "
                f"(compute shaders), this context is {mgl.version_code}. {_FIX}"
            )
        self.mgl = mgl
        self.owned = owned
        self._programs: dict[tuple, moderngl.ComputeShader | moderngl.Program] = {}
        self.released = False

    @property
    def limits(self) -> dict[str, int]:
        """GL limits that bound image and handle sizes."""
        info = self.mgl.info
        return {
            "max_texture_size": int(info["GL_MAX_TEXTURE_SIZE"]),
            "max_ssbo_size": int(info["GL_MAX_SHADER_STORAGE_BLOCK_SIZE"]),
            "max_work_groups_x": int(info["GL_MAX_COMPUTE_WORK_GROUP_COUNT"][0]),
        }

    def compute(
        self, parts: Iterable[str], defines: Mapping[str, object] | None = None
    ) -> moderngl.ComputeShader:
        """The compute program made of these shader files and defines (compiled once)."""
        parts = tuple(parts)
        key = ("compute", parts, tuple(sorted((defines or {}).items())))
        program = self._programs.get(key)
        if program is None:
            program = self.mgl.compute_shader(compose(parts, defines))
            self._programs[key] = program
        return program

    def program(
        self,
        vertex: Iterable[str],
        fragment: Iterable[str],
        defines: Mapping[str, object] | None = None,
    ) -> moderngl.Program:
        """The vertex/fragment program made of these files and defines (compiled once)."""
        vertex, fragment = tuple(vertex), tuple(fragment)
        key = ("render", vertex, fragment, tuple(sorted((defines or {}).items())))
        program = self._programs.get(key)
        if program is None:
            program = self.mgl.program(
                vertex_shader=compose(vertex, defines),
                fragment_shader=compose(fragment, defines),
            )
            self._programs[key] = program
        return program

    def make_current(self) -> None:
        """Make this context current (EGL or a window's). It stays current afterwards:
        moderngl's ``with ctx:`` would release it on exit, leaving no context current."""
        self.mgl.__enter__()

    def release(self) -> None:
        """Release the cached programs, and the context itself if glmls created it."""
        if self.released:
            return
        self.make_current()  # delete in this context, whichever was current
        for program in self._programs.values():
            program.release()
        self._programs.clear()
        if self.owned:
            self.mgl.release()
        self.released = True


_R = TypeVar("_R")


def current(method: Callable[..., _R]) -> Callable[..., _R]:
    """Run a method of an object holding ``self._gl`` (a :class:`GLContext`) with that context
    current: a window or a second headless context may have been made current since."""

    @functools.wraps(method)
    def wrapper(self, *args, **kwargs):
        self._gl.make_current()
        return method(self, *args, **kwargs)

    return wrapper


def create_headless() -> GLContext:
    """A new offscreen OpenGL 4.3+ core context through EGL (no display needed)."""
    try:
        mgl = moderngl.create_context(standalone=True, backend="egl", require=REQUIRED_GL)
    except Exception as error:  # glcontext raises bare Exception
        raise _explain(error) from error
    return GLContext(mgl, owned=True)


_default: GLContext | None = None
_adopted: dict[int, GLContext] = {}


def get_context(ctx: moderngl.Context | GLContext | None = None) -> GLContext:
    """The :class:`GLContext` to use: the shared headless one, or a wrapper of ``ctx``.

    Passing a window's moderngl context makes glmls render into it with the same pipeline.
    """
    global _default
    if isinstance(ctx, GLContext):
        return ctx
    if ctx is None:
        if _default is None or _default.released:
            _default = create_headless()
        return _default
    if not isinstance(ctx, moderngl.Context):
        raise TypeError(f"ctx must be a moderngl.Context or None, got {type(ctx).__name__}")
    wrapper = _adopted.get(id(ctx))
    if wrapper is None or wrapper.released or wrapper.mgl is not ctx:
        wrapper = _adopted[id(ctx)] = GLContext(ctx, owned=False)
    return wrapper


def release_all() -> None:
    """Release the shared headless context and every adopted context's programs."""
    global _default
    if _default is not None:
        _default.release()
        _default = None
    for wrapper in _adopted.values():
        wrapper.release()
    _adopted.clear()


atexit.register(release_all)
