"""What the batched paths share to move a chunk's keypoints by f itself (``backward``,
``splat``, ``paper-quads``): the configuration that one
:class:`~glmls.engine.batched.BatchLattices` evaluation serves, f at every image's points in
passes over slices of them, and the keypoints moved by f at their probes and tested against
what the chunk shows, as the single path (:class:`~glmls.batch.single.SingleWarper`) moves
and tests them."""

from __future__ import annotations

import numpy as np

from ..core.config import MLSConfig
from ..core.handles import OFFSET_GAIN, fit_boxes, set_bounds
from ..core.handleset import HandleSet
from ..engine.batched import BatchLattices
from ..engine.kernel import DEFAULT_STORAGE
from ..engine.storage import check_storage
from .inputs import BatchInput
from .labels import visible_chunk
from .single import in_domain, probe_points, probed

__all__ = ["CONFIG_KEYS", "SLICE_BYTES", "batch_config", "f_at", "far_targets", "keypoints_by_f"]

#: The most bytes of points one pass of f at a chunk's keypoints takes (:func:`f_at`).
SLICE_BYTES = 8 << 20
#: The keywords of :func:`glmls.warp_batch` that make its :class:`~glmls.MLSConfig`.
CONFIG_KEYS = ("transform", "weight", "alpha", "s", "radius", "interpolating")


def batch_config(batch: BatchInput, mls_options: dict) -> MLSConfig | None:
    """The configuration of every image where one :class:`BatchLattices` evaluation takes
    the batch's handles (no spatial bins, handles in a storage buffer), else None (each
    image's own MLS)."""
    config = MLSConfig(**{k: v for k, v in mls_options.items() if k in CONFIG_KEYS})
    storage = mls_options.get("storage", DEFAULT_STORAGE)
    check_storage(storage)
    counts = [len(p) for p in batch.src]
    if not BatchLattices.takes(config, counts, storage, mls_options.get("bins")):
        return None
    return config


def far_targets(batch: BatchInput, mls_options: dict, segments: list[dict]) -> list[bool]:
    """Which images' own MLS holds its targets moved back by a translation on the GPU
    (:meth:`~glmls.core.handleset.HandleSet.near_targets`: targets far from their sources):
    the batched passes share no such frame, so these take the single path, and each equals
    its own warp bit for bit."""
    config = MLSConfig(**{k: v for k, v in mls_options.items() if k in CONFIG_KEYS})
    if config.weight_entry.support == "radius":
        return [False] * len(batch)
    far = [False] * len(batch)
    alike: dict[tuple, list[int]] = {}  # point handles only, by their count and image shape
    for i, image in enumerate(batch.images):
        if segments[i]:
            handles = HandleSet.validate(batch.src[i], batch.dst[i], **segments[i])
            far[i] = bool(handles.near_targets(image.shape[:2])[1].any())
        elif len(batch.src[i]):  # no handle: no offset
            alike.setdefault((len(batch.src[i]), image.shape[:2]), []).append(i)
    for (_, shape), members in alike.items():
        src = np.stack([batch.src[i] for i in members])
        dst = np.stack([batch.dst[i] for i in members])
        for i, offset in zip(members, _offsets(src, dst, shape), strict=True):
            far[i] = bool(offset)
    return far


