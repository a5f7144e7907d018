"""The GPU path of a batch for the forward methods, ``splat`` and ``paper-quads``: the pixel
centres of many images of one shape pushed forward in one submission per chunk.

Per chunk of images (:func:`~glmls.batch.gpu.chunk_size`):

1. f at every image's pixel centres (the lattice of the single warp: past the image by its
   mesh's margin with a border mode, for ``paper-quads`` one pixel more) in one dispatch
   (:class:`~glmls.engine.batched.BatchLattices`; :class:`~glmls.batch.gpu.KernelLattices`
   for segments and bins) into the mesh table;
2. ``splat``: ONE instanced draw of points (``batch/splat.vert.glsl``, an instance per
   image) into an atlas of the output canvases stacked top to bottom: each point rounded to
   its pixel centre and the points in reverse scan order, as the single draw
   (:mod:`glmls.imaging.raster`) places them, so that where f folds the first source pixel
   in scan order shows; ``paper-quads`` (:mod:`.paper`): ONE scan of every image's squares
   (and, linear, one of their source points) and ONE draw from its keys; the masks
   (nearest) and, for keypoints and maps, the numbers of the source pixels drawn into more
   attachments of the same draw (:class:`~glmls.batch.canvases.ForwardTargets`);
3. ONE read-back of the atlas.

Each image equals its :func:`glmls.warp`, bit for bit. The keypoints are moved by f at
their probes, every image's in one pass (:func:`~glmls.batch.probes.keypoints_by_f`), and
tested against the pixels drawn; the maps (f's inverse, by Newton's method), and the
keypoints with them or with a border mode, are each image's own, as the single path finds
them (:class:`~glmls.batch.single.SingleWarper`), with the pixels drawn taken from the batch.
With a border mode the images of a chunk share one margin (:mod:`glmls.batch.margins`);
images with segment handles or without handles then take the single path.
"""

from __future__ import annotations

from contextlib import ExitStack

import moderngl
import numpy as np

from ..core.mesh import MeshLattice
from ..engine.batched import BatchLattices
from ..gl.context import current
from ..gl.dispatch import set_uniforms
from ..gl.resources import keep_framebuffer
from ..imaging.frame import Frame, make_frame
from ..imaging.options import WarpOptions
from ..imaging.source import (
    BORDERS,
    SourceImage,
    background_color,
    prepare_image,
    prepare_images,
)
from ..mls import MLS
from .canvases import ForwardTargets
from .drawer import BatchDrawer, mesh_stride, upload_meshes
from .gpu import CHUNK_BYTES, KernelLattices, chunk_size, fits
from .inputs import BatchInput, naming
from .margins import batch_margins, warn_short
from .paper import BatchPaper, chunk_squares, paper_lattice
from .probes import batch_config, far_targets, keypoints_by_f
from .single import ImageLabels, SingleWarper, mask_form, restore_mask

__all__ = ["BatchSplat", "forward_batchable", "warp_forward"]

#: The keywords of :func:`glmls.warp_batch` that make its :class:`~glmls.MLSConfig`.
_CONFIG_KEYS = ("transform", "weight", "alpha", "s", "radius", "interpolating")

#: The methods of the batched forward path.
FORWARD_METHODS = ("splat", "paper-quads")


def forward_batchable(options: WarpOptions) -> bool:
    """Does a batch of these options take the batched forward path (``splat``,
    ``paper-quads``)?"""
    return options.method in FORWARD_METHODS


def warp_forward(
    batch: BatchInput,
    options: WarpOptions,
    mls_options: dict,
    segments: list[dict],
    *,
    maps: bool,
    max_bytes: int | None,
) -> list[ImageLabels | None]:
    """Each image's :class:`ImageLabels` from the batched ``splat`` or ``paper-quads``
    (None for an image it leaves to the single path: a mesh beyond one dispatch, a lattice
    that the single warp refuses, or with a border mode an image of its own MLS)."""
    run = _ForwardRun(batch, options, mls_options, segments, maps, max_bytes or CHUNK_BYTES)
    return run.results


