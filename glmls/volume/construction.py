"""The GPU passes that build a deformed volume, slab by slab of output slices.

One :class:`VolumeWarper` per GL context (:meth:`VolumeWarper.of`). For each slab of output
slices (:meth:`VolumeWarper.slabs`: its buffers within :class:`~.options.SlabOptions`, and a
box of columns and rows of them where whole slices exceed a texture's side or a storage
buffer), the deformed lattice is held band by band of z layers (:class:`LatticeBands`); then

- ``quads`` (the cells method): ``volume/raster.comp.glsl`` keeps, per output voxel, the
  first cell in scan order of the source whose deformed tetrahedra contain it (atomicMin of
  the cell's key), then ``volume/resolve.comp.glsl`` samples the source at the point
  interpolated in that cell's tetrahedron into the slab texture, read back into the output;
- ``backward``: the same two passes write source points instead (the first guess), Newton's
  method on f refines them (the field's :meth:`refine`) over the slab and the voxels about
  it, the fold pass (:mod:`.folds`) takes the voxels left without one next to a fold from
  their neighbours' points, and ``volume/sample.comp.glsl`` samples the source there.

The source volume is one texture where it fits, else the box of voxels that each piece of a
band (``quads``: a box of its cells) or each sampling pass over a box of the voxels a slab's
points read first (``backward``) samples (:mod:`.texture`). Every pass computes each voxel
from the same inputs whatever the slab, band and piece of the source it falls in (keys are
global cell numbers, places are taken from the output's origin): the slabbed result equals
the one-piece result exactly.
"""

from __future__ import annotations

import functools
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
from .fields import FOLD_REACH, Field
from .folds import COORD_BYTES, FoldPass
from .frame import CornerLattice, VolumeFrame, check_memory
from .kernel_field import pending_bytes
from .margins import border_margin3
from .options import SlabOptions, VolumeOptions
from .pieces import (
    band_pieces,
    hold_cells,
    plan_slabs,
    sample_passes,
    slab_region,
    used_pieces,
)
from .source import SourceVolume, prepare_volume, volume_background
from .target import SlabTargets
from .texture import SourceTexture

