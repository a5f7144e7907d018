"""The one-call batch front end :func:`warp_batch`."""

from __future__ import annotations

import dataclasses

import numpy as np

from ..core.config import check_flag, check_integer, counted
from ..core.handleset import HandleSet
from ..gl import helper
from ..gl.context import forked_from_gl
from ..imaging.options import FIELDS, WarpOptions
from ..mls import MLS, MLS_KEYWORDS
from .chunks import warp_chunks
from .footprints import RING, footprint_radius, footprint_sets, seen_whole
from .forward import forward_batchable, warp_forward
from .gpu import batchable
from .inputs import BatchInput, check_batch, item_array, naming, stack_or_list
from .labels import on_canvas
from .result import BatchResult
from .single import ImageLabels, SingleWarper

__all__ = ["check_flags", "warp_batch"]

_PER_IMAGE = ("src_segments", "dst_segments")


def warp_batch(
    images: object,
    src: object,
    dst: object,
    *,
    keypoints: object = None,
    masks: object = None,
    return_maps: bool = False,
    max_batch_bytes: int | None = None,
    **options: object,
) -> np.ndarray | list[np.ndarray] | BatchResult:
    """Deform a batch of images, each by the MLS map of its own handles, with its labels.

    Equal to one :func:`glmls.warp` per image, bit for bit. ``quads``, ``backward`` and
    ``backward-swap`` on the regular mesh run batched on the GPU: per chunk of images of one
    shape (and, with a border mode, of one mesh margin), f on every
    image's mesh in one pass, one scan of every mesh (and for ``backward`` one Newton pass
    over every pixel), one fill and one read-back; ``backward-swap`` evaluates every image's
    swapped-handles map at every output pixel in one pass, samples in one draw and reads
    back once (its keypoints by s's inverse, Newton on s for every image's keypoints in a
    few dispatches; image by image where s folds or Newton from f leaves a point);
    ``splat`` likewise, f at every image's
    pixel centres in one pass, one instanced draw of every image's points and one
    read-back, and ``paper-quads`` with one scan of every image's squares of pixel centres
    and one draw from its keys (their keypoints moved by f in one pass of the chunk, their
    maps each image's own, as the single path finds them). The other cases take the single
    pipeline image by image (:doc:`/batch`).
    In a process forked from one in which glmls used GL (a data loader's worker), it runs in
    a helper process started fresh, with the same result (see ``glmls.gl.context``).

    Parameters
    ----------
    images : array_like or sequence of array_like
        An (N, H, W) or (N, H, W, C) array (C in 1..4; uint8, uint16, float32 or float64), or
        a sequence of N such images of any shapes.
    src, dst : array_like or sequence of array_like
        Per image, its handles p and q: (N, K, 2) arrays, or sequences of N arrays of shape
        (K_i, 2) (a different number of handles per image; none, as for :func:`glmls.warp`:
        the identity, or the segment handles alone).
    keypoints : array_like or sequence of array_like or None, default None
        Per image, source points (x, y) to move along: an (N, P, 2) array or a sequence of
        (P_i, 2) arrays. ``quads`` on a regular mesh moves them by the mesh's piecewise
        linear map that placed the pixels (by f beyond the mesh), ``backward-swap`` by the
        inverse of the swapped-handles map that it samples with, the other methods by f.
    masks : array_like or sequence of array_like or None, default None
        Per image, an (H, W) label image of an integer or bool dtype (labels within
        +-2**24 unless uint8, uint16 or bool): warped like its image with nearest sampling
        (never a mixed label), 0 (False) where nothing is shown.
    return_maps : bool, default False
        Also return each image's map from output pixels to the source points they show and
        its valid mask.
    max_batch_bytes : int or None, default None
        The most GPU memory one chunk of the batch takes (None: 256 MiB): the batched path
        runs the batch chunk by chunk, each chunk as large as this and the GL limits (the
        atlas of its output canvases within the texture size) allow.
    **options
        Those of :func:`glmls.warp`, for every image: the fields of
        :class:`glmls.WarpOptions` (``method``, ``interpolation``, ``grid``, ``tolerance``,
        ``border``, ``background``, ``output_shape``, ``origin``; or ``options``) and of
        :class:`glmls.MLS` (``transform``, ``weight``, ``alpha``, ``s``, ``radius``,
        ``interpolating``, ``ctx``, ``storage``, ``bins``); ``src_segments`` and
        ``dst_segments`` as sequences of N per-image values (None for an image without).

    Returns
    -------
    numpy.ndarray or list of numpy.ndarray or BatchResult
        Without labels or maps, the warped images: an array (N, H, W[, C]) of the input's
        dtype and channels where all images share one shape and dtype, else a list in input
        order. With ``keypoints``, ``masks`` or ``return_maps``, a :class:`glmls.BatchResult`
        of the images and what was asked for (keypoints in output pixel coordinates).

    Raises
    ------
    ValueError, TypeError
        For an empty batch, for an item of a bad shape, dtype or count, or not finite,
        naming it (``src[3] has shape (5, 3); expected (K, 2)``), for a ``return_maps``
        that is not a bool or a ``max_batch_bytes`` below 1, and as :func:`glmls.warp`.

    Examples
    --------
    >>> import numpy as np
    >>> import glmls
    >>> images = np.arange(48, dtype=np.uint8).reshape(2, 4, 6)
    >>> src = [[[0, 0], [5, 3]], [[0, 0], [5, 3]]]
    >>> dst = [[[1, 0], [6, 3]], [[0, 0], [5, 3]]]
    >>> out = glmls.warp_batch(images, src, dst, transform="similarity")
    >>> out.shape, out[0, 0].tolist(), bool((out[1] == images[1]).all())
    ((2, 4, 6), [0, 0, 1, 2, 3, 4], True)
    >>> glmls.warp_batch(images, src, [[[1, 0], [6, 3]], [[0, 0, 1]]])
    Traceback (most recent call last):
    ...
    ValueError: dst[1] has shape (1, 3); expected (K, 2)
    """
    max_batch_bytes = check_flags(return_maps, max_batch_bytes)
    masks, binary = _bytes_of_bool_masks(masks)
    if options.get("ctx") is None and forked_from_gl():  # GL would hang here: a clean helper
        keywords = {"keypoints": keypoints, "masks": masks, "return_maps": return_maps}
        keywords["max_batch_bytes"] = max_batch_bytes
        result = helper.call(__name__, "warp_batch", (images, src, dst), keywords | options)
        return _bool_masks_back(result, binary)
    chosen, mls_options, segments = _split_options(options)
    given = check_batch(images, src, dst, keypoints, masks)
    segments = _check_segments(segments, given, mls_options.get("transform"))
    batch = given
    if given.keypoints is not None:  # each with its footprint's edge: see footprints.py
        radius = footprint_radius(chosen.interpolation)
        rings = footprint_sets(given.keypoints, radius)
        batch = dataclasses.replace(given, keypoints=rings)
    warper = SingleWarper.of(mls_options.get("ctx"))
    done: list = [None] * len(batch)
    whole: dict = {}
    if batchable(chosen) and len(batch):
        done, whole = warp_chunks(
            batch, chosen, mls_options, segments, maps=return_maps, max_bytes=max_batch_bytes
        )
    elif forward_batchable(chosen) and len(batch):  # splat, paper-quads: batched forward
        done = warp_forward(
            batch, chosen, mls_options, segments, maps=return_maps, max_bytes=max_batch_bytes
        )
    results = [
        done[i]
        if done[i] is not None
        else warper.warp_one(
            MLS(batch.src[i], batch.dst[i], shape=image.shape[:2], **segments[i], **mls_options),
            image,
            chosen,
            mask=None if batch.masks is None else batch.masks[i],
            points=None if batch.keypoints is None else batch.keypoints[i],
            maps=return_maps,
            index=i,
        )
        for i, image in enumerate(batch.images)
    ]
    if batch.keypoints is not None:
        results = _seen_whole(results, batch, chosen.method)
    if return_maps and chosen.border != "constant":
        shapes = [image.shape[:2] for image in batch.images]
        results = [_on_source(r, shape) for r, shape in zip(results, shapes, strict=True)]
    result = _assemble(given, results, return_maps, whole)
    return _bool_masks_back(result, binary)


