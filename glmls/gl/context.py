"""The one place where glmls creates or adopts OpenGL contexts, and the rules for using them
from threads and processes.

By default glmls renders headless through EGL (``moderngl.create_context(standalone=True,
backend="egl", require=430)``), one shared context per process; a window hands in its own
context instead. Each context is wrapped in a :class:`GLContext` that also caches the programs
compiled for it and the objects shared by everything that renders with it
(:meth:`GLContext.shared`, e.g. the one warp pipeline per context).

Threads: a GL context is current in at most one thread at a time. glmls makes its contexts
current only for the duration of a call (:meth:`GLContext.use`: the context's lock, bind,
restore what was bound before), so any thread may use them, one call at a time; several
threads calling at once wait for each other. A context that is kept current in one thread (a
window's, adopted in its thread; or one bound with :meth:`GLContext.make_current`) can only be
used from that thread: another raises :class:`~glmls.ContextError`.

Processes: GL drivers do not survive ``fork()``: on Mesa's llvmpipe even a new context made in
the child hangs in its first compute dispatch (the driver's worker threads are gone), and
NVIDIA's driver does not support use after fork either. So in a process forked from one in
which glmls made a GL context, :func:`glmls.warp`, :func:`glmls.warp_batch`, the methods of an
:class:`~glmls.MLS` (made before the fork or after it, without a ``ctx``) and the ``render_*``
pictures of :mod:`glmls.analysis` run in a helper process started fresh
(:mod:`glmls.gl.helper`; one per forked process, started on first use and kept), with the same
result bit for bit; making a context there (:func:`get_context`, a window, a
:class:`~glmls.analysis.Canvas`, an MLS given a ``ctx``) raises
:class:`~glmls.GLUnavailableError` at once, saying to use the ``spawn`` start method. A
process forked before glmls touched GL makes its own context on first use.
"""

from __future__ import annotations

import contextlib
import functools
import os
import threading
import weakref
from collections import OrderedDict
from collections.abc import Callable, Hashable, Mapping
from typing import Protocol, TypeVar

import moderngl

from ..errors import ContextError, GLUnavailableError, ReleasedError
from . import bindings, dropped, exiting, llvm
from .locks import ContextLock, ThreadBindings
from .shaders import ComposedSource, ShaderCompileError, ShaderLibrary, dump, library
from .signals import signals_held
from .unavailable import FIX, FORKED, explain

REQUIRED_GL = 430
#: Compute programs kept compiled per context (each is ~0.1-0.2 MB on llvmpipe, every
#: configuration together ~1 GB): the least recently used beyond this are released.
MAX_PROGRAMS = 128
_MIN_PROGRAMS = 16  # one image pass uses up to ~8: never evict one while it runs


class Releasable(Protocol):
    def release(self) -> None: ...


_T = TypeVar("_T", bound=Releasable)


class _Unbinder:
    """Unbinds a context kept current by a thread (:meth:`GLContext.make_current`) when that
    thread ends without :meth:`GLContext.unbind`: held in the thread's own state, it goes with
    the thread, in the thread. EGL would keep the context current in the ended thread, and
    no other thread could bind it again (every GL call there would fail)."""

    __slots__ = ("context",)

    def __init__(self, context: GLContext) -> None:
        self.context = context

    def __del__(self) -> None:
        context = self.context
        try:
            if context._held_by == threading.get_ident() and context.pid == os.getpid():
                context._held_by = None
                if context.alive and not context.released:
                    context.mgl.__exit__(None, None, None)
        except Exception:  # a thread's end: no one to report to
            pass


_thread = ThreadBindings()


class _Binding:
    """One outermost :meth:`GLContext.use` block: the lock, bind, then restore."""

    __slots__ = ("context", "previous")

    def __init__(self, context: GLContext) -> None:
        self.context = context
        self.previous: GLContext | None = None

    def __enter__(self) -> GLContext:
        context = self.context
        exiting.halt_if_exiting(holding=_thread.held > 0)  # a daemon thread at exit
        context.check_usable()
        lock = context._lock
        # a signal's handler (Ctrl-C) may raise as acquire() returns: undone by the count
        before, held = lock.count(), _thread.held
        try:
            lock.acquire()
            if context.released:  # released by another thread while this one waited
                lock.release()
                exiting.halt_if_exiting(holding=_thread.held > 0)
                context.check_usable()
            _thread.held += 1
            if _thread.current is not context:
                context._check_thread()
                self.previous = _thread.current
                context.mgl.__enter__()
                _thread.current = context
            else:  # bound by another block of this thread meanwhile
                self.previous = context
        except BaseException:
            _thread.held = held
            if lock.count() > before:
                lock.release()
            raise
        try:
            context._release_orphans()
        except BaseException:  # an interrupt while freeing them: unbind, let the lock go
            self.__exit__(None, None, None)
            raise
        return context

    def __exit__(self, *exc: object) -> None:
        context, previous = self.context, self.previous
        try:
            if previous is context or context._held_by == threading.get_ident():
                pass  # still wanted here (make_current() inside the block)
            elif previous is not None and previous.alive and not previous.released:
                previous.mgl.__enter__()
                _thread.current = previous
            else:
                if context.alive:
                    context.mgl.__exit__(None, None, None)
                _thread.current = None
        finally:
            _thread.held -= 1
            context._lock.release()


