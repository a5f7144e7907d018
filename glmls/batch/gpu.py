"""The GPU path of a batch: the ``quads``, ``backward`` or ``backward-swap`` of many images of
one shape in one submission.

Per chunk of images (:func:`chunk_size`):

1. f at every image's mesh vertices in one dispatch
   (:class:`~glmls.engine.batched.BatchLattices`, ``mls/points.comp.glsl`` with
   ``MLS_BATCH``; :class:`KernelLattices`, a pass per image's own kernel, for segments and
   bins) into one mesh buffer;
2. ``batch/cells.comp.glsl``: ONE dispatch scan-converts every cell of every image, keeping
   per output pixel the key of the first triangle in scan order (the single warp's keys and
   fold rule), in a winner buffer laid out as an atlas of the output canvases stacked top to
   bottom;
3. ``batch/resolve.frag.glsl``: ONE draw fills the atlas from the keys, sampling the sources
   as layers of one texture array (nearest: the key's source pixel; linear: the winning
   triangle interpolated, then sampled bilinearly; where ``batch/check.comp.glsl`` shows a
   bilinear image's mesh to be an embedding, the scan colours its pixels itself, without
   keys, and the draw covers only the other images' rows: :mod:`.fill`); for ``backward``
   (:meth:`BatchQuads.backward`) the draw writes the source points, ONE dispatch of
   ``warp/inverse.comp.glsl`` refines them by Newton's method on each image's f, and ONE
   draw of ``batch/backward.frag.glsl`` samples the sources there;
4. ONE read-back of the atlas.

Nearest 8-bit chunks take the fused scan on the caller's bytes instead
(:mod:`glmls.batch.texels`: one upload, a GPU test of which meshes are embeddings, the
colours written in the scan, the atlas packed into the caller's layout on the GPU).

The arithmetic is the single warp's (the same edge functions, keys, barycentrics, Newton
steps and sampling), so each image equals its :func:`glmls.warp`, bit for bit. This path
takes ``quads`` and ``backward`` on the regular mesh with any border (a chunk's images
share the margin of their meshes past the image, :mod:`glmls.batch.margins`), and
``backward-swap`` (:mod:`glmls.batch.swap`: no mesh, ONE dispatch of the swapped-handles
map over the atlas of maps, then :meth:`BatchQuads.sample_maps` and one read-back).
``splat`` and ``paper-quads`` take :mod:`glmls.batch.forward`; the adaptive mesh and the
other cases take the single pipeline per image (:mod:`glmls.batch.single`).
"""

from __future__ import annotations

import moderngl
import numpy as np

from ..core.mesh import MeshLattice
from ..engine.passes import POINTS_PER_INVOCATION, evaluate_lattice
from ..gl import bindings
from ..gl.context import GLContext, current
from ..gl.dispatch import (
    LOCAL_SIZE,
    LOCAL_SIZE_2D,
    ScanPieces,
    SecondPass,
    fill_buffer,
    set_uniforms,
)
from ..gl.resources import keep_framebuffer
from ..gl.tables import TABLE_WIDTH
from ..imaging.frame import Frame
from ..imaging.inverse import (
    ACCEPT_STEPS,
    NEWTON_ACCEPT,
    NEWTON_STEPS,
    NEWTON_TOLERANCE,
    RESCUE_RUNS,
)
from ..imaging.options import WarpOptions
from ..imaging.quads import key_layout
from ..imaging.readback import read_rgba8
from ..imaging.source import BORDERS, SourceImage
from .covering import MeshVertices
from .drawer import BatchDrawer, mesh_stride, upload_meshes
from .fill import array_form, embedding_flags, runs, scan

__all__ = [
    "CHUNK_BYTES",
    "BatchQuads",
    "KernelLattices",
    "batchable",
    "chunk_size",
    "fits",
    "mesh_capacity",
]

