"""A spatial grid of bins over the handles, so that a point visits only the handles in reach.

For the weights with an influence radius R (support ``radius`` in ``glmls.core.weights``:
w = 0 for d >= R; support ``gaussian``: cut where the weight is negligible), the handles are
sorted by the bin of a square grid that contains them (on the CPU: an argsort, ~10 ms for
65,536 handles) and the shader (``glmls/shaders/mls/visit.glsl`` with ``MLS_BINS``) walks only
the bins that meet the square of half-side ``reach`` around the point: one contiguous run of
sorted handles per bin row, from a table of where each bin's handles start (a storage buffer,
binding ``BIN_STARTS``).

Gaussian cut: weights are normalised so that the nearest handle's is 1 (it is the largest),
and a handle is left out when its weight is below tau W1 / N: d^2 > m + R^2 ln(N / (tau W1)),
m the nearest's squared distance, N the handle count, tau = GAUSSIAN_TOLERANCE = 2^-24
(float32's unit roundoff, in ``glmls.core.weights``) and W1 >= 1 a lower bound of the total
weight: the weights of the handles in the bins next to the point (all kept), or 1 (the
nearest alone). At most N handles
are left out, so the left-out weight is below tau W1 <= tau W: under one float32 rounding of
the total. The denser the handles, the larger W1 and the nearer the cut (65,536 handles on a
1024^2 lattice, R = 16 px: W1 ~ 25, the cut at ~4.95 R instead of 5.3 R with W1 = 1). Points
with no handle within R sqrt(ln(N / tau)) look on in squares of twice the side until the
nearest is certain.
"""

from __future__ import annotations

from dataclasses import dataclass

import moderngl
import numpy as np

from ..core.handles import point_bounds
from ..core.weights import REGISTRY, gaussian_cut
from ..gl import bindings
from ..gl.dispatch import set_uniforms

#: Bin side as a fraction of the radius R (for gaussian too, whose reach is ~5 R):
#: smaller bins fit the disc of reach better (fewer handles visited) but cost more rows, and
#: the nearest handle is first looked for within one bin side (see mls/visit.glsl).
BIN_FRACTION = 0.5
#: At most this many bins per side (the start table stays <= 4 MB).
MAX_BINS = 1024
#: Automatic binning from this many handles on, and only when the reach is below this
#: fraction of the handles' extent (else every point visits most bins anyway).
AUTO_MIN_HANDLES = 256
AUTO_MAX_REACH = 0.25


@dataclass(frozen=True)
class HandleBins:
    """Handles sorted by bin: ``order`` sorts the handles, ``starts[b]`` is where bin b's
    handles begin in that order (bins row-major, ``starts[-1]`` = N)."""

    order: np.ndarray
    starts: np.ndarray
    origin: tuple[float, float]
    size: float
    dims: tuple[int, int]
    reach: float

    @classmethod
    def build(cls, points: np.ndarray, reach_: float, radius: float) -> HandleBins:
        """Bins for ``points`` (N, 2) in scaled coordinates, of side BIN_FRACTION x ``radius``
        (more where the bins would exceed MAX_BINS per side), for points that look as far as
        ``reach_``."""
        lo, hi = point_bounds(points) if len(points) else (np.zeros(2), np.zeros(2))
        extent = float(max((hi - lo).max(), 1e-12))
        # at most the extent (a huge radius: one bin, a finite size), at least MAX_BINS per side
        size = max(min(radius * BIN_FRACTION, extent), extent / (MAX_BINS - 1))
        dims = np.minimum(np.floor((hi - lo) / size).astype(int) + 1, MAX_BINS)
        cell = np.minimum(np.floor((points - lo) / size).astype(int), dims - 1)
        key = cell[:, 1] * dims[0] + cell[:, 0]
        order = np.argsort(key, kind="stable")
        counts = np.bincount(key, minlength=int(dims[0] * dims[1]))
        starts = np.concatenate([[0], np.cumsum(counts)]).astype(np.int32)
        return cls(
            order,
            starts,
            (float(lo[0]), float(lo[1])),
            float(size),
            (int(dims[0]), int(dims[1])),
            float(reach_),
        )

    def uniforms(self) -> dict[str, object]:
        return {
            "u_bin_origin": self.origin,
            "u_bin_size": self.size,
            "u_bin_dims": self.dims,
            "u_bin_reach": self.reach,
            "u_bin_cut": gaussian_cut(len(self.order)),
        }


def worth_binning(weight: str, radius: float | None, points: np.ndarray) -> bool:
    """The automatic choice: many handles and a reach well inside their extent."""
    if radius is None or len(points) < AUTO_MIN_HANDLES:
        return False
    reach = REGISTRY[weight].reach(radius, len(points))
    if reach is None:
        return False
    lo, hi = point_bounds(points)
    extent = float((hi - lo).max())
    return reach < AUTO_MAX_REACH * extent


class BinBuffer:
    """The start table of :class:`HandleBins` on the GPU (binding ``BIN_STARTS``) and its
    uniforms."""

    def __init__(self, ctx: moderngl.Context, bins: HandleBins, *, radius: float) -> None:
        self.bins = bins
        self.radius = radius  # the scaled radius the bins were built for
        self._buffer: moderngl.Buffer | None = ctx.buffer(bins.starts.tobytes())

    def bind(self, program: moderngl.ComputeShader | moderngl.Program) -> None:
        if self._buffer is None:
            raise RuntimeError("the bin table was released")
        self._buffer.bind_to_storage_buffer(bindings.BIN_STARTS.index)
        set_uniforms(program, self.bins.uniforms())

    def release(self) -> None:
        if self._buffer is not None:
            self._buffer.release()
            self._buffer = None
