"""The GPU passes that build a deformed volume, slab by slab of output slices.

One :class:`VolumeWarper` per GL context (:meth:`VolumeWarper.of`). For each slab of output
slices (:meth:`VolumeWarper.slabs`: its buffers within :class:`~.options.SlabOptions`), the
deformed lattice is held band by band of z layers (:class:`LatticeBands`); then

- ``quads`` (the cells method): ``volume/raster.comp.glsl`` keeps, per output voxel, the
  first cell in scan order of the source whose deformed tetrahedra contain it (atomicMin of
  the cell's key), then ``volume/resolve.comp.glsl`` samples the source at the point
  interpolated in that cell's tetrahedron into the slab texture, read back into the output;
- ``backward``: the same two passes write source points instead (the first guess), Newton's
  method on f refines them (the field's :meth:`refine`), and ``volume/sample.comp.glsl``
  samples the source there.

The source volume is one texture where it fits, else the slices each piece of a band
(``quads``) or each sampling pass over a range of the slices a slab's points read
(``backward``) samples (:mod:`.texture`). Every pass computes each voxel from the same
inputs whatever the slab, band and slices it falls in (keys are global cell numbers): the
slabbed result equals the one-piece result exactly.
"""

from __future__ import annotations

from collections.abc import Iterator

import moderngl
import numpy as np

from ..gl import bindings
from ..gl.context import GLContext, current, get_context
from ..gl.dispatch import ScanPieces, fill_buffer, run_1d, set_uniforms
from ..gl.resources import Resources
from ..imaging.source import BORDERS
from .bands import (
    KEY_BYTES,
    POINT_BYTES,
    REACH_SAMPLES,
    LatticeBands,
    Slab,
    band_layers,
    displacement_reach,
    jacobian_band,
    survey_pieces,
)
from .fields import Field
from .frame import CornerLattice, VolumeFrame, check_memory
from .kernel_field import pending_bytes
from .margins import border_margin3
from .options import SlabOptions, VolumeOptions
from .source import SourceVolume, prepare_volume, volume_background
from .texture import SourceTexture, border_runs, runs_size

__all__ = ["VolumeWarper", "make_volume_frame"]

#: Bytes of one voxel's source point (backward).
COORD_BYTES = 16
#: Bytes of one voxel's slope (the guess's tetrahedron's inverse Jacobian, 3 vec4).
SLOPE_BYTES = 48
#: Bytes of one voxel in the backward method's largest slab buffer (each buffer is within
#: the GL limit of a storage buffer, and ``slab_bytes``, on its own).
BACKWARD_BYTES = max(COORD_BYTES, SLOPE_BYTES)
_NO_KEY = 0xFFFFFFFF


