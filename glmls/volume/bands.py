"""How the volume construction holds its work: output slabs, and f on the lattice band by band
of z layers (:class:`LatticeBands`) (the lattice's margins for the border modes:
:mod:`.margins`)."""

from __future__ import annotations

from dataclasses import dataclass

import moderngl
import numpy as np

from ..gl import bindings
from ..gl.context import GLContext
from ..gl.dispatch import LOCAL_SIZE, run_1d, run_groups, set_uniforms
from ..gl.resources import Resources
from .fields import Field
from .frame import CornerLattice

__all__ = [
    "JACOBIAN_BYTES",
    "KEY_BYTES",
    "POINT_BYTES",
    "REACH_SAMPLES",
    "SURVEY_PIECE",
    "LatticeBands",
    "Slab",
    "band_layers",
    "displacement_reach",
    "jacobian_band",
    "survey_pieces",
]

#: Bytes of one lattice point in the band buffer (3 float32).
POINT_BYTES = 12
#: Bytes of one voxel's key (6 cell + tetrahedron).
KEY_BYTES = 4
#: Bytes of one lattice point's inverse Jacobian and f in the backward method's texture (three
#: RGBA32F texels: ``volume/jacobians.comp.glsl``).
JACOBIAN_BYTES = 48


@dataclass(frozen=True)
class Slab:
    """Output slices ``first`` .. ``first + depth - 1`` of a frame, ``width`` x ``height``
    voxels of each from column ``column`` and row ``row`` (0 and the whole slice where the
    slices fit a texture and a storage buffer)."""

    first: int
    depth: int
    width: int
    height: int
    column: int = 0
    row: int = 0

    @property
    def corner(self) -> tuple[int, int, int]:
        """The slab's first output voxel (x, y, z)."""
        return self.column, self.row, self.first

    @property
    def voxels(self) -> int:
        return self.depth * self.width * self.height

    @property
    def size(self) -> tuple[int, int, int]:
        return self.width, self.height, self.depth


#: Points an axis at most at which :func:`displacement_reach` samples f.
REACH_SAMPLES = 17


def displacement_reach(field: Field, lattice: CornerLattice) -> np.ndarray | None:
    """(x, y, z): how far f moves a point of ``lattice``'s box (its margins included) along
    each axis at most, voxels: the largest component of f's displacement at up to
    :data:`REACH_SAMPLES` points an axis over the box, plus, for what lies between them,
    its largest change between neighbouring samples along each of the three axes (twice
    what f changes by from a point to its nearest sample where it changes linearly between
    samples: the other half for a peak between them), and at least its displacement at the
    handles' sources in the box (where a handle moved far among others that hold, f's
    displacement peaks within a few voxels of it, which the samples may straddle). None
    where f is not a number at one of them."""
    first, last = np.array(lattice.first), np.array(lattice.last)
    axes = [
        np.linspace(a, b, min(REACH_SAMPLES, n))
        for a, b, n in zip(first, last, lattice.dims, strict=True)
    ]
    z, y, x = np.meshgrid(axes[2], axes[1], axes[0], indexing="ij")
    points = np.stack([x, y, z], axis=-1)
    sources = np.asarray(field.sources, dtype=np.float64).reshape(-1, 3)
    sources = sources[np.all((sources >= first) & (sources <= last), axis=1)]
    # one evaluation of f for the samples and the sources
    every = np.concatenate([points.reshape(-1, 3), sources])
    moved_every = field.evaluate(every) - every
    if not np.all(np.isfinite(moved_every)):
        return None
    samples = len(every) - len(sources)
    moved = moved_every[:samples].reshape(points.shape)
    reach = np.abs(moved).max(axis=(0, 1, 2))
    for axis in range(3):  # (z, y, x) of the samples
        if moved.shape[axis] > 1:
            reach = reach + np.abs(np.diff(moved, axis=axis)).max(axis=(0, 1, 2))
    if len(sources):
        reach = np.maximum(reach, np.abs(moved_every[samples:]).max(axis=0))
    return reach


#: Lattice points of a z layer that one work group of ``volume/survey.comp.glsl`` reduces,
#: at most (its loop stays far below llvmpipe's cap on a loop's iterations, 65,535).
SURVEY_PIECE = LOCAL_SIZE * 16384