__all__ = ["VolumeWarper", "make_volume_frame"]

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
        self._targets = SlabTargets(self._gl, self._resources)
        # the Jacobians' texture and its size, kept while the next call's size is the same
        self._jacobian_texture: tuple[tuple[int, int, int], moderngl.Texture3D] | None = None

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
        cached = self._jacobian_texture
        if cached is not None and self._gl.usable:
            with self._gl.use():
                cached[1].release()
        self._jacobian_texture = None
        self._targets.release()
        self._resources.release()

    # -- planning -------------------------------------------------------------------------

    def slabs(
        self,
        frame: VolumeFrame,
        voxel_bytes: int,
        slab_bytes: int,
        side: int | None = None,
        reach: int = 0,
    ) -> Iterator[Slab]:
        """The slabs of ``frame`` (:func:`~.pieces.plan_slabs` on this context)."""
        return plan_slabs(self._gl, frame, voxel_bytes, slab_bytes, side, reach)

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
        # an output_shape beyond this machine's memory is a ValueError before its slabs are
        # listed or its array allocated
        check_memory(frame.shape, source.channels * np.dtype(source.dtype).itemsize)
        voxel_bytes = max(per_voxel, source.voxel_bytes)
        reach = FOLD_REACH if backward else 0
        planned = list(self.slabs(frame, voxel_bytes, slabs.slab_bytes, slabs.texture_side, reach))
        folds = FoldPass(self._gl, self._resources, planned, frame.shape) if backward else None
        out = source.empty_output(frame.shape)
        texture = SourceTexture(self._gl, source, slabs.texture_bytes, slabs.texture_side)
        try:
            survey = len(planned) > 1
            bands = self._bands(
                field, source.shape, frame, options, slabs, survey=survey, backward=backward
            )
            for slab in planned:
                target = self._targets.texture(slab, source)
                defines = {
                    "WARP_LINEAR": options.interpolation == "linear",
                    "WARP_BORDER": BORDERS.index(options.border),
                    "VOLUME_INTEGER": source.integer,
                    "VOLUME_IMAGE_FORMAT": source.image_format,
                    "VOLUME_SOURCE_TILES": not texture.planar,
                }
                uniforms = {
                    "u_source_size": source.shape[::-1],
                    "u_volume_size": source.shape[::-1],
                    "u_background": background,
                    "u_value_max": _value_max(source),
                }
                target.bind_to_image(bindings.VOLUME_TARGET.index, read=False, write=True)
                if backward:
                    coords = self._solve(field, bands, frame, slab, options, source.shape, folds)
                    program = self._gl.compute("volume/sample.comp.glsl", defines)
                    set_uniforms(program, uniforms | {"u_slab_size": slab.size})
                    _sample(program, texture, coords, slab, options, self._max_groups)
                else:
                    self._cells(bands, frame, slab, defines, uniforms, source=texture)
                self._gl.mgl.memory_barrier()
                self._targets.read(target, slab, source, out)
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
        check_memory(frame.shape, 16 + 12 + 4 + 1)  # points, the result's, residual, covered
        planned = list(
            self.slabs(frame, BACKWARD_BYTES, slabs.slab_bytes, slabs.texture_side, FOLD_REACH)
        )
        folds = FoldPass(self._gl, self._resources, planned, frame.shape)
        points = np.empty((*frame.shape, 4), np.float32)
        bands = self._bands(
            field, shape, frame, options, slabs, survey=len(planned) > 1, backward=True
        )
        for slab in planned:
            coords = self._solve(field, bands, frame, slab, options, shape, folds)
            raw = coords.read(size=slab.voxels * COORD_BYTES)
            points[slab_region(slab)] = np.frombuffer(raw, np.float32).reshape(
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
        cached = self._jacobian_texture
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
            "u_slab_first": slab.corner,
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
        # the last band rastered is still held: resolved first; over a source held in
        # pieces, in boxes of a band's cells whose voxels one texture holds
        pieces = band_pieces(wanted[::-1] or [(0, 0)], lattice, source)
        if source is not None and not source.whole:  # only those that hold a voxel's cell
            self._gl.mgl.memory_barrier()
            raw = np.frombuffer(keys.read(size=slab.voxels * KEY_BYTES), np.uint32)
            pieces = used_pieces(pieces, lattice, raw[raw != _NO_KEY] // 6)
        for index, ((whole_first, whole_layers), (first, layers), rows) in enumerate(pieces):
            if whole_layers:
                bands.load(whole_first, whole_layers)
            if source is not None:
                border = BORDERS[defines["WARP_BORDER"]]
                held = hold_cells(source, lattice, (first, layers), rows, border)
                set_uniforms(program, held | {"u_cell_rows": rows})
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

    def _solve(self, field, bands, frame, slab: Slab, options: VolumeOptions, shape, folds):
        """Backward: the source point of every voxel of ``slab`` in the coordinates buffer
        (x, y, z, w) in source voxels, w >= 0 the residual where found, else -1 - residual:
        the cells' first guess, refined by the field's Newton's method (:meth:`_newton`),
        over the slab's window, then the fold pass (``folds``, a :class:`~.folds.FoldPass`)."""
        newton = functools.partial(self._newton, field, bands, frame, options, shape)
        constant = options.border == "constant"
        origin = frame.origin_voxels
        return folds.solve(field, slab, newton, origin=origin, shape=shape, constant=constant)

    def _newton(self, field, bands, frame, options, shape, region: Slab, coords) -> None:
        """The backward method's source points of the voxels of ``region`` (a box of the
        canvas) into ``coords``: the cells' first guess (the passes over ``bands``), refined
        by ``field``'s Newton's method."""
        coords.bind_to_storage_buffer(bindings.VOLUME_COORDS.index)
        slopes = self._resources.buffer("volume_slopes", region.voxels * SLOPE_BYTES)
        slopes.bind_to_storage_buffer(bindings.VOLUME_SLOPES.index)
        defines = {"WARP_BORDER": BORDERS.index(options.border)}
        self._cells(bands, frame, region, defines, {"u_volume_size": shape[::-1]})
        self._gl.mgl.memory_barrier()
        field.refine(
            coords,
            region.size,
            frame.origin_voxels,
            shape,
            constant=options.border == "constant",
            first=region.corner,
            pending=self._resources.buffer("volume_pending", pending_bytes(region.voxels)),
        )


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
    set), once per :func:`sample_passes`."""
    gl = texture.gl
    points = np.zeros((0, 4), np.float32)
    if not texture.whole:
        raw = coords.read(size=slab.voxels * COORD_BYTES)
        points = np.frombuffer(raw, np.float32).reshape(-1, 4)
    for index, (low, high, box) in enumerate(sample_passes(texture, points, options)):
        held = texture.hold(box)
        coords.bind_to_storage_buffer(bindings.VOLUME_COORDS.index)
        uniforms = {"u_first_low": low, "u_first_high": high, "u_write_uncovered": index == 0}
        set_uniforms(program, held | uniforms)
        gl.mgl.memory_barrier()
        run_1d(program, slab.voxels, max_groups=groups)


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
