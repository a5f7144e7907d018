"""The public :class:`MLS` deformation, evaluated by a compute shader."""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Sequence
from typing import TypeVar

import moderngl
import numpy as np

from .bins import BinBuffer, HandleBins, reach, worth_binning
from .config import RADIUS_WEIGHTS, MLSConfig
from .context import GLContext, current, get_context
from .errors import ReleasedError
from .handles import (
    Scaling,
    as_points,
    check_affine_handles,
    pack_handles,
    validate_handles,
)
from .pipeline import WarpPipeline
from .storage import check_storage, make_storage, resolve_storage, unroll_slots

#: Points closer than this (pixels) to a handle whose weight is infinite there map to q_i.
SNAP_DISTANCE = 1e-3
_WEIGHT_CODES = {"idw": 0, "cressman": 1, "shepard": 2, "gaussian": 3, "linear": 4}
_TRANSFORM_CODES = {"affine": 0, "similarity": 1, "rigid": 2}
_LOCAL_SIZE = 64
#: Handle storage unless told otherwise: the uniform block where the handles fit, else the
#: storage buffer (docs/handles.md: the uniform block is the fastest on llvmpipe wherever it
#: fits; only the storage buffer and the texture take tens of thousands).
DEFAULT_STORAGE = "auto"
_WRITE_BINDINGS = {"f": 2, "M": 3}
_R = TypeVar("_R")


def on_gpu(method: Callable[..., _R]) -> Callable[..., _R]:
    """Check the MLS is alive, then run ``method`` with its GL context current."""
    inner = current(method)

    @functools.wraps(method)
    def wrapper(self, *args, **kwargs):
        self._check_alive()
        return inner(self, *args, **kwargs)

    return wrapper


def as_shape(shape: object) -> tuple[int, int]:
    """(H, W) from an image shape ``(H, W)`` or ``(H, W, C)``; ``ValueError`` otherwise."""
    try:
        dims = tuple(int(n) for n in shape)  # type: ignore[union-attr]
    except (TypeError, ValueError):
        raise TypeError(f"shape must be (H, W) integers, got {shape!r}") from None
    if len(dims) not in (2, 3) or dims[0] < 1 or dims[1] < 1:
        raise ValueError(f"shape must be (H, W) with H, W >= 1, got {shape!r}")
    return dims[0], dims[1]


def mesh_axes(shape: tuple[int, int], grid: int) -> tuple[np.ndarray, np.ndarray]:
    """x and y of the mesh of pixel-square corners: -0.5, -0.5 + grid, ..., up to W - 0.5."""
    if isinstance(grid, bool) or not isinstance(grid, (int, np.integer)) or grid < 1:
        raise ValueError(f"grid must be an integer >= 1 (pixels), got {grid!r}")
    height, width = shape
    xs = np.minimum(-0.5 + grid * np.arange(math.ceil(width / grid) + 1), width - 0.5)
    ys = np.minimum(-0.5 + grid * np.arange(math.ceil(height / grid) + 1), height - 0.5)
    return xs, ys