def _alive(ident: int) -> bool:
    return any(thread.ident == ident for thread in threading.enumerate())


class GLContext:
    """A moderngl context plus the glmls programs compiled for it and its shared objects.

    The shared objects are those used by everything that renders with the context (one warp
    pipeline per context, :meth:`shared`). Make one with :func:`get_context` (the shared
    headless context, or a wrapper of a window's) or :func:`create_headless` (a context of
    one's own); constructing it directly wraps a moderngl context.

    Parameters
    ----------
    mgl : moderngl.Context
        An OpenGL 4.3+ core context.
    owned : bool
        Whether glmls made the context: :meth:`release` releases an owned one; a borrowed
        one (a window's, adopted in the thread where it is current, which keeps it current
        there) is left to its owner, and only glmls's objects on it are released.
    shaders : ShaderLibrary, optional
        Where programs come from (the package's shaders by default).
    max_programs : int, optional
        Compute programs kept compiled (least recently used released first), at least 16.

    Attributes
    ----------
    mgl : moderngl.Context
        The wrapped context.
    owned : bool
        Whether glmls made it.
    released : bool
        Whether :meth:`release` was called.

    Raises
    ------
    GLUnavailableError
        When the context is older than OpenGL 4.3 or lacks binding points glmls needs.
    TypeError
        When ``max_programs`` is not an integer.
    ValueError
        When ``max_programs`` is below 16.

    See Also
    --------
    get_context : the context glmls uses by default.

    Examples
    --------
    >>> from glmls.gl import create_headless
    >>> context = create_headless()  # a headless context of one's own
    >>> context.owned, context.alive, context.compiled
    (True, True, 0)
    >>> context.limits["max_texture_size"] >= 4096
    True
    >>> with context:  # current in this thread for the block
    ...     print(context.mgl.version_code >= 430)
    True
    >>> context.release()
    >>> context.released
    True
    """

    def __init__(
        self,
        mgl: moderngl.Context,
        *,
        owned: bool,
        shaders: ShaderLibrary | None = None,
        max_programs: int = MAX_PROGRAMS,
    ) -> None:
        if mgl.version_code < REQUIRED_GL:
            raise GLUnavailableError(
                f"OpenGL unavailable: glmls needs OpenGL {REQUIRED_GL // 100}.3 core "
                f"(compute shaders), this context is {mgl.version_code}. {FIX}"
            )
        if isinstance(max_programs, bool) or not isinstance(max_programs, int):
            raise TypeError(f"max_programs must be an integer, got {max_programs!r}")
        if max_programs < _MIN_PROGRAMS:
            raise ValueError(f"max_programs must be >= {_MIN_PROGRAMS}, got {max_programs}")
        lacking = bindings.shortfall(mgl.info)  # the binding points of glmls.gl.bindings
        if lacking:
            raise GLUnavailableError(f"OpenGL unavailable: {lacking}. {FIX}")
        self.mgl = mgl
        self.owned = owned
        self.shaders = shaders if shaders is not None else library()
        self.max_programs = max_programs
        self.pid = os.getpid()
        self._when_dropped: weakref.finalize | None = None  # dropped.free_when_dropped
        self._programs: OrderedDict[tuple, moderngl.ComputeShader] = OrderedDict()
        self._render_programs: dict[tuple, moderngl.Program] = {}
        self._shared: dict[Hashable, Releasable] = {}
        #: Objects given back by the garbage collector (release_later), released at the
        #: start of the next use.
        self._orphans: list[Releasable] = []
        self._lock = ContextLock()
        _every.add(self)
        #: The thread keeping this context current outside glmls's calls, if any: the
        #: adopting thread for a borrowed context, else the caller of make_current().
        self._held_by: int | None = None
        if not owned:  # a window's: current in the thread that adopts it, and stays so
            self._held_by = threading.get_ident()
            _thread.current = self
        self.released = False

    # A context is this process's GL state, not a value: a copy of what holds it (an Augment
    # or a transform given ctx=) renders on it too, and no other process can use it.
    def __copy__(self) -> GLContext:
        return self

    def __deepcopy__(self, memo: dict) -> GLContext:
        return self

    def __reduce__(self) -> tuple:
        raise TypeError(
            "a glmls GLContext cannot be pickled: it is this process's OpenGL state, and "
            "another process (a spawn worker) makes its own: leave ctx out of what it is sent"
        )

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
            "max_renderbuffer_size": int(info["GL_MAX_RENDERBUFFER_SIZE"]),
        }

    @property
    def loop_limit(self) -> int | None:
        """The most loop iterations the driver runs in one shader invocation, counted over
        all its loops, where it caps them (Mesa's llvmpipe: 65,535, then it leaves the loops
        as if done); None where it runs them all (GPU drivers)."""
        return 65535 if "llvmpipe" in str(self.mgl.info["GL_RENDERER"]).lower() else None

    @functools.cached_property
    def piece_pixels(self) -> int:
        """The most pixels one invocation of a scan conversion walks, larger primitives
        being walked in pieces (``glmls/shaders/common/pieces.glsl``): a quarter of
        :attr:`loop_limit` (a walk steps at most twice per pixel, the rest is margin); 0, no
        bound and no pieces, without one. Set on a context before its first compute program
        to walk in smaller pieces (the tests check that pieces change no pixel)."""
        limit = self.loop_limit
        return 0 if limit is None else limit // 4

    @property
    def _compute_defines(self) -> dict[str, object]:
        """What every compute program of this context is compiled with besides the library's
        common defines: ``SCAN_PIECE_PIXELS`` (:attr:`piece_pixels`) and ``LOOP_CAP`` (1
        where the driver caps an invocation's loop iterations, :attr:`loop_limit`)."""
        return {"SCAN_PIECE_PIXELS": self.piece_pixels, "LOOP_CAP": self.loop_limit is not None}

    # -- being current ----------------------------------------------------------------------

    @property
    def alive(self) -> bool:
        """Whether the moderngl context still exists (its owner may have released it)."""
        return type(self.mgl.mglo).__name__ != "InvalidObject"

    def check_usable(self) -> None:
        """Raise if the context cannot be used in this process.

        Raises
        ------
        ReleasedError
            Once released (or its owner released the moderngl context).
        GLUnavailableError
            In a process forked from the one that made it.
        """
        if self.pid != os.getpid():
            raise GLUnavailableError(FORKED.format(pid=self.pid))
        if self.released or not self.alive:
            raise ReleasedError(
                "the GL context of this object has been released (GLContext.release(), or "
                "its window closed): its GPU objects are gone; create them again"
            )

    def _check_thread(self) -> None:
        holder = self._held_by
        if holder is not None and holder != threading.get_ident() and _alive(holder):
            kind = "a window's, adopted" if not self.owned else "bound with make_current()"
            raise ContextError(
                f"this GL context is current in another thread ({kind} there): a GL context "
                "is current in one thread at a time, so use it from that thread (or call "
                "unbind() there first); glmls's own headless context works from any thread"
            )

    def use(self) -> contextlib.AbstractContextManager[GLContext]:
        """This context current in the calling thread for the ``with`` block (reentrant; other
        threads wait), then what glmls had bound before is bound again."""
        if _thread.current is self:  # inside a glmls call already, or kept current here
            return contextlib.nullcontext(self)
        return _Binding(self)

    def __enter__(self) -> GLContext:
        """``with context:`` is :meth:`use`."""
        block = self.use()
        block.__enter__()
        _thread.blocks.append(block)
        return self

    def __exit__(self, *exc: object) -> None:
        _thread.blocks.pop().__exit__(*exc)  # type: ignore[arg-type]

    @property
    def usable(self) -> bool:
        """Whether GL calls can be made here (not released, this process, not kept current
        by another live thread): release paths skip the GL calls where not."""
        holder = self._held_by
        return (
            not self.released
            and self.pid == os.getpid()
            and self.alive
            and (holder in (None, threading.get_ident()) or not _alive(holder))
        )

    def make_current(self) -> None:
        """Bind this context in the calling thread until :meth:`unbind` (for raw moderngl
        calls between glmls's; glmls's own calls do not need it). While bound here, other
        threads cannot use it."""
        self.check_usable()
        with self._lock:
            self._check_thread()
            me = threading.get_ident()
            previous = _thread.current
            if previous is not self:
                self.mgl.__enter__()
                if previous is not None and previous._held_by == me:
                    previous._held_by = None
                _thread.current = self
            self._held_by = me
            if self not in _thread.unbinders:
                _thread.unbinders[self] = _Unbinder(self)

    def unbind(self) -> None:
        """Undo :meth:`make_current` in the calling thread."""
        with self._lock:
            if self._held_by == threading.get_ident():
                self._held_by = None
            _thread.unbinders.pop(self, None)
            if _thread.current is self and self.alive:
                self.mgl.__exit__(None, None, None)
                _thread.current = None

    # -- programs and shared objects --------------------------------------------------------

    def compute(self, entry: str, defines: Mapping[str, object] | None = None):
        """The compute program of an entry file and defines, compiled once.

        It is kept while among the ``max_programs`` most recently used. Call it within
        :meth:`use` (glmls's calls are).

        Parameters
        ----------
        entry : str
            The program's entry file under the shaders, e.g. ``"mls/points.comp.glsl"``.
        defines : mapping, optional
            Preprocessor definitions, name to value.

        Returns
        -------
        moderngl.ComputeShader
            The compiled program.
        """
        key = (entry, _frozen(defines))
        program = self._programs.get(key)
        if program is None:
            self.check_usable()
            source = self.shaders.compose(entry, self._compute_defines | dict(defines or {}))
            program = self._compile({"compute_shader": source}, self._compute_shader)
            self._programs[key] = program
            while len(self._programs) > self.max_programs:
                _, oldest = self._programs.popitem(last=False)
                oldest.release()
        else:
            self._programs.move_to_end(key)
        return program

    def program(
        self, vertex: str, fragment: str, defines: Mapping[str, object] | None = None
    ) -> moderngl.Program:
        """The vertex/fragment program of these entry files and defines, compiled once.

        The drawing programs are a small fixed set, kept for the context's life.

        Parameters
        ----------
        vertex, fragment : str
            The stages' entry files under the shaders.
        defines : mapping, optional
            Preprocessor definitions, name to value.

        Returns
        -------
        moderngl.Program
            The compiled program.
        """
        key = (vertex, fragment, _frozen(defines))
        program = self._render_programs.get(key)
        if program is None:
            self.check_usable()
            stages = {
                "vertex_shader": self.shaders.compose(vertex, defines),
                "fragment_shader": self.shaders.compose(fragment, defines),
            }
            program = self._compile(stages, self.mgl.program)
            self._render_programs[key] = program
        return program

    @property
    def compiled(self) -> int:
        """How many programs are compiled now."""
        return len(self._programs) + len(self._render_programs)

    def _compute_shader(self, compute_shader: str) -> moderngl.ComputeShader:
        return self.mgl.compute_shader(compute_shader)

    def _compile(self, stages: dict[str, ComposedSource], build: Callable):
        folder = os.environ.get("GLMLS_DUMP_SHADERS")
        if folder:  # the sources, for tools/check_shaders.py (shaders.dump)
            dump(stages, folder)
        texts = {stage: source.text for stage, source in stages.items()}
        try:
            with signals_held():  # moderngl dies of an exception in its callbacks
                return build(**texts)
        except moderngl.Error as error:
            raise ShaderCompileError(self.shaders.explain(str(error), stages)) from None

    def release_later(self, obj: Releasable) -> None:
        """Release ``obj`` at the start of this context's next use, in the thread that uses it.

        For finalizers: the garbage collector runs anywhere, in any thread, even inside a GL
        call or another context's, where releasing GL objects is not safe.

        Parameters
        ----------
        obj : object
            Has a ``release()`` method that frees its GL objects on this context.
        """
        if self.released:  # its GL objects went with the context
            return
        self._orphans.append(obj)  # a list's append is atomic: no lock, which a finalizer
        # could otherwise wait on in the thread that holds it

    def _release_orphans(self) -> None:
        while self._orphans:
            obj = self._orphans.pop()
            try:
                obj.release()
            except Exception:  # a leftover must not fail the user's call
                pass
            except BaseException:  # interrupted: freed at a later use (release is idempotent)
                self._orphans.append(obj)
                raise

    def shared(self, key: Hashable, factory: Callable[[], _T]) -> _T:
        """The object stored under ``key`` for this context, made on first use.

        One per context, released with it (or by :meth:`release_shared`).

        Parameters
        ----------
        key : hashable
            The object's name.
        factory : callable
            Makes the object (with a ``release()`` method) when there is none yet.

        Returns
        -------
        object
            The stored object.
        """
        with self._lock:
            obj = self._shared.get(key)
            if obj is None:
                obj = self._shared[key] = factory()
            return obj  # type: ignore[return-value]

    def release_shared(self) -> None:
        """Release the shared objects (e.g. the warp pipeline's cached textures and buffers);
        they are made again when next needed."""
        with self.use():
            while self._shared:
                _, obj = self._shared.popitem()
                obj.release()

    def release(self) -> None:
        """Release the shared objects, the cached programs, and the context itself if glmls
        created it. Objects made on it raise :class:`~glmls.ReleasedError` afterwards. Where
        the context is gone already, or belongs to another process or thread, only the
        references are dropped."""
        if self.released:
            return
        if self._when_dropped is not None:
            self._when_dropped.detach()
        with self._lock:
            if self.usable:
                with self.use():
                    while self._shared:
                        self._shared.popitem()[1].release()
                    for program in [*self._programs.values(), *self._render_programs.values()]:
                        program.release()
                if self.owned:
                    self.unbind()
                    self.mgl.release()
            self._shared.clear()
            self._orphans.clear()  # released with the context
            self._programs.clear()
            self._render_programs.clear()
            if _thread.current is self:
                _thread.current = None
            self.released = True


