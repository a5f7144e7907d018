"""Read-only arrays that compute shaders index item by item, kept in 2-D textures ("tables")
and read with ``texelFetch`` (``common/table.glsl``): item ``i`` is texel (``i & (TABLE_WIDTH
- 1)``, ``i >> TABLE_SHIFT``), each item 1, 2 or 4 float32 or uint32 components.

Why textures and not storage buffers: where neighbouring invocations read different items (a
triangle's vertices, a cell's grid points), llvmpipe loads a storage buffer's values one
component and one lane at a time, each behind a branch, while a texel fetch gathers whole
texels; the adaptive mesh's scan, fold check and cell tests read ~2.5-4x faster so. GPUs
fetch read-only texels at least as fast as they load buffers.

A table's texture only grows (rows to the next power of two), so that a warp whose mesh is a
little larger than the last one's does not reallocate it.
"""

from __future__ import annotations

from typing import Protocol

import moderngl
import numpy as np

__all__ = ["TABLE_SHIFT", "TABLE_WIDTH", "TableContext", "Tables", "table_rows"]

#: log2 of a table's width: its texture's width is ``TABLE_WIDTH`` (GL 4.3 allows 16384 at
#: least), so a table holds 8192 x GL_MAX_TEXTURE_SIZE items.
TABLE_SHIFT = 13
TABLE_WIDTH = 1 << TABLE_SHIFT

_DTYPES = {np.dtype(np.float32): "f4", np.dtype(np.uint32): "u4"}


class TableContext(Protocol):
    """What tables need of a :class:`~glmls.gl.context.GLContext` (not imported: the shader
    loader, which the context imports, takes :data:`TABLE_SHIFT` from here)."""

    @property
    def mgl(self) -> moderngl.Context: ...

    @property
    def limits(self) -> dict[str, int]: ...


def table_rows(count: int) -> int:
    """The texture rows that ``count`` items fill (1 at least)."""
    return max(1, -(-int(count) // TABLE_WIDTH))


class Tables:
    """The tables of one owner on ``gl``, one texture per role; :meth:`release` frees them."""

    def __init__(self, gl: TableContext) -> None:
        self._gl = gl
        self._textures: dict[str, moderngl.Texture] = {}
        self._staging: moderngl.Buffer | None = None

    def _texture(self, role: str, count: int, components: int, dtype: str) -> moderngl.Texture:
        """The texture of ``role`` with room for ``count`` items (made again, larger, when
        it has fewer rows or another format)."""
        rows = table_rows(count)
        limit = self._gl.limits["max_texture_size"]
        if rows > limit:
            raise ValueError(
                f"{role}: {count:,} items do not fit a table of this GL ({limit} rows of "
                f"{TABLE_WIDTH}): use a smaller image or a larger tolerance"
            )
        texture = self._textures.get(role)
        if (
            texture is not None
            and texture.height >= rows
            and (texture.components, texture.dtype) == (components, dtype)
        ):
            return texture
        if texture is not None:
            texture.release()
        height = min(limit, 1 << (rows - 1).bit_length())
        texture = self._gl.mgl.texture((TABLE_WIDTH, height), components, dtype=dtype)
        texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self._textures[role] = texture
        return texture

    def write(self, role: str, data: np.ndarray, unit: int | None) -> None:
        """Items ``data`` ((N, C) float32 or uint32, C in 1, 2, 4; C-contiguous) into the
        table ``role``, bound to texture ``unit`` (None: not bound; :meth:`bind_image`)."""
        data = np.asarray(data)
        if data.ndim != 2 or data.shape[1] not in (1, 2, 4) or data.dtype not in _DTYPES:
            raise ValueError(
                f"{role}: a table takes (N, 1, 2 or 4) float32 or uint32 items, got "
                f"{data.shape} {data.dtype}"
            )
        count, components = data.shape
        texture = self._texture(role, count, components, _DTYPES[data.dtype])
        full = count // TABLE_WIDTH
        data = np.ascontiguousarray(data)
        if full:
            texture.write(data[: full * TABLE_WIDTH], viewport=(0, 0, TABLE_WIDTH, full))
        if count > full * TABLE_WIDTH:
            rest = data[full * TABLE_WIDTH :]
            texture.write(rest, viewport=(0, full, len(rest), 1))
        if unit is not None:
            texture.use(unit)

    def copy(
        self,
        role: str,
        source: moderngl.Buffer,
        items: tuple[int, int],
        components: int,
        unit: int,
    ) -> None:
        """Items ``items`` = (first, end) of the float32 array in ``source`` (``components``
        per item, from byte 0) into the same places of the table ``role`` (whose earlier
        items it keeps, where the texture did not have to grow), by GPU-side copies; the
        table bound to texture ``unit``. The rows copied are whole: ``source`` must hold
        them (:func:`table_rows` of ``end``)."""
        first, end = items
        rows = table_rows(end)
        grown = self._textures.get(role)
        texture = self._texture(role, end, components, "f4")
        if texture is not grown:
            first = 0  # a new texture: everything
        row_bytes = TABLE_WIDTH * components * 4
        if source.size < rows * row_bytes:
            raise ValueError(f"{role}: the buffer holds fewer than {rows} rows")
        if end > first:  # nothing new: no copies
            top = first // TABLE_WIDTH
            # a pixel unpack from a buffer reads from its start: the rows go through a
            # staging buffer unless they start there
            if top:
                size = (rows - top) * row_bytes
                if self._staging is None or self._staging.size < size:
                    if self._staging is not None:
                        self._staging.release()
                    self._staging = self._gl.mgl.buffer(reserve=max(size, 2 * row_bytes))
                mgl = self._gl.mgl
                mgl.copy_buffer(self._staging, source, size=size, read_offset=top * row_bytes)
                source = self._staging
            texture.write(source, viewport=(0, top, TABLE_WIDTH, rows - top))
        texture.use(unit)

    def bind(self, role: str, unit: int) -> None:
        """Bind the table ``role`` (written before) to texture ``unit`` again."""
        self._textures[role].use(unit)

    def bind_image(self, role: str, unit: int) -> None:
        """Bind the one-component uint32 table ``role`` (written before) to image ``unit`` as
        r32ui, read-only (``common/table.glsl``'s ``TABLE_LOAD``): where a shader reads
        words of it at random, llvmpipe loads an image's texels in about half the time of
        a texel fetch."""
        texture = self._textures[role]
        if (texture.components, texture.dtype) != (1, "u4"):
            raise ValueError(f"{role}: an image binding takes a table of single uint32 items")
        texture.bind_to_image(unit, read=True, write=False)

    def release(self) -> None:
        """Free the textures (idempotent)."""
        for texture in self._textures.values():
            texture.release()
        self._textures.clear()
        if self._staging is not None:
            self._staging.release()
            self._staging = None
