"""The lattice of points where f is evaluated for an image: one value object for its geometry.

Two kinds, both for an image of ``shape`` (H, W) with pixel centres at integer coordinates:

- ``corners`` (step ``grid``): the pixel-square corners x = -0.5, -0.5 + grid, ..., up to
  W - 0.5 (the last step may be shorter; with a margin, regular to its end), likewise in
  y. The quads of the paper's forward method are its cells; the error field at ``grid`` > 1
  is evaluated there.
- ``centres``: the pixel centres x = 0 .. W - 1, y = 0 .. H - 1 (the simple forward method
  and the error field at ``grid`` = 1).

A ``margin`` of m pixels extends either kind by m pixels past every side of the image (the
border modes of the forward methods: the source continues there by the border rule). The
``shape`` stays the image's, so that f (its default radius) does not depend on the margin.

Every pass asks a :class:`MeshLattice` for its sizes, bands and uniforms instead of working
them out again; the shaders compute point (i, j) as ``min(origin + (i, j) step, last)``
(``glmls/shaders/mls/lattice.glsl``), so that vertices shared by two bands are identical;
the image passes use the lattice's own pixels (``glmls/shaders/common/lattice.glsl``).
"""

from __future__ import annotations

import math
import operator
from collections.abc import Iterable, Iterator
from dataclasses import dataclass

import numpy as np

from .config import check_integer, is_integer
from .handles import COORDINATE_LIMIT, Scaling

__all__ = ["KINDS", "MAX_GRID", "MAX_MARGIN", "MeshLattice", "as_shape", "check_grid"]

KINDS = ("corners", "centres")
#: The largest mesh step (pixels): beyond any image side, and the shaders' integers hold it.
MAX_GRID = 1 << 20
#: The largest margin (pixels) past the image: the shaders' integers hold the lattice's sides.
MAX_MARGIN = 1 << 24


def as_shape(shape: object) -> tuple[int, int]:
    """(H, W) from an image shape ``(H, W)`` or ``(H, W, C)`` of integers
    (:func:`~glmls.core.config.is_integer`: a float such as 5.0 or a bool is a
    ``TypeError``); ``ValueError`` for another length, a side below 1 or beyond
    :data:`~glmls.core.handles.COORDINATE_LIMIT` (the image's pixels are points in the
    coordinate range, and f's float32 scaling spans the image)."""
    if isinstance(shape, (str, bytes)) or not isinstance(shape, (Iterable, np.ndarray)):
        raise TypeError(f"shape must be (H, W) integers, got {shape!r}")
    values = tuple(shape)  # type: ignore[arg-type]
    if len(values) not in (2, 3):
        raise ValueError(f"shape must be (H, W) or (H, W, C), got {shape!r}")
    if not all(is_integer(n) for n in values):
        raise TypeError(f"shape must be (H, W) integers, got {shape!r}")
    dims = tuple(operator.index(n) for n in values)
    if dims[0] < 1 or dims[1] < 1:
        raise ValueError(f"shape must be (H, W) with H, W >= 1, got {shape!r}")
    if max(dims[0], dims[1]) > COORDINATE_LIMIT:
        raise ValueError(
            f"shape must have H, W <= {COORDINATE_LIMIT:.0e} (glmls's coordinate range, pixels), "
            f"got {shape!r}"
        )
    return dims[0], dims[1]


def check_grid(grid: object, unit: str = "pixels") -> int:
    """``grid`` as an int from 1 to :data:`MAX_GRID` (a mesh step in ``unit``: pixels, or a
    volume's voxels): ``TypeError`` for another type than an integer (2.0 too), ``ValueError``
    out of range (:func:`~glmls.core.config.check_integer`)."""
    what = f"an integer from 1 to {MAX_GRID} ({unit})"
    return check_integer("grid", grid, 1, MAX_GRID, what=what)