def _frozen(defines: Mapping[str, object] | None) -> tuple:
    return tuple(sorted((defines or {}).items()))


_R = TypeVar("_R")


def current(method: Callable[..., _R]) -> Callable[..., _R]:
    """Run a method of an object holding ``self._gl`` (a :class:`GLContext`) with that context
    current (:meth:`GLContext.use`)."""

    @functools.wraps(method)
    def wrapper(self, *args, **kwargs):
        with self._gl.use():
            return method(self, *args, **kwargs)

    return wrapper


#: Processes in which glmls made or adopted a GL context (inherited by forked children).
_gl_pids: set[int] = set()
_registry_lock = threading.RLock()
_default: GLContext | None = None
#: Every live wrapper by id() of its moderngl context: one GLContext per moderngl context.
_wrappers: dict[int, GLContext] = {}
#: Every live GLContext, whose locks a forked child makes anew (see _after_fork_in_child).
_every: weakref.WeakSet[GLContext] = weakref.WeakSet()


def forked_from_gl() -> bool:
    """Whether this process was forked from one in which glmls made or adopted a GL context
    (where GL cannot be used; :func:`glmls.gl.helper.call` does GL work in a clean helper)."""
    return bool(_gl_pids - {os.getpid()})


def _check_process() -> None:
    """GL in a process forked from one that used GL would hang: raise instead."""
    pid = os.getpid()
    parents = _gl_pids - {pid}
    if parents:
        raise GLUnavailableError(FORKED.format(pid=min(parents)))


