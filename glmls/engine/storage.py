"""Where the handles live on the GPU: a storage buffer, a uniform block or a texture.

Every storage is a shader file (``glmls/shaders/mls/handles_<name>.glsl``, chosen by the
``MLS_STORAGE`` define) defining ``int mls_handle_count()`` and ``vec4 mls_handle(int i)`` (the
handle as ``(p.x, p.y, q.x, q.y)``, scaled) plus the GL object behind it. They differ in how many
handles fit and how fast a shader reads them (:doc:`/handles` has the measurements):

========== ============================ ====================== ==========================
storage     GL object                    guaranteed by GL 4.3    llvmpipe (this driver)
========== ============================ ====================== ==========================
``ssbo``    std430 shader storage buffer 16 MB: 1,048,576       128 MB: 8,388,608
``ubo``     std140 uniform block         16 KB: 1,024           64 KB: 4,096
``texture`` RGBA32F 2D texture           16384² texels           16384² texels
========== ============================ ====================== ==========================
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Protocol

import moderngl
import numpy as np

from ..gl import bindings
from ..gl.dispatch import set_uniforms

#: The storages; a storage's index is its ``MLS_STORAGE`` code in the shaders.
STORAGES = ("ssbo", "ubo", "texture")
#: Handle counts up to which buffer storages compile the evaluation unrolled (MLS_UNROLL in
#: glmls/shaders/mls/visit.glsl): constant indices let llvmpipe load each handle once for all lanes.
UNROLL_SLOTS = (16, 64)


class HandleStorage(Protocol):
    """How the handles reach the shaders. ``name`` is one of :data:`STORAGES`; ``defines``
    what the shaders need compiled in (``MLS_STORAGE`` and the storage's own); ``capacity``
    the most handles it takes on this context; ``unrolls`` whether reading at constant indices
    pays (``MLS_UNROLL``)."""

    name: str
    count: int
    segments: int
    segment_offset: int
    unrolls: bool

    @property
    def defines(self) -> Mapping[str, int | bool]: ...
    @property
    def capacity(self) -> int: ...
    def upload(self, packed: np.ndarray, segments: np.ndarray | None = None) -> None: ...
    def bind(self, program: moderngl.ComputeShader | moderngl.Program) -> None: ...
    def release(self) -> None: ...


def _as_packed(packed: np.ndarray | None) -> np.ndarray:
    if packed is None:
        return np.zeros((0, 4), np.float32)
    packed = np.ascontiguousarray(packed, dtype=np.float32)
    if packed.ndim != 2 or packed.shape[1] != 4:
        raise ValueError(f"packed handles must be (N, 4) float32, got shape {packed.shape}")
    return packed


def _rows(
    packed: np.ndarray, segments: np.ndarray | None, pad: bool
) -> tuple[np.ndarray, int, int, int]:
    """The storage's rows: the point handles (followed, where ``pad``, by zero rows up to the
    unrolled slots: empty slots read zeros), then two rows per segment handle
    (``glmls/shaders/mls/segments.glsl``); the index of the first segment row, and the counts
    of point and segment handles."""
    points = _as_packed(packed)
    segment_rows = _as_packed(segments)
    offset = max(unroll_slots(len(points)), len(points)) if pad else len(points)
    data = np.zeros((max(offset + len(segment_rows), 1), 4), np.float32)
    data[: len(points)] = points
    data[offset : offset + len(segment_rows)] = segment_rows
    return data, offset, len(points), len(segment_rows) // 2


def stored_rows(name: str, points: int, segment_rows: int) -> int:
    """The rows storage ``name`` (or ``"auto"``: a buffer's) holds for ``points`` point
    handles and ``segment_rows`` segment rows: the buffers pad the point handles to the
    unrolled slots before the segments (:func:`_rows`), the texture does not."""
    if name == "texture":
        return points + segment_rows
    return max(unroll_slots(points), points) + segment_rows


def capacities(ctx: moderngl.Context) -> dict[str, int]:
    """The rows each of :data:`STORAGES` holds on ``ctx``'s driver."""
    info = ctx.info
    return {
        "ssbo": int(info["GL_MAX_SHADER_STORAGE_BLOCK_SIZE"]) // 16,
        "ubo": int(info["GL_MAX_UNIFORM_BLOCK_SIZE"]) // 16,
        "texture": int(info["GL_MAX_TEXTURE_SIZE"]) ** 2,
    }


def capacity_advice(ctx: moderngl.Context, name: str, rows: int) -> str:
    """What to do where ``rows`` exceed storage ``name``'s capacity: the storage that holds
    them on this driver, else fewer handles."""
    held = capacities(ctx)
    roomy = [other for other in STORAGES if other != name and held[other] >= rows]
    if roomy:
        return f"use storage={max(roomy, key=held.__getitem__)!r}"
    return f"use fewer handles (every storage holds at most {max(held.values())} rows here)"


def _check_capacity(ctx: moderngl.Context, name: str, count: int, capacity: int) -> None:
    if count > capacity:
        raise ValueError(
            f"{count} rows of handles exceed the {name} handle storage's capacity of "
            f"{capacity} rows on this GL driver; {capacity_advice(ctx, name, count)}"
        )


def unroll_slots(count: int) -> int:
    """The MLS_UNROLL slots for ``count`` handles: the smallest of :data:`UNROLL_SLOTS` that
    holds them, or 0 (a loop) for more."""
    return next((slots for slots in UNROLL_SLOTS if count <= slots), 0)


class _BufferStorage:
    """Shared by the buffer-backed storages: one buffer, grown as needed, never shrunk."""

    name = ""

    def __init__(self, ctx: moderngl.Context) -> None:
        self._ctx = ctx
        self._buffer: moderngl.Buffer | None = None
        self.count = 0
        self.segments = 0
        self.segment_offset = 0

    #: The handles may be read at constant indices (MLS_UNROLL).
    unrolls = True

    @property
    def defines(self) -> Mapping[str, int | bool]:
        return {"MLS_STORAGE": STORAGES.index(self.name)}

    def _write(self, data: bytes, needed: int) -> None:
        if self._buffer is None or self._buffer.size < needed:
            if self._buffer is not None:
                self._buffer.release()
            self._buffer = self._ctx.buffer(reserve=needed)
        if data:
            self._buffer.write(data)

    def _fill(self, packed: np.ndarray, segments: np.ndarray | None, reserve: int | None) -> None:
        rows, offset, count, segment_count = _rows(packed, segments, pad=True)
        _check_capacity(self._ctx, self.name, len(rows), self.capacity)
        data = rows.tobytes()
        self._write(data, reserve if reserve is not None else len(data))
        self.count, self.segments, self.segment_offset = count, segment_count, offset

    def _bind_count(self, program: moderngl.ComputeShader | moderngl.Program) -> None:
        if self._buffer is None:
            raise RuntimeError("handles were not uploaded")
        set_uniforms(program, _count_uniforms(self))

    def release(self) -> None:
        if self._buffer is not None:
            self._buffer.release()
            self._buffer = None


class SSBOHandleStorage(_BufferStorage):
    """Handles in a std430 shader storage buffer of vec4 (binding ``HANDLES``)."""

    name = "ssbo"

    @property
    def capacity(self) -> int:
        return capacities(self._ctx)["ssbo"]

    def upload(self, packed: np.ndarray, segments: np.ndarray | None = None) -> None:
        self._fill(packed, segments, None)

    def bind(self, program: moderngl.ComputeShader | moderngl.Program) -> None:
        self._bind_count(program)
        self._buffer.bind_to_storage_buffer(bindings.HANDLES.index)  # type: ignore[union-attr]


class UBOHandleStorage(_BufferStorage):
    """Handles in a std140 uniform block of vec4 (binding ``HANDLES_BLOCK``), as long as the
    driver allows (``GL_MAX_UNIFORM_BLOCK_SIZE``; the bound buffer always has the block's full
    length)."""

    name = "ubo"

    @property
    def capacity(self) -> int:
        return capacities(self._ctx)["ubo"]

    @property
    def defines(self) -> Mapping[str, int | bool]:
        return {"MLS_STORAGE": STORAGES.index(self.name), "MLS_UBO_CAPACITY": self.capacity}

    def upload(self, packed: np.ndarray, segments: np.ndarray | None = None) -> None:
        self._fill(packed, segments, 16 * self.capacity)

    def bind(self, program: moderngl.ComputeShader | moderngl.Program) -> None:
        self._bind_count(program)
        self._buffer.bind_to_uniform_block(bindings.HANDLES_BLOCK.index)  # type: ignore[union-attr]


class TextureHandleStorage:
    """Handles in an RGBA32F 2D texture, row by row, on texture unit ``HANDLE_TEXTURE``
    (always read in a loop: a texel fetch gathers per lane whatever its index)."""

    name = "texture"
    unrolls = False

    def __init__(self, ctx: moderngl.Context) -> None:
        self._ctx = ctx
        self._texture: moderngl.Texture | None = None
        self._width = 1
        self.count = 0
        self.segments = 0
        self.segment_offset = 0

    @property
    def defines(self) -> Mapping[str, int | bool]:
        return {"MLS_STORAGE": STORAGES.index(self.name)}

    @property
    def capacity(self) -> int:
        return capacities(self._ctx)["texture"]

    def upload(self, packed: np.ndarray, segments: np.ndarray | None = None) -> None:
        handles, offset, count, segment_count = _rows(packed, segments, pad=False)
        _check_capacity(self._ctx, "texture", len(handles), self.capacity)
        side = int(self._ctx.info["GL_MAX_TEXTURE_SIZE"])
        width = max(1, min(len(handles), side))
        rows = max(1, -(-len(handles) // width))
        data = np.zeros((rows * width, 4), np.float32)
        data[: len(handles)] = handles
        if self._texture is None or self._texture.size != (width, rows):
            if self._texture is not None:
                self._texture.release()
            self._texture = self._ctx.texture((width, rows), 4, dtype="f4")
            self._texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self._texture.write(data.tobytes())
        self._width = width
        self.count, self.segments, self.segment_offset = count, segment_count, offset

    def bind(self, program: moderngl.ComputeShader | moderngl.Program) -> None:
        if self._texture is None:
            raise RuntimeError("handles were not uploaded")
        self._texture.use(bindings.HANDLE_TEXTURE.index)
        set_uniforms(program, _count_uniforms(self) | {"u_handle_width": self._width})

    def release(self) -> None:
        if self._texture is not None:
            self._texture.release()
            self._texture = None


def _count_uniforms(storage: HandleStorage) -> dict[str, int]:
    return {
        "u_handle_count": storage.count,
        "u_segment_count": storage.segments,
        "u_segment_offset": storage.segment_offset,
    }


_CLASSES = {"ssbo": SSBOHandleStorage, "ubo": UBOHandleStorage, "texture": TextureHandleStorage}


def check_storage(storage: object) -> str:
    """``storage`` if it names a storage or ``"auto"``; ``TypeError``/``ValueError`` otherwise."""
    choices = ("auto", *STORAGES)
    if not isinstance(storage, str):
        raise TypeError(f"storage must be a string, one of {', '.join(choices)}; got {storage!r}")
    if storage not in choices:
        raise ValueError(f"unknown storage {storage!r}; choose one of {', '.join(choices)}")
    return storage


def resolve_storage(
    storage: str, ctx: moderngl.Context, count: int, *, binned: bool = False
) -> str:
    """``count``: the rows of the handles as a buffer stores them (:func:`stored_rows`).
    ``"auto"``: the uniform block where the handles fit (the fastest on llvmpipe at every
    count it takes, :doc:`/handles`), else the texture for handles in bins (each lane reads
    its own handles: llvmpipe fetches texels 2x faster than it gathers from a storage
    buffer; 65,536 handles, R = 24 px), else the storage buffer; other names as they are."""
    if check_storage(storage) != "auto":
        return storage
    if count <= int(ctx.info["GL_MAX_UNIFORM_BLOCK_SIZE"]) // 16:
        return "ubo"
    return "texture" if binned else "ssbo"


def storage_for(
    request: str,
    ctx: moderngl.Context,
    points: int,
    segment_rows: int,
    *,
    binned: bool,
    current: HandleStorage | None,
) -> HandleStorage:
    """The storage that holds ``points`` point handles and ``segment_rows`` segment rows as
    ``request`` asks (``auto``: :func:`resolve_storage`): ``current`` where it is of that
    kind, else a new one; ``ValueError`` naming the handles, the rows and the padding where
    they do not fit (a new storage released first), before anything of them is uploaded."""
    padded = stored_rows("auto", points, segment_rows)
    name = resolve_storage(request, ctx, padded, binned=binned)
    rows = stored_rows(name, points, segment_rows)
    storage = current if current is not None and current.name == name else make_storage(name, ctx)
    if rows <= storage.capacity:
        return storage
    capacity = storage.capacity
    if storage is not current:
        storage.release()
    lines = segment_rows // 2
    what = f"{points} handle{'s' * (points != 1)}" + (
        f" and {lines} segment{'s' * (lines != 1)} (2 rows each)" if lines else ""
    )
    padding = rows - points - segment_rows
    held = f" ({padding} rows of padding after the points)" if padding else ""
    raise ValueError(
        f"{what} exceed the {name} handle storage's capacity of {capacity} rows on this GL "
        f"driver{held}; {capacity_advice(ctx, name, rows)}"
    )


def make_storage(storage: str, ctx: moderngl.Context) -> HandleStorage:
    """A new, empty handle storage of kind ``storage`` (one of :data:`STORAGES`)."""
    if check_storage(storage) == "auto":
        raise ValueError("resolve 'auto' with resolve_storage() first: it depends on the count")
    return _CLASSES[storage](ctx)
