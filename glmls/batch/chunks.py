"""A batch cut into chunks for the GPU path (:mod:`glmls.batch.gpu`): images of one shape
and dtype, as many per chunk as the GL limits and :data:`~glmls.batch.gpu.CHUNK_BYTES` allow,
each chunk's images, masks and keypoints in one submission and one read-back."""

from __future__ import annotations

from contextlib import ExitStack
from functools import partial

import numpy as np

from ..core.mesh import MeshLattice
from ..engine.batched import BatchLattices
from ..engine.kernel import check_loop_budget
from ..imaging.frame import make_frame
from ..imaging.options import WarpOptions
from ..imaging.readback import add_channel, drop_channels
from ..imaging.source import SourceImage, background_color, prepare_image, prepare_images
from ..mls import MLS
from .embedding import embedded
from .footprints import RING
from .gpu import CHUNK_BYTES, BatchQuads, KernelLattices, chunk_size, fits
from .inputs import BatchInput, naming
from .labels import mesh_keypoints, on_canvas
from .margins import batch_margins, warn_short
from .probes import batch_config, far_targets, keypoints_by_f
from .single import (
    ImageLabels,
    SingleWarper,
    beyond_mesh,
    mask_form,
    mask_options,
    packable,
    restore_mask,
)
from .swap import swapped_keypoints, swapped_lattices, warp_swapped
from .texels import chunk_size as texel_chunk_size
from .texels import takes, warp_texels

__all__ = ["warp_chunks"]


def warp_chunks(
    batch: BatchInput,
    options: WarpOptions,
    mls_options: dict,
    segments: list[dict],
    *,
    maps: bool,
    max_bytes: int | None,
) -> tuple[list[ImageLabels | None], dict[str, np.ndarray]]:
    """Each image's :class:`ImageLabels` from the batched GPU path (None for an image it
    left to the single path: keys too long for its mesh, a mesh beyond one dispatch), and
    where that path wrote every image's pixels (and masks) into one array, those arrays
    ("images", "masks"): the per-image results are views of them."""
    run = _GPURun(batch, options, mls_options, segments, maps, max_bytes or CHUNK_BYTES)
    return run.results, run.whole