def create_headless(
    *, shaders: ShaderLibrary | None = None, max_programs: int = MAX_PROGRAMS
) -> GLContext:
    """A new offscreen OpenGL 4.3+ core context of one's own, through EGL (no display needed).

    The context is owned by glmls and usable from any thread, one call at a time; threads
    that should render in parallel can each have their own (``MLS(..., ctx=...)``). Release
    it with :meth:`GLContext.release`.

    Parameters
    ----------
    shaders : ShaderLibrary, optional
        Where programs come from (the package's shaders by default).
    max_programs : int, optional
        Compute programs kept compiled (least recently used released first), at least 16.

    Returns
    -------
    GLContext
        The new context, owned by glmls.

    Raises
    ------
    GLUnavailableError
        Where EGL, a driver or OpenGL 4.3 is missing (naming what and the packages that
        provide it), and in a process forked from one that used GL.
    TypeError, ValueError
        For a ``max_programs`` that is not an integer of at least 16.

    See Also
    --------
    get_context : the shared context that glmls uses by default.

    Examples
    --------
    >>> context = glmls.gl.create_headless()
    >>> src = np.array([[0.0, 0.0], [20.0, 0.0], [0.0, 20.0]])
    >>> with glmls.MLS(src, src + 1.0, ctx=context) as m:
    ...     print(m.ctx is context, m([[5.0, 5.0]]).round(3).tolist())
    True [[6.0, 6.0]]
    >>> context.release()
    """
    _check_process()
    dropped.free_dropped(_adopted)
    previous = _thread.current
    llvm.load_llvm_users_first()
    try:
        mgl = moderngl.create_context(standalone=True, backend="egl", require=REQUIRED_GL)
    except Exception as error:  # glcontext raises bare Exception
        raise explain(error) from error
    _gl_pids.add(os.getpid())
    try:
        context = GLContext(mgl, owned=True, shaders=shaders, max_programs=max_programs)
        context._when_dropped = dropped.free_when_dropped(context, mgl)
    finally:
        # creation made it current here: bind again what glmls had bound before
        if previous is not None and previous.alive and not previous.released:
            previous.mgl.__enter__()
        else:
            mgl.__exit__(None, None, None)
    return context


