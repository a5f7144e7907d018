"""A batch cut into chunks for the GPU path (:mod:`glmls.batch.gpu`): images of one shape
and dtype, as many per chunk as the GL limits and :data:`~glmls.batch.gpu.CHUNK_BYTES` allow,
each chunk's images, masks and keypoints in one submission and one read-back."""

from __future__ import annotations

from collections import defaultdict
from contextlib import ExitStack

import numpy as np

from ..core.config import MLSConfig
from ..core.mesh import MeshLattice
from ..engine.batched import BatchLattices
from ..engine.kernel import DEFAULT_STORAGE
from ..engine.storage import check_storage
from ..imaging.frame import make_frame
from ..imaging.options import WarpOptions
from ..imaging.readback import add_channel, drop_channels
from ..imaging.source import background_color, prepare_image
from ..mls import MLS
from .gpu import CHUNK_BYTES, BatchQuads, KernelLattices, chunk_size
from .inputs import BatchInput
from .labels import mesh_keypoints
from .single import ImageLabels, SingleWarper, mask_form, mask_options, packable, restore_mask

__all__ = ["warp_chunks"]

#: The keywords of :func:`glmls.warp_batch` that make its :class:`~glmls.MLSConfig`.
_CONFIG_KEYS = ("transform", "weight", "alpha", "s", "radius", "interpolating")


def _groups(batch: BatchInput) -> dict[tuple, list[int]]:
    """Image indices by what a chunk shares: shape, dtype, and how its mask travels."""
    groups: dict[tuple, list[int]] = defaultdict(list)
    for i, image in enumerate(batch.images):
        mask = None if batch.masks is None else batch.masks[i]
        key = (image.shape, image.dtype.str, None if mask is None else mask.dtype.str)
        groups[key].append(i)
    return groups


def warp_chunks(
    batch: BatchInput,
    options: WarpOptions,
    mls_options: dict,
    segments: list[dict],
    *,
    maps: bool,
    max_bytes: int | None,
) -> list[ImageLabels | None]:
    """Each image's :class:`ImageLabels` from the batched GPU path (None for an image it
    left to the single path: keys too long for its mesh)."""
    results: list[ImageLabels | None] = [None] * len(batch)
    quads = BatchQuads.of(mls_options.get("ctx"))
    warper = SingleWarper.of(mls_options.get("ctx"))
    limit = warper.pipeline.max_image_size
    config = _batch_config(batch, mls_options)
    backward = options.method == "backward"
    if backward and (config is None or batch.keypoints is not None):
        return results  # f at the keypoints, bins, segments: each image's own MLS
    for indices in _groups(batch).values():
        first = batch.images[indices[0]]
        source = prepare_image(first, limit, normalized=True)
        frame = make_frame(options.output_shape, options.origin, source.shape, limit)
        lattice = MeshLattice.corners(source.shape, options.grid)
        size = chunk_size(
            quads.ctx, source, frame, lattice, max_bytes or CHUNK_BYTES, backward=backward
        )
        for start in range(0, len(indices), size):
            chunk = indices[start : start + size]
            if backward and any(segments[i] for i in chunk):
                continue
            with ExitStack() as stack:
                if config is not None and not any(segments[i] for i in chunk):
                    src, dst = [batch.src[i] for i in chunk], [batch.dst[i] for i in chunk]
                    lattices = BatchLattices(config, src, dst, source.shape)
                else:  # each image's own MLS
                    mlss = [
                        stack.enter_context(
                            MLS(
                                batch.src[i],
                                batch.dst[i],
                                shape=source.shape,
                                **segments[i],
                                **mls_options,
                            )
                        )
                        for i in chunk
                    ]
                    lattices = KernelLattices([m.kernel for m in mlss])
                with quads.ctx.use():  # the chunk's passes, its meshes kept, in one hold
                    done = _chunk(
                        quads, warper, batch, chunk, lattices, options, frame, lattice, maps
                    )
            if done is None:
                continue
            for i, labels in zip(chunk, done, strict=True):
                results[i] = labels
    return results