class _GPURun:
    """One :func:`warp_chunks`: the batch's groups of one shape, each group's parts of one
    mesh lattice (one margin past the images, with a border mode), each part's chunks."""

    def __init__(self, batch, options, mls_options, segments, maps, budget) -> None:
        self.batch, self.options, self.maps, self.budget = batch, options, maps, budget
        self.mls_options, self.segments = mls_options, segments
        self.results: list[ImageLabels | None] = [None] * len(batch)
        self.whole: dict[str, np.ndarray] = {}
        self.quads = BatchQuads.of(mls_options.get("ctx"))
        self.warper = SingleWarper.of(mls_options.get("ctx"))
        self.config = batch_config(batch, mls_options)
        self.backward = options.method in ("backward", "backward-swap")
        # backward-swap: the swapped map at every pixel, no mesh (glmls.batch.swap)
        self.swap = options.method == "backward-swap"
        if self.backward and self.config is None:
            return  # bins, segments: each image's own MLS
        if self.backward:
            _check_newton_budget(self.quads.ctx, batch)
        if options.border != "constant" and self.config is None:
            return  # each image's own kernel finds its mesh's margin
        # segment handles, or no point handle at all: the image's own MLS, as one warp does
        self.own = [bool(segments[i]) or not len(batch.src[i]) for i in range(len(batch))]
        far = far_targets(batch, mls_options, segments)  # the single path
        groups = [kept for kept in ([i for i in g if not far[i]] for g in batch.groups()) if kept]
        for indices in groups:
            self._group(indices, alone=len(groups) == 1 and not any(far))

    def _group(self, indices: list[int], *, alone: bool) -> None:
        batch, options, quads = self.batch, self.options, self.quads
        first = batch.images[indices[0]]
        limit = self.warper.pipeline.max_image_size
        with naming(indices[0]):
            source = prepare_image(first, limit, normalized=True)
        frame = make_frame(options.output_shape, options.origin, source.shape, limit)
        lattice = MeshLattice.corners(source.shape, options.grid)
        parts, short = [(lattice, indices)], {}
        if options.border != "constant" and not self.swap:  # by their meshes' margins
            taken = [i for i in indices if not self.own[i]]
            found, short = batch_margins(quads.ctx, self.config, batch, taken, lattice, frame)
            parts = [(lattice.with_margin(m), part) for m, part in sorted(found.items())]
        direct, outputs = None, None
        if takes(options, first.dtype, quads.fused):  # the constant border: one part
            direct = _Direct(batch, indices, options, frame)
        else:
            outputs = _Outputs.of(batch, indices, options, frame)
        for mesh, part in parts:
            if not fits(quads.ctx, source.shape, frame, mesh):
                if direct is not None:
                    direct.complete = False
                continue  # the single pipeline, in bands
            self._part(part, mesh, frame, source, (direct, outputs))
        if not self.backward:  # backward warns nowhere: Newton needs no mesh there
            warn_short(short, self.results, stacklevel=5)  # warp_batch's caller
        held = direct if direct is not None else outputs
        if held is not None and held.complete and alone:
            self.whole["images"] = held.out
            if held.labels is not None:
                self.whole["masks"] = held.labels

    def _part(self, part: list[int], mesh, frame, source, holders) -> None:
        """The images ``part`` of one group on one ``mesh`` lattice, chunk by chunk
        (``holders``: the group's :class:`_Direct` and :class:`_Outputs`, or None each)."""
        batch, quads, budget = self.batch, self.quads, self.budget
        direct, outputs = holders
        if self.backward:  # an image of its own MLS takes the single path, not its chunk
            part = [i for i in part if not self.own[i]]
        size = chunk_size(quads.ctx, source, frame, mesh, budget, backward=self.backward)
        if direct is not None and not self.maps and (batch.masks is None or direct.packed):
            size = texel_chunk_size(
                quads.ctx, batch.images[part[0]].shape, frame, mesh, direct.packed, budget
            )
        for start in range(0, len(part), size):
            chunk = part[start : start + size]
            into = (None, None) if outputs is None else outputs.slot(chunk)
            done = self._chunk(chunk, mesh, frame, source, direct, start, into)
            if done is None:  # the keys do not fit: the single path takes the chunk
                if direct is not None:
                    direct.complete = False
                continue
            if outputs is not None:
                outputs.commit(chunk, done)
            for i, labels in zip(chunk, done, strict=True):
                self.results[i] = labels
        if batch.keypoints is not None and not self.backward:
            own_mls = (self.segments, self.mls_options, source.shape)
            batched = (self.quads, self.config, self.own)
            _beyond_mesh_by_f(self.results, part, batch, mesh, frame, own_mls, batched)

    def _chunk(
        self, chunk, lattice, frame, source, direct, start, into
    ) -> list[ImageLabels] | None:
        """One chunk through the GPU path on ``lattice`` (``direct``: the group's
        :class:`_Direct` where it takes the chunk, ``start`` the chunk's place there;
        ``into``: the arrays its images and masks are read into, :meth:`_Outputs.slot`)."""
        batch = self.batch
        with ExitStack() as stack:
            if self.config is not None and not any(self.own[i] for i in chunk):
                src, dst = [batch.src[i] for i in chunk], [batch.dst[i] for i in chunk]
                if self.swap:
                    lattices = swapped_lattices(self.config, src, dst, source.shape)
                    if lattices is None:
                        return None  # a q the batched checks refuse: the single path
                else:
                    lattices = BatchLattices(self.config, src, dst, source.shape)
            else:  # each image's own MLS
                mlss = [
                    stack.enter_context(
                        MLS(
                            batch.src[i],
                            batch.dst[i],
                            shape=source.shape,
                            **self.segments[i],
                            **self.mls_options,
                        )
                    )
                    for i in chunk
                ]
                lattices = KernelLattices([m.kernel for m in mlss])
            with self.quads.ctx.use():  # the chunk's passes, its meshes kept, in one hold
                args = (self.quads, self.warper, batch, chunk, lattices, self.options, frame)
                args += (lattice, self.maps)
                if self.swap:
                    return _chunk(*args, swap=(self.warper, self.mls_options), into=into)
                if direct is not None:
                    return direct.chunk(start, *args)
                return _chunk(*args, into=into)