def get_context(ctx: moderngl.Context | GLContext | None = None) -> GLContext:
    """The :class:`GLContext` to use: the process's shared headless one, or a wrapper of ``ctx``.

    Passing a window's moderngl context (current in the calling thread) makes glmls render
    into it with the same pipeline. The shared headless context is made on first use (EGL, no
    display needed) and released at exit; any thread may use it, one call at a time.

    Parameters
    ----------
    ctx : moderngl.Context or GLContext, optional
        None for the shared headless context; a moderngl context to adopt (one wrapper per
        moderngl context); a :class:`GLContext` is returned as it is (one made before a fork
        is refused in the child).

    Returns
    -------
    GLContext
        The context.

    Raises
    ------
    TypeError
        When ``ctx`` is neither None, a moderngl context nor a :class:`GLContext`.
    GLUnavailableError
        When no OpenGL 4.3 context can be made, or in a process forked after glmls used GL.

    Examples
    --------
    >>> context = glmls.gl.get_context()
    >>> context is glmls.gl.get_context(), context.owned
    (True, True)
    >>> glmls.gl.get_context(context) is context
    True
    """
    global _default
    exiting.halt_if_exiting(holding=_thread.held > 0)  # no new context at exit
    if isinstance(ctx, GLContext):
        if ctx.pid != os.getpid():  # made before a fork: its driver state is not ours
            raise GLUnavailableError(FORKED.format(pid=ctx.pid))
        return ctx
    with _registry_lock:
        if ctx is None:
            if _default is None or _default.released or _default.pid != os.getpid():
                _default = create_headless()
                _wrappers[id(_default.mgl)] = _default
            return _default
        check_ctx(ctx)
        _check_process()
        wrapper = _wrappers.get(id(ctx))
        if wrapper is None or wrapper.released or wrapper.mgl is not ctx:
            wrapper = _wrappers[id(ctx)] = GLContext(ctx, owned=False)
            _gl_pids.add(os.getpid())
        return wrapper


