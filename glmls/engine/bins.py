"""A spatial grid of bins over the handles, so that a point visits only the handles in reach.

For the weights with an influence radius R (support ``radius`` in ``glmls.core.weights``:
w = 0 for d >= R; support ``gaussian``: cut where the weight is negligible), the handles are
sorted by the bin of a square grid that contains them (on the CPU: an argsort, ~2 ms for
65,536 handles) and the shader (``glmls/shaders/mls/visit.glsl`` with ``MLS_BINS``) walks only
the bins that meet the square of half-side ``reach`` around the point: one contiguous run of
sorted handles per bin row, from a table of where each bin's handles start (a storage buffer,
binding ``BIN_STARTS``).

Gaussian cut: measured against the nearest handles apart from the nearest one's place (at
squared distance g, the least above the nearest's), whose moments about the nearest handle
decide M (the nearest's own are 0): a handle is left out when its weight is below tau W1 / N
of theirs: d^2 > g + R^2 ln(N / (tau W1)), N the handle count, tau = GAUSSIAN_TOLERANCE =
2^-24 (float32's unit roundoff, in ``glmls.core.weights``) and W1 >= 1 a lower bound of the
total weight of the handles apart, relative to theirs: the weights of those in the bins next
to the point (all kept), or 1. At most N handles are left out, so the left-out weight is
below tau W1 <= tau W: under one float32 rounding of the moments' total weight, also in a
gaussian's far tail, where the nearest outweighs the others by e^30 and more. The denser
the handles, the larger W1 and the nearer the cut (65,536 handles on a
1024^2 lattice, R = 16 px: W1 ~ 25, the cut at ~4.95 R instead of 5.3 R with W1 = 1). Points
with no handle within R sqrt(ln(N / tau)) look on in squares of twice the side until the
nearest, and the nearest apart from its place, are certain.

Segment handles go into every bin their reach touches (the bins within ``reach`` of the
segment, plus a bin's half-diagonal): a point visits the segments listed in its own bin only,
each once. The grid then covers the segments' reach too, so that a point beyond it is out of
every segment's reach. The gaussian's cut is relative to the nearest handles: where it reaches
farther than the bins list segments for (far from every handle), a point visits every segment.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import moderngl
import numpy as np

from ..core.handles import point_bounds
from ..core.weights import REGISTRY, gaussian_cut
from ..gl import bindings
from ..gl.dispatch import set_uniforms

#: Bin side as a fraction of the radius R (for gaussian too, whose reach is ~5 R), at most:
#: smaller bins fit the disc of reach better (fewer handles visited) but cost more rows.
BIN_FRACTION = 0.5
#: ... and at least (dense handles: many tiny rows cost more than the handles they spare).
MIN_BIN_FRACTION = 0.1
#: Between the two, the bin side is this many times the handles' mean spacing (the side of
#: the square per handle over their bounding box): about one handle per bin, where the
#: chords of the disc (mls/visit.glsl) fit it best for their cost (65,536 handles on a 1024^2
#: lattice, R = 24 px: 4 px bins, 2x faster than R / 2).
BIN_SPACING = 1.0
#: The nearest handle is first looked for within this many mean spacings (at least a bin
#: side), then in squares of twice the side (see mls/visit.glsl).
NEAR_SPACING = 1.0
#: At most this many bins per side (the start table stays <= 4 MB).
MAX_BINS = 1024
#: Automatic binning from this many handles on, and only when the reach is below this
#: fraction of the handles' extent (else every point visits most bins anyway).
AUTO_MIN_HANDLES = 256
AUTO_MAX_REACH = 0.25


@dataclass(frozen=True)
class HandleBins:
    """Handles sorted by bin: ``order`` sorts the point handles, ``starts[b]`` is where bin
    b's handles begin in that order (bins row-major, ``starts[-1]`` = N); bin b lists the
    segment handles ``segment_list[segment_starts[b]:segment_starts[b + 1]]``."""

    order: np.ndarray
    starts: np.ndarray
    origin: tuple[float, float]
    size: float
    dims: tuple[int, int]
    reach: float
    near: float
    segment_starts: np.ndarray
    segment_list: np.ndarray
    handles: int
    #: The segment handles (each listed in every bin it reaches: ``segment_list`` repeats
    #: them), which a visit of every handle walks once each.
    segment_count: int = 0

    @classmethod
    def build(
        cls,
        points: np.ndarray,
        reach_: float,
        radius: float,
        segments: np.ndarray | None = None,
    ) -> HandleBins:
        """Bins for ``points`` (N, 2) and ``segments`` (S, 2, 2) in scaled coordinates, of
        side BIN_SPACING x the points' mean spacing, within MIN_BIN_FRACTION and BIN_FRACTION
        x ``radius`` (more where the bins would exceed MAX_BINS per side), for points that
        look as far as ``reach_``; the nearest handle is first looked for within ``near``,
        NEAR_SPACING x the spacing (at least a bin side, at most the reach)."""
        segments = np.zeros((0, 2, 2)) if segments is None else segments
        everything = np.concatenate([points, segments.reshape(-1, 2)])
        lo, hi = point_bounds(everything) if len(everything) else (np.zeros(2), np.zeros(2))
        if len(segments):
            lo, hi = lo - reach_, hi + reach_  # a point beyond is out of every segment's reach
        extent = float(max((hi - lo).max(), 1e-12))
        spacing = _mean_spacing(points)
        size = min(max(BIN_SPACING * spacing, radius * MIN_BIN_FRACTION), radius * BIN_FRACTION)
        # at most the extent (a huge radius: one bin, a finite size), at least MAX_BINS per side
        size = max(min(size, extent), extent / (MAX_BINS - 1))
        near = min(max(NEAR_SPACING * spacing, size), max(reach_, size))
        dims = np.minimum(np.floor((hi - lo) / size).astype(int) + 1, MAX_BINS)
        cell = np.minimum(np.floor((points - lo) / size).astype(int), dims - 1)
        key = cell[:, 1] * dims[0] + cell[:, 0]
        order = np.argsort(key, kind="stable")
        counts = np.bincount(key, minlength=int(dims[0] * dims[1]))
        starts = np.concatenate([[0], np.cumsum(counts)]).astype(np.int32)
        segment_starts, segment_list = _segment_lists(segments, lo, size, dims, reach_)
        return cls(
            order,
            starts,
            (float(lo[0]), float(lo[1])),
            float(size),
            (int(dims[0]), int(dims[1])),
            float(reach_),
            float(near),
            segment_starts,
            segment_list,
            len(points) + len(segments),
            len(segments),
        )

    @functools.cached_property
    def walks(self) -> tuple[int, int]:
        """The most loop iterations of one walk over the bins that a square around a point
        meets, of half-side max(reach, near) and of twice that: a row and an empty run per
        bin row, and the handles, one an iteration. Computed when first asked (where a
        driver caps loop iterations: :meth:`evaluation_loops`)."""
        columns, rows = self.dims
        counts = np.diff(self.starts).reshape(rows, columns)
        half = max(self.reach, self.near)
        spans = [int(min(math.floor(k * half / self.size) + 2, max(self.dims))) for k in (2, 4)]
        most = _most_in_windows(counts, *spans)
        return 2 * spans[0] + most[0], 2 * spans[1] + most[1]

    def evaluation_loops(self, *, gaussian: bool, full: bool, bound: bool = False) -> int:
        """The loop iterations of one evaluation of f through these bins (``mls_eval`` of
        ``glmls/shaders/mls/visit.glsl``) at the point where the handles crowd most, for one
        lane (a CPU renderer counts a vector of lanes together: lanes walking apart add up):
        what decides, on a driver that caps an invocation's loop iterations, whether the bins
        serve (:mod:`glmls.engine.loops`). A point walks the bins of a square about the
        nearest handle's spacing, then, where that finds no certain nearest, of half-side up
        to twice the reach, and of the reach for the moments (and for affine's float64
        moments where ``full``), and lists the segments of its bin as often. The
        ``gaussian`` walks its cut's weight bound too, and a point whose search for the
        nearest doubles its square past twice the reach, or whose cut reaches that far,
        visits every handle instead, sixteen a loop iteration (four in the float64 moments),
        and every segment. For the gaussian an estimate, for a point in the handles' midst:
        one whose nearest handle lies far from the others doubles its square several
        times; ``bound``: the most, counting those squares' walks."""
        walk, wide = self.walks
        segments = int(np.diff(self.segment_starts).max()) if len(self.segment_list) else 0
        segments *= 3 + full
        if not gaussian:
            return (2 + full) * walk + wide + segments + 48
        everything = 2 * (self.handles // 16 + 1) + full * (self.handles // 4 + 1)
        everything += (2 + full) * self.segment_count + 48
        loops = (3 + full) * walk + wide + segments + 48
        if bound:
            doublings = min(40, math.ceil(math.log2(2.0 * self.reach / self.near + 1.0)) + 2)
            loops = (doublings + 2 + full) * wide + walk + segments + 48
        return int(max(loops, everything))

    def table(self) -> np.ndarray:
        """The int32 table on the GPU: point starts, segment starts, segment list."""
        return np.concatenate([self.starts, self.segment_starts, self.segment_list]).astype(
            np.int32
        )

    def uniforms(self) -> dict[str, object]:
        return {
            "u_bin_origin": self.origin,
            "u_bin_size": self.size,
            "u_bin_dims": self.dims,
            "u_bin_reach": self.reach,
            "u_bin_near": self.near,
            "u_bin_cut": gaussian_cut(self.handles),
            "u_bin_segment_starts": len(self.starts),
            "u_bin_segment_list": len(self.starts) + len(self.segment_starts),
        }


def _most_in_windows(counts: np.ndarray, *spans: int) -> list[int]:
    """For each span, the most of ``counts`` (bins, rows x columns) in any span x span block
    of bins (the whole grid where it is smaller)."""
    total = np.zeros((counts.shape[0] + 1, counts.shape[1] + 1), np.int64)
    total[1:, 1:] = counts.cumsum(0).cumsum(1)
    most = []
    for span in spans:
        rows, columns = min(span, counts.shape[0]), min(span, counts.shape[1])
        block = (
            total[rows:, columns:]
            - total[:-rows, columns:]
            - total[rows:, :-columns]
            + total[:-rows, :-columns]
        )
        most.append(int(block.max()))
    return most


def _mean_spacing(points: np.ndarray) -> float:
    """The side of the square per point over the points' bounding box (infinite for < 2
    points: the bins are then R / 2; points on a line: their extent per point)."""
    if len(points) < 2:
        return float("inf")
    lo, hi = point_bounds(points)
    width, height = hi - lo
    area = width * height if min(width, height) > 0 else max(width, height) ** 2
    return float(np.sqrt(area / len(points)))


def _segment_lists(
    segments: np.ndarray, lo: np.ndarray, size: float, dims: np.ndarray, reach: float
) -> tuple[np.ndarray, np.ndarray]:
    """For each bin (row-major) the segments within ``reach`` of some point of it, as CSR
    (starts, list): each segment's candidate bins are those of its bounding box grown by the
    reach, kept where the distance from the bin's centre to the segment is at most the reach
    plus the bin's half-diagonal."""
    bins, owners = [], []
    half_diagonal = size * np.sqrt(0.5)
    for s, (a, b) in enumerate(segments):
        first = np.clip(np.floor((np.minimum(a, b) - reach - lo) / size).astype(int), 0, dims - 1)
        last = np.clip(np.floor((np.maximum(a, b) + reach - lo) / size).astype(int), 0, dims - 1)
        ix, iy = np.meshgrid(np.arange(first[0], last[0] + 1), np.arange(first[1], last[1] + 1))
        centres = lo + (np.stack([ix.ravel(), iy.ravel()], axis=1) + 0.5) * size
        ab = b - a
        t = np.clip(((centres - a) @ ab) / (ab @ ab), 0.0, 1.0)
        distance = np.hypot(*(centres - a - t[:, None] * ab).T)
        keep = distance <= reach + half_diagonal
        bins.append(iy.ravel()[keep] * dims[0] + ix.ravel()[keep])
        owners.append(np.full(int(keep.sum()), s))
    count = int(dims[0] * dims[1])
    if not bins:
        return np.zeros(count + 1, np.int32), np.zeros(0, np.int32)
    key = np.concatenate(bins)
    owner = np.concatenate(owners)
    order = np.argsort(key, kind="stable")
    starts = np.concatenate([[0], np.cumsum(np.bincount(key, minlength=count))])
    return starts.astype(np.int32), owner[order].astype(np.int32)


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
        self._buffer: moderngl.Buffer | None = ctx.buffer(bins.table().tobytes())

    def bind(self, program: moderngl.ComputeShader | moderngl.Program) -> None:
        if self._buffer is None:
            raise RuntimeError("the bin table was released")
        self._buffer.bind_to_storage_buffer(bindings.BIN_STARTS.index)
        set_uniforms(program, self.bins.uniforms())

    def release(self) -> None:
        if self._buffer is not None:
            self._buffer.release()
            self._buffer = None