def _offsets(src: np.ndarray, dst: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """(N,) bool: the handle sets (N, K, 2) (K >= 1) whose
    :func:`~glmls.core.handles.fit_offset` on an image of ``shape`` is not zero, for all
    at once with its float64 operations (minima, maxima, halves, rounding: the same
    values)."""
    src_lo, src_hi = set_bounds(src)
    dst_lo, dst_hi = set_bounds(dst)
    centre = (src_lo + src_hi) / 2
    offset = np.round((dst_lo + dst_hi) / 2 - centre)  # (N, 2)
    moved = (offset[:, 0] != 0) | (offset[:, 1] != 0)
    if not moved.any():
        return moved
    height, width = shape
    corner = np.array([width - 0.5, height - 0.5])

    def scales(q: np.ndarray) -> np.ndarray:  # Scaling.fit(src, q, shape).scale, per set
        q_lo, q_hi = set_bounds(q)
        lo = np.minimum(np.minimum(src_lo, q_lo), -0.5)
        hi = np.maximum(np.maximum(src_hi, q_hi), corner)
        return fit_boxes(lo, hi)[1]

    return moved & (scales(dst - offset[:, None]) * OFFSET_GAIN <= scales(dst))


def f_at(gl, resources, lattices, points: list[np.ndarray], chosen) -> list[np.ndarray]:
    """f of each image of ``lattices`` at its ``points`` ((P_i, 2) each), in passes over
    slices of the images' points. A pass pads each image's slice to the longest, so the
    images whose points have run out leave the later passes (``chosen(images)``: the
    lattices of those images of the chunk alone, each image's f the same): one image with
    many points makes no other image's work or buffer as long. Slices of an even length
    keep the single evaluation's pairs of points per invocation."""
    sizes = [len(p) for p in points]
    most = max(sizes)
    step = max(2, min(most, SLICE_BYTES // (8 * len(points))) // 2 * 2)
    values = [np.empty((size, 2)) for size in sizes]
    shape = lattices.shape
    for start in range(0, most, step):
        busy = [k for k, size in enumerate(sizes) if size > start]
        part = lattices if len(busy) == len(points) else chosen(busy)
        slices = [points[k][start : start + step] for k in busy]
        done = part.evaluate_points(gl, resources, slices, shape)
        for k, found in zip(busy, done, strict=True):
            values[k][start : start + len(found)] = found
    return values


def keypoints_by_f(gl, resources, lattices, batch, chunk, canvas, shown, *, drawn=False):
    """The chunk's keypoints moved by f, as the single path moves them (f and its Jacobian
    at every image's probes in one pass of the chunk's handles, ``lattices``), each valid
    where it lands on the canvas, in the image's domain and shown at its nearest pixel:
    two lists of the images' (P_i, 2) points and (P_i,) flags. ``shown``: per image of the
    chunk, the source points its output pixels show ((N, H, W, 2)) and where they show one
    ((N, H, W) bool): the backward maps, or with ``drawn`` (the forward methods) the source
    pixels the fill drew. ``canvas``: the frame and the border rule."""
    frame, border = canvas
    points = [batch.keypoints[i] for i in chunk]
    shape = batch.images[chunk[0]].shape[:2]
    if len({len(p) for p in points}) == 1:  # (P, N, 2): every image's probes at once
        probes = list(probe_points(np.stack(points, axis=1)).transpose(1, 0, 2))
    else:
        probes = [probe_points(p) for p in points]

    def chosen(images: list[int]) -> BatchLattices:
        src, dst = [batch.src[chunk[k]] for k in images], [batch.dst[chunk[k]] for k in images]
        return BatchLattices(lattices.config, src, dst, shape)

    values = f_at(gl, resources, lattices, probes, chosen)
    sizes = [len(p) for p in points]
    # the chunk's keypoints as one list: f at each one's five probes, (5, P, 2)
    every = np.concatenate(
        [v.reshape(5, size, 2) for v, size in zip(values, sizes, strict=True)], axis=1
    )
    out, jacobian = probed(every.reshape(-1, 2))
    out = out.copy()  # less the frame's origin, x and y apart (numpy's pair loops)
    out[:, 0] -= frame.origin[0]
    out[:, 1] -= frame.origin[1]
    source = np.concatenate(points).reshape(-1, 2)
    images = np.repeat(np.arange(len(points)), sizes)
    inside = in_domain(source, shape, border)
    coords, covered = shown
    valid = visible_chunk(source, images, out, jacobian, coords, covered, inside, drawn=drawn)
    ends = np.cumsum(sizes)[:-1]
    return np.split(out, ends), np.split(valid, ends)
