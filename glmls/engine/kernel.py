"""The GPU MLS of one configuration: handle storage, spatial bins, defines and uniforms behind
one upload path.

An :class:`MLSKernel` is what every pass over f needs (the points and lattice passes, the error
field, the backward map): :meth:`MLSKernel.program` compiles a pass with the kernel's defines,
:meth:`MLSKernel.bind` sets its uniforms and binds the handles. Handles reach the GPU only
through :meth:`MLSKernel.upload`, which chooses the storage for their count, sorts them into
bins where that pays (or where asked) and writes them; a pass over an image whose size gives
another radius (``radius=None``: the image diagonal) rebuilds the bins through the same path.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import replace
from functools import lru_cache

import moderngl
import numpy as np

from ..core.config import MLSConfig, image_diagonal, transform_code
from ..core.handles import COORDINATE_LIMIT, Scaling, pack_handles
from ..core.handleset import HandleSet
from ..core.segments import (
    segment_config,
    segment_panel_width,
    segment_pole,
    segments_interpolate,
)
from ..core.weights import GAUSSIAN_CAP, GAUSSIAN_TOLERANCE, RADIUS_WEIGHTS, SUPPORTS
from ..errors import ReleasedError
from ..gl.context import GLContext
from ..gl.dispatch import set_uniforms
from ..gl.resources import Resources
from .bins import BinBuffer, HandleBins, worth_binning
from .loops import (
    CAPPED_NEWTON_HANDLES,
    NEWTON_PASSES,
    bins_serve,
    check_loop_budget,
    check_plain_loops,
    newton_visits_all,
    walks_checked,
)
from .storage import (
    HandleStorage,
    check_storage,
    storage_for,
    unroll_slots,
)

__all__ = [
    "CAPPED_NEWTON_HANDLES",
    "DEFAULT_STORAGE",
    "NEWTON_PASSES",
    "SNAP_DISTANCE",
    "SNAP_RESOLUTION",
    "MLSKernel",
    "check_bins",
    "check_loop_budget",
    "config_defines",
    "handle_extent",
    "point_pole",
    "segment_hit2",
    "weight_rows",
    "weight_uniforms",
]

#: Points closer than this (pixels) to a handle whose weight is infinite there map to q_i
#: (closer still for alpha below ~1, see :func:`weight_uniforms`).
SNAP_DISTANCE = 1e-3
#: The largest relative weight that snapping may leave out: (h / d)^(2 alpha) for the snapping
#: distance h and handles d ~ the scaled extent (1) away, float32's unit roundoff.
SNAP_SHARE = 2.0**-24
#: The smallest squared snapping distance (scaled): a float32 normal number, so that 1 / m of
#: the weights' normalisation stays finite.
SNAP_FLOOR2 = 1e-36
#: float32's resolution of the scaled coordinates (|x| <= ~1: spacing 2^-24 .. 2^-23), a
#: few spacings: nearer to a segment, float32's distance to it is its rounding.
SNAP_RESOLUTION = 2.0**-22
#: Handle storage unless told otherwise: the uniform block where the handles fit, else the
#: storage buffer (:doc:`/handles`: the uniform block is the fastest on llvmpipe wherever it
#: fits; only the storage buffer and the texture take tens of thousands).
DEFAULT_STORAGE = "auto"


def handle_extent(rows: np.ndarray) -> float:
    """Half the largest side of the box around the points of ``rows`` ((N, 2k) float32 rows of
    k points each, scaled coordinates: packed handles p and q, segment end points); 1 without
    any. The same float32 rows give the same value wherever they are reduced (one MLS, one
    image of a batch)."""
    points = np.asarray(rows).reshape(-1, 2)
    if len(points) == 0:
        return 1.0
    sides = points.max(axis=0).astype(np.float64) - points.min(axis=0).astype(np.float64)
    return float(sides.max()) / 2


def weight_uniforms(
    config: MLSConfig, scale: float, radius: float | None, *, extent: float = 1.0
) -> dict[str, float | bool]:
    """The uniforms of ``glmls/shaders/mls/weighting.glsl`` (the weights, in any dimension) for
    ``config`` in coordinates scaled by ``scale``, with influence radius ``radius`` (pixels or
    voxels; None without one); ``extent``: how far apart the handles are, in scaled units
    (half their box's largest side; 1, the scaled box, by default). ``u_tiny_s`` (no
    uniform): idw's s is so small that float32 makes its weight infinite at d = 0, so points
    on a handle snap."""
    ((log2_s, scaled_radius, hit2, snap, tiny_s),) = weight_rows(config, [(scale, extent)], radius)
    return {
        "u_alpha": config.alpha,
        "u_log2_s": log2_s,
        "u_radius": scaled_radius,
        "u_hit2": hit2,
        "u_snap": snap,
        "u_tiny_s": tiny_s,
    }


def weight_rows(
    config: MLSConfig, pairs: list[tuple[float, float]], radius: float | None
) -> list[tuple[float, float, float, bool, bool]]:
    """For each (scale, extent) of ``pairs``, :func:`weight_uniforms`' ``u_log2_s``,
    ``u_radius``, ``u_hit2``, ``u_snap`` and ``u_tiny_s``: what depends on ``config`` alone
    found once (a batch's images each have their own scale)."""
    alpha = config.alpha
    twice = 2 * alpha
    log2_s0 = math.log2(config.s) if config.s > 0 else None
    # A snapped point leaves out the other handles, whose weights relative to the snapped
    # one's are (h / d)^p at the snapping distance h, d ~ the handles' extent, p the pole of
    # the weight (w ~ 1 / d^p: 2 alpha for idw, 1 for shepard, 2 alpha more interpolating):
    # with a shallow pole, or handles less than a few units apart, they are not negligible at
    # h = 1e-3 px (0.25 for alpha = 0.1, 1e-4 for shepard), so h shrinks until they are.
    pole = point_pole(config)
    share = SNAP_SHARE ** (2 / pole if pole > 0 else 1 / alpha)
    # idw with a tiny s is infinite at d = 0 for float32: snap there too.
    uses_s, infinite, least = config.weight_entry.uses_s, config.infinite_at_zero, math.log2(1e-6)
    rows = []
    for scale, extent in pairs:
        log2_s = log2_s0 - twice * math.log2(scale) if log2_s0 is not None else -1e30
        share2 = share * min(extent, 1.0) ** 2
        hit2 = max(min((SNAP_DISTANCE / scale) ** 2, share2), SNAP_FLOOR2)
        tiny_s = uses_s and log2_s - alpha * math.log2(hit2) < least
        rows.append((max(log2_s, -1e30), (radius or 1.0) / scale, hit2, infinite or tiny_s, tiny_s))
    return rows


@lru_cache(maxsize=64)  # a batch asks once per image; a config's replace() costs ~40 us
def point_pole(config: MLSConfig) -> float:
    """The power p of a point handle's weight w ~ 1 / d^p at d = 0 where it snaps: idw's with
    s = 0 (float32 snaps a tiny s too), times 1 / d^(2 alpha) more where interpolating."""
    return (replace(config, s=0.0) if config.weight_entry.uses_s else config).pole


def segment_hit2(config: MLSConfig, scale: float, extent: float) -> float:
    """The squared snapping distance (scaled) of segment handles whose weight, integrated
    along the segment, is infinite on it (``config`` as segments take it,
    :func:`~glmls.core.segments.segment_config`), in coordinates scaled by ``scale``, with the
    handles ``extent`` apart (scaled, :func:`handle_extent`).

    With w ~ 1 / d^p (p > 1), a segment h from v weighs J0 >= 2^(-p/2) h^(1-p) (its
    integral over an arc h long; segments are longer than that) and a handle D away
    1 / D^p: their share (h / D)^(p-1) / (2^(-p/2) D) is below float32's 2^-24
    (:data:`SNAP_SHARE`) within the distance returned (D the extent in pixels), at most
    :data:`SNAP_DISTANCE`. With p = 1 (shepard, idw with
    alpha = 1/2) J0 grows only like 2 log(L / h), and no distance makes the others
    negligible: f approaches the target like 1 / log(1 / h), and only points within
    :data:`SNAP_RESOLUTION` of the extent (at most 1), float32's resolution of the scaled
    coordinates of handles that far apart, snap.
    """
    pole = segment_pole(config)
    d_px = min(extent, 1.0) * scale
    h = 0.0
    if pole > 1.0 and d_px > 0.0:  # extent 0: one handle, staying where it is
        log_h = (math.log(SNAP_SHARE) - 0.5 * pole * math.log(2.0) + pole * math.log(d_px)) / (
            pole - 1.0
        )
        h = min(math.exp(min(log_h, 700.0)), SNAP_DISTANCE) / scale
    return max(max(h, SNAP_RESOLUTION * min(extent, 1.0)) ** 2, SNAP_FLOOR2)


def config_defines(
    config: MLSConfig, *, unroll: int, binned: bool, segments: bool
) -> dict[str, object]:
    """The ``#define`` values of ``glmls/shaders/mls/`` for ``config`` but the storage's:
    ``unroll`` slots (``MLS_UNROLL``), handles in bins, segment handles present."""
    entry = config.weight_entry
    defines = {
        "MLS_WEIGHT_FUNCTION": entry.glsl_function,
        "MLS_WEIGHT_USES_S": entry.uses_s,
        "MLS_REACH_GAUSSIAN": entry.support == "gaussian",
        "MLS_WEIGHT_RADIUS": entry.support == "radius",
        # idw's point handles, and any interpolating weight's: weights relative to the
        # nearest handles apart from the nearest one's place (mls/core.glsl, mls_begin)
        "MLS_WEIGHT_NEXT": (entry.uses_s or config.interpolating) and not segments,
        "MLS_GAUSSIAN_TOLERANCE": GAUSSIAN_TOLERANCE,
        "MLS_GAUSSIAN_CAP": GAUSSIAN_CAP,
        "MLS_TRANSFORM": transform_code(config.transform),
        "MLS_INTERPOLATING": config.interpolating,
        "MLS_ALPHA_ONE": config.alpha == 1.0,
        "MLS_UNROLL": unroll,
        "MLS_BINS": binned,
        "MLS_SEGMENTS": segments,
        "MLS_SEGMENT_CLOSED": entry.segment_closed_form(config) and not config.interpolating,
        "MLS_SEGMENT_SUPPORT": SUPPORTS.index(entry.support),
        # the coordinates glmls takes (pixels): a preimage past them is none
        # (warp/inverse.comp.glsl)
        "MLS_COORDINATE_LIMIT": COORDINATE_LIMIT,
    }
    if entry.edge64:  # its float64 version for the handles near d = R (mls/weighting.glsl)
        defines["MLS_WEIGHT_FUNCTION64"] = entry.glsl_function64
    return defines


def check_bins(bins: object, config: MLSConfig) -> None:
    """``bins`` as :class:`MLSKernel` takes it for ``config``: ``TypeError`` for a value
    that is not True, False or None, ``ValueError`` for bins with a weight without a radius."""
    if bins is not None and not isinstance(bins, bool):
        raise TypeError(f"bins must be True, False or None, got {bins!r}")
    if bins and not config.uses_radius:
        raise ValueError(
            f"bins need a weight with a radius ({', '.join(RADIUS_WEIGHTS)}); "
            f"{config.weight!r} reaches every handle"
        )


class MLSKernel:
    """The handles of one MLS on the GPU, for ``config`` on context ``gl``.

    ``shape``: the image size (H, W) that gives the radius where ``config.radius`` is None
    (passes over another image size use theirs); ``storage``: ``auto`` or one of
    :data:`glmls.engine.storage.STORAGES`; ``bins``: None (where it pays), True or False.
    Raises ``ValueError``/``TypeError`` for bad options. Empty until :meth:`upload`.
    """

    def __init__(
        self,
        gl: GLContext,
        config: MLSConfig,
        *,
        shape: tuple[int, int] | None = None,
        storage: str = DEFAULT_STORAGE,
        bins: bool | None = None,
    ) -> None:
        check_storage(storage)
        check_bins(bins, config)
        if bins and config.radius is None and shape is None:
            raise ValueError("bins need a radius: give radius= or shape=")
        self.gl = gl
        self.config = config
        self.shape = shape
        self.scaling = Scaling((0.0, 0.0), 1.0)
        #: t (2,) float64, pixels: the GPU's coordinates of the deformed plane (f's values,
        #: the points whose preimage is sought, the output canvas) are the true ones less t
        #: (:meth:`HandleSet.near_targets <glmls.core.handleset.HandleSet.near_targets>`).
        self.offset = np.zeros(2)
        #: The handles as the GPU holds them (targets less :attr:`offset`).
        self.handles = HandleSet.validate(np.zeros((0, 2)), np.zeros((0, 2)))
        self._storage_request = storage
        self._bins_request = bins
        self._storage: HandleStorage | None = None
        self._bins: BinBuffer | None = None
        self._packed = np.zeros((0, 4), np.float32)
        self._segments = np.zeros((0, 4), np.float32)  # two rows per segment: (a, b), (c, d)
        self._extent = 1.0  # handle_extent of the rows above
        #: Scratch buffers of the passes (points in, f and M out, error fields).
        self.scratch = Resources(gl, "this MLS")
        self._memo: dict[tuple, object] = {}
        self._released = False

    # -- the one upload path ------------------------------------------------------------

    def upload(
        self, handles: HandleSet, scaling: Scaling, offset: np.ndarray | None = None
    ) -> None:
        """Put validated ``handles`` (points and segments) on the GPU in the coordinates of
        ``scaling``: the storage for their rows (``auto`` chooses again; a segment takes two
        rows), in bins where they are used. ``offset``: the :attr:`offset` (None: 0) that
        their targets are already moved back by. On error (too many handles for the
        storage) nothing changes."""
        self.check_alive()
        shift = np.zeros(2) if offset is None else np.array(offset, np.float64).reshape(2)
        segments = np.concatenate(
            [handles.src_segments.reshape(-1, 4), handles.dst_segments.reshape(-1, 4)], axis=1
        ).reshape(-1, 2, 2)
        with self.gl.use():
            self._upload(
                pack_handles(handles.src, handles.dst, scaling),
                scaling.to_gpu(segments.reshape(-1, 2)).reshape(-1, 4),
                scaling,
            )
        self.handles, self.offset = handles, shift

    def swapped(self) -> MLSKernel:
        """A new kernel of the map with sources and targets exchanged (``backward-swap``),
        on this kernel's configuration, scaling and :attr:`offset`: its handles are this
        one's q - t -> p, so that it takes points of the deformed plane less t, as the
        canvas's uniforms give them (MLS is invariant under a common translation of its
        sources and the point)."""
        kernel = MLSKernel(
            self.gl,
            self.config,
            shape=self.shape,
            storage=self._storage_request,
            bins=self._bins_request,
        )
        kernel.upload(self.handles.swapped(), self.scaling, self.offset)
        return kernel

    def deformed(self, scaled: np.ndarray) -> np.ndarray:
        """Points of the deformed plane read back from the GPU (f's values, scaled; (K, 2)
        float32) in pixels, float64: the :attr:`offset` added back."""
        return self.scaling.from_gpu(scaled) + self.offset

    def _upload(self, packed: np.ndarray, segments: np.ndarray, scaling: Scaling) -> None:
        radius = self._radius(None, scaling.scale)
        wanted = self._use_bins(packed, segments, radius, self._bins_request)
        bins = self._plan_bins(packed, segments, radius, wanted)
        counts = (len(packed), len(segments))
        storage = storage_for(
            self._storage_request,
            self.gl.mgl,
            *counts,
            binned=bins is not None,
            current=self._storage,
        )
        # Nothing of the handles changes unless the upload succeeds: on error the GPU keeps
        # the handles before, and so does the host (set_handles: "on error nothing changes").
        before = (self._storage, self._packed, self._segments, self.scaling, self._extent)
        self._storage = storage
        self._packed, self._segments, self.scaling = packed, segments, scaling
        self._extent = handle_extent(np.concatenate([packed, segments]))
        try:
            self._write(radius, bins)
        except BaseException:
            if storage is not before[0]:
                storage.release()
            self._storage, self._packed, self._segments, self.scaling, self._extent = before
            raise
        if before[0] is not None and before[0] is not storage:
            before[0].release()
        self._memo.clear()

    def memo(self, key: tuple, compute: Callable[[], object]) -> object:
        """``compute()``'s value for ``key``, computed once per upload of the handles: for
        what a pass derives from f alone (the warp and its labels both need a mesh's
        margin)."""
        if key not in self._memo:
            self._memo[key] = compute()
        return self._memo[key]

    def _use_bins(
        self, packed: np.ndarray, segments: np.ndarray, radius: float | None, request: bool | None
    ) -> bool:
        """Whether handles ``packed`` and ``segments`` go into bins for ``radius`` (scaled):
        as asked, or (``request`` None) where it pays; never without a radius."""
        if radius is None or not self.config.uses_radius:
            return False
        if request is not None:
            return request
        sources = segments[0::2].reshape(-1, 2)
        everything = np.concatenate([packed[:, :2], sources]).astype(float)
        return worth_binning(self.config.weight, radius, everything)

    def _plan_bins(
        self,
        packed: np.ndarray,
        segments: np.ndarray,
        radius: float | None,
        use_bins: bool,
        *,
        rebuild: bool = False,
    ) -> HandleBins | None:
        """The bins of ``packed`` and ``segments`` for ``radius`` (scaled) where ``use_bins``
        and a driver's cap on loop iterations lets them serve, else None (``rebuild``: the
        bins of another image's radius for a pass compiled with bins, refused where they
        could not serve). ``ValueError`` where neither they nor visiting every handle fit
        in the cap. Changes nothing."""
        sources = segments[0::2].astype(float).reshape(-1, 2, 2)
        full = self.config.transform == "affine"  # affine's float64 moments
        limit = self.gl.loop_limit
        tried = use_bins and radius is not None and self.config.uses_radius
        if tried:
            count = len(packed) + len(sources)
            reach = self.config.weight_entry.reach(radius, count)
            bins = HandleBins.build(packed[:, :2].astype(float), reach, radius, sources)  # type: ignore[arg-type]
            requested = "bins=True" if self._bins_request else None
            if rebuild:
                requested = "the spatial bins of this image size's radius (its diagonal)"
            serve = bins_serve(
                limit,
                bins,
                gaussian=self.config.weight_entry.support == "gaussian",
                full=full,
                requested=requested,
            )
            if serve:
                return bins
        check_plain_loops(
            limit,
            len(packed),
            len(sources),
            full=full,
            binned=tried,
            radius=self.config.uses_radius and radius is not None,
        )
        return None

    def _write(self, radius: float | None, bins: HandleBins | None) -> None:
        """Write the packed handles to the storage, sorted by ``bins`` (for ``radius``,
        scaled) where there are bins."""
        packed = self._packed if bins is None else self._packed[bins.order]
        made = None if bins is None else BinBuffer(self.gl.mgl, bins, radius=radius)  # type: ignore[arg-type]
        try:
            self._storage.upload(packed, self._segments)  # type: ignore[union-attr]
        except BaseException:  # the storage refused them: the bins before stay
            if made is not None:
                made.release()
            raise
        if self._bins is not None:
            self._bins.release()
        self._bins = made

    def radius(self, shape: tuple[int, int] | None) -> float | None:
        """R in scaled units for an image of ``shape`` (the kernel's own when None); None
        without a radius (idw, or no size to take the diagonal of)."""
        return self._radius(shape, self.scaling.scale)

    def _radius(self, shape: tuple[int, int] | None, scale: float) -> float | None:
        config = self.config
        if not config.uses_radius:
            return None
        radius = config.radius
        if radius is None:
            shape = shape if shape is not None else self.shape
            if shape is None:
                return None
            radius = image_diagonal(shape)
        return radius / scale

    # -- what the passes need -----------------------------------------------------------

    @property
    def count(self) -> int:
        """Point handles."""
        return len(self._packed)

    @property
    def sources(self) -> np.ndarray:
        """(N, 2) float64: the point handles' source positions, pixels (as the GPU has them,
        rounded to float32 in scaled coordinates)."""
        return self.scaling.from_gpu(self._packed[:, :2])

    @property
    def segment_sources(self) -> np.ndarray:
        """(S, 2, 2) float64: the segment handles' source end points, pixels (as the GPU has
        them)."""
        rows = self._segments[0::2].astype(np.float64).reshape(-1, 2)
        return self.scaling.from_gpu(rows).reshape(-1, 2, 2)

    @property
    def extent(self) -> float:
        """Half the largest side of the box of the handles (points and segment end points, as
        the GPU has them), pixels; the scale without any."""
        return self._extent * self.scaling.scale

    @property
    def segments(self) -> int:
        """Segment handles."""
        return len(self._segments) // 2

    @property
    def storage(self) -> str:
        """The handle storage in use (``auto`` resolved for the handle count)."""
        return self._storage.name if self._storage is not None else self._storage_request

    @property
    def bins(self) -> HandleBins | None:
        """The spatial bins in use, or None."""
        return self._bins.bins if self._bins is not None else None

    @property
    def walks_checked(self) -> bool:
        """Whether the passes that evaluate f check that a driver's cap on loop iterations
        left each evaluation whole (:func:`glmls.engine.loops.walks_checked`): bins whose
        walks could exceed it."""
        bins = self.bins
        return bins is not None and walks_checked(
            self.gl.loop_limit,
            bins,
            gaussian=self.config.weight_entry.support == "gaussian",
            full=self.config.transform == "affine",
        )

    def defines(self, *, binned: bool | None = None) -> dict[str, object]:
        """The ``#define`` values of ``glmls/shaders/mls/`` for this configuration (``binned``
        False: visiting every handle, bins or not; None: through the bins there are)."""
        binned = self._bins is not None if binned is None else binned and self._bins is not None
        storage = self._storage
        unroll = storage is not None and storage.unrolls and not binned
        return config_defines(
            self.config,
            unroll=unroll_slots(self.count) if unroll else 0,
            binned=binned,
            segments=self.segments > 0,
        ) | dict(storage.defines if storage is not None else {})

    def uniforms(self, shape: tuple[int, int] | None = None) -> dict[str, float | bool]:
        """The uniforms of ``glmls/shaders/mls/core.glsl`` for an image of ``shape`` (scaled
        units; the kernel's own shape when None)."""
        c = self.config
        scale = self.scaling.scale
        radius = c.resolve_radius(shape if shape is not None else self.shape)
        weighting = weight_uniforms(c, scale, radius, extent=self._extent)
        segments = segment_config(c)  # the weight of segment handles
        # idw's s so small that float32 makes it infinite at d = 0: as s = 0
        snapping = replace(c, s=0.0) if weighting["u_tiny_s"] else c
        return weighting | {
            "u_snap_segments": segments_interpolate(snapping),
            "u_hit2_segments": segment_hit2(snapping, scale, self._extent),
            "u_segment_sigma": 1.0 if segments is c else 0.0,
            "u_segment_panel_width": segment_panel_width(c),
            "u_length_unit": scale,
        }

    def program(self, entry: str, defines: Mapping[str, object] | None = None):
        """The compute program of ``entry`` (a pass including ``mls/visit.glsl``) with this
        kernel's defines and ``defines``."""
        self.check_alive()
        bins = self._bins.bins if self._bins is not None else None
        gaussian = self.config.weight_entry.support == "gaussian"
        full = self.config.transform == "affine"
        limit = self.gl.loop_limit
        binned = bins is not None and not newton_visits_all(
            limit, entry, bins, count=self.count, gaussian=gaussian, full=full
        )
        evaluation = 0
        if binned and limit is not None:
            evaluation = bins.evaluation_loops(gaussian=gaussian, full=full)  # type: ignore[union-attr]
        check_loop_budget(self.gl, entry, self.count, binned=binned, evaluation=evaluation)
        with self.gl.use():
            return self.gl.compute(entry, self.defines(binned=binned) | dict(defines or {}))

    def bind(self, program: moderngl.ComputeShader, shape: tuple[int, int] | None = None) -> None:
        """Make ``program`` evaluate this kernel's f for an image of ``shape``: uniforms,
        handles and bins (built again first if that image gives another radius)."""
        self.check_alive()
        with self.gl.use():
            if self._bins is not None:
                radius = self.radius(shape)
                if radius != self._bins.radius:  # another image size: another radius
                    bins = self._plan_bins(self._packed, self._segments, radius, True, rebuild=True)
                    self._write(radius, bins)
            set_uniforms(program, self.uniforms(shape))
            self._storage.bind(program)  # type: ignore[union-attr]
            if self._bins is not None:
                self._bins.bind(program)

    # -- life -----------------------------------------------------------------------------

    def check_alive(self) -> None:
        """``ReleasedError`` once released (or its context), ``GLUnavailableError`` in a
        process forked from the one that made it."""
        if self._released:
            raise ReleasedError("this MLS has been released; create a new one")
        self.gl.check_usable()

    @property
    def released(self) -> bool:
        return self._released

    def release(self) -> None:
        """Free the handle storage, the bins and the scratch buffers. Idempotent."""
        if self._released:
            return
        if self.gl.usable:
            with self.gl.use():
                if self._storage is not None:
                    self._storage.release()
                if self._bins is not None:
                    self._bins.release()
        self.scratch.release()
        self._released = True
