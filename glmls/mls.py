"""The public :class:`MLS` deformation and the one-call :func:`warp`: the facade over the
engine (:mod:`glmls.engine`, f on the GPU) and the image construction (:mod:`glmls.imaging`)."""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence
from typing import TypeVar

import moderngl
import numpy as np

from .core.config import MLSConfig
from .core.handles import Scaling, as_points, check_coordinates
from .core.handleset import HandleSet
from .core.mesh import MeshLattice, as_shape
from .engine.error_field import error_at
from .engine.error_field import error_field as evaluate_error_field
from .engine.kernel import DEFAULT_STORAGE, MLSKernel
from .engine.passes import evaluate_lattice, evaluate_points
from .gl.context import GLContext, current, get_context
from .imaging.adaptive import AdaptiveMesh, check_adaptive, interpolate
from .imaging.deformed import DeformedImages

__all__ = ["MLS", "warp"]

_R = TypeVar("_R")


def on_gpu(method: Callable[..., _R]) -> Callable[..., _R]:
    """Check the MLS is alive, then run ``method`` with its GL context current."""
    inner = current(method)

    @functools.wraps(method)
    def wrapper(self, *args, **kwargs):
        self.kernel.check_alive()
        return inner(self, *args, **kwargs)

    return wrapper


class MLS(DeformedImages):
    """A Moving Least Squares deformation from source handles ``src`` (p) to ``dst`` (q).

    Points are ``(x, y)`` = (column, row) rows of (N, 2) float arrays; pixel centres sit at
    integer coordinates, so pixel (row r, column c) is the point (c, r) and covers
    [c - 0.5, c + 0.5] x [r - 0.5, r + 0.5]. With row vectors (the paper's eq. 1),
    ``f(v) = v @ M(v) + T(v)``.

    Segment handles (Schaefer et al. 2006, section 4): ``src_segments`` and ``dst_segments``,
    (S, 2, 2) arrays, segment s running from ``src_segments[s, 0]`` to ``src_segments[s, 1]``
    and going to ``dst_segments[s, 0]``-``dst_segments[s, 1]`` (:func:`glmls.polyline_segments`
    turns polylines into segments). Each weighs its points per unit of length, so a segment
    split in two is the same handle; they mix with point handles (``src``/``dst`` may be
    empty, shape (0, 2)). With a weight infinite at d = 0, f maps every point of a source
    segment onto its target segment.

    Parameters (keyword-only; :class:`glmls.MLSConfig` has the formulas): ``transform``,
    ``weight`` (:data:`glmls.WEIGHTS`), ``alpha``, ``s`` (idw), ``radius`` (pixels; the image
    diagonal when ``None`` and an image size is known), ``interpolating`` (make any weight
    interpolate the handles); ``shape`` (H, W) of the image, for the default radius; ``ctx``
    a moderngl context to render with (default: glmls's shared headless EGL one);
    ``storage`` where the handles live on the GPU: ``auto`` (default: ``ubo`` where they
    fit, else ``ssbo``), ``ssbo``, ``ubo`` or ``texture`` (:mod:`glmls.engine.storage`);
    ``bins``: sort the handles into a spatial grid so that each point visits only those in
    reach (radius weights, :mod:`glmls.engine.bins`): ``None`` (default) where it pays,
    ``True`` always, ``False`` never.

    Special cases: no handles is the identity and one handle a translation by q - p, for every
    transform. Affine needs 3 source handles not on one line (else
    :class:`glmls.DegenerateHandlesError`); where a compact-support weight reaches fewer at a
    point, that point uses the similarity solution. A point that no handle reaches stays put.

    GPU objects are released by :meth:`release` (or a ``with`` block); the images it builds
    come from its context's shared :class:`~glmls.gl.WarpPipeline`.
    """

    def __init__(
        self,
        src: object,
        dst: object,
        *,
        src_segments: object = None,
        dst_segments: object = None,
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
        handles = (src, dst, src_segments, dst_segments)
        self._setup(handles, config, shape, ctx, storage, bins)

    @classmethod
    def from_config(
        cls,
        src: object,
        dst: object,
        config: MLSConfig,
        *,
        src_segments: object = None,
        dst_segments: object = None,
        shape: Sequence[int] | None = None,
        ctx: moderngl.Context | GLContext | None = None,
        storage: str = DEFAULT_STORAGE,
        bins: bool | None = None,
    ) -> MLS:
        """An MLS with the settings of an :class:`MLSConfig`."""
        if not isinstance(config, MLSConfig):
            raise TypeError(f"config must be an MLSConfig, got {type(config).__name__}")
        self = cls.__new__(cls)
        self._setup((src, dst, src_segments, dst_segments), config, shape, ctx, storage, bins)
        return self

    def _setup(self, handles, config, shape, ctx, storage, bins) -> None:
        self.config = config
        self.shape = None if shape is None else as_shape(shape)
        if self.shape is not None:
            config.resolve_radius(self.shape)
        handles = self._validate(*handles)
        self._gl = get_context(ctx)
        self._options = {"shape": self.shape, "storage": storage, "bins": bins}
        self._kernel = MLSKernel(self._gl, config, **self._options)  # type: ignore[arg-type]
        self._swapped: MLSKernel | None = None
        try:
            self._store(handles)
        except ValueError:
            self._kernel.release()
            raise

    def _validate(self, src, dst, src_segments, dst_segments) -> HandleSet:
        handles = HandleSet.validate(src, dst, src_segments, dst_segments)
        if self.config.transform == "affine":
            handles.check_affine()
        return handles

    def _store(self, handles: HandleSet) -> None:
        """The one way handles get in: the kernel's upload, then the read-only copies."""
        scaling = Scaling.fit(handles.source_points(), handles.target_points(), self.shape)
        self._kernel.upload(handles, scaling)
        self._handles = handles
        if self._swapped is not None:
            self._swapped.release()
            self._swapped = None

    # -- public API ---------------------------------------------------------------------

    @property
    def src(self) -> np.ndarray:
        """Source handles p, (N, 2) float64, read-only."""
        return self._handles.src

    @property
    def dst(self) -> np.ndarray:
        """Target handles q, (N, 2) float64, read-only."""
        return self._handles.dst

    @property
    def src_segments(self) -> np.ndarray:
        """Source segment handles, (S, 2, 2) float64, read-only."""
        return self._handles.src_segments

    @property
    def dst_segments(self) -> np.ndarray:
        """Target segment handles, (S, 2, 2) float64, read-only."""
        return self._handles.dst_segments

    @property
    def handles(self) -> HandleSet:
        """Every handle, points and segments (read-only arrays)."""
        return self._handles

    @property
    def ctx(self) -> GLContext:
        return self._gl

    @property
    def kernel(self) -> MLSKernel:
        """The handles on the GPU and the defines and uniforms of the passes over f."""
        return self._kernel

    @property
    def scaling(self) -> Scaling:
        """The GPU's coordinates: (pixel - center) / scale."""
        return self._kernel.scaling

    @property
    def storage(self) -> str:
        """The handle storage in use (``"auto"`` resolved for this many handles)."""
        return self._kernel.storage

    def defines(self) -> dict[str, object]:
        """The ``#define`` values of the MLS shaders for this configuration (the kernel's)."""
        return self._kernel.defines()

    def uniforms(self, shape: tuple[int, int] | None = None) -> dict[str, float | bool]:
        """The MLS uniforms for an image of ``shape``, in scaled units (the kernel's)."""
        return self._kernel.uniforms(shape)

    @on_gpu
    def set_handles(
        self, src: object, dst: object, *, src_segments: object = None, dst_segments: object = None
    ) -> None:
        """Replace the handles (any count, points and segments), keeping the configuration.

        Validated like the constructor's; on error nothing changes. Cheaper than a new
        :class:`MLS` per frame of a drag: the handles go through the same upload as the
        constructor's (storage for their count, spatial bins rebuilt), nothing is compiled
        (unless segments appear or all go: their code is compiled in only where there are).
        """
        self._store(self._validate(src, dst, src_segments, dst_segments))

    def swapped_kernel(self) -> MLSKernel:
        """The kernel of the MLS map with p and q swapped (``backward-swap``), made on first
        use with this configuration and scaling."""
        self._kernel.check_alive()
        if self._swapped is None:
            swapped = MLSKernel(self._gl, self.config, **self._options)  # type: ignore[arg-type]
            swapped.upload(self._handles.swapped(), self.scaling)
            self._swapped = swapped
        return self._swapped

    @on_gpu
    def __call__(self, points: object) -> np.ndarray:
        """f(points): (K, 2) float64, evaluated on the GPU."""
        f, _ = evaluate_points(self._kernel, _points(points), with_matrix=False)
        return f

    @on_gpu
    def matrices(self, points: object) -> tuple[np.ndarray, np.ndarray]:
        """(M, T): (K, 2, 2) and (K, 2) float64 with ``f(v) = v @ M + T`` for each point."""
        v = _points(points)
        f, m = evaluate_points(self._kernel, v, with_matrix=True)
        return m, f - np.einsum("ki,kij->kj", v, m)  # type: ignore[return-value]

    @on_gpu
    def mesh(
        self, shape: Sequence[int], *, grid: int = 1, tolerance: float | None = None
    ) -> tuple[np.ndarray, np.ndarray] | AdaptiveMesh:
        """The mesh of pixel-square corners of an image of ``shape`` and its image under f.

        Vertices sit at x = -0.5, -0.5 + grid, ..., W - 0.5 (the last step may be shorter),
        likewise in y. Returns (vertices, deformed), each (rows, columns, 2) float64.

        With ``tolerance`` (pixels; ``grid`` must stay 1): the error-bounded adaptive mesh
        that :meth:`warp` draws with that tolerance, a :class:`~glmls.imaging.adaptive.AdaptiveMesh`
        (vertices, f at them, triangles, leaves; ``docs/adaptive.md``).
        """
        if tolerance is not None:
            value = check_adaptive("quads", grid, tolerance)
            return self._pipeline().adaptive.mesh(self._kernel, as_shape(shape), value)  # type: ignore[arg-type]
        lattice = MeshLattice.corners(shape, grid)
        vertices = lattice.points()
        buffer = self._kernel.scratch.buffer("mesh", lattice.count * 8)
        count = evaluate_lattice(self._kernel, lattice, buffer)
        self._gl.mgl.memory_barrier()
        out = np.frombuffer(buffer.read(size=count * 8), np.float32).reshape(-1, 2)
        return vertices, self.scaling.from_gpu(out).reshape(vertices.shape)

    @on_gpu
    def error_field(
        self, shape: Sequence[int], *, grid: int = 1, tolerance: float | None = None
    ) -> np.ndarray:
        """The MLS error field E_MLS (paper eq. 7) of an image of ``shape``: (H, W) float64.

        E_MLS(v) = sum_i |p_i M_v + T_v - q_i|^2 at every pixel centre, in square pixels,
        unweighted so that configurations with different weights compare fairly. ``grid``
        = 1 evaluates every pixel centre; ``grid`` > 1 the vertices of :meth:`mesh`'s mesh,
        interpolated bilinearly to the pixel centres (both on the GPU). ``tolerance``
        (``grid`` 1): the vertices of the adaptive mesh of that tolerance, interpolated on
        each leaf's quadratic patch (numpy). float32 on the GPU: expect a relative error of
        ~1e-6 to 1e-5.
        """
        lattice = MeshLattice.corners(shape, grid)  # validates shape and grid
        if tolerance is not None:
            mesh = self.mesh(lattice.shape, tolerance=tolerance)
            values = error_at(self._kernel, mesh.source, lattice.shape)  # type: ignore[union-attr]
            return interpolate(mesh, values, lattice.shape)  # type: ignore[arg-type]
        return evaluate_error_field(self._kernel, lattice.shape, grid=lattice.grid)

    def release(self) -> None:
        """Free this object's GPU buffers. Safe to call twice; later use raises
        :class:`glmls.ReleasedError`."""
        if self._kernel.released:
            return
        if self._swapped is not None:
            self._swapped.release()
            self._swapped = None
        self._kernel.release()

    @property
    def released(self) -> bool:
        return self._kernel.released

    def __enter__(self) -> MLS:
        return self

    def __exit__(self, *exc: object) -> None:
        self.release()

    def __repr__(self) -> str:
        c = self.config
        state = ", released" if self.released else ""
        segments = f", {self._handles.segments} segments" if self._handles.segments else ""
        return (
            f"MLS({self._handles.points} handles{segments}, transform={c.transform!r}, "
            f"weight={c.weight!r}, "
            f"alpha={c.alpha}, s={c.s}, radius={c.radius}, interpolating={c.interpolating}"
            f"{state})"
        )


def _points(points: object) -> np.ndarray:
    return check_coordinates(as_points(points), "points")


_WARP_OPTIONS = (
    "method",
    "interpolation",
    "grid",
    "background",
    "border",
    "output_shape",
    "origin",
    "tolerance",
)


def warp(image: object, src: object, dst: object, **options: object) -> np.ndarray:
    """Deform ``image`` by the MLS map taking handles ``src`` (p) to ``dst`` (q).

    ``options``: those of :meth:`MLS.warp` (``method``, ``interpolation``, ``grid``,
    ``tolerance``, ``background``, ``border``, ``output_shape``, ``origin``) and of :class:`MLS`
    (``src_segments``, ``dst_segments``, ``transform``, ``weight``, ``alpha``, ``s``,
    ``radius``, ``interpolating``, ``ctx``, ``storage``, ``bins``). The default radius is the
    image diagonal. The MLS's GPU objects are released before returning (the context's shared
    pipeline keeps its cached textures for the next call); keep an :class:`MLS` to warp many
    images with the same handles.
    """
    warp_options = {k: options.pop(k) for k in _WARP_OPTIONS if k in options}
    array = np.asarray(image)
    shape = array.shape[:2] if array.ndim in (2, 3) and array.size else None
    with MLS(src, dst, shape=shape, **options) as m:  # type: ignore[arg-type]
        return m.warp(array, **warp_options)  # type: ignore[arg-type]