def survey_pieces(nx: int, ny: int) -> int:
    """The pieces of :data:`SURVEY_PIECE` points in a z layer of ``nx`` x ``ny`` points."""
    return max(1, -(-nx * ny // SURVEY_PIECE))


def band_layers(lattice: CornerLattice, band_bytes: int, *, jacobians: bool = False) -> int:
    """The cell layers of ``lattice`` that a band of ``band_bytes`` holds (with
    ``jacobians``, their inverse Jacobians and a layer of points either side too).

    Raises
    ------
    ValueError
        Where not even one cell layer fits.
    """
    nx, ny, _ = lattice.dims
    layer_bytes = nx * ny * (POINT_BYTES + (JACOBIAN_BYTES if jacobians else 0))
    extra = 3 if jacobians else 1  # a band's layers of points past its cell layers
    if band_bytes // layer_bytes < 1 + extra:
        raise ValueError(
            f"a layer of {nx} x {ny} lattice points does not fit {1 + extra} times in the "
            f"lattice buffer of {band_bytes} bytes (SlabOptions.band_bytes, at most the "
            "device's storage-buffer size): give a larger band_bytes or a coarser grid"
        )
    return band_bytes // layer_bytes - extra


def jacobian_band(
    lattice: CornerLattice, band_bytes: int, max_buffer: int, side: int
) -> tuple[tuple[int, int, int], int] | None:
    """Where the backward method holds f's inverse Jacobians at a band's lattice points (its
    second-order first guess): the texture's size (3 nx, ny, layers) and the bytes of a band
    with it, for storage buffers of at most ``max_buffer`` bytes and 3D textures of at most
    ``side`` texels a side. None at grid 1 (the linear guess is within Newton's tolerance
    at most voxels there, and the texture would take 4 times the lattice's memory) and
    where a layer of points is wider than a texture or four layers exceed a buffer.

    Whether it is used depends on the lattice and the device, never on ``band_bytes``, so
    that the result does not depend on the bands either: a band holds at least four layers
    of points (one cell layer and its neighbours), past ``band_bytes`` if need be."""
    nx, ny, nz = lattice.dims
    layer_bytes = nx * ny * (POINT_BYTES + JACOBIAN_BYTES)
    fits = 4 * nx * ny * POINT_BYTES <= max_buffer
    if lattice.grid < 2 or 3 * nx > side or ny > side or not fits:
        return None
    budget = min(band_bytes, max_buffer // POINT_BYTES * layer_bytes, side * layer_bytes)
    budget = max(budget, 4 * layer_bytes)
    cell_layers = band_layers(lattice, budget, jacobians=True)
    return (3 * nx, ny, min(nz, cell_layers + 3)), budget


class LatticeBands:
    """f on a lattice, held band by band of z layers in one buffer of at most ``band_bytes``.

    Where the whole lattice fits in one band it is evaluated once and kept. With
    ``survey_out`` (a buffer for six floats a piece of a z layer of points,
    :func:`survey_pieces`), every band is evaluated
    once first and reduced on the GPU to the z range (source voxels) that each layer of
    cells reaches, so that each slab evaluates and scans only the layers that reach it
    (without, every slab takes every band). :attr:`box` (the box of every deformed point)
    is known after a survey.

    With ``jacobians`` (a 3D RGBA32F texture of at least (3 nx, ny, :attr:`cell_layers` + 3)
    texels, :func:`jacobian_band`), each band is held with one more z layer of points on
    either side (where the lattice has one), and f's inverse Jacobian at each of the band's
    own points is computed from its neighbours' f into the texture
    (``volume/jacobians.comp.glsl``): the same values whatever the bands, since every
    point's neighbours are held with it. ``band_bytes`` then bounds the buffer and the
    texture together.

    ``spares`` (a :class:`~glmls.gl.resources.Resources`, ``buffer``'s name there and a
    count ``kept``): up to ``kept`` bands are held at once, in ``buffer`` and buffers of its
    size named after it (``name.1``, ``name.2``, ...), the least recently loaded
    given up first, so that a slab's passes (the scan over every band, then the resolve
    over them again) evaluate each band once where the lattice takes a few buffers (the
    device's storage buffers are smaller than the lattice: 128 MiB on llvmpipe). The
    jacobians' texture holds one band: computed again when another band is taken up.
    :attr:`buffer` is the band last loaded's."""

    def __init__(
        self,
        field: Field,
        lattice: CornerLattice,
        buffer: moderngl.Buffer,
        band_bytes: int,
        *,
        gl: GLContext,
        survey_out: moderngl.Buffer | None = None,
        jacobians: moderngl.Texture3D | None = None,
        spares: tuple[Resources, str, int] | None = None,
    ) -> None:
        nz = lattice.dims[2]
        self.field = field
        self.gl = gl
        self.survey_out = survey_out
        self.jacobians = jacobians
        self.lattice = lattice
        self.buffer = buffer
        self._spares = spares
        self._kept = max(1, spares[2]) if spares is not None else 1
        #: the bands held, the last loaded last: (first cell layer, layers, first layer of
        #: points, buffer)
        self._held: list[tuple[int, int, int, moderngl.Buffer]] = []
        #: z layers of points held either side of a band's own (for the inverse Jacobians)
        self.halo = 0 if jacobians is None else 1
        self.cell_layers = band_layers(lattice, band_bytes, jacobians=jacobians is not None)
        if 6 * lattice.key_count >= 0xFFFFFFFF:  # keys: 6 per cell, in 32 bits
            limit = 715_827_882 // (lattice.key_count // lattice.cell_count)
            raise ValueError(
                f"a lattice of {lattice.cell_count} cells is more than the construction "
                f"numbers ({limit:,}); use a coarser grid"
            )
        self.cells = nz - 1
        self.loaded: tuple[int, int] | None = None
        self._held_first = 0
        #: per cell layer, the z range its deformed cells reach (None: not surveyed)
        self.low: np.ndarray | None = None
        self.high: np.ndarray | None = None
        #: the box of every deformed point (x, y, z low, then high), source voxels
        self.box = np.array([np.inf] * 3 + [-np.inf] * 3)
        if survey_out is not None:
            self._survey()
        elif self.whole:
            self.load(0, self.cells)

    @property
    def whole(self) -> bool:
        """The whole lattice fits in one band."""
        return self.cell_layers >= self.cells

    def _survey(self) -> None:
        """Each band evaluated once, its layers' boxes reduced on the GPU
        (``volume/survey.comp.glsl``, each layer in :func:`survey_pieces`): six floats a
        piece come back, not the lattice."""
        nx, ny, nz = self.lattice.dims
        boxes = np.empty((nz, 6), np.float32)
        gl = self.gl
        survey = gl.compute("volume/survey.comp.glsl", {"VOLUME_SURVEY_PIECE": SURVEY_PIECE})
        out = self.survey_out
        pieces = survey_pieces(nx, ny)
        for first, layers in self.all_bands():
            self.load(first, layers)
            self.buffer.bind_to_storage_buffer(bindings.VOLUME_LATTICE.index)
            out.bind_to_storage_buffer(bindings.VOLUME_SURVEY.index)
            skip = first - self._held_first  # halo layers before the band's own
            set_uniforms(
                survey, self.lattice.uniforms() | {"u_pieces": pieces, "u_skip_layers": skip}
            )
            gl.mgl.memory_barrier()
            items = (layers + 1) * pieces
            run_groups(survey, items, max_groups=gl.limits["max_work_groups_x"])
            gl.mgl.memory_barrier()
            raw = np.frombuffer(out.read(size=items * 6 * 4), np.float32)
            raw = raw.reshape(layers + 1, pieces, 6)
            boxes[first : first + layers + 1, :3] = raw[..., :3].min(axis=1)  # NaN-free
            boxes[first : first + layers + 1, 3:] = raw[..., 3:].max(axis=1)
        with np.errstate(all="ignore"):
            # a layer of NaN only (a degenerate f) reads +inf, -inf: left out by fmin, fmax
            self.box = np.concatenate(
                [np.fmin.reduce(boxes[:, :3], axis=0), np.fmax.reduce(boxes[:, 3:], axis=0)]
            ).astype(np.float64)
        low, high = boxes[:, 2].astype(np.float64), boxes[:, 5].astype(np.float64)
        self.low = np.fmin(low[:-1], low[1:])
        self.high = np.fmax(high[:-1], high[1:])

    def all_bands(self) -> list[tuple[int, int]]:
        """Every band (first cell layer, layers)."""
        step = self.cell_layers
        return [(f, min(step, self.cells - f)) for f in range(0, self.cells, step)]

    def load(self, first: int, layers: int) -> None:
        """Make :attr:`buffer` hold cell layers ``first`` .. ``first + layers - 1``."""
        if self.loaded is not None:
            held_first, held_layers = self.loaded
            if held_first <= first and first + layers <= held_first + held_layers:
                return
        for index, (band, count, low, buffer) in enumerate(self._held):
            if band <= first and first + layers <= band + count:  # held in another buffer
                self._held.append(self._held.pop(index))
                self._take(band, count, low, buffer)
                return
        low = max(0, first - self.halo)
        high = min(self.cells, first + layers + self.halo)  # the last layer of points held
        if not self._held:
            buffer = self.buffer
        elif len(self._held) < self._kept and self._spares is not None:
            resources, name, _ = self._spares
            buffer = resources.buffer(f"{name}.{len(self._held)}", self._held[0][3].size)
        else:
            buffer = self._held.pop(0)[3]  # the least recently loaded band's
        # the passes over the band the buffer held before (a slab's scan or resolve) may
        # still read it: a GPU overlaps them with the evaluation that overwrites it
        self.gl.mgl.memory_barrier()
        self.field.fill(self.lattice, low, high - low + 1, buffer)
        self._held.append((first, layers, low, buffer))
        self._take(first, layers, low, buffer)

    def _take(self, first: int, layers: int, low: int, buffer: moderngl.Buffer) -> None:
        """Make the band of cell layers ``first`` (``layers``), held from layer of points
        ``low`` in ``buffer``, the current one."""
        self.buffer = buffer
        self.loaded = (first, layers)
        self._held_first = low
        if self.jacobians is not None:
            self._invert(first, layers + 1)

    def _invert(self, first: int, layers: int) -> None:
        """f's inverse Jacobian at z layers of points ``first`` .. ``first + layers - 1``
        (held with their neighbours) into :attr:`jacobians`."""
        nx, ny, _ = self.lattice.dims
        gl = self.gl
        program = gl.compute("volume/jacobians.comp.glsl")
        self.buffer.bind_to_storage_buffer(bindings.VOLUME_LATTICE.index)
        self.jacobians.bind_to_image(  # type: ignore[union-attr]
            bindings.VOLUME_JACOBIANS_OUT.index, read=False, write=True
        )
        uniforms = {"u_band_first": self._held_first, "u_first_layer": first}
        set_uniforms(program, self.lattice.uniforms() | uniforms)
        gl.mgl.memory_barrier()
        run_1d(program, nx * ny * layers, max_groups=gl.limits["max_work_groups_x"])
        gl.mgl.memory_barrier()

    @property
    def band_first(self) -> int:
        """The first z layer of points held in the buffer (and the texture)."""
        return self._held_first if self.loaded is not None else 0

    def bands_for(self, z_low: float, z_high: float) -> list[tuple[int, int]]:
        """The bands (first cell layer, layers) of the cell layers that reach z from
        ``z_low`` to ``z_high`` (source voxels): runs of such layers, cut to the buffer
        (every band where not surveyed). Where the whole lattice is held, the runs need no
        new evaluation; they spare the passes the cells that reach no voxel of the slab."""
        if self.low is None or self.high is None:
            return self.all_bands()
        with np.errstate(invalid="ignore"):
            hit = (self.high >= z_low) & (self.low <= z_high)
        layers = np.flatnonzero(hit)
        if len(layers) == 0:
            return []
        out = []
        start = prev = int(layers[0])
        for layer in (*layers[1:].tolist(), None):
            if layer is not None and layer == prev + 1 and layer - start < self.cell_layers:
                prev = layer
                continue
            out.append((start, prev - start + 1))
            if layer is not None:
                start = prev = layer
        return out
