"""torch tensors in and out of :class:`glmls.augment.Augment`, without importing torch: a
tensor is recognised only where torch is already imported (``sys.modules``). Internal to
:class:`~glmls.augment.Augment` and the adapters; users pass tensors to them.

Images are taken in torch's layout, (N, C, H, W) or (N, H, W), or as a list of (C, H, W) or
(H, W) tensors (a ragged batch), and come back in it, of their dtype and on their device
(contiguous, whatever their memory format or strides); half-precision tensors (float16,
bfloat16) go through float32. Each argument comes back in the kind it came in, whatever the
others': numpy images with tensor keypoints give numpy images and tensor keypoints, tensor
images with numpy masks tensor images and numpy masks. A label is a tensor where it came as
one, or as a list or tuple of them (per image; polygons: an image's list of them), else
numpy. Keypoints, boxes and polygons come back of their dtype where it is a floating-point
one, and as float64 where they came as integers (the moved points lie between pixel centres:
an integer dtype would cut them to whole pixels). The results are new tensors, detached: no
gradient flows back through the deformation. The deformation itself runs on glmls's OpenGL
context, so a CUDA tensor goes through the host's memory (``.cpu()``, then ``.to(device)``):
one copy each way per batch.
"""

from __future__ import annotations

import dataclasses
import sys

import numpy as np

__all__ = ["any_tensors", "from_numpy", "is_tensor", "is_tensors", "to_numpy"]


def is_tensor(value: object) -> bool:
    """Whether ``value`` is a torch tensor (False where torch is not imported).

    Parameters
    ----------
    value : object
        Anything.

    Returns
    -------
    bool
        True for a ``torch.Tensor``.

    Examples
    --------
    >>> import numpy as np
    >>> from glmls.augment.tensors import is_tensor
    >>> is_tensor(np.zeros(3))
    False
    """
    torch = sys.modules.get("torch")
    return torch is not None and isinstance(value, torch.Tensor)


def is_tensors(value: object) -> bool:
    """Whether ``value`` is a torch tensor or a non-empty list or tuple of them.

    Parameters
    ----------
    value : object
        Anything.

    Returns
    -------
    bool
        True for a tensor or a sequence of tensors.

    Examples
    --------
    >>> from glmls.augment.tensors import is_tensors
    >>> is_tensors([1, 2])
    False
    """
    if is_tensor(value):
        return True
    return isinstance(value, (list, tuple)) and bool(value) and all(is_tensor(v) for v in value)


def _holds(value: object, tensor: type, depth: int) -> bool:
    """Whether ``value`` is a ``tensor``, or a list or tuple holding one within ``depth``
    levels."""
    if isinstance(value, tensor):
        return True
    if depth == 0 or not isinstance(value, (list, tuple)):
        return False
    if depth == 1:  # torch.Tensor's isinstance (its metaclass's) is the slower: arrays first
        return any(not isinstance(item, np.ndarray) and isinstance(item, tensor) for item in value)
    return any(_holds(item, tensor, depth - 1) for item in value)


def any_tensors(
    images: object,
    keypoints: object,
    masks: object,
    boxes: object,
    polygons: object,
    indices: object,
) -> bool:
    """Whether a call's arguments hold a torch tensor where :class:`~glmls.augment.Augment`
    takes one: an argument that is one or a list or tuple of them, or for ``polygons`` an
    image's list of them; such a call goes through the tensors' path, which turns them into
    numpy arrays and each result back into the kind of its argument.

    Parameters
    ----------
    images, keypoints, masks, boxes, polygons, indices : object
        The arguments of :meth:`~glmls.augment.Augment.__call__`.

    Returns
    -------
    bool
        True where one of them holds a tensor.

    Examples
    --------
    >>> import numpy as np
    >>> from glmls.augment.tensors import any_tensors
    >>> any_tensors(np.zeros((1, 4, 4)), None, None, None, [[np.zeros((3, 2))]], None)
    False
    """
    torch = sys.modules.get("torch")
    if torch is None:
        return False
    flat = (images, keypoints, masks, boxes, indices)
    return any(_holds(value, torch.Tensor, 1) for value in flat) or _holds(
        polygons, torch.Tensor, 2
    )


