"""How the volume construction cuts its work into pieces: the output into slabs (of whole
slices, or boxes of columns and rows of them where a slice exceeds a texture's side or a
storage buffer), and the sampling of a source that one texture does not hold into pieces that
each hold a box of it (:class:`~.texture.SourceTexture`): boxes of a band's cells for the
cells method, boxes of the voxels the points read first for the backward method. Every piece
computes its voxels as the one-piece construction does: the cuts change no voxel."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from ..gl.context import GLContext
from .bands import Slab
from .frame import CornerLattice, VolumeFrame
from .options import VolumeOptions
from .texture import Box, SourceTexture, border_runs, runs_size

__all__ = [
    "SLICE_LIMIT",
    "AxisRange",
    "CellPiece",
    "axis_ranges",
    "band_pieces",
    "even_piece",
    "hold_cells",
    "plan_slabs",
    "sample_passes",
    "slab_region",
    "used_pieces",
]


def plan_slabs(
    gl: GLContext,
    frame: VolumeFrame,
    voxel_bytes: int,
    slab_bytes: int,
    side: int | None = None,
    reach: int = 0,
) -> Iterator[Slab]:
    """The slabs of ``frame``: as many slices as keep ``voxel_bytes`` a voxel within
    ``slab_bytes`` and the GL limits (storage buffer, 3D texture side, or ``side`` where
    smaller); of whole slices where one fits both limits, else of boxes of columns and
    rows of them, as even as they can be, that do. ``reach``: the voxels about a slab whose
    points its buffers hold too, within the frame (the backward method's fold pass,
    :mod:`.folds`): a slab of whole slices computes ``reach`` slices past it (the slab
    before it computed those before it), a box of columns and rows ``reach`` voxels past
    each of its sides."""
    depth_all, height, width = frame.shape
    limit = int(gl.mgl.info["GL_MAX_3D_TEXTURE_SIZE"])
    side = limit if side is None else min(side, limit)
    max_buffer = gl.limits["max_ssbo_size"]
    tile_width = even_piece(width, side)
    wide = _grown(tile_width, width, reach)
    if wide * voxel_bytes > max_buffer:
        raise ValueError(
            f"a row of {wide} output voxels needs {wide * voxel_bytes} bytes, "
            "more than a GL storage buffer holds on this device"
        )
    tile_height = _tile_height(frame, tile_width, side, voxel_bytes, max_buffer, reach)
    while tile_height < 1:  # a box of one row with its reach does not fit: narrower boxes
        if tile_width == 1:
            raise ValueError(
                f"a box of one output voxel and {reach} more on each side needs "
                f"{voxel_bytes * (1 + 2 * reach) ** 3} bytes, more than a GL storage buffer "
                "holds on this device"
            )
        tile_width = even_piece(width, tile_width // 2)
        tile_height = _tile_height(frame, tile_width, side, voxel_bytes, max_buffer, reach)
    whole = tile_width == width and tile_height == height
    per_slice = wide * _grown(tile_height, height, reach) * voxel_bytes
    fit = min(slab_bytes, max_buffer) // per_slice
    if depth_all <= min(side, fit):
        depth = depth_all
    else:  # slices past the slab too: those of the next (whole slices), both sides (boxes)
        depth = max(1, min(side, fit - (reach if whole else 2 * reach)))
    for first in range(0, depth_all, depth):
        for row in range(0, height, tile_height):
            for column in range(0, width, tile_width):
                yield Slab(
                    first,
                    min(depth, depth_all - first),
                    min(tile_width, width - column),
                    min(tile_height, height - row),
                    column,
                    row,
                )


def _tile_height(
    frame: VolumeFrame, tile_width: int, side: int, voxel_bytes: int, max_buffer: int, reach: int
) -> int:
    """The rows of the slabs' boxes ``tile_width`` columns wide: whole slices where a slab of
    one slice and ``reach`` more (the next slab's) fits a storage buffer of ``max_buffer``
    bytes, else as many rows as keep a box of one slice with ``reach`` voxels more on every
    side within it; 0 where not one row does."""
    _, height, width = frame.shape
    wide = _grown(tile_width, width, reach)
    slab = (1 + reach) * height * wide * voxel_bytes
    if tile_width == width and height <= side and slab <= max_buffer:
        return height
    rows = max_buffer // (wide * voxel_bytes * (1 + 2 * reach)) - 2 * reach
    return even_piece(height, min(side, rows)) if rows >= 1 else 0


def _grown(side: int, whole: int, reach: int) -> int:
    """A piece of ``side`` of ``whole`` voxels with ``reach`` more each side, within it."""
    return side if side >= whole else min(whole, side + 2 * reach)


def even_piece(n: int, most: int) -> int:
    """The side of the fewest, most even pieces of ``n`` of at most ``most`` each."""
    count = -(-n // max(1, most))
    return -(-n // count)


def slab_region(slab: Slab) -> tuple[slice, slice, slice]:
    """``slab``'s voxels of the output array (D, H, W, ...)."""
    return (
        slice(slab.first, slab.first + slab.depth),
        slice(slab.row, slab.row + slab.height),
        slice(slab.column, slab.column + slab.width),
    )


#: A band (first cell layer, layers), a piece of it (first layer, layers) and the piece's
#: cells of a layer (first column, end column, first row, end row).
CellPiece = tuple[tuple[int, int], tuple[int, int], tuple[int, int, int, int]]

_AXES = ("source columns", "source rows", "source slices")


def _too_small(axis: int, what: str, most: int) -> ValueError:
    option = "texture_bytes" if axis == 2 else "texture_side"
    return ValueError(
        f"{what} {_AXES[axis]}, more than one texture holds ({most}); give a larger {option} "
        "(SlabOptions)"
    )


def _spans(count: int, step: int) -> list[tuple[int, int]]:
    """``0 .. count - 1`` in spans (first, end) of at most ``step``."""
    return [(first, min(first + step, count)) for first in range(0, max(count, 1), step)]


def band_pieces(
    bands: list[tuple[int, int]], lattice: CornerLattice, source: SourceTexture | None
) -> list[CellPiece]:
    """Each of ``bands`` (first cell layer, layers) with its pieces, boxes of its cells whose
    voxels (``grid`` a cell and one more either side, for trilinear interpolation) one texture
    holds along each axis (:data:`CellPiece`); the band itself, every cell of its layers, its
    one piece where the whole source is held."""
    ncx, ncy, _ = lattice.cells
    every = (0, ncx, 0, ncy)
    if source is None or source.whole:
        return [(band, band, every) for band in bands]
    grid = lattice.grid

    def step(axis: int) -> int:
        most = source.limits[axis]
        if (most - 2) // grid < 1:
            raise _too_small(axis, f"a layer of cells of grid {grid} samples {grid + 2}", most)
        return (most - 2) // grid

    columns = [(0, ncx)] if source.fits(0) else _spans(ncx, step(0))
    rows = [(0, ncy)] if source.fits(1) else _spans(ncy, step(1))
    pieces: list[CellPiece] = []
    for first, layers in bands:
        if layers == 0:
            pieces.append(((first, layers), (first, layers), every))
            continue
        if source.fits(2):
            layer_pieces = [(first, layers)]
        else:
            each = step(2)
            layer_pieces = [
                (f, min(each, first + layers - f)) for f in range(first, first + layers, each)
            ]
        for piece in layer_pieces:
            for row_first, row_end in rows:
                for column_first, column_end in columns:
                    cells = (column_first, column_end, row_first, row_end)
                    pieces.append(((first, layers), piece, cells))
    return pieces


def used_pieces(
    pieces: list[CellPiece], lattice: CornerLattice, cells: np.ndarray
) -> list[CellPiece]:
    """Those of ``pieces`` that hold one of ``cells`` (cell numbers in scan order, the
    margin's after the volume's as the raster pass ranks them), and the first, which writes
    the voxels no cell covers."""
    if not pieces:
        return pieces
    ncx, ncy, ncz = lattice.cells
    index = cells.astype(np.int64)
    index = np.where(index >= ncx * ncy * ncz, index - ncx * ncy * ncz, index)
    x, y, z = index % ncx, (index // ncx) % ncy, index // (ncx * ncy)
    columns = np.array(sorted({piece[2][0] for piece in pieces}), np.int64)
    rows = np.array(sorted({piece[2][2] for piece in pieces}), np.int64)
    column = np.searchsorted(columns, x, side="right") - 1
    row = np.searchsorted(rows, y, side="right") - 1
    codes = np.unique((row * len(columns) + column) * (ncz + 1) + z)
    if len(codes) == 0:
        return pieces[:1]
    starts = np.array([(p[1][0], p[1][1], p[2][0], p[2][2]) for p in pieces], np.int64)
    base = np.searchsorted(rows, starts[:, 3]) * len(columns) + np.searchsorted(
        columns, starts[:, 2]
    )
    low = base * (ncz + 1) + starts[:, 0]
    at = np.minimum(np.searchsorted(codes, low), len(codes) - 1)
    used = (codes[at] >= low) & (codes[at] < low + starts[:, 1])
    used[0] = True
    return [piece for piece, keep in zip(pieces, used.tolist(), strict=True) if keep]


def hold_cells(
    source: SourceTexture,
    lattice: CornerLattice,
    layers: tuple[int, int],
    cells: tuple[int, int, int, int],
    border: str,
) -> dict[str, tuple[int, int, int, int]]:
    """Hold the source voxels that the cells of ``cells`` (first column, end column, first
    row, end row) of layers ``layers`` (first, count) sample (their voxels, one more each side
    for trilinear, by the border rule); returns the sampling shader's uniforms of the runs."""
    first, count = layers
    if count == 0:  # nothing to sample: the fewest voxels
        box = tuple(source.runs(axis, 0, 0, border) for axis in range(3))
        return source.hold(box)  # type: ignore[arg-type]
    spans = ((cells[0], cells[1]), (cells[2], cells[3]), (first, first + count))
    offset = lattice.voxel_first
    box = tuple(
        source.runs(
            axis, low * lattice.grid + offset[axis] - 1, end * lattice.grid + offset[axis], border
        )
        for axis, (low, end) in enumerate(spans)
    )
    return source.hold(box)  # type: ignore[arg-type]


#: The bounds of the first voxels the sampling shader computes (volume_first_voxel).
SLICE_LIMIT = 1 << 30

#: Per axis of a pass: the range of first voxels (low, high) and the runs held.
AxisRange = tuple[int, int, list[tuple[int, int]]]


def axis_ranges(found: np.ndarray, n: int, most: int, border: str, axis: int) -> list[AxisRange]:
    """The ranges of the sorted first indices ``found`` along ``axis`` of ``n`` voxels whose
    voxels one texture holds (at most ``most``): cut into runs greedily; range k is
    [start_k - 1, start_(k+1) - 2] (the ends unbounded) and holds [start_k - 1, end_k + 2]."""

    def runs(start: int, end: int) -> list[tuple[int, int]]:
        return border_runs(start - 1, end + 2, n, border)

    if runs_size(runs(int(found[0]), int(found[0]))) > most:
        raise _too_small(axis, "a voxel samples up to 4", most)
    groups: list[tuple[int, int]] = []
    start = end = int(found[0])
    for value in found[1:].tolist():
        if runs_size(runs(start, value)) <= most:
            end = value
            continue
        groups.append((start, end))
        start = end = value
    groups.append((start, end))
    ranges = []
    for index, (start, end) in enumerate(groups):
        low = -SLICE_LIMIT if index == 0 else start - 1
        high = SLICE_LIMIT if index == len(groups) - 1 else groups[index + 1][0] - 2
        ranges.append((low, high, runs(start, end)))
    return ranges


def sample_passes(
    source: SourceTexture, points: np.ndarray, options: VolumeOptions
) -> list[tuple[tuple[int, int, int], tuple[int, int, int], Box]]:
    """The backward method's sampling passes over a slab whose source points are
    ``points`` ((voxels, 4) float32: x, y, z, and w >= 0 where found): per pass, the box of
    first voxels (``volume_first_voxel``, its lowest and highest (x, y, z)) of the voxels it
    samples and the source voxels it holds (runs of columns, rows and slices). One pass
    holding the volume where it fits; else along each axis that one texture does not hold
    whole, the first indices of the points found are cut into ranges whose voxels one
    texture holds (:func:`axis_ranges`), which tile every integer, so that each voxel is
    sampled in exactly one pass, and there is a pass for each box of ranges that holds a
    voxel. An index computed here from the float32 point may differ by one from the shader's
    (its snap to voxel centres), which each range's voxels allow for; so the boxes taken are
    those of each voxel's indices and their neighbours."""
    depth, height, width = source.source.shape
    sizes = (width, height, depth)
    unbounded = (-SLICE_LIMIT,) * 3, (SLICE_LIMIT,) * 3
    if source.whole:
        return [(*unbounded, tuple([(0, n - 1)] for n in sizes))]  # type: ignore[list-item]
    found = points[points[:, 3] >= 0, :3]
    if options.interpolation != "linear":
        found = found + np.float32(0.5)
    firsts = np.clip(np.floor(found), -SLICE_LIMIT, SLICE_LIMIT).astype(np.int64)
    if len(firsts) == 0:
        box = tuple(source.runs(axis, 0, 0, options.border) for axis in range(3))
        return [(*unbounded, box)]  # type: ignore[list-item]
    axes: list[list[AxisRange]] = []
    for axis, n in enumerate(sizes):
        if source.fits(axis):
            axes.append([(-SLICE_LIMIT, SLICE_LIMIT, [(0, n - 1)])])
        else:
            values = np.unique(firsts[:, axis])
            axes.append(axis_ranges(values, n, source.limits[axis], options.border, axis))
    # along each axis cut in ranges, those of a voxel's index - 1 .. + 1: (first, count - 1)
    cut = [axis for axis in range(3) if len(axes[axis]) > 1]
    spans = []
    for axis in cut:
        lows = np.array([low for low, _, _ in axes[axis]], np.int64)
        bound = len(axes[axis]) - 1
        low = np.clip(np.searchsorted(lows, firsts[:, axis] - 1, side="right") - 1, 0, bound)
        high = np.clip(np.searchsorted(lows, firsts[:, axis] + 1, side="right") - 1, 0, bound)
        spans.append(low * 3 + (high - low))
    if not spans:
        kinds = [()]
    elif len(spans) == 1:
        kinds = [(v,) for v in np.unique(spans[0]).tolist()]
    else:
        kinds = [tuple(row) for row in np.unique(np.stack(spans, axis=1), axis=0).tolist()]
    boxes: set[tuple[int, int, int]] = set()
    for kind in kinds:
        around = [range(1)] * 3
        for axis, v in zip(cut, kind, strict=True):
            around[axis] = range(v // 3, v // 3 + v % 3 + 1)
        boxes.update((k, j, i) for k in around[2] for j in around[1] for i in around[0])
    passes = []
    for z, y, x in sorted(boxes):
        chosen = (axes[0][x], axes[1][y], axes[2][z])
        low3 = tuple(r[0] for r in chosen)
        high3 = tuple(r[1] for r in chosen)
        passes.append((low3, high3, tuple(r[2] for r in chosen)))
    return passes  # type: ignore[return-value]