def _beyond_mesh_by_f(results, indices, batch, lattice, frame, own_mls, batched) -> None:
    """The group's ``quads`` keypoints outside the mesh's domain (outside the image: the
    past the margin of a border mode) moved by f, as the single path moves them: for the
    images of the batched configuration (``batched``: the quads, the configuration or None,
    and per image whether it takes its own MLS) all at once, f at each image's own points in
    one pass (:meth:`~glmls.engine.batched.BatchLattices.evaluate_points`, bit for bit the
    image's own MLS); for the others the image's own MLS (``own_mls``: the per-image
    segments, the MLS keywords, the shape), made only for the images that have such
    keypoints."""
    sets = [batch.keypoints[i] for i in indices]
    sizes = np.array([len(p) for p in sets])
    points = np.concatenate(sets)
    beyond = beyond_mesh(lattice, points)
    if not beyond.any():
        return
    # the images (places in ``indices``) with such keypoints whose labels the group gave;
    # the others are left to the single path, which moves them so itself
    owner = np.repeat(np.arange(len(indices)), sizes)
    hit = np.zeros(len(indices), bool)
    hit[owner[beyond]] = True
    todo = [
        j
        for j in np.flatnonzero(hit).tolist()
        if results[indices[j]] is not None and results[indices[j]].keypoints is not None
    ]
    if not todo:
        return
    chosen = np.zeros(len(indices), bool)
    chosen[todo] = True
    of_todo = chosen[owner]  # the keypoints of those images
    taken = beyond & of_todo  # the keypoints to move, image after image
    counts = np.bincount(owner[taken], minlength=len(indices))[todo]
    values = np.empty((int(counts.sum()), 2))
    done = np.zeros(len(todo), bool)
    segments, mls_options, shape = own_mls
    quads, config, own = batched
    shared = [n for n, j in enumerate(todo) if not own[indices[j]]] if config is not None else []
    ends = np.cumsum(counts)
    far = np.split(points[taken], ends[:-1])
    for start in range(0, len(shared), _POINTS_BLOCK):
        block = shared[start : start + _POINTS_BLOCK]
        images = [indices[todo[n]] for n in block]
        src, dst = [batch.src[i] for i in images], [batch.dst[i] for i in images]
        with quads.ctx.use():
            lattices = BatchLattices(config, src, dst, shape)
            points_n = [far[n] for n in block]
            found = lattices.evaluate_points(quads.ctx, quads.resources, points_n, shape)
        part = np.zeros(len(todo), bool)
        part[block] = True
        values[np.repeat(part, counts)] = np.concatenate(found)
        done |= part
    for n in np.flatnonzero(~done).tolist():
        i = indices[todo[n]]
        with MLS(batch.src[i], batch.dst[i], shape=shape, **segments[i], **mls_options) as m:
            values[ends[n] - counts[n] : ends[n]] = m(far[n])
    origin = frame.origin
    for axis in (0, 1):
        values[:, axis] -= origin[axis]
    # every moved image's keypoints at once, then one array each again
    keypoints = np.concatenate([results[indices[j]].keypoints for j in todo])
    keypoints[beyond[of_todo]] = values
    moved = np.split(keypoints, np.cumsum(sizes[todo])[:-1])
    for j, points_j in zip(todo, moved, strict=True):
        labels = results[indices[j]]
        results[indices[j]] = ImageLabels(*labels[:2], points_j, *labels[3:])


#: Images whose keypoints beyond their meshes one pass of f evaluates.
_POINTS_BLOCK = 1024