#: The most GPU memory one chunk of a batch takes (sources, atlas, keys, meshes), bytes: a
#: batch of 10,000 images runs chunk by chunk, never all on the GPU at once.
CHUNK_BYTES = 256 << 20


def batchable(options: WarpOptions) -> bool:
    """Does a batch of these options take the batched GPU path (``quads``, ``backward`` or
    ``backward-swap``, on the regular mesh)?"""
    return options.method in ("quads", "backward", "backward-swap") and options.tolerance is None


def chunk_size(
    gl: GLContext,
    source: SourceImage,
    frame: Frame,
    lattice: MeshLattice,
    max_bytes: int,
    *,
    backward: bool = False,
) -> int:
    """Images per chunk: the atlas within the GL texture size, the sources within the array
    layers, and the chunk's GPU memory within ``max_bytes`` (``backward``: with the atlas of
    backward maps, RGBA32F)."""
    (width, height), components, dtype = array_form(source)
    texel = components * (1 if dtype == "f1" else 4)
    target = 4 if source.normalized else 16
    per_image = width * height * texel + frame.pixels * (target + 8) + mesh_stride(lattice)
    per_image += frame.pixels * 16 if backward else 0
    atlas = gl.limits["max_texture_size"] // max(frame.shape[0], height)
    layers = int(gl.mgl.info.get("GL_MAX_ARRAY_TEXTURE_LAYERS", 256))
    block = gl.limits["max_ssbo_size"] // max(4 * frame.pixels, mesh_stride(lattice))  # keys
    return max(1, min(atlas, layers, block, mesh_capacity(gl, lattice), max_bytes // per_image))


def mesh_capacity(gl: GLContext, lattice: MeshLattice) -> int:
    """The most images whose meshes on ``lattice`` the mesh table holds (a texture of
    ``TABLE_WIDTH`` x ``GL_MAX_TEXTURE_SIZE`` vertices)."""
    return max(1, TABLE_WIDTH * gl.limits["max_texture_size"] // (mesh_stride(lattice) // 8))


def fits(gl: GLContext, shape: tuple[int, int], frame: Frame, lattice: MeshLattice) -> bool:
    """Can one image of ``shape`` (H, W) take this path to ``frame`` on ``lattice``: its
    mesh in one lattice dispatch and one storage block, its keys in one storage block, its
    canvas and source within the texture size, its bytes (4 a pixel at most) and its mesh
    within a table? (A larger one takes the single pipeline, which runs it in bands.)"""
    columns, rows = lattice.dims
    groups = -(-columns * rows // (LOCAL_SIZE * POINTS_PER_INVOCATION))
    block = gl.limits["max_ssbo_size"]
    side = gl.limits["max_texture_size"]
    table = TABLE_WIDTH * (side - 1)  # items (a row to spare)
    return (
        groups <= gl.limits["max_work_groups_x"]
        and max(mesh_stride(lattice), 4 * frame.pixels) <= block
        and max(*shape, *frame.shape) <= side
        and max(shape[0] * shape[1], frame.pixels, mesh_stride(lattice) // 8) <= table
    )


def _read_coords(mgl, framebuffer, atlas, count: int, frame: Frame, covered: int):
    """An RGBA32F atlas of maps read back: (N, H, W, 2) source points and (N, H, W) bool
    covered (its channel ``covered``)."""
    out_w, out_h = frame.size
    values_out = np.empty((atlas[1], atlas[0], 4), np.float32)
    with keep_framebuffer(mgl):
        framebuffer.use()
        framebuffer.read_into(values_out, (0, 0, *atlas), 4, dtype="f4")
    values_out = values_out.reshape(count, out_h, out_w, 4)
    return values_out[..., :2].copy(), values_out[..., covered] > 0.5


def _read_atlas(mgl, framebuffer, atlas, source: SourceImage, count: int, frame: Frame, out=None):
    """The atlas read back as (N, H, W, C) in the sources' dtype (``out``: 8-bit sources' (N,
    H, W[, C]) uint8 array, C-contiguous, read into and returned)."""
    out_w, out_h = frame.size
    with keep_framebuffer(mgl):
        framebuffer.use()
        if source.normalized and out is not None:
            read_rgba8(framebuffer, atlas, source.channels, out.reshape(atlas[1], out_w, -1))
            return out
        if source.normalized:
            values_out = read_rgba8(framebuffer, atlas, source.channels)
        else:
            values_out = np.empty((atlas[1], atlas[0], 4), np.float32)
            framebuffer.read_into(values_out, (0, 0, *atlas), 4, dtype="f4")
            values_out = values_out[..., : source.channels]
    return source.restore(values_out.reshape(count, out_h, out_w, -1))


class KernelLattices:
    """Images' own kernels (:class:`~glmls.engine.kernel.MLSKernel`) in the form of a
    :class:`~glmls.engine.batched.BatchLattices`: a lattice pass per image, for what the
    batched evaluation does not take (segments, spatial bins)."""

    def __init__(self, kernels: list) -> None:
        self.kernels = kernels
        self.centers = np.array([k.scaling.center for k in kernels], np.float64)
        self.scales = np.array([k.scaling.scale for k in kernels], np.float64)

    def __len__(self) -> int:
        return len(self.kernels)

    def evaluate(self, gl, resources, lattice: MeshLattice, target, stride: int) -> None:
        """f of image k on ``lattice`` into ``target`` from byte ``k * stride``."""
        del gl, resources
        for k, kernel in enumerate(self.kernels):
            evaluate_lattice(kernel, lattice, target, offset=k * stride)


class BatchQuads(BatchDrawer):
    """The batched quads of a context (see the module docstring); one per context,
    :meth:`of`."""

    label = "the batch quads"

    #: Nearest 8-bit chunks write the colours in the scan (fix-ups where triangles overlap,
    #: :mod:`glmls.batch.texels`) instead of a fill draw from the keys; tests take both ways.
    fused: bool = True
    #: Bilinear chunks: the meshes shown to be embeddings are coloured by the scan, without
    #: keys (``BATCH_CELLS_LINEAR``), the others by the fill draw; tests take both ways.
    fused_linear: bool = True
    #: The last :meth:`warp`'s scan's flags where it tested its meshes (:meth:`scan_folded`).
    _scan_folded: np.ndarray | None = None

    def scan_folded(self) -> np.ndarray | None:
        """(N,) bool: the meshes of the last :meth:`warp`'s chunk that its scan did not show
        to be embeddings, where the scan tested them (bilinear, fused); else None."""
        return self._scan_folded

    @current
    def coords(
        self, count: int, lattice: MeshLattice, frame: Frame
    ) -> tuple[np.ndarray, np.ndarray]:
        """The map of the last :meth:`warp`'s chunk (``count`` images, its ``lattice`` and
        ``frame``, its meshes still in the mesh buffer): (N, H, W, 2) float32 source point of
        each output pixel, the quads' interpolated one as the single warp's coordinate fill
        gives it, and (N, H, W) bool covered."""
        framebuffer, atlas = self._fill_coords(count, lattice, frame)
        return _read_coords(self._gl.mgl, framebuffer, atlas, count, frame, 2)

    def _fill_coords(self, count: int, lattice: MeshLattice, frame: Frame):
        """The quads' source points of the chunk's meshes (in the mesh buffer) drawn into
        the RGBA32F atlas ``coords`` (s.x, s.y, 1, 0 where covered; 0 elsewhere), as the
        single warp's coordinate fill: (framebuffer, atlas size)."""
        sub_bits, col_shift, row_shift = key_layout(lattice, source_pixel=False)  # type: ignore[misc]
        gl, mgl = self._gl, self._gl.mgl
        out_w, out_h = frame.size
        atlas = (out_w, out_h * count)
        winner = self._resources.buffer("winner", out_w * out_h * count * 4)
        fill_buffer(self._gl, winner, out_w * out_h * count * 4)
        values = {
            **lattice.pixel_uniforms(),
            "u_target_size": frame.size,
            "u_origin": frame.origin,
            "u_source_size": lattice.shape[::-1],
            "u_mesh_dims": lattice.dims,
            "u_mesh_stride": mesh_stride(lattice) // 8,
            "u_images": count,
            "u_sub_bits": sub_bits,
            "u_col_shift": col_shift,
            "u_row_shift": row_shift,
        }
        scan = gl.compute("batch/cells.comp.glsl", {"WARP_CELLS_SOURCE": False})
        set_uniforms(scan, values)
        tables = self._resources.tables  # the chunk's meshes, bound again
        tables.bind("batch mesh", bindings.BATCH_MESH.index)
        tables.bind("batch scaling", bindings.BATCH_SCALING.index)
        winner.bind_to_storage_buffer(bindings.WINNER.index)
        cells = (lattice.dims[0] - 1) * (lattice.dims[1] - 1)
        mgl.memory_barrier()
        ScanPieces(gl).run_1d(scan, cells * count, max_groups=gl.limits["max_work_groups_x"])
        mgl.memory_barrier()
        framebuffer = self._resources.framebuffer("coords", atlas, "f4", tall=True)
        self._resources.fill(framebuffer.color_attachments[0], (0.0,) * 4, rows=atlas[1])
        self._resolve(values, atlas, framebuffer, winner, True, 0, coords=True)
        return framebuffer, atlas

    @current
    def backward(
        self,
        lattices,
        sources: list[SourceImage],
        options: WarpOptions,
        frame: Frame,
        background: tuple[float, float, float, float],
        lattice: MeshLattice,
        labels: tuple[list[SourceImage], tuple[float, float, float, float]] | None = None,
        into: tuple[np.ndarray | None, np.ndarray | None] = (None, None),
    ):
        """The chunk's images warped by ``backward`` (``lattice``: the first guess's mesh, past
        the images by the margin of a border mode; ``labels``: as :meth:`warp`'s, sampled
        nearest at the same maps, (images, labels) returned; ``into``: as :meth:`warp`'s):
        the quads' source
        points as the first guess (:meth:`coords`' fill), Newton on each image's f for every
        output pixel of every image in one dispatch (``warp/inverse.comp.glsl`` with
        ``MLS_BATCH``), one draw sampling the sources (``batch/backward.frag.glsl``), one
        read-back; as :meth:`warp` returns. The backward maps stay in the ``coords`` atlas
        (:meth:`backward_coords`)."""
        height, width = sources[0].shape
        if key_layout(lattice, source_pixel=False) is None:
            return None
        count = len(sources)
        gl, mgl = self._gl, self._gl.mgl
        self.meshes(lattices, lattice)
        framebuffer, atlas = self._fill_coords(count, lattice, frame)
        coords = framebuffer.color_attachments[0]
        border = BORDERS.index(options.border)
        defines = {"WARP_SWAP": False, "WARP_NEWTON_STEPS": NEWTON_STEPS, "WARP_BORDER": border}
        groups = [-(-n // LOCAL_SIZE_2D) for n in frame.size]
        uniforms = {
            **frame.uniforms(),
            "u_source_size": (width, height),
            "u_tolerance": NEWTON_TOLERANCE,
            "u_newton_unit": 1.0,  # the images' pixels
            "u_accept": NEWTON_ACCEPT,
            "u_accept_steps": ACCEPT_STEPS,
        }
        # each part's pixels whose Newton ends above the residual accepted, again by damped
        # Newton in a second pass over those alone (the same parts, bound alike, in order)
        second = SecondPass(gl)
        passes = lattices.parts(
            gl, self._resources, lattice, "warp/inverse.comp.glsl",
            defines, defines | {"WARP_RESCUE": True},
        )  # fmt: skip
        for (program, rescue), rows in passes:
            set_uniforms(program, uniforms)
            second.start(program)
            mgl.memory_barrier()
            coords.bind_to_image(bindings.INVERSE_MAP.index, read=True, write=True)
            program.run(group_x=groups[0], group_y=groups[1], group_z=rows)
            set_uniforms(rescue, uniforms)
            second.finish_runs(rescue, RESCUE_RUNS)
        mgl.memory_barrier()
        maps = (coords, atlas, frame)
        return self.sample_maps(sources, maps, options, background, labels, into)

    def sample_maps(self, sources, maps, options, background, labels, into=(None, None)):
        """The chunk's ``sources`` sampled at its backward maps (``maps``: the maps' texture,
        the atlas's size and the frame; by ``options``' interpolation and border), read back,
        and with ``labels`` (the label images and their background) those sampled nearest at
        the same maps: as :meth:`backward` returns (``into``: as :meth:`warp`'s)."""
        linear = options.interpolation == "linear"
        border = BORDERS.index(options.border)
        out = self._sample(sources, maps, background, (linear, border), "atlas", into[0])
        if labels is None:
            return out
        label_sources, zero = labels
        warped = self._sample(label_sources, maps, zero, (False, border), "labels atlas", into[1])
        return out, warped

    def _sample(self, sources, maps, background, rule, name, out):
        """``sources`` sampled at the backward maps (``maps``: their texture, the atlas's
        size, the frame) by ``rule`` (bilinear, the WARP_BORDER code) into the atlas
        framebuffer ``name`` (``background`` where no map point is), read back
        (batch/backward.frag.glsl; into ``out`` where given)."""
        coords, atlas, frame = maps
        linear, border = rule
        source = sources[0]
        height, width = source.shape
        gl, mgl = self._gl, self._gl.mgl
        target = self._atlas(name, source, atlas, background)
        program = gl.program(
            "common/fullscreen.vert.glsl",
            "batch/backward.frag.glsl",
            {"WARP_LINEAR": linear, "WARP_BORDER": border},
        )
        set_uniforms(program, {"u_target_size": frame.size, "u_source_size": (width, height)})
        with keep_framebuffer(mgl):
            target.use()
            target.viewport = (0, 0, *atlas)
            self._sources.bind(sources, None, linear)
            coords.use(bindings.COORDS.index)
            mgl.disable(moderngl.DEPTH_TEST | moderngl.BLEND | moderngl.CULL_FACE)
            self._resources.vertex_array(program).render(moderngl.TRIANGLES, vertices=3)
        return _read_atlas(mgl, target, atlas, source, len(sources), frame, out)

    def backward_coords(self, count: int, frame: Frame) -> tuple[np.ndarray, np.ndarray]:
        """The last :meth:`backward`'s maps: (N, H, W, 2) float32 source points and (N, H,
        W) bool covered, as the single warp's backward map."""
        out_w, out_h = frame.size
        atlas = (out_w, out_h * count)
        framebuffer = self._resources.framebuffer("coords", atlas, "f4", tall=True)
        return _read_coords(self._gl.mgl, framebuffer, atlas, count, frame, 3)

    def _atlas(
        self, name: str, source: SourceImage, atlas, background, *, like=None
    ) -> moderngl.Framebuffer:
        """The framebuffer ``name`` of an atlas of ``atlas`` (W, H) texels in ``source``'s
        form (RGBA8, or RGBA32F for unnormalized values) in the first rows of its texture
        (kept from a larger chunk), those rows filled with ``background``. ``like``: a
        framebuffer whose texture's size this one's takes exactly (one framebuffer then
        draws both)."""
        dtype = "f1" if source.normalized else "f4"
        if like is None:
            framebuffer = self._resources.framebuffer(name, atlas, dtype, tall=True)
        else:
            framebuffer = self._resources.framebuffer(name, like.size, dtype)
        self._resources.fill(framebuffer.color_attachments[0], background, rows=atlas[1])
        return framebuffer

    def _resolve(
        self,
        values,
        atlas,
        framebuffer,
        winner,
        linear,
        border,
        *,
        coords=False,
        labels=False,
        keyed: np.ndarray | None = None,
    ) -> None:
        """The atlas filled from the keys by one draw (batch/resolve.frag.glsl), the sources
        (bound by :meth:`.fill.SourceArrays.bind`) read by the border rule ``border`` (its
        WARP_BORDER code); ``coords``: the source points instead of colours. ``winner``
        None: the keys of the last resolve again. ``labels``: the label images sampled at
        the keys' nearest source pixels into the framebuffer's second attachment by the same
        draw. ``keyed`` ((N,) bool): draw only the rows of those images (a draw over rows
        without keys costs llvmpipe as much as one with them); None: every image."""
        gl, mgl = self._gl, self._gl.mgl
        count = len(keyed) if keyed is not None else 1
        drawn = [(0, count)] if keyed is None else runs(keyed)
        if not drawn:
            return
        keys = self._resources.texture("winner", atlas, 1, "u4", tall=True)
        if winner is not None:
            keys.write(winner, viewport=(0, 0, *atlas))
        with keep_framebuffer(mgl):
            framebuffer.use()
            defines = {"WARP_LINEAR": linear, "WARP_OUTPUT_COORDS": coords, "WARP_BORDER": border}
            defines["BATCH_RESOLVE_LABELS"] = labels
            program = gl.program("common/fullscreen.vert.glsl", "batch/resolve.frag.glsl", defines)
            set_uniforms(program, values)
            keys.use(bindings.WINNER_TEXTURE.index)
            mgl.disable(moderngl.DEPTH_TEST | moderngl.BLEND | moderngl.CULL_FACE)
            rows = atlas[1] // count  # an image's
            for first, end in drawn:  # gl_FragCoord stays the atlas's pixel
                framebuffer.viewport = (0, first * rows, atlas[0], (end - first) * rows)
                self._resources.vertex_array(program).render(moderngl.TRIANGLES, vertices=3)

    @current
    def meshes(self, lattices, lattice: MeshLattice) -> moderngl.Buffer:
        """f of every image of ``lattices`` at the points of ``lattice`` into the mesh buffer
        (returned: :meth:`vertices` reads it back) and the tables the scans read
        (:func:`~glmls.batch.drawer.upload_meshes`)."""
        return upload_meshes(self._gl, self._resources, lattices, lattice)

    @current
    def vertices(self, lattices, lattice: MeshLattice) -> MeshVertices:
        """The last chunk's mesh vertices in pixels (f at the lattice of each image of
        ``lattices``, its chunk's), read back once and converted to float64 where indexed
        (:class:`~glmls.batch.covering.MeshVertices`)."""
        stride = mesh_stride(lattice)
        count = len(lattices)
        self._gl.mgl.memory_barrier()  # the lattice passes' stores before the read
        raw = self._resources.cached("mesh").read(size=count * stride)
        columns, rows = lattice.dims
        scaled = np.frombuffer(raw, np.float32).reshape(count, stride // 4)
        scaled = scaled[:, : rows * columns * 2].reshape(count, rows, columns, 2)
        return MeshVertices(scaled, lattices.scales, lattices.centers)

    @current
    def folded(self, count: int) -> np.ndarray:
        """(N,) bool: the meshes of the last chunk of :func:`~glmls.batch.texels.warp_texels`
        that ``batch/check.comp.glsl`` did not show to be embeddings."""
        return embedding_flags(self._gl, self._resources, count)

    @current
    def warp(
        self,
        lattices,
        sources: list[SourceImage],
        options: WarpOptions,
        frame: Frame,
        background: tuple[float, float, float, float],
        lattice: MeshLattice,
        labels: tuple[list[SourceImage], tuple[float, float, float, float]] | None = None,
        into: tuple[np.ndarray | None, np.ndarray | None] = (None, None),
    ):
        """The chunk's images warped (``lattices``: their handles, a
        :class:`~glmls.engine.batched.BatchLattices` or :class:`KernelLattices`; ``lattice``:
        their mesh's, past the images by the margin of a border mode) by a fill draw from the
        keys: (N, H, W, C) restored to the sources' dtype (each
        :meth:`SourceImage.restore`), or None where the keys of this mesh do not fit in 31
        bits (the single path's rasterizer then draws it). Nearest 8-bit chunks take the
        fused scan on their bytes instead (:mod:`glmls.batch.texels`).

        ``labels`` (the chunk's label images and their background) are warped with nearest
        sampling from the same scan: its keys then carry the nearest source pixel, and a
        bilinear fill of the images takes only the winning triangle from them (the one the
        keys without source pixels pick: those bits rank below the triangle's). Returns
        (images, labels) then. ``into``: arrays of 8-bit images and labels, (N, H, W[, C])
        uint8 and C-contiguous, or None each, that the read-back fills and returns (a batch's
        result written in place)."""
        self._scan_folded = None
        height, width = sources[0].shape
        linear = options.interpolation == "linear"
        nearest_keys = not linear or labels is not None
        layout = key_layout(lattice, source_pixel=nearest_keys)
        if layout is None:
            return None
        sub_bits, col_shift, row_shift = layout
        count = len(sources)
        gl, mgl = self._gl, self._gl.mgl
        stride = mesh_stride(lattice)
        self.meshes(lattices, lattice)  # 1. every image's f
        source = sources[0]
        out_w, out_h = frame.size
        atlas = (out_w, out_h * count)
        winner = self._resources.buffer("winner", out_w * out_h * count * 4)
        fill_buffer(self._gl, winner, out_w * out_h * count * 4)
        values = {
            **lattice.pixel_uniforms(),
            "u_target_size": frame.size,
            "u_origin": frame.origin,
            "u_source_size": (width, height),
            "u_mesh_dims": lattice.dims,
            "u_mesh_stride": stride // 8,
            "u_images": count,
            "u_sub_bits": sub_bits,
            "u_col_shift": col_shift,
            "u_row_shift": row_shift,
        }
        mgl.memory_barrier()
        framebuffer = self._atlas("atlas", source, atlas, background)
        label_sources, label_buffer = None, None
        if labels is not None:
            label_sources, zero = labels
            label_buffer = self._atlas(
                "labels atlas", label_sources[0], atlas, zero, like=framebuffer
            )
        winner.bind_to_storage_buffer(bindings.WINNER.index)
        self._sources.bind(sources, label_sources, linear)
        targets = [framebuffer, label_buffer]
        targets = [None if t is None else t.color_attachments[0] for t in targets]
        border = BORDERS.index(options.border)
        keys_form = (nearest_keys, linear, border)  # 2.
        fused = self.fused_linear
        keyed = scan(gl, self._resources, values, lattice, count, keys_form, targets, fused=fused)
        self._scan_folded = keyed
        mgl.memory_barrier()
        fill = (winner, linear, border)
        if labels is None:
            self._resolve(values, atlas, framebuffer, *fill, keyed=keyed)  # 3.
            return _read_atlas(mgl, framebuffer, atlas, source, count, frame, into[0])  # 4.
        # 3. into a second attachment of the same draw
        both = self._resources.attached("atlas and labels", ("atlas", "labels atlas"))
        self._resolve(values, atlas, both, *fill, labels=True, keyed=keyed)
        out = _read_atlas(mgl, framebuffer, atlas, source, count, frame, into[0])  # 4.
        label_source = label_sources[0]
        return out, _read_atlas(mgl, label_buffer, atlas, label_source, count, frame, into[1])
