"""The GPU pipeline that builds deformed images: mesh on the GPU, then the quads are filled.

One :class:`WarpPipeline` per GL context serves :meth:`glmls.MLS.warp`, the CLI and a window:
the handles (an :class:`~glmls.MLS`) are the only thing that changes between frames, every
other GL object is cached by size and reused. Stages never read back in between:

1. ``mls_points.comp.glsl`` (MLS_MESH) writes f at the mesh vertices into a buffer;
2. quads: ``warp_cells.comp.glsl`` scan-converts every deformed cell in a compute shader,
   keeping per pixel the key of the top triangle (atomicMax), then the pixels are filled
   from that triangle (see :meth:`WarpPipeline._draw_cells`: nearest colours of 8-bit images
   are written by the scan conversion itself, fold-overs fixed up after). This is the
   rasterizer's job without its per-triangle setup (~0.25 us per triangle on llvmpipe: 0.5 s
   for the 2 million triangles of a 1024^2 image at grid 1). It needs a viewport of the
   image's size (``warp``, and ``render`` into such a viewport); other viewports (a window
   scaling the image), keys too long for 32 bits and ``COMPUTE_QUADS = False`` use the GL
   rasterizer:
   ``warp_mesh.vert.glsl`` draws the buffer as triangles (or points, for ``splat``) and
   ``warp_mesh.frag.glsl`` samples the source texture at the interpolated source point;
3. ``backward``: the same draw writes the source point instead (a first guess of f⁻¹),
   ``mls_inverse.comp.glsl`` refines it by Newton's method, and ``warp_backward.frag.glsl``
   samples the source there.

:meth:`WarpPipeline.render` draws into any framebuffer (a window's, without read-back);
:meth:`WarpPipeline.warp` and :meth:`WarpPipeline.coordinate_map` are the numpy front ends.

Fold-overs: quads are drawn in one draw call in row-major order of their source cells, and
OpenGL writes the fragments of later primitives over those of earlier ones, so where deformed
quads overlap the cell with the larger source row (then column) is on top. The compute scan
conversion keeps the same order with keys (row, column, triangle) and atomicMax, so its result
does not depend on the order its invocations run in. ``splat`` and the first guess of
``backward`` follow the same rule, so the three agree on folds.

uint8 images stay 8-bit: RGBA8 source texture (sampled as value / 255), RGBA8 target, uint8
read-back (:attr:`SourceImage.normalized`).
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Iterator
from dataclasses import dataclass
from typing import TYPE_CHECKING

import moderngl
import numpy as np

from .context import GLContext, current, get_context
from .errors import ReleasedError
from .handles import pack_handles
from .storage import HandleStorage, make_storage

if TYPE_CHECKING:
    from .mls import MLS

METHODS = ("quads", "splat", "backward", "backward-swap")
INTERPOLATIONS = ("nearest", "linear")
DTYPES = (np.uint8, np.uint16, np.float32, np.float64)

#: Newton on f stops below this residual |f(s) - u| (pixels) ...
NEWTON_TOLERANCE = 1e-3
#: ... or after this many steps; a pixel whose residual stays above NEWTON_ACCEPT (pixels) is
#: left uncovered (no source point found).
NEWTON_STEPS = 8
NEWTON_ACCEPT = 0.05
#: Largest mesh buffer (bytes) of one band; bigger meshes are evaluated band by band.
BAND_BYTES = 1 << 26
_LOCAL_SIZE = 64
_MESH_BINDING = 2
_WINNER_BINDING = 4
_PACKED_SOURCE_BINDING = 5
_PACKED_TARGET_BINDING = 6
_FIXUPS_BINDING = 7
_FIXUP_DISPATCH_BINDING = 8
_CHECK_BINDING = 9
_MESH_UNIT = 2  # texture units of the resolve (the source is on 0)
_WINNER_UNIT = 3
#: Scan-convert quads in a compute shader (False: the GL rasterizer draws 2 triangles per cell).
COMPUTE_QUADS = True
#: Fused nearest quads: first the fast pass without keys, redone with keys only where the
#: mesh is not shown to be an embedding (warp_cells_check.comp.glsl).
FAST_EMBEDDED = True
#: Capacity of the fix-up list of the fused nearest quads (pixels where triangles overlap,
#: see _draw_cells): one pixel in FIXUP_FRACTION, at least FIXUP_MIN. Beyond it (heavy
#: fold-overs) the fix-up pass redoes every pixel instead: slower, same result.
FIXUP_MIN = 4096
FIXUP_FRACTION = 8


@dataclass(frozen=True)
class SourceImage:
    """An image prepared for the GPU: float32 (H, W, C) raw values plus what to restore."""

    data: np.ndarray
    dtype: np.dtype
    squeeze: bool  # the input was (H, W)
    #: ``data`` is the uint8 image itself: uploaded as an 8-bit texture (sampled as value /
    #: 255), drawn into an 8-bit target and read back as uint8 (4x less to convert, upload,
    #: clear and read than float32).
    normalized: bool = False

    @property
    def shape(self) -> tuple[int, int]:
        return self.data.shape[0], self.data.shape[1]

    @property
    def channels(self) -> int:
        return self.data.shape[2]

    def restore(self, values: np.ndarray) -> np.ndarray:
        """float32 (H, W, C) (uint8 if ``normalized``) back to the input's dtype and shape."""
        if self.normalized:
            out = np.ascontiguousarray(values)
            return out[..., 0] if self.squeeze else out
        if np.issubdtype(self.dtype, np.integer):
            top = np.iinfo(self.dtype).max
            values = np.clip(np.rint(values), 0, top)
        out = values.astype(self.dtype)
        return out[..., 0] if self.squeeze else out