class _Direct:
    """A group's chunks on their bytes (:func:`~glmls.batch.texels.warp_texels`), written
    into one array of the group's warped images (and of its labels where they ride along)."""

    def __init__(self, batch: BatchInput, indices: list[int], options: WarpOptions, frame):
        first = batch.images[indices[0]]
        masks = batch.masks
        self.packed = masks is not None and packable(first, masks[indices[0]], options)
        channels = first.shape[2] if first.ndim == 3 else 1
        form = SourceImage(
            np.zeros((1, 1, channels + self.packed), np.uint8), np.dtype(np.uint8), False, True
        )
        with naming(indices[0]):
            self.background = background_color(options.background, form)
        self.out = np.empty((len(indices), *frame.shape, *first.shape[2:]), np.uint8)
        shape = (len(indices), *frame.shape)
        self.labels = np.empty(shape, np.uint8) if self.packed else None
        self.complete = True

    def chunk(self, start, quads, warper, batch, chunk, lattices, options, frame, lattice, maps):
        """The chunk of the group's images from its ``start``: its :class:`ImageLabels`, or
        None where the keys do not fit (the single path takes them)."""
        data = _slab(batch.array, batch.images, chunk)
        labels = _slab(batch.mask_array, batch.masks, chunk) if self.packed else None
        out = self.out[start : start + len(chunk)]
        out_labels = None if self.labels is None else self.labels[start : start + len(chunk)]
        grid = options.grid
        if not warp_texels(
            quads, lattices, data, labels, grid, frame, self.background, out, out_labels
        ):
            return None
        folded = quads.folded(len(chunk)) if batch.keypoints is not None else None
        warped_masks: list = [None] * len(chunk) if out_labels is None else list(out_labels)
        if batch.masks is not None and not self.packed:
            warped_masks = _warp_masks(
                quads, warper, batch, chunk, lattices, options, frame, lattice
            )
            if warped_masks is None:
                return None
        labels = (lattice, maps, out, warped_masks, folded)
        return _finish(quads, batch, chunk, lattices, options, frame, *labels)


class _Outputs:
    """A group's 8-bit warped images (and uint8 masks) in one array each, which a chunk's
    read-back fills in place where its images are consecutive in the group (else arrays of
    its own, then copied there): :func:`warp_batch` returns them as they are where the group
    is the whole batch, instead of stacking every image's result again."""

    def __init__(self, batch: BatchInput, indices: list[int], frame, masks: bool) -> None:
        first = batch.images[indices[0]]
        self.place = {i: n for n, i in enumerate(indices)}
        self.out = np.empty((len(indices), *frame.shape, *first.shape[2:]), np.uint8)
        self.labels = np.empty((len(indices), *frame.shape), np.uint8) if masks else None
        self.written = np.zeros(len(indices), bool)

    @classmethod
    def of(cls, batch: BatchInput, indices: list[int], options: WarpOptions, frame):
        """The group's arrays where its images are uint8 (None else); its masks' where they
        are uint8 and do not ride as a channel of the images (``packable``)."""
        first = batch.images[indices[0]]
        if first.dtype != np.uint8:
            return None
        masks = batch.masks
        if masks is not None and packable(first, masks[indices[0]], options):
            return None  # the images' read-back holds the masks: they are split after it
        labelled = masks is not None and all(masks[i].dtype == np.uint8 for i in indices)
        return cls(batch, indices, frame, labelled)

    @property
    def complete(self) -> bool:
        """Did the chunks write every image of the group?"""
        return bool(self.written.all())

    def slot(self, chunk: list[int]) -> tuple[np.ndarray | None, np.ndarray | None]:
        """The arrays the chunk's images and masks are read into: the group's rows where
        the chunk's images are consecutive there, else None (:meth:`commit` copies them)."""
        first = self.place[chunk[0]]
        if any(self.place[i] != first + n for n, i in enumerate(chunk)):
            return None, None
        view = slice(first, first + len(chunk))
        return self.out[view], None if self.labels is None else self.labels[view]

    def commit(self, chunk: list[int], done: list[ImageLabels]) -> None:
        """The chunk's results ``done`` in the group's arrays: those read elsewhere copied."""
        places = np.array([self.place[i] for i in chunk])
        _put(self.out, places, [r.image for r in done])
        if self.labels is not None:
            _put(self.labels, places, [r.mask for r in done])
        self.written[places] = True


