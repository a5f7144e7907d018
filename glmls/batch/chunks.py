"""A batch cut into chunks for the GPU path (:mod:`glmls.batch.gpu`): images of one shape
and dtype, as many per chunk as the GL limits and :data:`~glmls.batch.gpu.CHUNK_BYTES` allow,
each chunk's images, masks and keypoints in one submission and one read-back."""

from __future__ import annotations

from collections import defaultdict
from contextlib import ExitStack

import numpy as np

from ..core.mesh import MeshLattice
from ..imaging.frame import make_frame
from ..imaging.options import WarpOptions
from ..imaging.source import background_color, prepare_image
from ..mls import MLS
from .gpu import CHUNK_BYTES, BatchQuads, chunk_size
from .inputs import BatchInput
from .labels import mesh_keypoints
from .single import ImageLabels, SingleWarper, mask_form, mask_options, packable, restore_mask

__all__ = ["warp_chunks"]


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
    for indices in _groups(batch).values():
        first = batch.images[indices[0]]
        source = prepare_image(first, limit, normalized=True)
        frame = make_frame(options.output_shape, options.origin, source.shape, limit)
        lattice = MeshLattice.corners(source.shape, options.grid)
        size = chunk_size(quads.ctx, source, frame, lattice, max_bytes or CHUNK_BYTES)
        for start in range(0, len(indices), size):
            chunk = indices[start : start + size]
            with ExitStack() as stack:
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
                done = _chunk(quads, warper, batch, chunk, mlss, options, frame, lattice, maps)
            if done is None:
                continue
            for i, labels in zip(chunk, done, strict=True):
                results[i] = labels
    return results


def _chunk(quads, warper, batch, chunk, mlss, options, frame, lattice, maps):
    limit = warper.pipeline.max_image_size
    kernels = [m.kernel for m in mlss]
    images = [batch.images[i] for i in chunk]
    masks = None if batch.masks is None else [batch.masks[i] for i in chunk]
    packed = masks is not None and packable(images[0], masks[0], options)
    if packed:  # each label rides as one more channel of its image
        images = [np.dstack([image, mask]) for image, mask in zip(images, masks, strict=True)]
    sources = [prepare_image(image, limit, normalized=True) for image in images]
    background = background_color(options.background, sources[0])
    out = quads.warp(kernels, sources, options, frame, background)
    if out is None:
        return None
    warped_masks: list = [None] * len(chunk)
    if packed:
        channels = batch.images[chunk[0]].ndim == 3 and batch.images[chunk[0]].shape[2]
        warped_masks = [restore_mask(o[..., -1], masks[0].dtype) for o in out]  # type: ignore[index]
        out = out[..., :channels] if channels else out[..., 0]
    keypoints = batch.keypoints
    vertices = quads.vertices(kernels, lattice) if keypoints is not None else None
    if masks is not None and not packed:
        label_sources = [prepare_image(mask_form(m), limit, normalized=True) for m in masks]
        label_options = mask_options(options)
        zero = background_color(0.0, label_sources[0])
        warped = quads.warp(kernels, label_sources, label_options, frame, zero)
        warped_masks = [restore_mask(w, masks[0].dtype) for w in warped]  # type: ignore[union-attr]
    results = []
    origin = np.asarray(frame.origin)
    height, width = frame.shape
    for k, i in enumerate(chunk):
        moved = valid = coords = covered = None
        if keypoints is not None:
            moved, valid = mesh_keypoints(lattice, vertices[k], keypoints[i], None)  # type: ignore[index]
            moved = moved - origin
            valid &= np.all((moved > -0.5) & (moved < (width - 0.5, height - 0.5)), axis=1)
        if maps:
            coords, covered = warper.source_points(
                mlss[k], frame.shape and lattice.shape, options, frame
            )
        results.append(ImageLabels(out[k], warped_masks[k], moved, valid, coords, covered))
    return results