def to_numpy(value: object) -> object:
    """A tensor as a numpy array (through the host for a CUDA tensor; float16 and bfloat16,
    which numpy lacks or glmls does not take, as float32), a list of them as a list of
    arrays, anything else as it is.

    Parameters
    ----------
    value : object
        A tensor, a list or tuple of tensors, or anything.

    Returns
    -------
    object
        The numpy counterpart.

    Examples
    --------
    >>> from glmls.augment.tensors import to_numpy
    >>> to_numpy([1, 2])
    [1, 2]
    """
    if is_tensor(value):
        torch = sys.modules["torch"]
        if value.dtype in (torch.float16, torch.bfloat16):  # type: ignore[attr-defined]
            value = value.float()  # type: ignore[attr-defined]
        return value.detach().cpu().numpy()  # type: ignore[attr-defined]
    if isinstance(value, (list, tuple)) and any(is_tensor(v) for v in value):
        return [to_numpy(v) for v in value]
    return value


def from_numpy(array: object, like: object, *, points: bool = False) -> object:
    """``array`` as a tensor of ``like``'s dtype and device (lists item by item).

    Parameters
    ----------
    array : numpy.ndarray or list or None
        The values (for a list ``like``, a list, or one array of the items stacked).
    like : torch.Tensor or list of torch.Tensor
        The tensor whose dtype and device to take (for a list, one per item or one for all).
    points : bool, default False
        Coordinates (keypoints, boxes, polygons): where ``like`` is of an integer or bool
        dtype, the tensor is float64 (as the values are), not cut to whole pixels.

    Returns
    -------
    object
        A tensor, a list of tensors, or None.

    Examples
    --------
    >>> import numpy as np
    >>> import torch
    >>> from glmls.augment.tensors import from_numpy
    >>> from_numpy(None, None) is None
    True
    >>> from_numpy(np.array([2.75]), torch.tensor([3]), points=True)
    tensor([2.7500], dtype=torch.float64)
    """
    if array is None:
        return None
    if isinstance(like, (list, tuple)) and not isinstance(array, list):
        array = list(array)  # a list's items stacked (masks of one shape): one tensor each
    if isinstance(array, list):
        likes = like if isinstance(like, (list, tuple)) else [like] * len(array)
        return [from_numpy(a, one, points=points) for a, one in zip(array, likes, strict=True)]
    torch = sys.modules["torch"]
    tensor = torch.from_numpy(np.ascontiguousarray(array))
    dtype = like.dtype  # type: ignore[attr-defined]
    if points and not (dtype.is_floating_point or dtype.is_complex):
        dtype = torch.float64  # moved points lie between pixel centres: no integer cut
    return tensor.to(device=like.device, dtype=dtype)  # type: ignore[attr-defined]


def _check_rank(images) -> None:
    """A tensor batch of torch's layout: ``ValueError`` naming the layouts, in torch's order
    (the numpy path's message would name numpy's)."""
    if isinstance(images, (list, tuple)):
        for i, image in enumerate(images):
            if image.ndim not in (2, 3) or (image.ndim == 3 and not 1 <= image.shape[0] <= 4):
                raise ValueError(
                    f"images[{i}] is a tensor of shape {tuple(image.shape)}; expected (C, H, W) "
                    "with C 1..4, or (H, W)"
                )
    elif images.ndim == 4 and not 1 <= images.shape[1] <= 4:  # (N, H, W, C) given, say
        raise ValueError(
            f"images is a tensor of shape {tuple(images.shape)}; expected a batch (N, C, H, W) "
            "with C 1..4 channels first, as torch orders them"
        )
    elif images.ndim not in (3, 4):
        raise ValueError(
            f"images is a tensor of shape {tuple(images.shape)}; expected a batch (N, C, H, W) "
            "or (N, H, W), or a list of (C, H, W) or (H, W) tensors"
        )


def _channels_last(images) -> tuple[object, bool]:
    _check_rank(images)
    if isinstance(images, (list, tuple)):  # (C, H, W) or (H, W) each
        arrays = [to_numpy(image) for image in images]
        return [
            np.ascontiguousarray(np.moveaxis(a, 0, -1)) if a.ndim == 3 else a for a in arrays
        ], True
    array = to_numpy(images)
    if array.ndim == 4:  # (N, C, H, W)
        return np.ascontiguousarray(np.moveaxis(array, 1, -1)), True
    return array, False