def _seen_whole(results: list[ImageLabels], batch: BatchInput, method: str) -> list:
    """The images' keypoints and their validity from those of their footprints' points
    (``batch.keypoints``), in one pass for the images of one size and canvas."""
    groups: dict[tuple, list[int]] = {}
    for i, (r, image) in enumerate(zip(results, batch.images, strict=True)):
        groups.setdefault((image.shape[:2], r.image.shape[:2]), []).append(i)
    out = list(results)
    for (source, canvas), members in groups.items():
        sizes = [len(batch.keypoints[i]) // len(RING) for i in members]  # type: ignore[index]
        moved, valid = seen_whole(
            np.concatenate([batch.keypoints[i] for i in members]),  # type: ignore[index]
            np.concatenate([results[i].keypoints for i in members]),
            np.concatenate([results[i].keypoints_valid for i in members]),
            source,
            canvas,
            hidden=method not in ("splat", "paper-quads"),
        )
        starts = np.cumsum([0, *sizes])
        for i, a, b in zip(members, starts[:-1], starts[1:], strict=True):
            r = results[i]
            out[i] = ImageLabels(r.image, r.mask, moved[a:b], valid[a:b], r.map, r.valid)
    return out


def _on_source(result: ImageLabels, shape: tuple[int, int]) -> ImageLabels:
    """``result`` with ``valid`` kept to the pixels whose source point lies on the source
    image of ``shape``: a border mode's copies beyond the image show no source pixel there."""
    if result.map is None or result.valid is None:
        return result
    inside = on_canvas(result.map.reshape(-1, 2), shape).reshape(result.valid.shape)
    return ImageLabels(
        result.image,
        result.mask,
        result.keypoints,
        result.keypoints_valid,
        result.map,
        result.valid & inside,
    )


def _bytes_of_bool_masks(masks: object) -> tuple[object, list[bool] | None]:
    """Bool masks as uint8 views (labels 0 and 1), and per mask whether it was bool (None
    where none was)."""
    if isinstance(masks, np.ndarray) and masks.dtype == bool and masks.ndim:
        return masks.view(np.uint8), [True] * len(masks)
    if isinstance(masks, (list, tuple)):
        arrays = [item_array(m, f"masks[{i}]") for i, m in enumerate(masks)]
        flags = [a.dtype == bool for a in arrays]
        if any(flags):
            return [a.view(np.uint8) if f else a for a, f in zip(arrays, flags, strict=True)], flags
    return masks, None


def _bool_masks_back(result: object, binary: list[bool] | None) -> object:
    """``result`` with the warped masks of bool masks bool again."""
    if binary is None or not isinstance(result, BatchResult) or result.masks is None:
        return result
    masks = result.masks
    if isinstance(masks, np.ndarray) and all(binary):
        return dataclasses.replace(result, masks=masks.astype(bool))
    out = [m.astype(bool) if f else m for m, f in zip(masks, binary, strict=True)]
    return dataclasses.replace(result, masks=out)


def check_flags(return_maps: object, max_batch_bytes: object) -> int | None:
    """:func:`warp_batch`'s ``return_maps`` and ``max_batch_bytes``, checked (``TypeError``,
    ``ValueError`` naming the value)."""
    check_flag("return_maps", return_maps)
    if max_batch_bytes is None:
        return None
    return check_integer("max_batch_bytes", max_batch_bytes, 1, what="an integer >= 1 or None")


def _split_options(options: dict) -> tuple[WarpOptions, dict, dict]:
    warp_options = {k: options.pop(k) for k in sorted(FIELDS | {"options"}) if k in options}
    segments = {k: options.pop(k) for k in _PER_IMAGE if k in options}
    unknown = sorted(set(options) - MLS_KEYWORDS)
    if unknown:
        raise TypeError(
            f"warp_batch() got {'unknown keywords' if len(unknown) > 1 else 'an unknown keyword'}"
            f" {', '.join(unknown)}"
        )
    chosen = WarpOptions.of(warp_options.pop("options", None), **warp_options)
    return chosen, options, segments


def _check_segments(segments: dict, batch: BatchInput, transform: object) -> list[dict]:
    """Per image, its ``src_segments`` and ``dst_segments`` where given, each image's
    handles checked as its MLS will check them (segments; handles that span the plane for
    the affine ``transform``), the error naming the image, before any GPU work."""
    count = len(batch)
    per_image: list[dict] = [{} for _ in range(count)]
    for name, value in segments.items():
        if value is None:
            continue
        what = f"{name} must be a sequence of one value per image ({count})"
        if isinstance(value, np.ndarray):
            if value.ndim != 4:  # one image's (S, 2, 2) segments, say
                raise ValueError(f"{what}, got an array of shape {value.shape}")
            value = list(value)
        if not isinstance(value, (list, tuple)):
            raise TypeError(f"{what}, got {value!r}")
        if len(value) != count:
            raise ValueError(f"{what}, got {counted(len(value), 'value')}")
        for i, item in enumerate(value):
            if item is not None:
                per_image[i][name] = item
    affine = transform == "affine"
    for i, given in enumerate(per_image):
        if given or affine:
            with naming(i, (TypeError, ValueError)):
                handles = HandleSet.validate(batch.src[i], batch.dst[i], **given)
                if affine:
                    handles.check_affine()
    return per_image


def _assemble(
    batch: BatchInput,
    results: list[ImageLabels],
    maps: bool,
    whole: dict[str, np.ndarray],
):
    """The output of :func:`warp_batch`: stacked where the inputs were (``whole``: the arrays
    of every image's pixels or masks where the batched path wrote them, of which the results
    are views)."""
    if batch.stacked and "images" in whole:
        out = whole["images"]
    else:
        out = stack_or_list([r.image for r in results], batch.stacked)
    if batch.keypoints is None and batch.masks is None and not maps:
        return out

    def field(name: str, stacked: bool):
        return stack_or_list([getattr(r, name) for r in results], stacked)

    given = batch.keypoints is not None
    return BatchResult(
        images=out,
        keypoints=field("keypoints", batch.stacked_points) if given else None,
        keypoints_valid=field("keypoints_valid", batch.stacked_points) if given else None,
        masks=whole["masks"]
        if batch.stacked and "masks" in whole
        else field("mask", True)
        if batch.masks is not None
        else None,
        maps=field("map", True) if maps else None,
        valid=field("valid", True) if maps else None,
    )
