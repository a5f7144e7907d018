"""What the adapters (:mod:`glmls.augment.albumentations`, :mod:`glmls.augment.torchvision`)
replay of an :class:`~glmls.augment.Augment`'s draws: labels alone, images of any number of
channels, boxes around their moved outlines, and masks of any dtype, each value back bit for
bit."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from . import labels as lab
from .core import Augment, AugmentResult, mesh_grid
from .params import check_params, label_options_of

__all__ = ["replay_boxes", "replay_images", "replay_labels", "replay_masks"]


def replay_labels(augment: Augment, params: Sequence[Mapping], **labels) -> AugmentResult:
    """``augment.replay`` of labels alone (``masks``, ``keypoints``, ``boxes``): each draw
    on an empty canvas of its shape, the draws all of one shape."""
    canvas = np.zeros((len(params), *check_params(params, len(params))[0]["shape"]), np.uint8)
    return augment.replay(canvas, params, **labels)


def replay_images(augment: Augment, images: np.ndarray, params: Sequence[Mapping]) -> np.ndarray:
    """``augment.replay`` of (N, H, W) or (N, H, W, C) images of any number of channels, as
    albumentations and torchvision take them: more than 4 channels go in groups of at most 4,
    each group through the same draws (one map for every channel)."""
    if images.ndim == 3 or images.shape[-1] <= 4:
        return np.asarray(augment.replay(images, params).images)
    groups = [
        np.asarray(augment.replay(np.ascontiguousarray(images[..., k : k + 4]), params).images)
        for k in range(0, images.shape[-1], 4)
    ]
    return np.concatenate(groups, axis=-1)


def replay_boxes(
    augment: Augment, params: Sequence[Mapping], boxes: Sequence[np.ndarray]
) -> list[np.ndarray]:
    """Per draw, its (B, 4) boxes ``(x_min, y_min, x_max, y_max)`` around their moved outlines,
    NOT clipped to the canvas: albumentations and torchvision clip boxes themselves, and
    albumentations' ``min_visibility`` measures what the clipping takes away."""
    params = check_params(params, len(boxes))
    grid = mesh_grid(params[0]["options"]) if len(params) else None
    outlines = [
        lab.box_outlines(
            np.asarray(b, np.float64),
            label_options_of(p, augment.label_options)["box_step"],
            mesh=None if grid is None else (grid, tuple(p["shape"])),
            near=tuple(p["shape"]),
        )
        for b, p in zip(boxes, params, strict=True)
    ]
    moved = replay_labels(augment, params, keypoints=[points for points, _ in outlines]).keypoints
    return [
        lab.boxes_from_outlines(np.asarray(points), counts, tuple(p["shape"]), clip=False)[0]
        for points, (_, counts), p in zip(moved, outlines, params, strict=True)
    ]


#: The most distinct values of a floating-point mask that travel as integer labels.
_FLOAT_LABELS = 1 << 24


def replay_masks(augment: Augment, params: Sequence[Mapping], masks: np.ndarray) -> np.ndarray:
    """(N, H, W) masks deformed, one per draw, with nearest sampling, 0 where nothing is
    shown; of their dtype (bool masks too; floating-point masks, as albumentations and
    torchvision allow, as labels numbering their distinct values, so that every value comes
    back bit for bit: the GPU's float32 would round a float64 value; a mask of 2**24 distinct
    values or more goes as a float32 image with nearest sampling). Integer labels beyond
    +-2**24 (instance ids) are numbered alike."""
    params = check_params(params, len(masks))
    wide = masks.dtype.kind in "iu" and masks.dtype.itemsize > 2 and masks.size
    large = wide and max(-int(masks.min()), int(masks.max())) > _FLOAT_LABELS  # instance ids
    if masks.dtype.kind == "f" or large:
        values, numbers = _distinct(masks)
        if len(values) < _FLOAT_LABELS:  # label 0: nothing shown, value k + 1: values[k]
            labels = (numbers.reshape(masks.shape) + 1).astype(np.int32)
            moved = np.asarray(replay_labels(augment, params, masks=labels).masks)
            return np.concatenate([np.zeros(1, masks.dtype), values])[moved]
        if large:
            raise ValueError(f"masks hold {len(values)} distinct labels beyond +-2**24")
        nearest = {"interpolation": "nearest", "background": 0.0}  # soft values, very many
        draws = [{**p, "options": {**p["options"], **nearest}} for p in params]
        values = masks if masks.dtype in (np.float32, np.float64) else masks.astype(np.float32)
        return np.asarray(augment.replay(values, draws).images).astype(masks.dtype)
    labels = masks.astype(np.uint8) if masks.dtype == bool else masks
    return np.asarray(replay_labels(augment, params, masks=labels).masks).astype(masks.dtype)


def _distinct(masks: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The distinct values of ``masks`` and each element's number among them (as
    :func:`numpy.unique`'s ``return_inverse``), floating-point values told apart by their
    bits: -0.0 and 0.0, and NaNs of different payloads, are labels of their own."""
    bits = {2: np.uint16, 4: np.uint32, 8: np.uint64}.get(masks.dtype.itemsize)
    if masks.dtype.kind != "f" or bits is None:
        return np.unique(masks, return_inverse=True)
    keys, numbers = np.unique(np.ascontiguousarray(masks).view(bits), return_inverse=True)
    return keys.view(masks.dtype), numbers