class MLS:
    """A Moving Least Squares deformation from source handles ``src`` (p) to ``dst`` (q).

    Points are ``(x, y)`` = (column, row) rows of (N, 2) float arrays; pixel centres sit at
    integer coordinates, so pixel (row r, column c) is the point (c, r) and covers
    [c - 0.5, c + 0.5] x [r - 0.5, r + 0.5]. With row vectors (the paper's eq. 1),
    ``f(v) = v @ M(v) + T(v)``.

    Parameters (keyword-only; see :class:`glmls.MLSConfig` for the formulas):
    transform ``affine`` | ``similarity`` | ``rigid``; weight ``idw`` | ``cressman`` |
    ``shepard`` | ``gaussian`` | ``linear``; ``alpha``, ``s`` (idw); ``radius`` (pixels, the
    image diagonal when ``None`` and an image size is known); ``interpolating`` (make any
    weight interpolate the handles); ``shape`` (H, W) of the image, for the default radius;
    ``ctx`` a moderngl context to render with (default: glmls's shared headless EGL one);
    ``storage`` where the handles live on the GPU: ``auto`` (default: ``ubo`` where they fit,
    else ``ssbo``), ``ssbo``, ``ubo`` or ``texture`` (see :mod:`glmls.storage`; ``ubo`` takes
    at most ``GL_MAX_UNIFORM_BLOCK_SIZE / 16``, at least 1,024);
    ``bins`` sort the handles into a spatial grid so that each point visits only those in
    reach (weights with a radius; see :mod:`glmls.bins`): ``None`` (default) when it pays
    (256+ handles, reach under a quarter of their extent), ``True`` always, ``False`` never.

    Special cases: no handles is the identity and one handle a translation by q - p, for every
    transform. Affine needs 3 source handles not on one line (else
    :class:`glmls.DegenerateHandlesError`); where a compact-support weight reaches fewer at a
    point, that point uses the similarity solution. A point that no handle reaches stays put.

    GPU objects are released by :meth:`release` (or a ``with`` block).
    """

    def __init__(
        self,
        src: object,
        dst: object,
        *,
        transform: str = "rigid",
        weight: str = "idw",
        alpha: float = 1.0,
        s: float = 1e-8,
        radius: float | None = None,
        interpolating: bool = False,
        shape: Sequence[int] | None = None,
        ctx: moderngl.Context | GLContext | None = None,
        storage: str = DEFAULT_STORAGE,
        bins: bool | None = None,
    ) -> None:
        config = MLSConfig(
            transform=transform,
            weight=weight,
            alpha=alpha,
            s=s,
            radius=radius,
            interpolating=interpolating,
        )
        self._setup(src, dst, config, shape, ctx, storage, bins)

    @classmethod
    def from_config(
        cls,
        src: object,
        dst: object,
        config: MLSConfig,
        *,
        shape: Sequence[int] | None = None,
        ctx: moderngl.Context | GLContext | None = None,
        storage: str = DEFAULT_STORAGE,
        bins: bool | None = None,
    ) -> MLS:
        """An MLS with the settings of an :class:`MLSConfig`."""
        if not isinstance(config, MLSConfig):
            raise TypeError(f"config must be an MLSConfig, got {type(config).__name__}")
        self = cls.__new__(cls)
        self._setup(src, dst, config, shape, ctx, storage, bins)
        return self

    def _setup(self, src, dst, config, shape, ctx, storage, bins) -> None:
        self._released = True  # until fully built, release() has nothing to free
        check_storage(storage)
        if bins is not None and not isinstance(bins, bool):
            raise TypeError(f"bins must be True, False or None, got {bins!r}")
        if bins and config.weight not in RADIUS_WEIGHTS:
            raise ValueError(
                f"bins need a weight with a radius ({', '.join(RADIUS_WEIGHTS)}); "
                f"{config.weight!r} reaches every handle"
            )
        src, dst = validate_handles(src, dst)
        if config.transform == "affine":
            check_affine_handles(src)
        self.config = config
        self.shape = None if shape is None else as_shape(shape)
        if self.shape is not None:
            config.resolve_radius(self.shape)
        self._src, self._dst = src.copy(), dst.copy()  # never freeze the caller's arrays
        self._src.flags.writeable = False
        self._dst.flags.writeable = False
        self.scaling = Scaling.fit(src, dst, self.shape)
        self._gl = get_context(ctx)
        if bins and config.radius is None and self.shape is None:
            raise ValueError("bins need a radius: give radius= or shape=")
        self._bins_wanted = bins
        self._bins: BinBuffer | None = None
        self._gl.make_current()
        #: The storage in use (``"auto"`` resolved for this many handles).
        self.storage = resolve_storage(storage, self._gl.mgl, len(src))
        self._handles = make_storage(self.storage, self._gl.mgl)
        try:
            self._upload_handles(self.shape)
        except ValueError:
            self._handles.release()
            raise
        self._buffers: dict[str, moderngl.Buffer] = {}
        self._pipeline: WarpPipeline | None = None
        self._released = False

    # -- public API ---------------------------------------------------------------------

    @property
    def src(self) -> np.ndarray:
        """Source handles p, (N, 2) float64, read-only."""
        return self._src

    @property
    def dst(self) -> np.ndarray:
        """Target handles q, (N, 2) float64, read-only."""
        return self._dst

    @property
    def ctx(self) -> GLContext:
        return self._gl

    @on_gpu
    def set_handles(self, src: object, dst: object) -> None:
        """Replace the handles (any count), keeping the configuration and GPU objects.

        Validated like the constructor's; on error nothing changes. Cheaper than a new
        :class:`MLS` per frame of a drag: only the handle buffer is rewritten.
        """
        src, dst = validate_handles(src, dst)
        if self.config.transform == "affine":
            check_affine_handles(src)
        scaling = Scaling.fit(src, dst, self.shape)
        self._handles.upload(pack_handles(src, dst, scaling))
        self._src, self._dst, self.scaling = src.copy(), dst.copy(), scaling
        self._src.flags.writeable = False
        self._dst.flags.writeable = False

    @on_gpu
    def __call__(self, points: object) -> np.ndarray:
        """f(points): (K, 2) float64, evaluated on the GPU."""
        v = as_points(points)
        f, _ = self._evaluate_points(v, with_matrix=False)
        return f

    @on_gpu
    def matrices(self, points: object) -> tuple[np.ndarray, np.ndarray]:
        """(M, T): (K, 2, 2) and (K, 2) float64 with ``f(v) = v @ M + T`` for each point."""
        v = as_points(points)
        f, m = self._evaluate_points(v, with_matrix=True)
        return m, f - np.einsum("ki,kij->kj", v, m)

    @on_gpu
    def mesh(self, shape: Sequence[int], *, grid: int = 1) -> tuple[np.ndarray, np.ndarray]:
        """The mesh of pixel-square corners of an image of ``shape`` and its image under f.

        Vertices sit at x = -0.5, -0.5 + grid, ..., W - 0.5 (the last step may be shorter),
        likewise in y. Returns (vertices, deformed), each (rows, columns, 2) float64.
        """
        shape = as_shape(shape)
        xs, ys = mesh_axes(shape, grid)
        vertices = np.stack(np.meshgrid(xs, ys), axis=-1)
        count = vertices.shape[0] * vertices.shape[1]
        program = self._program(mesh=True, with_matrix=False)
        sc = self.scaling
        origin = sc.to_gpu(np.array([[xs[0], ys[0]]]))[0]
        last = sc.to_gpu(np.array([[xs[-1], ys[-1]]]))[0]
        program["u_mesh_origin"].value = tuple(origin)
        program["u_mesh_step"].value = (grid / sc.scale, grid / sc.scale)
        program["u_mesh_last"].value = tuple(last)
        program["u_mesh_dims"].value = (len(xs), len(ys))
        program["u_mesh_first_row"].value = 0  # the program is shared with banded passes
        out = self._run(program, count, shape, with_matrix=False)
        deformed = sc.from_gpu(out["f"]).reshape(vertices.shape)
        return vertices, deformed

    @on_gpu
    def error_field(self, shape: Sequence[int], *, grid: int = 1) -> np.ndarray:
        """The MLS error field E_MLS (paper eq. 7) of an image of ``shape``: (H, W) float64.

        See :func:`glmls.analysis.error_field`.
        """
        from .analysis import error_field

        return error_field(self, shape, grid=grid)

    @on_gpu
    def warp(
        self,
        image: object,
        *,
        method: str = "quads",
        interpolation: str = "nearest",
        grid: int = 1,
        background: object = 0,
    ) -> np.ndarray:
        """The image deformed by f: a new array of ``image``'s shape and dtype.

        ``image``: H x W or H x W x C (C in 1..4), uint8, uint16, float32 or float64 (computed
        as float32). The output has the input's size; what f moves outside is cut off.

        ``method``:
          - ``"quads"`` (forward with polygon interpolation): the mesh of pixel-square corners,
            step ``grid`` pixels, is deformed and each deformed quad is filled (scan-converted
            on the GPU).
          - ``"splat"`` (simple forward): each source pixel v is written at round(f(v)), gaps
            and all.
          - ``"backward"``: each output pixel u samples the source at s with f(s) = u (Newton's
            method from the rasterized inverse of the mesh); ``grid`` is that guess's mesh.
          - ``"backward-swap"``: s = the MLS map with p and q swapped, the shortcut of other MLS
            tools; only for comparison, it is not f's inverse.

        ``interpolation``: ``"nearest"`` takes one source pixel's value (no new colours);
        ``"linear"`` interpolates bilinearly (``splat`` ignores it).

        ``background``: what uncovered pixels hold: a scalar, or one value per channel; images
        with alpha (C = 2 or 4) get alpha 0 there unless ``background`` gives it.

        Fold-overs: where deformed quads overlap, the cell with the larger source row (then
        column) is drawn last and shows; ``splat`` and ``backward`` follow the same order.
        """
        return self._warp_pipeline().warp(
            self,
            image,
            method=method,
            interpolation=interpolation,
            grid=grid,
            background=background,
        )

    @on_gpu
    def coordinate_map(
        self,
        shape: Sequence[int],
        *,
        method: str = "backward",
        grid: int = 1,
        residual: bool = False,
    ) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
        """The (H, W, 2) float32 map from output pixels to source points (x, y): f's inverse.

        For each output pixel u = (column, row), the source point s with f(s) = u, solved on
        the GPU (``method="backward"``; ``"backward-swap"`` gives the swapped-handles shortcut
        instead). Points outside the source image are kept (a remapper fills them with its
        border value). Feed it to OpenCV or scikit-image::

            xy = m.coordinate_map(image.shape)
            out = cv2.remap(image, xy[..., 0], xy[..., 1], cv2.INTER_LINEAR)
            out = skimage.transform.warp(image, np.stack([xy[..., 1], xy[..., 0]]), order=1)

        ``residual=True`` also returns |f(s) - u| per pixel (float32, pixels; NaN for
        backward-swap). Newton stops below 1e-3 px; pixels where it ends above 0.05 px (no
        inverse found) hold its last iterate.
        """
        shape = as_shape(shape)
        xy, res, _ = self._warp_pipeline().coordinate_map(self, shape, method=method, grid=grid)
        return (xy, res) if residual else xy

    def _warp_pipeline(self) -> WarpPipeline:
        self._check_alive()
        if self._pipeline is None:
            self._pipeline = WarpPipeline(self._gl)
        return self._pipeline

    def release(self) -> None:
        """Free this object's GPU buffers. Safe to call twice; later use raises."""
        if self._released:
            return
        self._gl.make_current()
        self._handles.release()
        if self._bins is not None:
            self._bins.release()
            self._bins = None
        for buffer in self._buffers.values():
            buffer.release()
        self._buffers.clear()
        if self._pipeline is not None:
            self._pipeline.release()
            self._pipeline = None
        self._released = True

    @property
    def released(self) -> bool:
        return self._released

    def __enter__(self) -> MLS:
        return self

    def __exit__(self, *exc: object) -> None:
        self.release()

    def __repr__(self) -> str:
        c = self.config
        state = ", released" if self._released else ""
        return (
            f"MLS({len(self._src)} handles, transform={c.transform!r}, weight={c.weight!r}, "
            f"alpha={c.alpha}, s={c.s}, radius={c.radius}, interpolating={c.interpolating}"
            f"{state})"
        )

    # -- GPU evaluation -----------------------------------------------------------------

    def _upload_handles(self, shape: tuple[int, int] | None, use: bool | None = None) -> None:
        """Upload the handles, sorted into bins when they are used (``use``; by default as
        asked at construction) for the radius that ``shape`` gives (the image diagonal when
        no radius was set)."""
        packed = pack_handles(self._src, self._dst, self.scaling)
        radius = self.config.radius
        if radius is None and shape is not None and self.config.weight in RADIUS_WEIGHTS:
            radius = self.config.resolve_radius(shape)
        use = self._bins_wanted if use is None else use
        if radius is not None and self.config.weight in RADIUS_WEIGHTS:
            scaled = radius / self.scaling.scale
            if use is None:
                use = worth_binning(self.config.weight, scaled, packed[:, :2].astype(float))
        else:
            use = False
        if self._bins is not None:
            self._bins.release()
            self._bins = None
        if use:
            reach_ = reach(self.config.weight, scaled, len(packed))
            bins = HandleBins.build(packed[:, :2], reach_, scaled)
            packed = packed[bins.order]
            self._bins = BinBuffer(self._gl.mgl, bins, radius=scaled)
        self._handles.upload(packed)

    def _check_alive(self) -> None:
        if self._released:
            raise ReleasedError("this MLS has been released; create a new one")

    def defines(self) -> dict[str, int | bool]:
        """The ``#define`` values that ``mls_core.glsl`` expects for this configuration."""
        c = self.config
        binned = self._bins is not None
        unroll = self._handles.unrolls and not binned
        return {
            "MLS_WEIGHT": _WEIGHT_CODES[c.weight],
            "MLS_TRANSFORM": _TRANSFORM_CODES[c.transform],
            "MLS_INTERPOLATING": c.interpolating,
            "MLS_ALPHA_ONE": c.alpha == 1.0,
            "MLS_UNROLL": unroll_slots(len(self._src)) if unroll else 0,
            "MLS_BINS": binned,
        }

    def _compute(self, shader: str, **defines: int | bool) -> moderngl.ComputeShader:
        """The compute program: handle storage + ``mls_core.glsl`` + ``shader`` (a file)."""
        self._check_alive()
        parts = (self._handles.glsl_part, "mls_core.glsl", shader)
        return self._gl.compute(parts, self.defines() | dict(self._handles.defines) | defines)

    def _program(self, *, mesh: bool, with_matrix: bool) -> moderngl.ComputeShader:
        return self._compute("mls_points.comp.glsl", MLS_MESH=mesh, MLS_WRITE_MATRIX=with_matrix)

    def uniforms(self, shape: tuple[int, int] | None = None) -> dict[str, float | bool]:
        """The MLS uniforms of ``mls_core.glsl`` for an image of ``shape`` (scaled units)."""
        c = self.config
        scale = self.scaling.scale
        radius = c.resolve_radius(shape if shape is not None else self.shape)
        alpha = c.alpha
        log2_s = math.log2(c.s) - 2 * alpha * math.log2(scale) if c.s > 0 else -1e30
        hit2 = (SNAP_DISTANCE / scale) ** 2
        # idw with a tiny s is infinite at d = 0 for float32: snap there too.
        tiny_s = c.weight == "idw" and log2_s - alpha * math.log2(hit2) < math.log2(1e-6)
        return {
            "u_alpha": alpha,
            "u_log2_s": max(log2_s, -1e30),
            "u_radius": (radius or 1.0) / scale,
            "u_hit2": hit2,
            "u_snap": c.infinite_at_zero or tiny_s,
        }

    def _set_uniforms(self, program, shape) -> None:
        for name, value in self.uniforms(shape).items():
            if name in program:
                program[name].value = value
        if self._bins is not None and self.uniforms(shape)["u_radius"] != self._bins.radius:
            self._upload_handles(shape, use=True)  # another image size: another radius
        self._handles.bind(program)
        if self._bins is not None:
            self._bins.bind(program)

    def _buffer(self, name: str, nbytes: int) -> moderngl.Buffer:
        """A cached buffer of at least ``nbytes``, grown (never shrunk) as needed."""
        buffer = self._buffers.get(name)
        if buffer is None or buffer.size < nbytes:
            if buffer is not None:
                buffer.release()
            buffer = self._buffers[name] = self._gl.mgl.buffer(reserve=max(nbytes, 16))
        return buffer

    def _run(self, program, count: int, shape, *, with_matrix: bool) -> dict[str, np.ndarray]:
        self._set_uniforms(program, shape)
        outputs = {"f": 2} | ({"M": 4} if with_matrix else {})
        for name, width in outputs.items():
            self._buffer(name, count * width * 4).bind_to_storage_buffer(_WRITE_BINDINGS[name])
        program["u_count"].value = count
        max_groups = self._gl.limits["max_work_groups_x"]
        groups = math.ceil(count / _LOCAL_SIZE)
        for first in range(0, groups, max_groups):
            program["u_offset"].value = first * _LOCAL_SIZE
            program.run(group_x=min(max_groups, groups - first))
        return {
            name: np.frombuffer(
                self._buffers[name].read(size=count * width * 4), dtype=np.float32
            ).reshape(count, width)
            for name, width in outputs.items()
        }

    def _evaluate_points(self, v: np.ndarray, *, with_matrix: bool):
        program = self._program(mesh=False, with_matrix=with_matrix)
        if len(v) == 0:
            return np.zeros((0, 2)), np.zeros((0, 2, 2))
        self._buffer("points", v.size * 4).write(self.scaling.to_gpu(v).tobytes())
        self._buffers["points"].bind_to_storage_buffer(1)
        out = self._run(program, len(v), None, with_matrix=with_matrix)
        f = self.scaling.from_gpu(out["f"])
        m = out["M"].astype(np.float64).reshape(-1, 2, 2) if with_matrix else None
        return f, m
