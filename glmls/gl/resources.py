"""Cached GL objects of one owner: buffers that only grow, one texture (and framebuffer) per
role replaced when its size changes (or, asked for ``tall``, only when it has too few rows),
attribute-less vertex arrays per program, and the read-only tables of compute shaders
(:mod:`.tables`).

Owners (an MLS kernel's scratch buffers, a warp pipeline) keep a :class:`Resources` and call
:meth:`Resources.release` when they go; nothing else frees these objects.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Hashable, Iterator

import moderngl
import numpy as np

from ..errors import ReleasedError
from .context import GLContext
from .tables import Tables

__all__ = ["FILL_BYTES", "Resources", "can_fill", "keep_framebuffer"]

#: The most bytes of the buffer :meth:`Resources.fill` copies from (whole rows: one at least).
FILL_BYTES = 1 << 20


class Resources:
    """GL objects cached by name or role for one owner on ``gl`` (see the module docstring);
    ``owner`` names it in the error once released."""

    def __init__(self, gl: GLContext, owner: str = "this GL cache") -> None:
        self._gl = gl
        self._owner = owner
        self._buffers: dict[str, tuple[Hashable, moderngl.Buffer]] = {}
        self._textures: dict[str, tuple[tuple, moderngl.Texture]] = {}
        self._framebuffers: dict[str, tuple[int, moderngl.Framebuffer]] = {}
        #: framebuffers over several of the textures: role -> (their roles, framebuffer)
        self._attached: dict[str, tuple[tuple[str, ...], moderngl.Framebuffer]] = {}
        self._vaos: dict[tuple, moderngl.VertexArray] = {}
        self._staging: dict[str, np.ndarray] = {}
        self._released = False
        #: The owner's read-only arrays for compute shaders (:mod:`.tables`).
        self.tables = Tables(gl)

    @property
    def limits(self) -> dict[str, int]:
        """The GL limits of the owner's context (:attr:`GLContext.limits`)."""
        return self._gl.limits

    def check_alive(self) -> None:
        if self._released:
            raise ReleasedError(f"{self._owner} has been released")

    def buffer(self, name: str, nbytes: int) -> moderngl.Buffer:
        """A buffer of at least ``nbytes`` (at least 16), grown (never shrunk) as needed."""
        cached = self._buffers.get(name)
        if cached is not None and cached[1].size >= nbytes:
            return cached[1]
        return self._replace_buffer(
            name, None, lambda: self._gl.mgl.buffer(reserve=max(nbytes, 16))
        )

    def grown(self, name: str, nbytes: int, *, keep: int) -> moderngl.Buffer:
        """The buffer ``name`` with room for at least ``nbytes``, its first ``keep`` bytes
        kept: where it must grow, the new one (twice the old size at least, so that a buffer
        filled in many steps is copied a few times only) gets them by a GPU-side copy."""
        cached = self._buffers.get(name)
        if cached is not None and cached[1].size >= nbytes:
            return cached[1]
        old = None if cached is None else cached[1]
        size = max(nbytes, 16, 0 if old is None else 2 * old.size)
        self.check_alive()
        new = self._gl.mgl.buffer(reserve=size)
        if old is not None and keep > 0:
            self._gl.mgl.copy_buffer(new, old, size=min(keep, old.size))
        return self._replace_buffer(name, None, lambda: new)

    def staging(self, name: str, shape: tuple[int, ...], dtype: object) -> np.ndarray:
        """A host array of ``shape`` and ``dtype`` for a read-back that does not leave the
        owner (the caller copies out what it returns), kept between calls and grown as
        needed: a new array of many megabytes costs the kernel's zeroing of its fresh pages,
        more than the read-back that fills it (~1-2 ms a megabyte on a virtual machine)."""
        self.check_alive()
        dtype = np.dtype(dtype)
        nbytes = int(np.prod(shape, dtype=np.int64)) * dtype.itemsize
        held = self._staging.get(name)
        if held is None or held.nbytes < nbytes:
            held = self._staging[name] = np.empty(nbytes, np.uint8)
        return held[:nbytes].view(dtype).reshape(shape)

    def cached(self, name: str) -> moderngl.Buffer:
        """The buffer last made under ``name`` (``KeyError`` if none)."""
        return self._buffers[name][1]

    def keyed_buffer(self, name: str, key: Hashable, make: Callable[[], bytes]) -> moderngl.Buffer:
        """The buffer holding ``make()``, made again only when ``key`` changes."""
        cached = self._buffers.get(name)
        if cached is not None and cached[0] == key:
            return cached[1]
        return self._replace_buffer(name, key, lambda: self._gl.mgl.buffer(make()))

    def _replace_buffer(self, name: str, key: Hashable, make: Callable[[], moderngl.Buffer]):
        self.check_alive()
        old = self._buffers.pop(name, None)
        if old is not None:
            for vao_key in [k for k in self._vaos if k[1] == old[1].glo]:
                self._vaos.pop(vao_key).release()
            old[1].release()
        buffer = make()
        self._buffers[name] = (key, buffer)
        return buffer

    def texture(
        self,
        role: str,
        size: tuple[int, int],
        components: int,
        dtype: str = "f4",
        *,
        tall: bool = False,
    ) -> moderngl.Texture:
        """The texture of ``role``, made again (with its framebuffer) when size, components
        or dtype change; clamped to its edges. ``tall``: the one kept serves while it has
        ``size``'s width and at least its rows (an atlas of fewer images than the last; its
        user draws, fills and reads only its first ``size[1]`` rows), so that chunks of
        different sizes do not make their textures again each time."""
        self.check_alive()
        key = (tuple(size), components, dtype)
        cached = self._textures.get(role)
        if cached is not None and (cached[0] == key or (tall and _holds(cached[0], key))):
            return cached[1]
        if cached is not None:
            self._drop_texture(role)
        texture = self._gl.mgl.texture(size, components, dtype=dtype)
        texture.repeat_x = texture.repeat_y = False
        self._textures[role] = (key, texture)
        return texture

    def _drop_texture(self, role: str) -> None:
        _, texture = self._textures.pop(role)
        framebuffer = self._framebuffers.pop(role, None)
        if framebuffer is not None:
            framebuffer[1].release()
        for name in [n for n, (roles, _) in self._attached.items() if role in roles]:
            self._attached.pop(name)[1].release()
        texture.release()

    def fill(
        self,
        texture: moderngl.Texture,
        colour: tuple[float, float, float, float],
        *,
        rows: int | None = None,
    ) -> None:
        """Set every texel of the RGBA ``texture`` (RGBA8 or RGBA32F) to ``colour``, as a
        framebuffer clear would (RGBA8: each channel clamped to 0..1 and rounded to the
        nearest of 0..255), by copies from a buffer of that colour (made once per colour
        and width, :data:`FILL_BYTES` at most): on llvmpipe a clear goes through the
        rasterizer's tiles, 0.13 ms at 512 x 512 RGBA8 (1.0 ms RGBA32F) against 0.03 ms
        (0.11 ms) for the copies. ``rows``: only the first rows (all by default)."""
        if not can_fill(texture):
            raise ValueError(
                f"fill needs a single-sample RGBA8 or RGBA32F texture, got {texture!r}"
                + (
                    f": {texture.components} components of {texture.dtype!r}, "
                    f"{texture.samples} samples"
                    if isinstance(texture, moderngl.Texture)
                    else ""
                )
            )
        values = np.asarray(colour, np.float64)
        if texture.dtype == "f1":
            texel = np.rint(np.clip(values, 0.0, 1.0) * 255.0).astype(np.uint8).tobytes()
        else:
            texel = values.astype(np.float32).tobytes()
        width, height = texture.size
        if rows is not None:
            height = min(height, rows)
        step = max(1, min(height, FILL_BYTES // (len(texel) * width)))
        count = step * width
        source = self.keyed_buffer("fill", (texel, count), lambda: texel * count)
        for top in range(0, height, step):
            texture.write(source, viewport=(0, top, width, min(step, height - top)))

    def framebuffer(
        self, role: str, size: tuple[int, int], dtype: str = "f4", *, tall: bool = False
    ):
        """A framebuffer around the RGBA texture ``role`` of ``size`` (RGBA32F, or RGBA8 for
        ``dtype="f1"``; ``tall`` as :meth:`texture`'s)."""
        texture = self.texture(role, size, 4, dtype, tall=tall)
        cached = self._framebuffers.get(role)
        if cached is not None and cached[0] == texture.glo:
            return cached[1]
        framebuffer = self._gl.mgl.framebuffer(color_attachments=[texture])
        self._framebuffers[role] = (texture.glo, framebuffer)
        return framebuffer

    def attached(self, role: str, textures: tuple[str, ...]) -> moderngl.Framebuffer:
        """A framebuffer ``role`` whose colour attachments are the textures of the roles
        ``textures`` (made by :meth:`texture` or :meth:`framebuffer`), in that order: one
        draw writes them all. Made again when one of them is made again."""
        cached = self._attached.get(role)
        if cached is not None and cached[0] == textures:
            return cached[1]
        if cached is not None:
            self._attached.pop(role)[1].release()
        self.check_alive()
        attachments = [self._textures[name][1] for name in textures]
        framebuffer = self._gl.mgl.framebuffer(color_attachments=attachments)
        self._attached[role] = (textures, framebuffer)
        return framebuffer

    def vertex_array(
        self, program: moderngl.Program, index: moderngl.Buffer | None = None
    ) -> moderngl.VertexArray:
        """An attribute-less vertex array: the shaders index their data by gl_VertexID."""
        self.check_alive()
        key = (program.glo, None if index is None else index.glo)
        vao = self._vaos.get(key)
        if vao is not None and vao.program is not program:  # a released program's name reused
            vao.release()
            vao = None
        if vao is None:
            if index is None:
                vao = self._gl.mgl.vertex_array(program, [])
            else:
                vao = self._gl.mgl.vertex_array(program, [], index_buffer=index)
            self._vaos[key] = vao
        return vao

    def release(self) -> None:
        """Free every object. Idempotent; later use raises :class:`glmls.ReleasedError`.
        Where the context is gone (or not usable here) the references are only dropped."""
        if self._released:
            return
        if self._gl.usable:
            with self._gl.use():
                for role in list(self._textures):
                    self._drop_texture(role)  # and the framebuffers over it
                for vao in self._vaos.values():
                    vao.release()
                for _, buffer in self._buffers.values():
                    buffer.release()
                self.tables.release()
        self._textures.clear()
        self._framebuffers.clear()
        self._attached.clear()
        self._vaos.clear()
        self._buffers.clear()
        self._staging.clear()
        self._released = True


def can_fill(texture: object) -> bool:
    """Whether :meth:`Resources.fill` takes ``texture``: a single-sample RGBA8 or RGBA32F
    :class:`moderngl.Texture`."""
    return (
        isinstance(texture, moderngl.Texture)
        and texture.components == 4
        and texture.dtype in ("f1", "f4")
        and texture.samples == 0
    )


@contextlib.contextmanager
def keep_framebuffer(mgl: moderngl.Context) -> Iterator[None]:
    """Leave the bound framebuffer as found: moderngl re-binds the bound one when it creates
    another, and binding one of ours after we released it is a GL error."""
    bound = mgl.fbo
    if bound is None:  # a standalone context starts with none: framebuffer 0
        bound = mgl.detect_framebuffer(0)
    try:
        yield
    finally:
        bound.use()


def _holds(kept: tuple, asked: tuple) -> bool:
    """Does a texture of the form ``kept`` (size, components, dtype) hold one of ``asked``
    in its first rows?"""
    (width, height), *form = kept
    (asked_width, asked_height), *asked_form = asked
    return width == asked_width and height >= asked_height and form == asked_form