def _images_back(out, images, moved_channels: bool):
    if isinstance(images, (list, tuple)):
        return [
            from_numpy(np.moveaxis(o, -1, 0) if like.ndim == 3 else o, like)
            for o, like in zip(map(np.asarray, out), images, strict=True)
        ]
    out = np.asarray(out)
    return from_numpy(np.moveaxis(out, -1, 1) if moved_channels else out, images)


def _flags(valid, like):
    torch = sys.modules["torch"]
    if isinstance(valid, list):
        likes = like if isinstance(like, (list, tuple)) else [like] * len(valid)
        return [_flags(v, one) for v, one in zip(valid, likes, strict=True)]
    return torch.as_tensor(np.asarray(valid), device=like.device)


def _polygons_in(polygons: object) -> object:
    """Per image, its polygons as numpy arrays where they came as tensors (all of them, or a
    (P, V, 2) tensor; a list with some tensors as a list of arrays)."""
    if is_tensor(polygons):
        return to_numpy(polygons)
    if not isinstance(polygons, (list, tuple)):
        return polygons
    return [
        to_numpy(list(shapes)) if isinstance(shapes, (list, tuple)) else to_numpy(shapes)
        for shapes in polygons
    ]


def _polygons_back(moved: list | None, polygons: object) -> list | None:
    """The moved polygons as tensors where the image's came as tensors (each like its own)."""
    if moved is None or not (isinstance(polygons, (list, tuple)) or is_tensor(polygons)):
        return moved
    return [
        from_numpy(list(out), list(given), points=True) if is_tensors(given) else out
        for out, given in zip(moved, polygons, strict=True)
    ]


def _images_in(images) -> tuple[object, bool]:
    """The images as numpy arrays, channels last where they came as a torch batch (and whether
    its channels moved); numpy images (a list with some tensors: arrays) as they are."""
    if is_tensors(images):
        return _channels_last(images)
    return to_numpy(images), False


def _back(result, images, keypoints, masks, boxes, moved_channels: bool, polygons=None):
    changes = {}
    if is_tensors(images):
        changes["images"] = _images_back(result.images, images, moved_channels)
    if getattr(result, "polygons", None) is not None:
        changes["polygons"] = _polygons_back(result.polygons, polygons)
    if is_tensors(keypoints) and result.keypoints is not None:
        changes["keypoints"] = from_numpy(result.keypoints, keypoints, points=True)
        changes["keypoints_valid"] = _flags(result.keypoints_valid, keypoints)
    if is_tensors(masks) and result.masks is not None:
        changes["masks"] = from_numpy(result.masks, masks)
    if is_tensors(boxes) and result.boxes is not None:
        changes["boxes"] = from_numpy(result.boxes, boxes, points=True)
        changes["boxes_valid"] = _flags(result.boxes_valid, boxes)
    return dataclasses.replace(result, **changes)


def call_on_tensors(aug, images, keypoints, masks, boxes, polygons, indices):
    """``aug(images, ...)`` where an argument holds torch tensors (:func:`any_tensors`): the
    numpy call, each result as its argument came (a tensor's as a tensor)."""
    array, moved = _images_in(images)
    result = aug(
        array,
        keypoints=to_numpy(keypoints),
        masks=to_numpy(masks),
        boxes=to_numpy(boxes),
        polygons=_polygons_in(polygons),
        indices=to_numpy(indices),
    )
    return _back(result, images, keypoints, masks, boxes, moved, polygons)


def replay_on_tensors(aug, images, params, keypoints, masks, boxes, polygons):
    """``aug.replay(images, params, ...)`` where an argument holds torch tensors."""
    array, moved = _images_in(images)
    result = aug.replay(
        array,
        params,
        keypoints=to_numpy(keypoints),
        masks=to_numpy(masks),
        boxes=to_numpy(boxes),
        polygons=_polygons_in(polygons),
    )
    return _back(result, images, keypoints, masks, boxes, moved, polygons)