class BatchSplat(BatchDrawer):
    """The batched splat of a context (see the module docstring); one per context,
    :meth:`of`."""

    label = "the batch splat"

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
        *,
        drawn: bool = False,
    ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
        """The chunk's images splatted on ``lattice`` (the pixel centres, past the images by
        the margin of a border mode): (N, H, W, C) in the sources' dtype, the label images
        (``labels``: the chunk's and their background) warped nearest alike or None, and
        where ``drawn`` the (N, H, W, 2) float32 numbers + 1 of the image pixels drawn (0
        where none is) or None."""
        gl, mgl, resources = self._gl, self._gl.mgl, self._resources
        count = len(sources)
        height, width = sources[0].shape
        upload_meshes(gl, resources, lattices, lattice)
        targets = ForwardTargets(
            resources, count, frame, sources[0], background, labels, drawn=drawn
        )
        defines = {
            "WARP_LINEAR": options.interpolation == "linear",
            "WARP_BORDER": BORDERS.index(options.border),
            "BATCH_FORWARD_LABELS": labels is not None,
            "BATCH_FORWARD_DRAWN": drawn,
        }
        program = gl.program("batch/splat.vert.glsl", "batch/splat.frag.glsl", defines)
        set_uniforms(
            program,
            {
                **lattice.pixel_uniforms(),
                "u_target_size": frame.size,
                "u_origin": frame.origin,
                "u_source_size": (width, height),
                "u_mesh_dims": lattice.dims,
                "u_mesh_stride": mesh_stride(lattice) // 8,
                "u_images": count,
            },
        )
        self._sources.bind(sources, targets.label_sources, defines["WARP_LINEAR"])
        with keep_framebuffer(mgl):
            framebuffer = targets.framebuffer
            framebuffer.use()
            framebuffer.viewport = (0, 0, *targets.size)
            mgl.disable(moderngl.DEPTH_TEST | moderngl.BLEND | moderngl.CULL_FACE)
            mgl.point_size = 1.0
            vao = resources.vertex_array(program)
            vao.render(moderngl.POINTS, vertices=lattice.count, instances=count)
        return targets.read(mgl)