def _batch_config(batch: BatchInput, mls_options: dict) -> MLSConfig | None:
    """The configuration of every image where one :class:`BatchLattices` evaluation takes
    the batch's handles (no spatial bins), else None (each image's own MLS)."""
    keys = {k: v for k, v in mls_options.items() if k in _CONFIG_KEYS}
    config = MLSConfig(**keys)
    counts = [len(p) for p in batch.src]
    storage = mls_options.get("storage", DEFAULT_STORAGE)
    check_storage(storage)
    bins = mls_options.get("bins")
    if not BatchLattices.takes(config, counts, storage, bins):
        return None
    return config


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


def _chunk(quads, warper, batch, chunk, lattices, options, frame, lattice, maps):
    limit = warper.pipeline.max_image_size
    images = [batch.images[i] for i in chunk]
    masks = None if batch.masks is None else [batch.masks[i] for i in chunk]
    packed = masks is not None and packable(images[0], masks[0], options)
    if packed:  # each label rides as one more channel of its image
        channels = images[0].shape[2] if images[0].ndim == 3 else 1
        both = np.empty((len(images), *images[0].shape[:2], channels + 1), np.uint8)
        add_channel(np.stack(images), np.stack(masks), both)
        images = list(both)
    sources = [prepare_image(image, limit, normalized=True) for image in images]
    background = background_color(options.background, sources[0])
    backward = options.method == "backward"
    if backward:
        out = quads.backward(lattices, sources, options, frame, background)
    else:
        out = quads.warp(lattices, sources, options, frame, background, both if packed else None)
    if out is None:
        return None
    warped_masks: list = [None] * len(chunk)
    if packed:
        warped_masks = list(restore_mask(out[..., -1], masks[0].dtype))  # type: ignore[index]
        out = _drop_last(out, batch.images[chunk[0]].ndim == 2)
    keypoints = batch.keypoints
    vertices = folded = None
    if keypoints is not None:  # the meshes, read back once
        vertices, folded = quads.last_vertices, quads.last_folded
        if vertices is None:
            vertices = quads.vertices(lattices, lattice)
    if masks is not None and not packed:
        label_sources = [prepare_image(mask_form(m), limit, normalized=True) for m in masks]
        label_options = mask_options(options)
        zero = background_color(0.0, label_sources[0])
        warp = quads.backward if backward else quads.warp
        warped = warp(lattices, label_sources, label_options, frame, zero)
        if warped is None:  # the labels' keys are longer: the single path takes the chunk
            return None
        warped_masks = [restore_mask(w, masks[0].dtype) for w in warped]  # type: ignore[union-attr]
    moved_all = valid_all = None
    if keypoints is not None:  # every keypoint of the chunk at once
        points = [keypoints[i] for i in chunk]
        sizes = [len(p) for p in points]
        which = np.repeat(np.arange(len(chunk)), sizes)
        moved_all, valid_all = mesh_keypoints(
            lattice,
            vertices,
            np.concatenate(points),
            None,
            which,  # type: ignore[arg-type]
            folded,
        )
        moved_all = moved_all - np.asarray(frame.origin)
        height, width = frame.shape
        valid_all &= np.all((moved_all > -0.5) & (moved_all < (width - 0.5, height - 0.5)), axis=1)
        ends = np.cumsum(sizes)[:-1]
        moved_all, valid_all = np.split(moved_all, ends), np.split(valid_all, ends)
    coords_all = covered_all = None
    if maps:  # the quads' source points, from the chunk's meshes still on the GPU
        if backward:
            coords_all, covered_all = quads.backward_coords(len(chunk), frame)
        else:
            coords_all, covered_all = quads.coords(len(chunk), lattice, frame)
    results = []
    for k, _ in enumerate(chunk):
        coords = None if coords_all is None else coords_all[k]
        covered = None if covered_all is None else covered_all[k]
        moved = None if moved_all is None else moved_all[k]
        valid = None if valid_all is None else valid_all[k]
        results.append(ImageLabels(out[k], warped_masks[k], moved, valid, coords, covered))
    return results