@dataclass(frozen=True)
class MeshLattice:
    """The evaluation lattice of an image of ``shape`` (H, W): ``corners`` every ``grid``
    pixels, or the pixel ``centres`` (``grid`` 1), ``margin`` pixels past every side. Build
    with :meth:`corners` or :meth:`centres`, which validate."""

    shape: tuple[int, int]
    grid: int = 1
    kind: str = "corners"
    margin: int = 0

    def __post_init__(self) -> None:
        object.__setattr__(self, "shape", as_shape(self.shape))
        object.__setattr__(self, "grid", check_grid(self.grid))
        if self.kind not in KINDS:
            raise ValueError(f"kind must be one of {', '.join(KINDS)}, got {self.kind!r}")
        if self.kind == "centres" and self.grid != 1:
            raise ValueError("the lattice of pixel centres has grid 1")
        object.__setattr__(self, "margin", check_integer("margin", self.margin, 0, MAX_MARGIN))

    @classmethod
    def corners(cls, shape: object, grid: object = 1, *, margin: int = 0) -> MeshLattice:
        return cls(shape, grid, "corners", margin)  # type: ignore[arg-type]

    @classmethod
    def centres(cls, shape: object, *, margin: int = 0) -> MeshLattice:
        return cls(shape, 1, "centres", margin)  # type: ignore[arg-type]

    def with_margin(self, margin: int) -> MeshLattice:
        """This lattice extended ``margin`` pixels past every side of the image."""
        return MeshLattice(self.shape, self.grid, self.kind, margin)

    # -- geometry in pixels ---------------------------------------------------------------

    @property
    def padded_shape(self) -> tuple[int, int]:
        """(H, W) of the lattice's pixel domain: the image and its margin (corners: up to the
        regular lattice's last point, less than ``grid`` further on the far sides)."""
        height, width = self._margined
        if self.margin and self.kind == "corners":
            nx, ny = self.dims
            return (ny - 1) * self.grid, (nx - 1) * self.grid
        return height, width

    @property
    def _margined(self) -> tuple[int, int]:
        height, width = self.shape
        return height + 2 * self.margin, width + 2 * self.margin

    @property
    def offset(self) -> tuple[int, int]:
        """(x, y) of the image pixel that is the lattice's pixel (0, 0)."""
        return -self.margin, -self.margin

    @property
    def dims(self) -> tuple[int, int]:
        """(points per row, rows)."""
        height, width = self._margined
        if self.kind == "centres":
            return width, height
        return math.ceil(width / self.grid) + 1, math.ceil(height / self.grid) + 1

    @property
    def count(self) -> int:
        nx, ny = self.dims
        return nx * ny

    @property
    def cells(self) -> tuple[int, int]:
        """(cells per row, rows of cells) between the points."""
        nx, ny = self.dims
        return nx - 1, ny - 1

    @property
    def origin(self) -> tuple[float, float]:
        """Point (0, 0), image pixels."""
        first = -float(self.margin) - (0.0 if self.kind == "centres" else 0.5)
        return first, first

    @property
    def last(self) -> tuple[float, float]:
        """The last point of the last row, image pixels: every coordinate is clamped to it.
        Without a margin, the image's last corner (the last step may be shorter); with one,
        the regular lattice's last point, at or past the margin's end, so that the cells over
        the image are the same whatever the margin (which grows with the canvas)."""
        height, width = self.shape
        if self.margin and self.kind == "corners":
            nx, ny = self.dims
            first = self.origin[0]
            return first + (nx - 1) * self.grid, first + (ny - 1) * self.grid
        end = self.margin - (1.0 if self.kind == "centres" else 0.5)
        return width + end, height + end

    @property
    def axes(self) -> tuple[np.ndarray, np.ndarray]:
        """x of the points of a row and y of the rows, pixels."""
        nx, ny = self.dims
        (x0, y0), (x1, y1) = self.origin, self.last
        xs = np.minimum(x0 + self.grid * np.arange(nx), x1)
        ys = np.minimum(y0 + self.grid * np.arange(ny), y1)
        return xs, ys

    def points(self) -> np.ndarray:
        """Every point, (rows, points per row, 2) float64 (x, y)."""
        xs, ys = self.axes
        return np.stack(np.meshgrid(xs, ys), axis=-1)

    def boundary(self) -> np.ndarray:
        """The points on the lattice's border, (K, 2) float64 (x, y), each once, in the
        triangles' turning sense: the first row left to right, the last column down, the
        last row back, the first column up."""
        xs, ys = self.axes
        top = np.stack([xs[:-1], np.full(len(xs) - 1, ys[0])], axis=-1)
        right = np.stack([np.full(len(ys) - 1, xs[-1]), ys[:-1]], axis=-1)
        bottom = np.stack([xs[:0:-1], np.full(len(xs) - 1, ys[-1])], axis=-1)
        left = np.stack([np.full(len(ys) - 1, xs[0]), ys[:0:-1]], axis=-1)
        ring = np.concatenate([top, right, bottom, left])
        return ring if len(ring) else np.array([[xs[0], ys[0]]])

    def cell_mask(self, cells: np.ndarray) -> np.ndarray:
        """(H, W) bool: the image's pixels in the (corner lattice's) cells marked in
        ``cells`` (rows of cells, cells per row)."""
        height, width = self.shape
        grid, m = self.grid, self.margin
        mask = np.repeat(np.repeat(cells, grid, axis=0), grid, axis=1)
        return mask[m : m + height, m : m + width]

    # -- bands ----------------------------------------------------------------------------

    @property
    def band_overlap(self) -> int:
        """Rows two consecutive bands share: one for cells (a cell needs both its rows)."""
        return 1 if self.kind == "corners" else 0

    def rows_per_band(self, band_bytes: int, *, bytes_per_point: int = 8, indexed: bool = False):
        """Rows of a band whose buffer of ``bytes_per_point`` per point stays within
        ``band_bytes``; where ``indexed`` (the GL rasterizer's quads, 6 uint32 indices per
        cell), the index buffer too. At least 2."""
        nx = self.dims[0]
        rows = max(2, band_bytes // (bytes_per_point * nx))
        if indexed:
            rows = max(2, min(rows, band_bytes // (24 * max(nx - 1, 1)) + 1))
        return rows

    def bands(self, rows_per_band: int, *, overlap: int | None = None) -> Iterator[tuple[int, int]]:
        """(first row, rows) of each band of at most ``rows_per_band`` rows, in order; bands
        of cells overlap by one row (:attr:`band_overlap`), or by ``overlap`` rows where given
        (the squares of pixel centres of ``paper-quads`` need both their rows too)."""
        ny = self.dims[1]
        overlap = self.band_overlap if overlap is None else overlap
        first = 0
        while True:
            rows = min(rows_per_band, ny - first)
            yield first, rows
            first += rows - overlap
            if first + overlap >= ny:
                return

    def one_band(self, rows_per_band: int) -> bool:
        return rows_per_band >= self.dims[1]

    # -- uniforms -------------------------------------------------------------------------

    def pixel_uniforms(self) -> dict[str, object]:
        """The uniforms of ``glmls/shaders/common/lattice.glsl`` (the lattice's own pixels)."""
        height, width = self.padded_shape
        return {
            "u_grid": self.grid,
            "u_lattice_size": (width, height),
            "u_lattice_offset": self.offset,
        }

    def uniforms(self, scaling: Scaling) -> dict[str, object]:
        """Origin, step and last point in the GPU's scaled coordinates, and the dims."""
        origin = scaling.to_gpu(np.array([self.origin]))[0]
        last = scaling.to_gpu(np.array([self.last]))[0]
        step = self.grid / scaling.scale
        return {
            "u_lattice_origin": (float(origin[0]), float(origin[1])),
            "u_lattice_step": (step, step),
            "u_lattice_last": (float(last[0]), float(last[1])),
            "u_lattice_dims": self.dims,
        }