def _adopted(mgl: moderngl.Context) -> bool:
    """Whether ``mgl`` was handed to :func:`get_context` too (and is in use there)."""
    wrapper = _wrappers.get(id(mgl))
    return wrapper is not None and wrapper.mgl is mgl


def check_ctx(ctx: object) -> None:
    """``TypeError`` unless ``ctx`` is None, a moderngl context or a :class:`GLContext` (the
    ``ctx`` that :func:`get_context` takes), checked without making or touching a context."""
    if ctx is not None and not isinstance(ctx, (moderngl.Context, GLContext)):
        raise TypeError(f"ctx must be a moderngl.Context or None, got {type(ctx).__name__}")


def release_all() -> None:
    """Release the shared headless context and glmls's objects in every adopted context (of
    this process: a forked child leaves its parent's alone)."""
    global _default
    # outside the registry's lock, which a thread holding a context's lock may wait on
    with _registry_lock:
        mine = [w for w in _wrappers.values() if w.pid == os.getpid()]
        default = _default if _default is not None and _default.pid == os.getpid() else None
    for wrapper in [w for w in mine if w is not default]:
        wrapper.release()
    if default is not None:
        default.release()
    with _registry_lock:
        _default = None
        _wrappers.clear()


def _after_fork_in_child() -> None:
    """Forget the parent's contexts without touching them (their driver state is not ours).
    Their locks are made anew: one held by another thread of the parent at the fork would
    be held for ever here, and release() or unbind() of such a context would hang."""
    global _default, _wrappers, _registry_lock
    _default = None
    _wrappers = {}
    _registry_lock = threading.RLock()
    _thread.current = None
    for context in list(_every):
        context._lock = ContextLock()
        context._held_by = None  # no thread of the parent's exists here


os.register_at_fork(after_in_child=_after_fork_in_child)
exiting.at_exit(release_all)