def _put(array: np.ndarray, places: np.ndarray, values: list[np.ndarray]) -> None:
    """``values`` at ``places`` of ``array``, unless they are its rows already (views read
    into it: a chunk's read-back fills them all or none)."""
    if values[0].base is not array:
        array[places] = values


def _slab(array: np.ndarray | None, items: list[np.ndarray] | None, chunk: list[int]):
    """The chunk's items as one C-contiguous array: a slice of ``array`` where they are
    consecutive in it (no copy for a C-contiguous array), else stacked."""
    if array is not None and chunk[-1] - chunk[0] + 1 == len(chunk):
        return np.ascontiguousarray(array[chunk[0] : chunk[-1] + 1])
    return np.stack([items[i] for i in chunk])  # type: ignore[index]


def _warp_masks(quads, warper, batch, chunk, lattices, options, frame, lattice):
    """The chunk's masks warped on their own (nearest, background 0) after the fused scan of
    its images (which keeps no keys to share), restored; None where their keys do not fit."""
    limit = warper.pipeline.max_image_size
    masks = [batch.masks[i] for i in chunk]
    label_sources = prepare_images([mask_form(m) for m in masks], limit, normalized=True)
    label_options = mask_options(options)
    zero = background_color(0.0, label_sources[0])
    warped = quads.warp(lattices, label_sources, label_options, frame, zero, lattice)
    if warped is None:
        return None
    return [restore_mask(w, masks[0].dtype) for w in warped]


def _check_newton_budget(gl, batch: BatchInput) -> None:
    """``ValueError`` naming the first image whose handles the batched Newton pass could
    not all visit on ``gl``'s driver, as that image's own MLS refuses them: the pass would
    leave handles out of its f without a word."""
    for i, p in enumerate(batch.src):
        with naming(i):
            check_loop_budget(gl, "warp/inverse.comp.glsl", len(p))


def _drop_last(rgba: np.ndarray, squeeze: bool) -> np.ndarray:
    """The warped images without the mask that rode as their last channel."""
    if squeeze:
        return rgba[..., 0].copy()
    if rgba.shape[3] != 4:
        return rgba[..., :-1].copy()
    out = np.empty((*rgba.shape[:3], 3), np.uint8)
    width = rgba.shape[2]
    drop_channels(np.ascontiguousarray(rgba).reshape(-1, width, 4), out.reshape(-1, width, 3))
    return out


def _chunk(
    quads, warper, batch, chunk, lattices, options, frame, lattice, maps, swap=None, into=None
):
    limit = warper.pipeline.max_image_size
    into = (None, None) if into is None else into
    images = [batch.images[i] for i in chunk]
    masks = None if batch.masks is None else [batch.masks[i] for i in chunk]
    packed = masks is not None and packable(images[0], masks[0], options)
    if packed:  # each label rides as one more channel of its image (read back with it)
        into = (None, None)
        channels = images[0].shape[2] if images[0].ndim == 3 else 1
        both = np.empty((len(images), *images[0].shape[:2], channels + 1), np.uint8)
        add_channel(np.stack(images), np.stack(masks), both)
        images = list(both)
    names = [f"images[{i}]" for i in chunk]
    sources = prepare_images(images, limit, normalized=True, names=names)
    with naming(chunk[0]):
        background = background_color(options.background, sources[0])
    warped_masks: list = [None] * len(chunk)
    warp = quads.backward if options.method == "backward" else quads.warp
    if swap is not None:
        warp = partial(warp_swapped, quads)
    if masks is not None and not packed:  # the labels from the images' scan (or maps)
        label_sources = prepare_images([mask_form(m) for m in masks], limit, normalized=True)
        both = (label_sources, background_color(0.0, label_sources[0]))
        done = warp(lattices, sources, options, frame, background, lattice, both, into=into)
        if done is None:
            return None
        out, warped = done
        warped_masks = [restore_mask(w, masks[0].dtype) for w in warped]
    else:
        out = warp(lattices, sources, options, frame, background, lattice, into=into)
    if out is None:
        return None
    if packed:
        warped_masks = list(restore_mask(out[..., -1], masks[0].dtype))  # type: ignore[index]
        out = _drop_last(out, batch.images[chunk[0]].ndim == 2)
    # the meshes the scan did not show to be embeddings, where it tested them: the keypoints
    # need no test of their own on the others
    folded = quads.scan_folded() if warp == quads.warp else None
    labels = (lattice, maps, out, warped_masks, folded)
    return _finish(quads, batch, chunk, lattices, options, frame, *labels, swap)


