"""The one place where glmls creates or adopts OpenGL contexts.

By default glmls renders headless through EGL (``moderngl.create_context(standalone=True,
backend="egl", require=430)``); a window hands in its own context instead. Each context is
wrapped in a :class:`GLContext` that also caches the programs compiled for it and the objects
shared by everything that renders with it (:meth:`GLContext.shared`, e.g. the one warp
pipeline per context).
"""

from __future__ import annotations

import atexit
import functools
from collections.abc import Callable, Hashable, Mapping
from typing import Protocol, TypeVar

import moderngl

from ..errors import GLUnavailableError
from . import bindings
from .shaders import ComposedSource, ShaderCompileError, ShaderLibrary, library

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


class Releasable(Protocol):
    def release(self) -> None: ...


_T = TypeVar("_T", bound=Releasable)


class GLContext:
    """A moderngl context plus the glmls programs compiled for it and the objects shared by
    everything that renders with it.

    ``owned`` contexts (made by :func:`create_headless`) are released with :meth:`release`;
    borrowed ones (a window's) are left to their owner, only glmls's objects are released.
    ``shaders``: where programs come from (the package's shaders by default).
    """

    def __init__(
        self, mgl: moderngl.Context, *, owned: bool, shaders: ShaderLibrary | None = None
    ) -> None:
        if mgl.version_code < REQUIRED_GL:
            raise GLUnavailableError(
                f"OpenGL unavailable: glmls needs OpenGL {REQUIRED_GL // 100}.3 core "
                f"(compute shaders), this context is {mgl.version_code}. {_FIX}"
            )
        _check_binding_limits(mgl)
        self.mgl = mgl
        self.owned = owned
        self.shaders = shaders if shaders is not None else library()
        self._programs: dict[tuple, moderngl.ComputeShader | moderngl.Program] = {}
        self._shared: dict[Hashable, Releasable] = {}
        self.released = False

    @property
    def limits(self) -> dict[str, int]:
        """GL limits that bound image and handle sizes."""
        info = self.mgl.info
        return {
            "max_texture_size": int(info["GL_MAX_TEXTURE_SIZE"]),
            "max_ssbo_size": int(info["GL_MAX_SHADER_STORAGE_BLOCK_SIZE"]),
            "max_ubo_size": int(info["GL_MAX_UNIFORM_BLOCK_SIZE"]),
            "max_work_groups_x": int(info["GL_MAX_COMPUTE_WORK_GROUP_COUNT"][0]),
            "max_viewport": min(int(v) for v in info["GL_MAX_VIEWPORT_DIMS"]),
        }

    def compute(self, entry: str, defines: Mapping[str, object] | None = None):
        """The compute program whose entry file is ``entry`` (e.g. ``"mls/points.comp.glsl"``)
        with ``defines`` (compiled once per context)."""
        key = ("compute", entry, _frozen(defines))
        program = self._programs.get(key)
        if program is None:
            source = self.shaders.compose(entry, defines)
            program = self._compile({"compute_shader": source}, self._compute_shader)
            self._programs[key] = program
        return program

    def program(
        self, vertex: str, fragment: str, defines: Mapping[str, object] | None = None
    ) -> moderngl.Program:
        """The vertex/fragment program of these entry files and defines (compiled once)."""
        key = ("render", vertex, fragment, _frozen(defines))
        program = self._programs.get(key)
        if program is None:
            stages = {
                "vertex_shader": self.shaders.compose(vertex, defines),
                "fragment_shader": self.shaders.compose(fragment, defines),
            }
            program = self._compile(stages, self.mgl.program)
            self._programs[key] = program
        return program

    def _compute_shader(self, compute_shader: str) -> moderngl.ComputeShader:
        return self.mgl.compute_shader(compute_shader)

    def _compile(self, stages: dict[str, ComposedSource], build: Callable):
        try:
            return build(**{stage: source.text for stage, source in stages.items()})
        except moderngl.Error as error:
            raise ShaderCompileError(self.shaders.explain(str(error), stages)) from None

    def shared(self, key: Hashable, factory: Callable[[], _T]) -> _T:
        """The object stored under ``key`` for this context, made by ``factory()`` on first
        use: one per context, released with it (or by :meth:`release_shared`)."""
        obj = self._shared.get(key)
        if obj is None:
            obj = self._shared[key] = factory()
        return obj  # type: ignore[return-value]

    def release_shared(self) -> None:
        """Release the shared objects (e.g. the warp pipeline's cached textures and buffers);
        they are made again when next needed."""
        self.make_current()
        while self._shared:
            _, obj = self._shared.popitem()
            obj.release()

    def make_current(self) -> None:
        """Make this context current (EGL or a window's). It stays current afterwards:
        moderngl's ``with ctx:`` would release it on exit, leaving no context current."""
        self.mgl.__enter__()

    @property
    def alive(self) -> bool:
        """Whether the moderngl context still exists (its owner may have released it)."""
        return type(self.mgl.mglo).__name__ != "InvalidObject"

    def release(self) -> None:
        """Release the shared objects, the cached programs, and the context itself if glmls
        created it. Where the context is already gone, only the references are dropped."""
        if self.released:
            return
        if self.alive:
            self.release_shared()  # makes it current: delete in this context
            for program in self._programs.values():
                program.release()
            if self.owned:
                self.mgl.release()
        self._shared.clear()
        self._programs.clear()
        self.released = True


def _frozen(defines: Mapping[str, object] | None) -> tuple:
    return tuple(sorted((defines or {}).items()))


def _check_binding_limits(mgl: moderngl.Context) -> None:
    """The binding points of :mod:`glmls.gl.bindings` must exist on this driver."""
    for limit, needed in bindings.needed().items():
        offered = mgl.info.get(limit)
        if offered is not None and int(offered) < needed:
            raise GLUnavailableError(
                f"OpenGL unavailable: glmls needs {needed} binding points of {limit}, this "
                f"driver offers {int(offered)}. {_FIX}"
            )


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
#: Every live wrapper by id() of its moderngl context: one GLContext per moderngl context.
_wrappers: dict[int, GLContext] = {}


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
            _wrappers[id(_default.mgl)] = _default
        return _default
    if not isinstance(ctx, moderngl.Context):
        raise TypeError(f"ctx must be a moderngl.Context or None, got {type(ctx).__name__}")
    wrapper = _wrappers.get(id(ctx))
    if wrapper is None or wrapper.released or wrapper.mgl is not ctx:
        wrapper = _wrappers[id(ctx)] = GLContext(ctx, owned=False)
    return wrapper


def release_all() -> None:
    """Release the shared headless context and glmls's objects in every adopted context."""
    global _default
    for wrapper in [w for w in _wrappers.values() if w is not _default]:
        wrapper.release()
    if _default is not None:
        _default.release()
        _default = None
    _wrappers.clear()


atexit.register(release_all)