def prepare_image(image: object, max_size: int, *, normalized: bool = False) -> SourceImage:
    """Validate an image (H x W or H x W x C, C in 1..4) and convert it to float32, or with
    ``normalized`` keep a uint8 image as it is (see :attr:`SourceImage.normalized`)."""
    array = np.asarray(image)
    if array.dtype not in DTYPES:
        names = ", ".join(np.dtype(d).name for d in DTYPES)
        raise TypeError(f"image dtype must be one of {names}; got {array.dtype}")
    if array.ndim not in (2, 3) or (array.ndim == 3 and not 1 <= array.shape[2] <= 4):
        raise ValueError(f"image must be H x W or H x W x C with C in 1..4, got {array.shape}")
    if array.size == 0:
        raise ValueError(f"image is empty: shape {array.shape}")
    height, width = array.shape[:2]
    if max(height, width) > max_size:
        raise ValueError(
            f"image of {height} x {width} pixels exceeds the GL texture size limit of "
            f"{max_size} pixels per side on this device; split it or scale it down"
        )
    squeeze = array.ndim == 2
    if normalized and array.dtype == np.uint8:
        return SourceImage(
            np.ascontiguousarray(array.reshape(height, width, -1)), array.dtype, squeeze, True
        )
    data = np.ascontiguousarray(array.reshape(height, width, -1), dtype=np.float32)
    return SourceImage(data, array.dtype, squeeze)


def background_color(background: object, image: SourceImage) -> tuple[float, float, float, float]:
    """The clear colour: ``background`` per channel, and alpha 0 for images with alpha.

    ``background`` is a scalar (every colour channel), or one value per channel (C values,
    alpha included, or C - 1 for an image with alpha, whose alpha is then 0).
    """
    channels = image.channels
    has_alpha = channels in (2, 4)
    values = np.asarray(background, dtype=object)
    if values.ndim == 0:
        values = np.array([background] * (channels - has_alpha), dtype=object)
    if values.ndim != 1 or len(values) not in (channels, channels - has_alpha):
        raise ValueError(
            f"background must be a scalar or {channels} values (one per channel)"
            + (f" or {channels - 1} (colour only)" if has_alpha else "")
            + f", got {background!r}"
        )
    out = []
    for value in values:
        if isinstance(value, (bool, np.bool_)) or not isinstance(
            value, (int, float, np.integer, np.floating)
        ):
            raise TypeError(f"background values must be real numbers, got {background!r}")
        out.append(float(value))
    if np.issubdtype(image.dtype, np.integer):
        top = np.iinfo(image.dtype).max
        if not all(0 <= v <= top for v in out):
            raise ValueError(f"background {background!r} is outside 0..{top} of {image.dtype}")
    if image.normalized:
        out = [v / 255.0 for v in out]
    if len(out) < channels:
        out.append(0.0)  # transparent where nothing is drawn
    return (*out, *[0.0] * (4 - len(out)))  # type: ignore[return-value]


def check_options(method: object, interpolation: object, grid: object) -> None:
    for name, value, choices in (
        ("method", method, METHODS),
        ("interpolation", interpolation, INTERPOLATIONS),
    ):
        if not isinstance(value, str) or value not in choices:
            raise ValueError(f"unknown {name} {value!r}; choose one of {', '.join(choices)}")
    if isinstance(grid, bool) or not isinstance(grid, (int, np.integer)) or grid < 1:
        raise ValueError(f"grid must be an integer >= 1 (pixels), got {grid!r}")


def cell_key_layout(
    shape: tuple[int, int], grid: int, *, source_pixel: bool
) -> tuple[int, int, int] | None:
    """Bit layout of warp_cells.comp.glsl's triangle keys, (sub bits, column shift, row shift),
    or None where a key would not fit in 31 bits (the rasterizer draws those meshes).

    A key is cell row, cell column, triangle and, with ``source_pixel``, the chosen source
    pixel's column and row inside the cell (``sub bits`` each), most significant first: keys
    order triangles as one draw call in row-major cell order would (later ones on top).
    """
    height, width = shape
    rows, columns = math.ceil(height / grid), math.ceil(width / grid)
    sub_bits = (grid - 1).bit_length() if source_pixel else 0
    col_shift = 1 + 2 * sub_bits
    row_shift = col_shift + (columns - 1).bit_length()
    if row_shift + (rows - 1).bit_length() > 31:
        return None
    return sub_bits, col_shift, row_shift