class VolumeWarper:
    """The GPU passes that turn a :class:`~.fields.Field` and a source volume into the
    deformed volume, slab by slab (see the module docstring). One per context
    (:meth:`of`); its GL objects are cached for the next call."""

    def __init__(self, ctx: moderngl.Context | GLContext | None = None) -> None:
        self._gl = get_context(ctx)
        self._resources = Resources(self._gl, "this volume warper")

    @classmethod
    def of(cls, ctx: moderngl.Context | GLContext | None = None) -> VolumeWarper:
        """The warper shared by everything that renders volumes with ``ctx``."""
        gl = get_context(ctx)
        return gl.shared(VolumeWarper, lambda: cls(gl))

    @property
    def ctx(self) -> GLContext:
        return self._gl

    def release(self) -> None:
        """Free the cached GL objects. Idempotent."""
        for name in ("_target_texture", "_jacobian_texture"):
            cached = getattr(self, name, None)
            if cached is not None and self._gl.usable:
                with self._gl.use():
                    cached[1].release()
            setattr(self, name, None)
        self._resources.release()

    # -- planning -------------------------------------------------------------------------

    def slabs(self, frame: VolumeFrame, voxel_bytes: int, slab_bytes: int) -> Iterator[Slab]:
        """The slabs of ``frame``: as many slices as keep ``voxel_bytes`` a voxel within
        ``slab_bytes`` and the GL limits (storage buffer, 3D texture side)."""
        depth_all, height, width = frame.shape
        limits = self._gl.mgl.info
        side = int(limits["GL_MAX_3D_TEXTURE_SIZE"])
        if max(width, height) > side:
            raise ValueError(
                f"output slices of {height} x {width} voxels exceed the GL 3D texture size "
                f"limit of {side} voxels per side on this device"
            )
        budget = min(slab_bytes, self._gl.limits["max_ssbo_size"])
        per_slice = width * height * voxel_bytes
        if per_slice > self._gl.limits["max_ssbo_size"]:
            raise ValueError(
                f"one output slice of {height} x {width} voxels needs {per_slice} bytes, more "
                "than a GL storage buffer holds on this device"
            )
        depth = max(1, min(depth_all, side, budget // per_slice))
        for first in range(0, depth_all, depth):
            yield Slab(first, min(depth, depth_all - first), width, height)

    # -- the construction -----------------------------------------------------------------

    @current
    def warp(
        self,
        field: Field,
        volume: object,
        options: VolumeOptions,
        slabs: SlabOptions | None = None,
    ) -> np.ndarray:
        """The deformed volume, read back (see :func:`glmls.volume.warp_volume`)."""
        self._resources.check_alive()
        slabs = slabs if slabs is not None else SlabOptions()
        source = prepare_volume(volume)
        frame = make_volume_frame(options, source.shape)
        background = volume_background(options.background, source)
        backward = options.method == "backward"
        per_voxel = BACKWARD_BYTES if backward else KEY_BYTES
        # the GL limits on the output's slices first: an output_shape beyond them is a
        # ValueError, not the allocation of its array
        planned = list(self.slabs(frame, max(per_voxel, source.voxel_bytes), slabs.slab_bytes))
        check_memory(frame.shape, source.channels * np.dtype(source.dtype).itemsize)
        out = source.empty_output(frame.shape)
        texture = SourceTexture(self._gl, source, slabs.texture_bytes)
        try:
            survey = len(planned) > 1
            bands = self._bands(
                field, source.shape, frame, options, slabs, survey=survey, backward=backward
            )
            for slab in planned:
                target = self._target(slab, source)
                defines = {
                    "WARP_LINEAR": options.interpolation == "linear",
                    "WARP_BORDER": BORDERS.index(options.border),
                    "VOLUME_INTEGER": source.integer,
                    "VOLUME_IMAGE_FORMAT": source.image_format,
                }
                uniforms = {
                    "u_source_size": source.shape[::-1],
                    "u_volume_size": source.shape[::-1],
                    "u_background": background,
                    "u_value_max": _value_max(source),
                }
                target.bind_to_image(bindings.VOLUME_TARGET.index, read=False, write=True)
                if backward:
                    coords = self._solve(field, bands, frame, slab, options, source.shape)
                    program = self._gl.compute("volume/sample.comp.glsl", defines)
                    set_uniforms(program, uniforms | {"u_slab_size": slab.size})
                    _sample(program, texture, coords, slab, options, self._max_groups)
                else:
                    self._cells(bands, frame, slab, defines, uniforms, source=texture)
                self._gl.mgl.memory_barrier()
                self._read(target, slab, source, out)
        finally:
            texture.release()
        return source.view(out)

    @current
    def coordinate_map(
        self,
        field: Field,
        shape: tuple[int, int, int],
        options: VolumeOptions,
        slabs: SlabOptions | None = None,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The backward method's source point of every output voxel: (D, H, W, 3) float32
        (x, y, z) in handle units, the residual |f(s) - u| in voxels (D, H, W), and whether
        each was found (D, H, W) bool (inside the volume, for ``constant``)."""
        self._resources.check_alive()
        slabs = slabs if slabs is not None else SlabOptions()
        frame = make_volume_frame(options, shape)
        planned = list(self.slabs(frame, BACKWARD_BYTES, slabs.slab_bytes))
        check_memory(frame.shape, 16 + 12 + 4 + 1)  # points, the result's, residual, covered
        points = np.empty((*frame.shape, 4), np.float32)
        bands = self._bands(
            field, shape, frame, options, slabs, survey=len(planned) > 1, backward=True
        )
        for slab in planned:
            coords = self._solve(field, bands, frame, slab, options, shape)
            raw = coords.read(size=slab.voxels * COORD_BYTES)
            points[slab.first : slab.first + slab.depth] = np.frombuffer(raw, np.float32).reshape(
                slab.depth, slab.height, slab.width, 4
            )
        w = points[..., 3]
        covered = w >= 0
        residual = np.where(covered, w, -1.0 - w).astype(np.float32)
        return points[..., :3] * frame.scale.astype(np.float32), residual, covered

    # -- passes ---------------------------------------------------------------------------

    @current
    def bounds(
        self, field: Field, shape: tuple[int, int, int], grid: int, slabs: SlabOptions | None = None
    ) -> np.ndarray:
        """(low x, y, z, high x, y, z) of f at the corners of ``grid``'s lattice of a volume of
        ``shape``, source voxels."""
        self._resources.check_alive()
        slabs = slabs if slabs is not None else SlabOptions()
        options = VolumeOptions(grid=grid)
        return self._bands(field, shape, make_volume_frame(options, shape), options, slabs).box

    @property
    def _max_groups(self) -> int:
        return self._gl.limits["max_work_groups_x"]

    def _bands(
        self, field, shape, frame, options, slabs, *, survey=True, backward=False
    ) -> LatticeBands:
        lattice = _lattice(field, shape, frame, options, backward=backward)
        nx, ny, nz = lattice.dims
        band_bytes = min(slabs.band_bytes, self._gl.limits["max_ssbo_size"])
        jacobians = None
        if backward:
            planned = self._jacobians(lattice, slabs.band_bytes)
            if planned is not None:
                jacobians, band_bytes = planned
        # the layers of points a band holds
        held = band_layers(lattice, band_bytes, jacobians=jacobians is not None)
        held = min(nz, held + (1 if jacobians is None else 3))
        buffer = self._resources.buffer("volume_lattice", nx * ny * held * POINT_BYTES)
        boxes = held * survey_pieces(nx, ny) * 24  # per piece of a z layer, its box, a band
        out = self._resources.buffer("volume_survey", boxes) if survey else None
        return LatticeBands(
            *(field, lattice, buffer, band_bytes),
            gl=self._gl,
            survey_out=out,
            jacobians=jacobians,
            spares=(self._resources, "volume_lattice", slabs.band_bytes // band_bytes),
        )

    def _jacobians(
        self, lattice: CornerLattice, band_bytes: int
    ) -> tuple[moderngl.Texture3D, int] | None:
        """The texture of :func:`~.bands.jacobian_band`'s plan, and the band's bytes."""
        side = int(self._gl.mgl.info["GL_MAX_3D_TEXTURE_SIZE"])
        plan = jacobian_band(lattice, band_bytes, self._gl.limits["max_ssbo_size"], side)
        if plan is None:
            return None
        size, budget = plan
        cached = getattr(self, "_jacobian_texture", None)
        if cached is not None and cached[0] == size:
            return cached[1], budget
        if cached is not None:
            cached[1].release()
        texture = self._gl.mgl.texture3d(size, 4, dtype="f4")
        texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self._jacobian_texture = (size, texture)
        return texture, budget

    def _cells(
        self,
        bands: LatticeBands,
        frame,
        slab: Slab,
        defines,
        uniforms,
        *,
        source: SourceTexture | None = None,
    ):
        """The cells method's two passes over ``slab``: keys, then the resolve pass (into the
        slab texture, sampling ``source``, or without it the coordinates buffer)."""
        coords = source is None
        lattice = bands.lattice
        ox, oy, oz = frame.origin_voxels
        origin = (ox, oy, oz + slab.first)  # the slab's voxel (0, 0, 0), to choose bands
        keys = self._resources.buffer("volume_keys", slab.voxels * KEY_BYTES)
        fill_buffer(self._gl, keys, slab.voxels * KEY_BYTES, word=_NO_KEY)
        keys.bind_to_storage_buffer(bindings.VOLUME_KEYS.index)
        ncx, ncy, _ = lattice.cells
        common = lattice.uniforms() | {
            "u_slab_size": slab.size,
            "u_frame_origin": (ox, oy, oz),
            "u_slab_first": slab.first,
        }
        raster = self._gl.compute("volume/raster.comp.glsl")
        wanted = bands.bands_for(origin[2] - 1.0, origin[2] + slab.depth)
        for first, layers in wanted:
            bands.load(first, layers)
            bands.buffer.bind_to_storage_buffer(bindings.VOLUME_LATTICE.index)
            set_uniforms(
                raster,
                common | {"u_band_first": bands.band_first, "u_cell_first": first},
            )
            self._gl.mgl.memory_barrier()
            # with the pieces of large cells on llvmpipe (common/pieces.glsl)
            ScanPieces(self._gl).run_1d(raster, layers * ncx * ncy, max_groups=self._max_groups)
        hermite = coords and bands.jacobians is not None
        program = self._gl.compute(
            "volume/resolve.comp.glsl",
            defines | {"VOLUME_COORDS": coords, "VOLUME_HERMITE": hermite},
        )
        set_uniforms(program, common | uniforms)
        # the last band rastered is still held: resolved first; over a source held a few
        # slices at a time, in pieces of a band whose cells' slices one texture holds
        pieces = _band_pieces(wanted[::-1] or [(0, 0)], lattice, source)
        for index, ((whole_first, whole_layers), (first, layers)) in enumerate(pieces):
            if whole_layers:
                bands.load(whole_first, whole_layers)
            if source is not None:
                held = _hold_band(source, lattice, first, layers, defines["WARP_BORDER"])
                set_uniforms(program, {"u_source_runs": held})
            bands.buffer.bind_to_storage_buffer(bindings.VOLUME_LATTICE.index)
            keys.bind_to_storage_buffer(bindings.VOLUME_KEYS.index)
            if hermite:
                bands.jacobians.use(bindings.VOLUME_JACOBIANS.index)  # type: ignore[union-attr]
            set_uniforms(
                program,
                {
                    "u_band_first": bands.band_first,
                    "u_key_first": first * ncx * ncy,
                    "u_key_end": (first + layers) * ncx * ncy,
                    "u_write_uncovered": index == 0,
                },
            )
            self._gl.mgl.memory_barrier()
            run_1d(program, slab.voxels, max_groups=self._max_groups)

    def _solve(self, field, bands, frame, slab: Slab, options: VolumeOptions, shape):
        """Backward: the source point of every voxel of ``slab`` in the coordinates buffer
        (x, y, z, w) in source voxels, w >= 0 the residual where found, else -1 - residual:
        the cells' first guess, refined by the field's Newton's method."""
        coords = self._resources.buffer("volume_coords", slab.voxels * COORD_BYTES)
        coords.bind_to_storage_buffer(bindings.VOLUME_COORDS.index)
        slopes = self._resources.buffer("volume_slopes", slab.voxels * SLOPE_BYTES)
        slopes.bind_to_storage_buffer(bindings.VOLUME_SLOPES.index)
        defines = {"WARP_BORDER": BORDERS.index(options.border)}
        uniforms = {"u_volume_size": shape[::-1]}
        self._cells(bands, frame, slab, defines, uniforms)
        self._gl.mgl.memory_barrier()
        ox, oy, oz = frame.origin_voxels
        field.refine(
            coords,
            slab.size,
            (ox, oy, oz),
            shape,
            constant=options.border == "constant",
            first=slab.first,
            pending=self._resources.buffer("volume_pending", pending_bytes(slab.voxels)),
        )
        self._gl.mgl.memory_barrier()
        return coords

    def _target(self, slab: Slab, source: SourceVolume) -> moderngl.Texture3D:
        key = (slab.size, source.target_components, source.texture_dtype)
        cached = getattr(self, "_target_texture", None)
        if cached is not None and cached[0] == key:
            return cached[1]
        if cached is not None:
            cached[1].release()
        texture = self._gl.mgl.texture3d(slab.size, key[1], dtype=key[2])
        self._target_texture = (key, texture)
        return texture

    def _read(self, target, slab: Slab, source: SourceVolume, out: np.ndarray) -> None:
        """The slab into ``out`` through a pixel-pack buffer: the GPU copies the texture into
        it, the host reads it once, straight into ``out`` where the layouts agree (a plain
        texture read went through the driver's staging at ~1.3 GB/s on an H200 machine)."""
        nbytes = slab.voxels * source.voxel_bytes
        pack = self._resources.buffer("volume_readback", nbytes)
        target.read_into(pack, alignment=1)
        region = out[slab.first : slab.first + slab.depth]
        if source.target_components == source.channels and out.dtype == source.data.dtype:
            pack.read_into(region, size=nbytes)
            return
        raw = np.frombuffer(pack.read(size=nbytes), dtype=source.data.dtype)
        values = raw.reshape(slab.depth, slab.height, slab.width, source.target_components)
        region[...] = values[..., : source.channels]


def _lattice(field, shape, frame, options: VolumeOptions, *, backward: bool) -> CornerLattice:
    """The lattice of the cells: past each face of the volume as far as f moves it inward
    (and the frame reaches past it) with a border mode other than ``constant``, and for the
    backward method's guesses with ``constant``: there the margins' cells give a first
    guess to the voxels that no cell of the volume covers (where f moves the volume's faces
    inward; Newton from the voxel itself took ~5 evaluations of f each, most of the second
    pass), ranked after the volume's cells so that they never choose which preimage of a
    fold over the volume's face Newton finds. The backward method's lattice has one more
    layer of points on every side: f's inverse Jacobians at the points of the cells that
    give guesses are then central differences (the same whatever the margins), as
    everywhere inside the volume. Then cut to the cells that f can take into the frame
    (:func:`_cropped`)."""
    step = options.lattice_step
    lattice = CornerLattice(shape, step)
    if options.border != "constant" or backward:
        margins = border_margin3(field, lattice, frame, cover=options.border != "constant")
        if backward:
            margins = tuple((low + step, high + step) for low, high in margins)
        lattice = CornerLattice(
            shape, step, margins, box_first=options.border == "constant", regular=True
        )
    return _cropped(field, lattice, frame, pad=1 if backward else 0)


def _cropped(field, lattice: CornerLattice, frame: VolumeFrame, *, pad: int) -> CornerLattice:
    """``lattice`` cut to the cells that hold a source point that f can take into
    ``frame``: those within f's largest displacement along each axis
    (:func:`~.bands.displacement_reach`) and a voxel of the frame's voxels, and ``pad``
    cells more a side (the backward method's inverse Jacobians at the points of those
    cells are then central differences, as in the whole lattice). The cells left out
    cover no voxel of the frame: the result is the whole lattice's. A slice of the volume
    (the volume window's views) takes a slab of the lattice about its plane. Not sampled
    where the lattice has fewer than 8 times the samples' points."""
    nx, ny, nz = lattice.dims
    if nx * ny * nz < 8 * REACH_SAMPLES**3:
        return lattice
    reach = displacement_reach(field, lattice)
    if reach is None:
        return lattice
    low = np.array(frame.origin_voxels)
    high = low + np.array(frame.shape[::-1]) - 1
    return lattice.cropped(low - reach - 1, high + reach + 1, pad)


def _sample(program, texture: SourceTexture, coords, slab: Slab, options, groups: int) -> None:
    """The backward method's sampling pass over ``slab`` (``program``, its other uniforms
    set), once per :func:`_sample_passes`."""
    gl = texture.gl
    for index, (slices, runs) in enumerate(_sample_passes(texture, coords, slab, options)):
        held = texture.hold(runs)
        coords.bind_to_storage_buffer(bindings.VOLUME_COORDS.index)
        uniforms = {"u_source_runs": held, "u_slices": slices, "u_write_uncovered": index == 0}
        set_uniforms(program, uniforms)
        gl.mgl.memory_barrier()
        run_1d(program, slab.voxels, max_groups=groups)


def _band_pieces(
    bands: list[tuple[int, int]], lattice: CornerLattice, source: SourceTexture | None
) -> list[tuple[tuple[int, int], tuple[int, int]]]:
    """Each of ``bands`` (first cell layer, layers) with its pieces, those whose cells sample
    no more source slices than one texture holds (``grid`` a layer and one more either side,
    for trilinear interpolation): (band, piece) pairs, the band itself its one piece where
    the whole source is held."""
    if source is None or source.whole:
        return [(band, band) for band in bands]
    step = (source.max_slices - 2) // lattice.grid
    if step < 1:
        raise ValueError(
            f"a layer of cells of grid {lattice.grid} samples {lattice.grid + 2} source slices, "
            f"more than one texture holds ({source.max_slices}); give a larger texture_bytes "
            "(SlabOptions)"
        )
    return [
        ((first, layers), (f, min(step, first + layers - f)))
        for first, layers in bands
        for f in range(first, first + max(layers, 1), step)
    ]


def _hold_band(source: SourceTexture, lattice, first: int, layers: int, border: int):
    """Hold the source slices that cell layers ``first`` .. ``first + layers - 1`` sample
    (their voxels, one more each side for trilinear, by the border rule); returns
    ``u_source_runs``."""
    depth = source.source.shape[0]
    if source.whole or layers == 0:
        return source.hold([(0, depth - 1 if source.whole else 0)])
    offset = lattice.voxel_first[2]
    low = first * lattice.grid + offset - 1
    high = (first + layers) * lattice.grid + offset
    return source.hold(border_runs(low, high, depth, BORDERS[border]))


#: The bounds of the first slices the sampling shader computes (volume_first_slice).
_SLICE_LIMIT = 1 << 30


def _sample_passes(
    source: SourceTexture, coords, slab: Slab, options: VolumeOptions
) -> list[tuple[tuple[int, int], list[tuple[int, int]]]]:
    """The backward method's sampling passes over ``slab``: per pass, the range of first
    slices (``volume_first_slice``) of the voxels it samples and the source slices it holds
    (runs, :func:`~.texture.border_runs`). One pass holding the volume where it fits; else
    the first slices of the points in ``coords`` (read back) are cut into runs whose slices
    one texture holds, and the ranges tile every integer, so that each voxel is sampled in
    exactly one pass. A slice computed here from the float32 point may differ by one from
    the shader's (its snap to voxel centres), which each pass's range and slices allow for:
    pass k takes [start_k - 1, start_(k+1) - 2] and holds [start_k - 1, end_k + 2]."""
    depth = source.source.shape[0]
    every = (-_SLICE_LIMIT, _SLICE_LIMIT)
    if source.whole:
        return [(every, [(0, depth - 1)])]
    raw = np.frombuffer(coords.read(size=slab.voxels * COORD_BYTES), np.float32)
    points = raw.reshape(-1, 4)
    z = points[points[:, 3] >= 0, 2]
    if options.interpolation != "linear":
        z = z + np.float32(0.5)
    found = np.unique(np.clip(np.floor(z), -_SLICE_LIMIT, _SLICE_LIMIT).astype(np.int64))
    if len(found) == 0:
        return [(every, [(0, 0)])]

    def runs(start: int, end: int) -> list[tuple[int, int]]:
        return border_runs(start - 1, end + 2, depth, options.border)

    if runs_size(runs(int(found[0]), int(found[0]))) > source.max_slices:
        raise ValueError(
            f"a voxel samples up to 4 source slices about its point, more than one texture "
            f"holds ({source.max_slices}); give a larger texture_bytes (SlabOptions)"
        )
    groups: list[tuple[int, int]] = []
    start = end = int(found[0])
    for value in found[1:].tolist():
        if runs_size(runs(start, value)) <= source.max_slices:
            end = value
            continue
        groups.append((start, end))
        start = end = value
    groups.append((start, end))
    passes = []
    for index, (start, end) in enumerate(groups):
        low = -_SLICE_LIMIT if index == 0 else start - 1
        high = _SLICE_LIMIT if index == len(groups) - 1 else groups[index + 1][0] - 2
        passes.append(((low, high), runs(start, end)))
    return passes


def _value_max(source: SourceVolume) -> float:
    if source.integer:
        return float(np.iinfo(source.data.dtype).max)
    return 0.0


def make_volume_frame(options: VolumeOptions, shape: tuple[int, int, int]) -> VolumeFrame:
    """The :class:`VolumeFrame` of ``options`` for a source volume of ``shape``."""
    return VolumeFrame(
        options.output_shape or tuple(shape),  # type: ignore[arg-type]
        options.origin or (0.0, 0.0, 0.0),
        options.spacing or (1.0, 1.0, 1.0),
    )