class _ForwardRun:
    """One :func:`warp_forward`: the batch's groups of one shape, each group's parts of one
    lattice (one margin past the images, with a border mode), each part's chunks."""

    def __init__(self, batch, options, mls_options, segments, maps, budget) -> None:
        self.batch, self.options, self.maps, self.budget = batch, options, maps, budget
        self.mls_options, self.segments = mls_options, segments
        self.results: list[ImageLabels | None] = [None] * len(batch)
        self.paper = options.method == "paper-quads"
        self.drawer = (BatchPaper if self.paper else BatchSplat).of(mls_options.get("ctx"))
        self.warper = SingleWarper.of(mls_options.get("ctx"))
        self.config = batch_config(batch, mls_options)
        # segment handles, or no point handle at all: the image's own MLS, as one warp does
        self.own = [bool(segments[i]) or not len(batch.src[i]) for i in range(len(batch))]
        if options.border != "constant" and self.config is None:
            return  # each image's own kernel finds its mesh's margin
        far = far_targets(batch, mls_options, segments)  # the single path
        for indices in batch.groups():
            if kept := [i for i in indices if not far[i]]:
                self._group(kept)

    def _group(self, indices: list[int]) -> None:
        batch, options = self.batch, self.options
        limit = self.warper.pipeline.max_image_size
        with naming(indices[0]):
            source = prepare_image(batch.images[indices[0]], limit, normalized=True)
        frame = make_frame(options.output_shape, options.origin, source.shape, limit)
        parts, short = [(0, indices)], {}
        if options.border != "constant":  # the images by their meshes' margins
            corners = MeshLattice.corners(source.shape, 1)
            taken = [i for i in indices if not self.own[i]]
            gl = self.drawer.ctx
            found, short = batch_margins(gl, self.config, batch, taken, corners, frame)
            parts = sorted(found.items())
        for margin, part in parts:
            lattice = self._lattice(source.shape, margin)
            if lattice is not None and fits(self.drawer.ctx, source.shape, frame, lattice):
                self._part(part, lattice, frame, source)
        warn_short(short, self.results, stacklevel=5)  # warp_batch's caller

    def _lattice(self, shape: tuple[int, int], margin: int) -> MeshLattice | None:
        """The single warp's lattice of pixel centres for images of ``shape`` whose corner
        mesh reaches ``margin`` past them (None: one the single path refuses, naming the
        image)."""
        if self.paper:
            return paper_lattice(shape, margin, self.options.border)
        return MeshLattice.centres(shape, margin=margin)

    def _part(self, part: list[int], lattice: MeshLattice, frame: Frame, source) -> None:
        gl = self.drawer.ctx
        # a linear paper-quads: an atlas of source points (RGBA32F) besides the keys
        points = self.paper and self.options.interpolation == "linear"
        size = chunk_size(gl, source, frame, lattice, self.budget, backward=points)
        size = min(size, gl.limits["max_viewport"] // frame.shape[0])
        if self.paper:
            size = min(size, chunk_squares(lattice))
        for start in range(0, len(part), size):
            chunk = part[start : start + size]
            for i, labels in zip(chunk, self._chunk(chunk, lattice, frame), strict=True):
                self.results[i] = labels

    def _chunk(self, chunk: list[int], lattice: MeshLattice, frame: Frame) -> list[ImageLabels]:
        batch, options = self.batch, self.options
        shape = lattice.shape
        with ExitStack() as stack:
            if self.config is not None and not any(self.own[i] for i in chunk):
                src, dst = [batch.src[i] for i in chunk], [batch.dst[i] for i in chunk]
                lattices = BatchLattices(self.config, src, dst, shape)
            else:  # each image's own MLS
                mlss = [stack.enter_context(self._mls(i, shape)) for i in chunk]
                lattices = KernelLattices([m.kernel for m in mlss])
            limit = self.warper.pipeline.max_image_size
            images, names = [batch.images[i] for i in chunk], [f"images[{i}]" for i in chunk]
            sources = prepare_images(images, limit, normalized=True, names=names)
            with naming(chunk[0]):
                background = background_color(options.background, sources[0])
            labels = None
            if batch.masks is not None:
                masks = [batch.masks[i] for i in chunk]
                label_sources = prepare_images(
                    [mask_form(m) for m in masks], limit, normalized=True
                )
                labels = (label_sources, background_color(0.0, label_sources[0]))
            more = self.maps or batch.keypoints is not None
            moved = valid = None
            with self.drawer.ctx.use():
                args = (lattices, sources, options, frame, background, lattice, labels)
                out, warped, numbers = self.drawer.warp(*args, drawn=more)
                if (
                    batch.keypoints is not None
                    and not self.maps
                    and options.border == "constant"
                    and isinstance(lattices, BatchLattices)
                ):  # every image's keypoints by f at their probes in one pass
                    shown = (numbers - 1.0, numbers[..., 0] > 0.5)  # type: ignore[index]
                    moved, valid = keypoints_by_f(
                        self.drawer.ctx,
                        self.drawer.resources,
                        lattices,
                        batch,
                        chunk,
                        (frame, options.border),
                        shown,
                        drawn=True,
                    )
        results = []
        for k, i in enumerate(chunk):
            mask = None
            if warped is not None:
                mask = restore_mask(warped[k], batch.masks[i].dtype)  # type: ignore[index]
            if moved is not None and valid is not None:
                results.append(ImageLabels(out[k], mask, moved[k], valid[k]))
            elif more:
                labels = self._labels(i, out[k], mask, numbers[k], frame)  # type: ignore[index]
                results.append(labels)
            else:
                results.append(ImageLabels(out[k], mask))
        return results

    def _mls(self, i: int, shape: tuple[int, int]) -> MLS:
        batch = self.batch
        return MLS(batch.src[i], batch.dst[i], shape=shape, **self.segments[i], **self.mls_options)

    def _labels(self, i, image, mask, numbers, frame) -> ImageLabels:
        """Image ``i``'s keypoints and maps, as the single path finds them (f's inverse and
        f at the keypoints, by the image's own MLS), ``numbers`` the batch's numbers + 1 of
        the image pixels drawn."""
        batch, options = self.batch, self.options
        shape = batch.images[i].shape[:2]
        with self._mls(i, shape) as mls:
            pixels = numbers.astype(np.float64) - 1.0
            filled = numbers[..., 0] > 0.5
            coords = covered = None
            # f's inverse at every pixel (Newton's method) for the maps and a border mode's
            # copies; keypoints on the constant border need only the pixels drawn
            if self.maps or options.border != "constant":
                coords, covered = self.warper.source_points(mls, shape, options, frame)
                covered = covered & filled
            if options.border != "constant":  # beyond the image a drawn pixel is the border
                # rule's copy, of another number: f's inverse there
                height, width = shape
                edge = (coords < 0.5) | (coords > (width - 1.5, height - 1.5))
                pixels = np.where(edge.any(axis=-1)[..., None], coords, pixels)
            moved = valid = None
            points = None if batch.keypoints is None else batch.keypoints[i]
            if points is not None:
                shown = (pixels, filled)
                moved, valid = self.warper.keypoints(mls, shape, options, frame, points, shown)
        if not self.maps:
            coords = covered = None
        return ImageLabels(image, mask, moved, valid, coords, covered)
