"""The output canvas of a volume warp and the lattice of voxel corners.

- :class:`VolumeFrame`: ``shape`` (D, H, W) output voxels; output voxel (k, j, i) shows the
  deformed space's point ``origin + (i dx, j dy, k dz)`` (handle units, ``spacing`` =
  (dz, dy, dx)). Inside the construction every position is in source voxels: point
  (x, y, z) in handle units is (x / dx, y / dy, z / dz) there.
- :class:`VolumeBounds`: the bounding box of a deformed volume and the canvas showing it.
- :class:`CornerLattice`: the voxel-corner lattice, step ``grid`` voxels, with margins past
  the volume's sides (each its own), and its cells in scan order.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..core.config import check_real, check_result_bytes
from ..imaging.frame import FIT_SLACK

__all__ = ["CornerLattice", "Margins", "VolumeBounds", "VolumeFrame", "check_memory"]


def check_memory(shape: tuple[int, ...], voxel_bytes: int) -> None:
    """``ValueError`` naming ``output_shape`` where the arrays of an output of ``shape``
    (D, H, W), ``voxel_bytes`` a voxel, would not fit in this machine's memory: refused
    before anything is allocated or evaluated (:func:`~glmls.core.config.check_result_bytes`)."""
    check_result_bytes(f"output_shape {tuple(shape)}", math.prod(shape) * voxel_bytes)


@dataclass(frozen=True)
class VolumeFrame:
    """The output canvas: ``shape`` (D, H, W), ``origin`` (x0, y0, z0) in handle units,
    ``spacing`` (dz, dy, dx)."""

    shape: tuple[int, int, int]
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)
    spacing: tuple[float, float, float] = (1.0, 1.0, 1.0)

    @property
    def scale(self) -> np.ndarray:
        """(dx, dy, dz): handle units per source voxel along x, y, z."""
        dz, dy, dx = self.spacing
        return np.array([dx, dy, dz])

    @property
    def origin_voxels(self) -> tuple[float, float, float]:
        """The origin in source voxels (x, y, z)."""
        x, y, z = np.asarray(self.origin) / self.scale
        return float(x), float(y), float(z)

    @property
    def voxels(self) -> int:
        d, h, w = self.shape
        return d * h * w


@dataclass(frozen=True)
class VolumeBounds:
    """The bounding box of a deformed volume, and the canvas that shows all of it.

    In handle units: the deformed corners of the voxel cubes, so the identity on a volume of
    shape (D, H, W) and spacing (dz, dy, dx) gives x from -dx/2 to (W - 1/2) dx. Made by
    :func:`glmls.volume.volume_bounds`.

    Parameters
    ----------
    x0, y0, z0 : float
        The box's smallest x, y, z.
    x1, y1, z1 : float
        Its largest.
    spacing : (float, float, float)
        (dz, dy, dx), the voxel size of the canvas.

    Examples
    --------
    >>> from glmls.volume import VolumeBounds
    >>> b = VolumeBounds(-0.5, -0.5, -0.5, 5.5, 3.5, 1.5)
    >>> b.output_shape, b.origin
    ((2, 4, 6), (0.0, 0.0, 0.0))
    >>> VolumeBounds(-3.2, 0.5, 0.0, 40.5, 20.9, 2.0).output_shape
    (3, 21, 44)

    Values that are not finite numbers, a spacing that is not three positive ones, or an
    inverted box (``x1 < x0``) are refused:

    >>> VolumeBounds(5.0, 0.0, 0.0, 1.0, 3.0, 3.0)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ValueError: VolumeBounds x1 must be >= x0 (...), got x0=5.0, x1=1.0
    """

    x0: float
    y0: float
    z0: float
    x1: float
    y1: float
    z1: float
    spacing: tuple[float, float, float] = (1.0, 1.0, 1.0)

    def __post_init__(self) -> None:
        for name in ("x0", "y0", "z0", "x1", "y1", "z1"):
            object.__setattr__(self, name, check_real(f"VolumeBounds {name}", getattr(self, name)))
        what = "three finite numbers > 0 (dz, dy, dx)"
        try:
            sizes = tuple(self.spacing)
        except TypeError:
            raise TypeError(f"VolumeBounds spacing must be {what}, got {self.spacing!r}") from None
        if len(sizes) != 3:
            raise ValueError(f"VolumeBounds spacing must be {what}, got {self.spacing!r}")
        spacing = tuple(
            check_real("VolumeBounds spacing", d, low=0, low_open=True, what=what) for d in sizes
        )
        object.__setattr__(self, "spacing", spacing)
        for low, high in (("x0", "x1"), ("y0", "y1"), ("z0", "z1")):
            if getattr(self, high) < getattr(self, low):
                raise ValueError(
                    f"VolumeBounds {high} must be >= {low} (a box's largest value is not below "
                    f"its smallest), got {low}={getattr(self, low)!r}, "
                    f"{high}={getattr(self, high)!r}"
                )

    def _axes(self):
        dz, dy, dx = self.spacing
        return ((self.x0, self.x1, dx), (self.y0, self.y1, dy), (self.z0, self.z1, dz))

    @property
    def origin(self) -> tuple[float, float, float]:
        """(x0, y0, z0) of the first voxel the box touches (whole voxels).

        Examples
        --------
        >>> from glmls.volume import VolumeBounds
        >>> VolumeBounds(-3.2, 0.5, 0.0, 40.5, 20.9, 2.0).origin
        (-3.0, 1.0, 0.0)
        """
        x, y, z = (float(math.floor(lo / d + 0.5 + FIT_SLACK)) * d for lo, _, d in self._axes())
        return x, y, z

    @property
    def output_shape(self) -> tuple[int, int, int]:
        """(D, H, W) of the voxels the box touches, at least 1 each.

        Examples
        --------
        >>> from glmls.volume import VolumeBounds
        >>> VolumeBounds(-0.5, -0.5, -0.5, 5.5, 3.5, 1.5).output_shape
        (2, 4, 6)
        >>> VolumeBounds(2.0, 2.0, 2.0, 2.0, 2.0, 2.0).output_shape  # a point: one voxel
        (1, 1, 1)
        """
        sizes = []
        for lo, hi, d in self._axes():
            first = math.floor(lo / d + 0.5 + FIT_SLACK)
            sizes.append(max(1, math.ceil(hi / d - 0.5 - FIT_SLACK) - first + 1))
        w, h, depth = sizes
        return depth, h, w


#: A lattice's margins past the volume, voxels: ((x low, x high), (y low, y high), (z low,
#: z high)).
Margins = tuple[tuple[int, int], tuple[int, int], tuple[int, int]]


def _margins(margin: object, grid: int) -> Margins:
    """``margin`` (one count for every side, or a (low, high) pair per axis x, y, z) as
    :data:`Margins`, each a multiple of ``grid`` >= 0."""
    what = (
        f"an int >= 0 or three (low, high) pairs (x, y, z) of ints >= 0, multiples of the "
        f"grid ({grid})"
    )
    if isinstance(margin, (str, bytes)):
        raise TypeError(f"CornerLattice margin must be {what}, got {margin!r}")
    try:
        pairs = ((margin, margin),) * 3 if isinstance(margin, (int, np.integer)) else tuple(margin)
        pairs = tuple(tuple(pair) for pair in pairs)
    except TypeError:
        raise TypeError(f"CornerLattice margin must be {what}, got {margin!r}") from None
    if len(pairs) != 3 or any(len(pair) != 2 for pair in pairs):
        raise ValueError(f"CornerLattice margin must be {what}, got {margin!r}")
    for value in (v for pair in pairs for v in pair):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
            raise TypeError(f"CornerLattice margin must be {what}, got {margin!r}")
        if value < 0 or value % grid:
            raise ValueError(f"CornerLattice margin must be {what}, got {margin!r}")
    return tuple((int(a), int(b)) for a, b in pairs)  # type: ignore[return-value]


@dataclass(frozen=True)
class CornerLattice:
    """The corners of the voxel cubes of a volume of ``shape`` (D, H, W), every ``grid``
    voxels, with margins (voxels, multiples of ``grid``) past the volume's sides: ``margin``
    is one count for every side or a (low, high) pair per axis x, y, z (:attr:`margins`).
    Point (a, b, c) is at (x, y, z) = (-low - 1/2 + grid (a, b, c)), ``low`` each axis's
    low margin. ``regular`` (None: where any side has a margin): the lattice is regular to
    its last point, so that a point, and the cells, do not depend on the margins (which
    grow with the output canvas and with how far f moves each face); else (the
    ``constant`` border's lattice) each coordinate is clamped to the volume's last corner
    ``size - 1/2`` (the last step shorter where ``grid`` does not divide ``size``). Cells
    are numbered in scan order of the source, ((z cell) ny + y cell) nx + x cell: the
    order of any two cells is the same whatever the margins. ``box_first``: a cell's key
    ranks the cells that hold none of the volume's voxels (those of the margins) after
    every cell that holds some, so that where both cover a voxel the volume's cell is the
    first (the backward method's guesses with the ``constant`` border: the margins only
    start Newton where no cell of the volume reaches). ``crop`` (cells (first, end) along
    x, y, z of the lattice so made, :meth:`cropped`): only those cells and their points,
    numbered in the same scan order (the cells f can take into a canvas that shows part of
    the volume)."""

    shape: tuple[int, int, int]
    grid: int = 1
    margin: int | Margins = 0
    box_first: bool = False
    regular: bool | None = None
    crop: tuple[tuple[int, int], tuple[int, int], tuple[int, int]] | None = None

    def __post_init__(self) -> None:
        margins = _margins(self.margin, self.grid)
        object.__setattr__(self, "margin", margins)
        any_margin = any(v for pair in margins for v in pair)
        regular = any_margin if self.regular is None else bool(self.regular)
        if any_margin and not regular:
            raise ValueError(
                f"CornerLattice with margins {margins} must be regular (its last point "
                "past the volume is not clamped), got regular=False"
            )
        object.__setattr__(self, "regular", regular)
        if self.crop is not None:
            crop = tuple((int(a), int(b)) for a, b in self.crop)
            full = self._full_dims
            if len(crop) != 3 or any(
                not 0 <= a < b <= n - 1 for (a, b), n in zip(crop, full, strict=True)
            ):
                raise ValueError(
                    f"CornerLattice crop must be three (first, end) cell ranges within the "
                    f"lattice's {tuple(n - 1 for n in full)} cells, got {self.crop!r}"
                )
            object.__setattr__(self, "crop", crop)

    @property
    def margins(self) -> Margins:
        """((x low, x high), (y low, y high), (z low, z high)), voxels."""
        return self.margin  # type: ignore[return-value]

    @property
    def low_margin(self) -> tuple[int, int, int]:
        """The margins before the volume along x, y, z, voxels."""
        x, y, z = (low for low, _ in self.margins)
        return x, y, z

    @property
    def high_margin(self) -> tuple[int, int, int]:
        """The margins past the volume's far sides along x, y, z, voxels."""
        x, y, z = (high for _, high in self.margins)
        return x, y, z

    @property
    def sizes(self) -> tuple[int, int, int]:
        """(W, H, D) with the margins."""
        d, h, w = self.shape
        x, y, z = (n + low + high for n, (low, high) in zip((w, h, d), self.margins, strict=True))
        return x, y, z

    @property
    def _full_dims(self) -> tuple[int, int, int]:
        x, y, z = (math.ceil(n / self.grid) + 1 for n in self.sizes)
        return x, y, z

    @property
    def _crop_first(self) -> tuple[int, int, int]:
        """The first cell of the crop along x, y, z (0 without one)."""
        if self.crop is None:
            return 0, 0, 0
        x, y, z = (a for a, _ in self.crop)
        return x, y, z

    @property
    def dims(self) -> tuple[int, int, int]:
        """Points along x, y, z (of the crop where there is one)."""
        if self.crop is None:
            return self._full_dims
        x, y, z = (b - a + 1 for a, b in self.crop)
        return x, y, z

    @property
    def cells(self) -> tuple[int, int, int]:
        """Cells along x, y, z."""
        x, y, z = self.dims
        return x - 1, y - 1, z - 1

    @property
    def cell_count(self) -> int:
        x, y, z = self.cells
        return x * y * z

    @property
    def first(self) -> tuple[float, float, float]:
        """The first point's (x, y, z), voxels."""
        x, y, z = (
            -low - 0.5 + self.grid * c
            for low, c in zip(self.low_margin, self._crop_first, strict=True)
        )
        return x, y, z

    @property
    def last(self) -> tuple[float, float, float]:
        """The last point's (x, y, z) of the whole lattice (the crop's or not), voxels: every
        coordinate is clamped to it (the volume's last corner where not :attr:`regular`, the
        regular lattice's last point where it is)."""
        d, h, w = self.shape
        if not self.regular:
            return w - 0.5, h - 0.5, d - 0.5
        x, y, z = (
            -low - 0.5 + self.grid * (n - 1)
            for low, n in zip(self.low_margin, self._full_dims, strict=True)
        )
        return x, y, z

    @property
    def voxel_first(self) -> tuple[int, int, int]:
        """The first voxel (x, y, z) of the first cell: cell c holds voxels ``voxel_first +
        grid c`` on (those of the margins past the volume's first)."""
        x, y, z = (
            self.grid * c - low for low, c in zip(self.low_margin, self._crop_first, strict=True)
        )
        return x, y, z

    @property
    def voxel_end(self) -> tuple[int, int, int]:
        """The voxel (x, y, z) after the last that a cell holds (the margins' past the
        volume's last)."""
        d, h, w = self.shape
        x, y, z = (n + high for n, high in zip((w, h, d), self.high_margin, strict=True))
        return x, y, z

    def cropped(self, low: np.ndarray, high: np.ndarray, pad: int = 0) -> CornerLattice:
        """This lattice cut to the cells that hold a source point in the box from ``low``
        to ``high`` ((x, y, z), voxels) and ``pad`` cells more on every side, within the
        lattice (one cell at least): the same points and cells, in the same scan order."""
        full = self._full_dims
        ends = []
        for axis in range(3):
            start = -self.low_margin[axis] - 0.5
            cells = full[axis] - 1
            a = math.floor((float(low[axis]) - start) / self.grid) - pad
            b = math.ceil((float(high[axis]) - start) / self.grid) + pad
            a = min(max(a, 0), cells - 1)
            ends.append((a, min(max(b, a + 1), cells)))
        if all(e == (0, n - 1) for e, n in zip(ends, full, strict=True)):
            return self
        return CornerLattice(
            self.shape, self.grid, self.margins, self.box_first, self.regular, tuple(ends)
        )

    def axes(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """x, y and z of the points along each axis, voxels."""
        return tuple(  # type: ignore[return-value]
            np.minimum(first + self.grid * np.arange(n), last)
            for first, n, last in zip(self.first, self.dims, self.last, strict=True)
        )

    def layer_points(self, first: int, layers: int) -> np.ndarray:
        """The points of z layers ``first`` .. ``first + layers - 1``, (layers, ny, nx, 3)
        float64 (x, y, z), voxels."""
        xs, ys, zs = self.axes()
        z, y, x = np.meshgrid(zs[first : first + layers], ys, xs, indexing="ij")
        return np.stack([x, y, z], axis=-1)

    def uniforms(self) -> dict[str, object]:
        """Those of ``glmls/shaders/volume/lattice.glsl``."""
        return {
            "u_lattice_dims": self.dims,
            "u_lattice_first": self.first,
            "u_lattice_last": self.last,
            "u_lattice_grid": self.grid,
            "u_lattice_voxel_first": self.voxel_first,
            "u_lattice_voxel_end": self.voxel_end,
            "u_lattice_box_first": self.box_first,
            "u_lattice_box_low": self.box_cells[0],
            "u_lattice_box_high": self.box_cells[1],
        }

    @property
    def box_cells(self) -> tuple[tuple[int, int, int], tuple[int, int, int]]:
        """The cells (x, y, z) that hold voxels of the volume: from the first to before the
        second (the others lie in the margins)."""
        low = tuple(
            m // self.grid - c for m, c in zip(self.low_margin, self._crop_first, strict=True)
        )
        high = tuple(
            first + math.ceil(n / self.grid) for first, n in zip(low, self.shape[::-1], strict=True)
        )
        return low, high  # type: ignore[return-value]

    @property
    def key_count(self) -> int:
        """Cell keys the lattice numbers (``box_first`` ranks the margins' after the rest)."""
        return self.cell_count * (2 if self.box_first else 1)