def _finish(
    quads, batch, chunk, lattices, options, frame, lattice, maps, out, masks, folded, swap=None
):
    """The chunk's :class:`ImageLabels`: its warped images ``out`` and ``masks``, its
    keypoints moved (``folded``: the meshes not shown to be embeddings where known) and its
    maps (``swap``: ``backward-swap``'s single warper and MLS keywords, which move its
    keypoints image by image)."""
    keypoints = batch.keypoints
    moved_all = valid_all = coords_all = covered_all = None
    backward = options.method in ("backward", "backward-swap")
    if backward and (maps or keypoints is not None):  # the maps the chunk sampled at
        coords_all, covered_all = quads.backward_coords(len(chunk), frame)
    if swap is not None and keypoints is not None:
        shown = (coords_all, covered_all)
        warper, mls_options = swap
        canvas = (frame, options)
        passes = (
            (quads.ctx, quads.resources, lattices) if isinstance(lattices, BatchLattices) else None
        )
        moved_all, valid_all = swapped_keypoints(
            warper, batch, chunk, mls_options, canvas, shown, passes
        )
    elif backward and keypoints is not None:
        shown = (coords_all, covered_all)
        moved_all, valid_all = keypoints_by_f(
            quads.ctx, quads.resources, lattices, batch, chunk, (frame, options.border), shown
        )
    elif keypoints is not None:  # every keypoint of the chunk at once, the meshes read once
        vertices = quads.vertices(lattices, lattice)
        if folded is None:
            folded = ~embedded(vertices[np.arange(len(chunk))])
        points = [keypoints[i] for i in chunk]
        sizes = [len(p) for p in points]
        which = np.repeat(np.arange(len(chunk)), sizes)
        moved_all, valid_all = mesh_keypoints(
            lattice,
            vertices,  # type: ignore[arg-type]
            np.concatenate(points),
            None,
            which,  # type: ignore[arg-type]
            folded,
            nearest=(len(RING), frame.origin),  # each keypoint followed by its footprint's edge
        )
        moved_all[:, 0] -= frame.origin[0]  # (its own array) x and y apart: numpy takes a
        moved_all[:, 1] -= frame.origin[1]  # pair off (P, 2) rows with loops of two
        valid_all &= on_canvas(moved_all, frame.shape)
        ends = np.cumsum(sizes).tolist()
        starts = [0, *ends[:-1]]
        moved_all = [moved_all[a:b] for a, b in zip(starts, ends, strict=True)]
        valid_all = [valid_all[a:b] for a, b in zip(starts, ends, strict=True)]
    if maps and not backward:  # the quads' source points, from the chunk's meshes on the GPU
        coords_all, covered_all = quads.coords(len(chunk), lattice, frame)
    results = []
    for k in range(len(chunk)):
        coords = None if coords_all is None or not maps else coords_all[k]
        covered = None if covered_all is None or not maps else covered_all[k]
        moved = None if moved_all is None else moved_all[k]
        valid = None if valid_all is None else valid_all[k]
        results.append(ImageLabels(out[k], masks[k], moved, valid, coords, covered))
    return results