def _as_rgba8(data: np.ndarray) -> np.ndarray:
    """(H, W, C) uint8 as (H, W, 4), channels filled as GL fills them when sampling."""
    if data.shape[2] == 4:
        return data
    flat = data.reshape(-1, data.shape[2])
    out = np.zeros((flat.shape[0], 4), np.uint8)
    out[:, 3] = 255
    for channel in range(data.shape[2]):  # one strided copy per channel: 4x faster here
        out[:, channel] = flat[:, channel]
    return out.reshape(*data.shape[:2], 4)


def _packable(source: moderngl.Texture, target: object) -> bool:
    """Can the fused nearest path write ``target``: RGBA8 textures of one size."""
    return (
        isinstance(target, moderngl.Texture)
        and target.size == source.size
        and (source.components, source.dtype) == (4, "f1")
        and (target.components, target.dtype) == (4, "f1")
    )


def _corner_mesh_dims(shape: tuple[int, int], grid: int) -> tuple[int, int]:
    """Vertices per row and rows of the mesh of pixel-square corners at step ``grid``."""
    height, width = shape
    return math.ceil(width / grid) + 1, math.ceil(height / grid) + 1


def _rows_per_band(nx: int, *, indexed: bool) -> int:
    """Mesh rows of ``nx`` vertices per band: the mesh buffer within BAND_BYTES and, where
    ``indexed`` (the GL rasterizer's quads), the index buffer too (6 uint32 per cell)."""
    rows = max(2, BAND_BYTES // (8 * nx))
    if indexed:
        rows = max(2, min(rows, BAND_BYTES // (24 * (nx - 1)) + 1))
    return rows


def _set_uniforms(program, values: dict[str, object]) -> None:
    """Set those of ``values`` the program uses (the compiler drops unused uniforms)."""
    for name, value in values.items():
        if name in program:
            program[name].value = value


def _use_texture(texture: moderngl.Texture, unit: int, linear: bool) -> None:
    mode = moderngl.LINEAR if linear else moderngl.NEAREST
    texture.filter = (mode, mode)
    texture.use(unit)


class WarpPipeline:
    """Cached GL objects and the passes that turn handles and a source texture into an image.

    Textures and framebuffers are kept for the last size of each role and replaced when the
    size changes; buffers only grow (up to :data:`BAND_BYTES`). :meth:`release` frees them all;
    the compiled programs belong to the :class:`~glmls.GLContext` and are shared.
    """

    def __init__(self, ctx: moderngl.Context | GLContext | None = None) -> None:
        self._gl = get_context(ctx)
        self._textures: dict[str, tuple[tuple, moderngl.Texture]] = {}
        self._framebuffers: dict[str, tuple[int, moderngl.Framebuffer]] = {}
        self._buffers: dict[str, moderngl.Buffer] = {}
        self._vaos: dict[tuple, moderngl.VertexArray] = {}
        self._index_dims = (0, 0)
        self._swap: HandleStorage | None = None  # the swapped handles (backward-swap)
        self._released = False

    @property
    def ctx(self) -> GLContext:
        return self._gl

    @property
    def max_image_size(self) -> int:
        """Largest image side this context can warp (the GL texture and viewport limit)."""
        info = self._gl.mgl.info
        return min(int(info["GL_MAX_TEXTURE_SIZE"]), *map(int, info["GL_MAX_VIEWPORT_DIMS"]))

    @contextlib.contextmanager
    def _keep_framebuffer(self) -> Iterator[None]:
        """Leave the bound framebuffer as found: moderngl re-binds the bound one when it
        creates another, and binding one of ours after we released it is a GL error."""
        mgl = self._gl.mgl
        bound = mgl.fbo
        if bound is None:  # a standalone context starts with none: framebuffer 0
            bound = mgl.detect_framebuffer(0)
        try:
            yield
        finally:
            bound.use()

    # -- cached GL objects --------------------------------------------------------------

    def _check_alive(self) -> None:
        if self._released:
            raise ReleasedError("this warp pipeline has been released")

    def _texture(
        self, role: str, size: tuple[int, int], components: int, dtype: str = "f4"
    ) -> moderngl.Texture:
        key = (size, components, dtype)
        cached = self._textures.get(role)
        if cached is not None and cached[0] == key:
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
        texture.release()

    def _framebuffer(
        self, role: str, size: tuple[int, int], dtype: str = "f4"
    ) -> moderngl.Framebuffer:
        """A framebuffer around the RGBA texture ``role`` of ``size`` (RGBA32F, or RGBA8
        for ``dtype="f1"``)."""
        texture = self._texture(role, size, 4, dtype)
        cached = self._framebuffers.get(role)
        if cached is not None and cached[0] == texture.glo:
            return cached[1]
        framebuffer = self._gl.mgl.framebuffer(color_attachments=[texture])
        self._framebuffers[role] = (texture.glo, framebuffer)
        return framebuffer

    def _buffer(self, name: str, nbytes: int) -> moderngl.Buffer:
        buffer = self._buffers.get(name)
        if buffer is None or buffer.size < nbytes:
            if buffer is not None:
                buffer.release()
            buffer = self._buffers[name] = self._gl.mgl.buffer(reserve=max(nbytes, 16))
        return buffer

    def _vao(self, program: moderngl.Program, index: moderngl.Buffer | None = None):
        """An attribute-less vertex array: the shaders index their data by gl_VertexID."""
        key = (program.glo, None if index is None else index.glo)
        vao = self._vaos.get(key)
        if vao is None:
            if index is None:
                vao = self._gl.mgl.vertex_array(program, [])
            else:
                vao = self._gl.mgl.vertex_array(program, [], index_buffer=index)
            self._vaos[key] = vao
        return vao

    def _index_buffer(self, nx: int, rows: int) -> moderngl.Buffer:
        """Triangles (00, 10, 11), (00, 11, 01) of each cell of a band of ``rows`` rows of
        ``nx`` vertices, row-major; a shorter band draws a prefix of it."""
        cached = self._buffers.get("index")
        if cached is not None and self._index_dims[0] == nx and self._index_dims[1] >= rows:
            return cached
        i = np.arange(nx * rows, dtype=np.uint32).reshape(rows, nx)
        a, b, c, d = i[:-1, :-1], i[:-1, 1:], i[1:, 1:], i[1:, :-1]
        triangles = np.stack([a, b, c, a, c, d], axis=-1)
        if cached is not None:
            for key in [k for k in self._vaos if k[1] == cached.glo]:
                self._vaos.pop(key).release()
            cached.release()
        self._buffers["index"] = self._gl.mgl.buffer(triangles.tobytes())
        self._index_dims = (nx, rows)
        return self._buffers["index"]

    @current
    def release(self) -> None:
        """Free every cached texture, framebuffer, buffer and vertex array. Idempotent."""
        if self._released:
            return
        for role in list(self._textures):
            self._drop_texture(role)
        for _, framebuffer in self._framebuffers.values():
            framebuffer.release()
        for obj in [*self._buffers.values(), *self._vaos.values()]:
            obj.release()
        self._framebuffers.clear()
        self._buffers.clear()
        self._vaos.clear()
        if self._swap is not None:
            self._swap.release()
            self._swap = None
        self._released = True

    # -- passes -------------------------------------------------------------------------

    @current
    def upload(self, image: SourceImage, role: str = "source") -> moderngl.Texture:
        """The source texture holding ``image``'s raw float32 values (8-bit normalized ones
        for a ``normalized`` image)."""
        self._check_alive()
        height, width = image.shape
        if image.normalized:
            # RGBA8 whatever the channels, as GL samples fewer (missing: 0, alpha: 1): texels
            # of one uint32 let the nearest resolve copy them whole (_draw_cells).
            texture = self._texture(role, (width, height), 4, "f1")
            texture.write(_as_rgba8(image.data))
            return texture
        texture = self._texture(role, (width, height), image.channels, "f4")
        texture.write(image.data)
        return texture

    def _dispatch(self, program: moderngl.ComputeShader, count: int) -> None:
        max_groups = self._gl.limits["max_work_groups_x"]
        groups = math.ceil(count / _LOCAL_SIZE)
        for first in range(0, groups, max_groups):
            program["u_offset"].value = first * _LOCAL_SIZE
            program.run(group_x=min(max_groups, groups - first))

    def _mesh_bands(
        self, mls: MLS, shape: tuple[int, int], grid: int, *, centres: bool, indexed: bool = True
    ):
        """Evaluate f on the mesh band by band into the mesh buffer; yields (first row, dims).

        ``centres``: the pixel centres (splat); else the pixel-square corners at step ``grid``.
        Quad bands overlap by one row of vertices (computed identically in both). ``indexed``:
        bands also small enough for the GL rasterizer's index buffer (6 indices per cell).
        """
        height, width = shape
        if centres:
            origin, step, last = (0.0, 0.0), 1, (width - 1.0, height - 1.0)
            nx, ny, overlap = width, height, 0
        else:
            origin, step = (-0.5, -0.5), grid
            last = (width - 0.5, height - 0.5)
            (nx, ny), overlap = _corner_mesh_dims(shape, grid), 1
        rows_per_band = _rows_per_band(nx, indexed=indexed and not centres)
        program = mls._program(mesh=True, with_matrix=False)
        mls._set_uniforms(program, shape)
        sc = mls.scaling
        program["u_mesh_origin"].value = tuple(sc.to_gpu(np.array([origin]))[0])
        program["u_mesh_step"].value = (step / sc.scale, step / sc.scale)
        program["u_mesh_last"].value = tuple(sc.to_gpu(np.array([last]))[0])
        buffer = self._buffer("mesh", min(nx * ny, rows_per_band * nx) * 8)
        first = 0
        while True:
            rows = min(rows_per_band, ny - first)
            program["u_mesh_dims"].value = (nx, rows)
            program["u_mesh_first_row"].value = first
            program["u_count"].value = nx * rows
            buffer.bind_to_storage_buffer(_MESH_BINDING)
            # Draws issued before may still read the buffer (llvmpipe shades fragments
            # later, at a flush): order them before it is overwritten.
            self._gl.mgl.memory_barrier()
            self._dispatch(program, nx * rows)
            self._gl.mgl.memory_barrier()
            yield first, (nx, rows)
            first += rows - overlap
            if first + overlap >= ny:
                break

    def _draw_cells(
        self,
        mls: MLS,
        source: moderngl.Texture,
        shape: tuple[int, int],
        *,
        linear: bool,
        grid: int,
        coords: bool,
        flip_y: bool,
        target: object = None,
    ) -> bool:
        """``quads`` by compute-shader scan conversion (warp_cells.comp.glsl) into the bound
        framebuffer, whose viewport must be the target's size; False (nothing drawn) where
        the triangle keys do not fit in 32 bits.

        Three ways to fill the pixels, fastest first:

        - nearest, into an RGBA8 texture ``target`` from an RGBA8 source: the scan conversion
          writes the colours itself and warp_cells_fixup.comp.glsl corrects fold-overs; a
          mesh in one band is first drawn without keys or atomics and redrawn with them only
          where warp_cells_check.comp.glsl cannot show it is an embedding (``_scan_fast``);
        - nearest otherwise: the scan picks each pixel's source pixel, and a draw
          (warp_cells_nearest.frag.glsl) copies it;
        - linear or source points: warp_cells.frag.glsl interpolates the winning triangle;
          a mesh too big for one band is evaluated twice (coverage, then each band's pixels).
        """
        height, width = shape
        nearest = not linear and not coords
        layout = cell_key_layout(shape, grid, source_pixel=nearest)
        if layout is None:
            return False
        sub_bits, col_shift, row_shift = layout
        fused = nearest and not flip_y and _packable(source, target)
        sc = mls.scaling
        values = {
            "u_center": sc.center,
            "u_scale": sc.scale,
            "u_target_size": (width, height),
            "u_source_size": (width, height),
            "u_grid": grid,
            "u_sub_bits": sub_bits,
            "u_col_shift": col_shift,
            "u_row_shift": row_shift,
            "u_fixup_capacity": max(FIXUP_MIN, width * height // FIXUP_FRACTION),
        }
        # padded to whole uvec4s for the clear of warp_cells_check.comp.glsl
        winner = self._buffer("winner", (width * height + 3) // 4 * 16)
        fast = fused and FAST_EMBEDDED and self._one_band(shape, grid)
        if not fast:  # the fast path clears it on the GPU if and when it needs it
            winner.clear(size=width * height * 4)
        if fused:
            self._prepare_fused(source, target, values["u_fixup_capacity"])
        cells = self._cells_program(nearest=nearest, fused=fused, fast=False)
        _set_uniforms(cells, values)
        bands = 0
        for first, dims in self._mesh_bands(mls, shape, grid, centres=False, indexed=False):
            cells["u_mesh_dims"].value = dims
            cells["u_first_row"].value = first
            self._buffers["mesh"].bind_to_storage_buffer(_MESH_BINDING)
            winner.bind_to_storage_buffer(_WINNER_BINDING)
            if fused:
                self._bind_fused()
            if fast:
                self._scan_fast(cells, values | {"u_mesh_dims": dims, "u_first_row": first})
            else:
                self._dispatch(cells, (dims[0] - 1) * (dims[1] - 1))
            bands += 1
        self._gl.mgl.memory_barrier()
        if fused:
            self._fix_up(values, target)
        else:
            whole_mesh = dims if bands == 1 else None
            self._resolve(mls, source, values, linear, coords, flip_y, whole_mesh)
        return True

    def _cells_program(self, *, nearest: bool, fused: bool, fast: bool):
        return self._gl.compute(
            ("warp_cells_packed.glsl", "warp_cells.comp.glsl"),
            {"WARP_CELLS_SOURCE": nearest, "WARP_CELLS_FUSED": fused, "WARP_CELLS_FAST": fast},
        )

    @staticmethod
    def _one_band(shape: tuple[int, int], grid: int) -> bool:
        """Is the quads mesh of ``shape`` at ``grid`` evaluated in a single band?"""
        nx, ny = _corner_mesh_dims(shape, grid)
        return _rows_per_band(nx, indexed=False) >= ny

    def _scan_fast(self, keyed: moderngl.ComputeShader, values: dict[str, object]) -> None:
        """The fused scan of a whole mesh (one band): the pass without keys, the embedding
        test, and the keyed pass ``keyed`` (after a clear of the winner buffer) dispatched
        with zero work groups where the mesh is an embedding (warp_cells_check.comp.glsl)."""
        gl = self._gl
        parts = ("warp_cells_packed.glsl", "warp_cells_check.comp.glsl")
        stages = [gl.compute(parts, {"WARP_CHECK_STAGE": stage}) for stage in range(3)]
        fast = self._cells_program(nearest=True, fused=True, fast=True)
        for program in (fast, *stages):
            _set_uniforms(program, values)
        check = self._buffer("check", 48)
        check.clear(size=16)
        check.bind_to_storage_buffer(_CHECK_BINDING)
        nx, ny = values["u_mesh_dims"]
        stages[0].run(group_x=math.ceil((2 * (nx - 1) + 2 * (ny - 1)) / _LOCAL_SIZE))
        self._dispatch(fast, (nx - 1) * (ny - 1))
        gl.mgl.memory_barrier()
        stages[1].run(group_x=1)
        gl.mgl.memory_barrier()
        stages[2].run_indirect(check, offset=16)
        gl.mgl.memory_barrier()
        keyed["u_offset"].value = 0
        keyed.run_indirect(check, offset=32)

    def _prepare_fused(
        self, source: moderngl.Texture, target: moderngl.Texture, capacity: int
    ) -> None:
        """The packed buffers of warp_cells_packed.glsl: copies of the source and of the
        target (its background), and an empty fix-up list."""
        width, height = source.size
        source.read_into(self._buffer("packed source", width * height * 4))
        # one spare texel at the end: uncovered lanes of the scan write there
        target.read_into(self._buffer("packed target", (width * height + 1) * 4))
        self._buffer("fixups", 16 + 4 * capacity).clear(size=16)

    def _bind_fused(self) -> None:
        self._buffers["packed source"].bind_to_storage_buffer(_PACKED_SOURCE_BINDING)
        self._buffers["packed target"].bind_to_storage_buffer(_PACKED_TARGET_BINDING)
        self._buffers["fixups"].bind_to_storage_buffer(_FIXUPS_BINDING)

    def _fix_up(self, values: dict[str, object], target: moderngl.Texture) -> None:
        """warp_cells_fixup.comp.glsl over the listed pixels (an indirect dispatch sized on
        the GPU: no read-back), then the packed target back into the texture."""
        parts = ("warp_cells_packed.glsl", "warp_cells_key.glsl", "warp_cells_fixup.comp.glsl")
        args = self._gl.compute(parts, {"WARP_FIXUP_ARGS": True})
        fixup = self._gl.compute(parts, {"WARP_FIXUP_ARGS": False})
        dispatch = self._buffer("fixup dispatch", 16)
        self._bind_fused()
        self._buffers["winner"].bind_to_storage_buffer(_WINNER_BINDING)
        dispatch.bind_to_storage_buffer(_FIXUP_DISPATCH_BINDING)
        for program in (args, fixup):
            _set_uniforms(program, values)
        args.run(group_x=1)
        self._gl.mgl.memory_barrier()
        fixup.run_indirect(dispatch)
        self._gl.mgl.memory_barrier()
        target.write(self._buffers["packed target"])

    def _resolve(self, mls, source, values, linear, coords, flip_y, whole_mesh) -> None:
        """Fill the bound framebuffer from the winner buffer with full-viewport draws.
        ``whole_mesh``: the dims of the mesh still in the mesh buffer, None if it was done
        in bands (it is then evaluated again, band by band)."""
        nearest = not linear and not coords
        if nearest:
            program = self._gl.program(
                ("warp_fullscreen.vert.glsl",),
                ("warp_target.glsl", "warp_cells_key.glsl", "warp_cells_nearest.frag.glsl"),
            )
        else:
            program = self._gl.program(
                ("warp_fullscreen.vert.glsl",),
                ("warp_target.glsl", "warp_sample.glsl", "warp_cells.frag.glsl"),
                {"WARP_LINEAR": linear, "WARP_OUTPUT_COORDS": coords},
            )
        units = {"u_source": 0, "u_mesh": _MESH_UNIT, "u_winner": _WINNER_UNIT}
        _set_uniforms(program, values | units | {"u_flip_y": flip_y})
        if not coords:
            _use_texture(source, 0, linear)
        self._gl.mgl.disable(moderngl.DEPTH_TEST | moderngl.BLEND | moderngl.CULL_FACE)
        width, height = values["u_target_size"]
        winner_texture = self._texture("winner", (width, height), 1, "u4")
        winner_texture.write(self._buffers["winner"])  # a copy on the GPU side
        winner_texture.use(_WINNER_UNIT)
        if nearest:
            self._vao(program).render(moderngl.TRIANGLES, vertices=3)
            return
        if whole_mesh is not None:
            bands = iter([(0, whole_mesh)])
        else:
            grid = values["u_grid"]
            bands = self._mesh_bands(mls, (height, width), grid, centres=False, indexed=False)
        for first, dims in bands:
            _set_uniforms(program, {"u_mesh_dims": dims, "u_first_row": first})
            mesh_texture = self._texture("mesh", dims, 2, "f4")
            mesh_texture.write(self._buffers["mesh"])
            mesh_texture.use(_MESH_UNIT)
            self._vao(program).render(moderngl.TRIANGLES, vertices=3)

    def _draw_mesh(
        self,
        mls: MLS,
        source: moderngl.Texture,
        shape: tuple[int, int],
        target_size: tuple[int, int],
        *,
        splat: bool,
        linear: bool,
        grid: int,
        coords: bool,
        flip_y: bool,
    ) -> None:
        program = self._gl.program(
            ("warp_mesh.vert.glsl",),
            ("warp_sample.glsl", "warp_mesh.frag.glsl"),
            {"WARP_SPLAT": splat, "WARP_LINEAR": linear, "WARP_OUTPUT_COORDS": coords},
        )
        sc = mls.scaling
        values = {
            "u_center": sc.center,
            "u_scale": sc.scale,
            "u_target_size": target_size,
            "u_flip_y": flip_y,
            "u_source_size": (shape[1], shape[0]),
            "u_grid": grid,
            "u_source": 0,
        }
        for name, value in values.items():
            if name in program:
                program[name].value = value
        if not coords:
            _use_texture(source, 0, linear)
        mgl = self._gl.mgl
        mgl.disable(moderngl.DEPTH_TEST | moderngl.BLEND | moderngl.CULL_FACE)
        if splat:
            mgl.point_size = 1.0
        for first, dims in self._mesh_bands(mls, shape, grid, centres=splat):
            for name, value in (("u_mesh_dims", dims), ("u_first_row", first)):
                if name in program:
                    program[name].value = value
            self._buffers["mesh"].bind_to_storage_buffer(_MESH_BINDING)
            if splat:
                self._vao(program).render(moderngl.POINTS, vertices=dims[0] * dims[1])
            else:
                # after _mesh_bands filled the band: the first band has the most rows
                index = self._index_buffer(*dims)
                cells = (dims[0] - 1) * (dims[1] - 1)
                self._vao(program, index).render(moderngl.TRIANGLES, vertices=6 * cells)

    @current
    def solve_inverse(
        self, mls: MLS, shape: tuple[int, int], *, swap: bool = False, grid: int = 1
    ) -> moderngl.Texture:
        """The RGBA32F texture (s.x, s.y, residual, covered) of the backward map, output
        pixels of an image of ``shape`` (the output has the source's size)."""
        self._check_alive()
        with self._keep_framebuffer():
            return self._solve_inverse(mls, shape, swap=swap, grid=grid)

    def _solve_inverse(self, mls: MLS, shape: tuple[int, int], *, swap: bool, grid: int):
        height, width = shape
        framebuffer = self._framebuffer("coords", (width, height))
        texture = self._textures["coords"][1]
        if not swap:
            # First guess: the rasterized piecewise linear inverse of the deformed mesh.
            framebuffer.use()
            framebuffer.viewport = (0, 0, width, height)
            framebuffer.clear(0.0, 0.0, 0.0, 0.0)
            drawn = COMPUTE_QUADS and self._draw_cells(
                mls, texture, shape, linear=False, grid=grid, coords=True, flip_y=False
            )
            if not drawn:
                self._draw_mesh(
                    mls,
                    texture,
                    shape,
                    (width, height),
                    splat=False,
                    linear=False,
                    grid=grid,
                    coords=True,
                    flip_y=False,
                )
        defines = mls.defines() | {"WARP_SWAP": swap, "WARP_NEWTON_STEPS": NEWTON_STEPS}
        handles = mls._handles
        if swap:
            if self._swap is None or self._swap.glsl_part != handles.glsl_part:
                if self._swap is not None:
                    self._swap.release()
                self._swap = make_storage(mls.storage, self._gl.mgl)
            handles = self._swap
            handles.upload(pack_handles(mls.dst, mls.src, mls.scaling))
        program = self._gl.compute(
            (handles.glsl_part, "mls_core.glsl", "mls_inverse.comp.glsl"),
            defines | dict(handles.defines),
        )
        mls._set_uniforms(program, shape)
        handles.bind(program)
        sc = mls.scaling
        values = {
            "u_target_size": (width, height),
            "u_source_size": (width, height),
            "u_center": sc.center,
            "u_scale": sc.scale,
            "u_tolerance": NEWTON_TOLERANCE,
            "u_accept": NEWTON_ACCEPT,
        }
        for name, value in values.items():
            if name in program:
                program[name].value = value
        self._gl.mgl.memory_barrier()
        texture.bind_to_image(0, read=True, write=True)
        program.run(group_x=math.ceil(width / 8), group_y=math.ceil(height / 8))
        self._gl.mgl.memory_barrier()
        return texture

    @current
    def render(
        self,
        mls: MLS,
        source: moderngl.Texture,
        framebuffer: moderngl.Framebuffer,
        *,
        method: str = "quads",
        interpolation: str = "nearest",
        grid: int = 1,
        flip_y: bool = False,
    ) -> None:
        """Draw the deformed ``source`` into ``framebuffer`` (its current viewport), no read-back.

        The caller clears the framebuffer to the background first. The output has the
        source's size in pixels; ``quads`` and ``splat`` scale to any viewport, ``backward``
        needs a viewport of that size. ``flip_y`` for a window, whose row 0 is at the bottom.
        The bound framebuffer is left as found.
        """
        self._check_alive()
        check_options(method, interpolation, grid)
        with self._keep_framebuffer():
            self._render(mls, source, framebuffer, method, interpolation == "linear", grid, flip_y)

    def _render(self, mls, source, framebuffer, method, linear, grid, flip_y) -> None:
        width, height = source.size
        shape = (height, width)
        if method in ("quads", "splat"):
            framebuffer.use()
            if (
                method == "quads"
                and COMPUTE_QUADS
                and tuple(framebuffer.viewport) == (0, 0, width, height)
                and self._draw_cells(
                    mls,
                    source,
                    shape,
                    linear=linear,
                    grid=grid,
                    coords=False,
                    flip_y=flip_y,
                    target=framebuffer.color_attachments[0],
                )
            ):
                return
            self._draw_mesh(
                mls,
                source,
                shape,
                (width, height),
                splat=method == "splat",
                linear=linear,
                grid=grid,
                coords=False,
                flip_y=flip_y,
            )
            return
        coords = self._solve_inverse(mls, shape, swap=method == "backward-swap", grid=grid)
        program = self._gl.program(
            ("warp_fullscreen.vert.glsl",),
            ("warp_target.glsl", "warp_sample.glsl", "warp_backward.frag.glsl"),
            {"WARP_LINEAR": linear},
        )
        program["u_source"].value = 0
        program["u_coords"].value = 1
        program["u_target_size"].value = (width, height)
        program["u_flip_y"].value = flip_y
        _use_texture(source, 0, linear)
        coords.use(1)
        framebuffer.use()
        self._vao(program).render(moderngl.TRIANGLES, vertices=3)

    # -- numpy front ends ---------------------------------------------------------------

    @current
    def warp(
        self,
        mls: MLS,
        image: object,
        *,
        method: str = "quads",
        interpolation: str = "nearest",
        grid: int = 1,
        background: object = 0,
    ) -> np.ndarray:
        """The deformed image as a new array of ``image``'s shape and dtype."""
        self._check_alive()
        check_options(method, interpolation, grid)
        source = prepare_image(image, self.max_image_size, normalized=True)
        clear = background_color(background, source)
        height, width = source.shape
        texture = self.upload(source)
        dtype = "f1" if source.normalized else "f4"
        with self._keep_framebuffer():
            framebuffer = self._framebuffer("target", (width, height), dtype)
            framebuffer.use()
            framebuffer.viewport = (0, 0, width, height)
            framebuffer.clear(*clear)
            self._render(mls, texture, framebuffer, method, interpolation == "linear", grid, False)
        components = source.channels if source.normalized else 4
        raw = framebuffer.read(viewport=(0, 0, width, height), components=components, dtype=dtype)
        values = np.frombuffer(raw, dtype=np.uint8 if source.normalized else np.float32)
        values = values.reshape(height, width, components)
        return source.restore(values[..., : source.channels])

    @current
    def coordinate_map(
        self, mls: MLS, shape: tuple[int, int], *, method: str = "backward", grid: int = 1
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(map (H, W, 2) float32, residual (H, W) float32, covered (H, W) bool)."""
        self._check_alive()
        if method not in ("backward", "backward-swap"):
            raise ValueError(f"unknown method {method!r}; choose backward or backward-swap")
        check_options(method, "nearest", grid)
        height, width = shape
        if max(height, width) > self.max_image_size:
            raise ValueError(
                f"shape {shape} exceeds the GL texture size limit of {self.max_image_size} pixels"
            )
        texture = self.solve_inverse(mls, shape, swap=method == "backward-swap", grid=grid)
        values = np.frombuffer(texture.read(), dtype=np.float32).reshape(height, width, 4)
        residual = values[..., 2].copy()
        if method == "backward-swap":
            residual[:] = np.nan
        return values[..., :2].copy(), residual, values[..., 3] > 0.5
