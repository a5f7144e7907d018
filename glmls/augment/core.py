"""Random MLS deformations of a batch: :class:`Augment` draws each sample's handles from
its preset with the sample's own random numbers, numbered by ``(seed, index)``, deforms the
batch with :func:`glmls.warp_batch` and moves its labels along."""

from __future__ import annotations

import dataclasses
import inspect
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from ..batch import BatchResult, warp_batch
from ..batch.inputs import check_point_sets, check_points, item_array
from ..core.config import check_integer, check_seed, counted
from ..core.mesh import as_shape
from . import labels as lab
from . import tensors
from .params import (
    LABEL_OPTIONS,
    as_lists,
    check_label_options,
    check_one_options,
    check_params,
    check_reach,
    check_warp_options,
    differing_options,
    fresh,
    jsonable,
    label_options_of,
    param_handles,
)
from .presets import preset_defaults, preset_from

__all__ = ["DEFAULT_WARP_OPTIONS", "Augment", "AugmentResult"]

#: The warp keywords an :class:`Augment` uses unless told otherwise: the similarity MLS (as
#: Luo et al.), bilinear sampling and the image's edge beyond its border (no black slivers
#: where the frame is pulled in). The preset's own go over these: ``warp_transform`` (affine
#: for ``text-perspective``, whose trapezoid the similarity MLS folds) and the ``grid`` of
#: the quads' mesh, ``warp_grid``: 4 for ``grid`` and 2 for the text presets (f's
#: evaluations a sixteenth and a quarter of grid 1's; the pixels and the labels follow that
#: mesh exactly, which departs from f by about 0.1 px at most with the presets' default
#: displacements), 1 for ``landmarks`` (each landmark lands next to its drawn target, a
#: tenth of a pixel away), and none where a ``tolerance`` (the adaptive mesh) or
#: ``paper-quads`` is asked for (grid 1).
DEFAULT_WARP_OPTIONS = {"transform": "similarity", "interpolation": "linear", "border": "edge"}


@dataclass(frozen=True, repr=False)  # BatchResult's repr: shapes, not pixels
class AugmentResult(BatchResult):
    """What :class:`Augment` returns: a batch result with boxes, polygons and the draws.

    A :class:`glmls.BatchResult` with the boxes and polygons moved too, and ``params``, each
    sample's draw (a list of JSON-able dicts).

    Parameters
    ----------
    images, keypoints, keypoints_valid, masks, maps, valid, params : object
        As :class:`glmls.BatchResult`; ``params`` holds one dict per sample: ``preset``,
        ``config`` (the preset's options), ``seed``, ``index``, ``shape`` (H, W), ``src`` and
        ``dst`` (the handles, lists of [x, y]), ``options`` (the warp keywords, but a
        ``ctx``, which replay takes from the Augment) and ``label_options`` (``box_step``,
        ``densify`` and ``clip_polygons``, which shaped the boxes and polygons).
    boxes : numpy.ndarray or list of numpy.ndarray or None
        (N, B, 4) or per image (B_i, 4) boxes ``(x_min, y_min, x_max, y_max)`` around the
        moved outlines, clipped to the canvas.
    boxes_valid : numpy.ndarray or list of numpy.ndarray or None
        (N, B) or per image (B_i,) bool: a positive width and height left on the canvas.
    polygons : list of list of numpy.ndarray or None
        Per image, its polygons' moved vertices (densified and clipped as asked).

    Examples
    --------
    >>> import numpy as np
    >>> from glmls.augment import Augment
    >>> result = Augment("grid", seed=1)(np.zeros((2, 16, 16), np.uint8))
    >>> type(result).__name__, result.images.shape, result.params[1]["index"]
    ('AugmentResult', (2, 16, 16), 1)
    """

    boxes: np.ndarray | list[np.ndarray] | None = None
    boxes_valid: np.ndarray | list[np.ndarray] | None = None
    polygons: list[list[np.ndarray]] | None = None


#: The ``warp_options`` that say where to render, not what: kept out of the params (JSON),
#: added again on replay.
_UNRECORDED = ("ctx",)


def _words(value: int) -> list[int]:
    """``value`` (>= 0) as 32-bit words, least significant first; 0 as one word."""
    words = [value & 0xFFFFFFFF]
    while value >> 32:
        value >>= 32
        words.append(value & 0xFFFFFFFF)
    return words


def sample_rng(seed: int, index: int) -> np.random.Generator:
    """The random numbers of sample ``index`` under ``seed``: ``numpy.random.default_rng((seed,
    index))`` for a seed below 2**32. numpy reads that pair as the words of both numbers, the
    last ones zero-padded, so a larger seed would share its draws with smaller ones (seed
    2**32 + s at index 0 with seed s at index 1); a seed of 2**32 or more draws from its
    word count, its words, the index's words and a closing 0, which no other pair spells.

    Examples
    --------
    >>> from glmls.augment.core import sample_rng
    >>> first = sample_rng(2**32, 0).uniform(size=3)
    >>> bool((first != sample_rng(0, 1).uniform(size=3)).all())
    True
    """
    if seed < 1 << 32:
        return np.random.default_rng((seed, index))
    seed_words = _words(seed)
    words = [len(seed_words), *seed_words, *_words(index), 0]
    return np.random.default_rng(np.random.SeedSequence(np.array(words, np.uint32)))


def mesh_grid(options: Mapping[str, object]) -> int | None:
    """The grid of the regular mesh whose piecewise linear map moves the points with a
    draw's warp ``options`` (``quads`` without a ``tolerance``), else None."""
    chosen = lab.warp_options_of(options)
    return chosen.grid if chosen.method == "quads" and chosen.tolerance is None else None


def _index_list(indices: object, count: int) -> list[int]:
    if indices is None:
        return list(range(count))
    if isinstance(indices, list):
        values = indices
    else:
        array = np.asarray(indices)
        if array.dtype == object and array.ndim == 0:  # a generator, a set: one object
            raise TypeError(
                f"indices must be a sequence of N integers, got {type(indices).__name__}"
            )
        if array.ndim != 1:  # a scalar, or a table that reshape would flatten silently
            raise ValueError(f"indices must be a sequence of N integers, got shape {array.shape}")
        values = list(array)
    if len(values) != count:
        raise ValueError(
            f"indices holds {counted(len(values), 'value')} for {counted(count, 'image')}"
        )
    checked = []
    for i, value in enumerate(tensors.to_numpy(values)):
        if isinstance(value, np.ndarray) and value.ndim == 0:  # a 0-d array or tensor
            value = value[()]
        checked.append(check_integer(f"indices[{i}]", value, 0))
    return checked


def _object_list(value: object) -> bool:
    """Whether ``value`` is a 1-D object array (of arrays of different sizes): a sequence."""
    return isinstance(value, np.ndarray) and value.dtype == object and value.ndim == 1


def _images(images: object) -> list[np.ndarray]:
    if _object_list(images):
        images = list(images)  # type: ignore[arg-type]
    if isinstance(images, np.ndarray):
        if images.ndim not in (3, 4):
            raise ValueError(
                f"images must be an (N, H, W) or (N, H, W, C) array or a sequence of images, "
                f"got shape {images.shape}"
            )
        items = list(images)
    elif isinstance(images, (list, tuple)):
        items = [item_array(image, f"images[{i}]") for i, image in enumerate(images)]
    else:
        raise TypeError(f"images must be an array or a sequence, got {type(images).__name__}")
    if not items:
        raise ValueError("images is an empty batch: nothing to augment")
    for i, image in enumerate(items):
        if image.ndim not in (2, 3) or image.size == 0:
            raise ValueError(f"images[{i}] has shape {image.shape}; expected (H, W) or (H, W, C)")
        if image.dtype.kind == "f" and not np.isfinite(image).all():
            raise ValueError(f"images[{i}] holds values that are not finite (NaN or inf)")
    return items


def _keypoint_list(keypoints: object, count: int) -> tuple[list[np.ndarray] | None, bool]:
    if keypoints is None:
        return None, False
    if isinstance(keypoints, np.ndarray) and keypoints.dtype != object:
        if keypoints.ndim != 3:
            raise ValueError(
                f"keypoints must be an (N, P, 2) array or a sequence of (P, 2) arrays, got "
                f"shape {keypoints.shape}"
            )
        items, stacked = list(keypoints), True
    elif isinstance(keypoints, (list, tuple)) or _object_list(keypoints):
        items = [item_array(k, f"keypoints[{i}]") for i, k in enumerate(keypoints)]  # type: ignore[arg-type]
        stacked = False
    else:
        raise TypeError(f"keypoints must be an array or a sequence, got {type(keypoints)}")
    if len(items) != count:
        raise ValueError(
            f"keypoints holds {counted(len(items), 'point set')} for {counted(count, 'image')}"
        )
    return check_point_sets(items, lambda i: f"keypoints[{i}]", rows="P"), stacked


def _landmark_list(landmarks: object, count: int) -> list[np.ndarray]:
    """:meth:`Augment.draw`'s ``landmarks``: ``count`` (P, 2) point sets, checked as
    keypoints are, the errors naming ``landmarks[i]``."""
    if isinstance(landmarks, (str, bytes)) or not isinstance(landmarks, (Sequence, np.ndarray)):
        raise TypeError(f"landmarks must be a sequence of (P, 2) arrays, got {type(landmarks)}")
    if len(landmarks) != count:
        raise ValueError(
            f"landmarks holds {counted(len(landmarks), 'point set')} for {counted(count, 'image')}"
        )
    return [
        check_points(item_array(marks, f"landmarks[{i}]"), f"landmarks[{i}]", rows="P")
        for i, marks in enumerate(landmarks)
    ]


def _stack(items: list[np.ndarray], stacked: bool):
    if stacked and items and all(a.shape == items[0].shape for a in items):
        return np.stack(items)
    return items


class Augment:
    """A random MLS deformation of a batch, reproducible sample by sample.

    Sample i draws its handles from the preset with ``numpy.random.default_rng((seed,
    indices[i]))`` (for a seed below 2**32; a larger seed draws from its words and the
    index's, so that no two seeds share a draw): ``aug(images[2:4], indices=[2, 3])``
    equals ``aug(images)`` at 2 and 3 whatever the batch size, order or number of workers.
    Each sample's draw is kept in the result's ``params`` (JSON-able dicts) and
    :meth:`replay` makes it again.

    Parameters
    ----------
    preset : str or preset object
        ``"grid"``, ``"text-distort"``, ``"text-stretch"``, ``"text-perspective"`` or
        ``"landmarks"`` (:data:`glmls.augment.PRESETS`), or a preset object
        (:class:`GridPreset` ...).
    seed : int, default 0
        The seed (>= 0) that, with each sample's index, numbers its random draw.
    warp_options : mapping or None, default None
        Keywords of :func:`glmls.warp_batch` (``transform``, ``interpolation``, ``border``,
        ``method``, ``grid``...), over :data:`DEFAULT_WARP_OPTIONS`; ``options``, a
        :class:`glmls.WarpOptions`, stands for its fields (over the defaults, under the
        other keywords).
    box_step : float, default 2.0
        Pixels between two points of a box's outline as it is moved (with ``quads`` on the
        regular mesh, the points where the outline crosses the mesh's cell and triangle
        edges and the mesh's vertices inside the box are added: the box is then the moved
        box's extent exactly, where the map folds too).
    densify : float or None, default None
        Pixels: add points along each polygon's edges so that none is longer, before moving
        it (a straight edge may bend); None: move the vertices only.
    clip_polygons : bool, default True
        Clip the moved polygons to the canvas.

    Other Parameters
    ----------------
    **preset_options
        The preset's options (:class:`GridPreset`'s ``rows``, ``cols``, ``displacement``,
        ``units``; the text presets' ``segments`` and ``radius``; :class:`LandmarksPreset`'s).

    Raises
    ------
    ValueError
        For an unknown preset (the valid ones listed) or a value out of range, naming it
        (also ``warp_options``' values; a magnitude that moves handles beyond the
        coordinate range when it draws).
    TypeError
        For an unknown option, a ``warp_options`` keyword that :func:`glmls.warp_batch`
        does not take (or ``keypoints``, ``masks``: the call's own; ``src_segments``,
        ``dst_segments``: the preset draws the handles), a ``clip_polygons`` that is not a
        bool, or a ``box_step`` or ``densify`` that is not a real number.

    Examples
    --------
    >>> import numpy as np
    >>> from glmls.augment import Augment
    >>> images = np.random.default_rng(0).integers(0, 255, (4, 24, 48), dtype=np.uint8)
    >>> aug = Augment("text-distort", seed=7)
    >>> whole = aug(images, keypoints=np.full((4, 1, 2), 20.0))
    >>> part = aug(images[2:4], indices=[2, 3], keypoints=np.full((2, 1, 2), 20.0))
    >>> bool((part.images == whole.images[2:4]).all())
    True
    >>> sorted(whole.params[0])
    ['config', 'dst', 'index', 'label_options', 'options', 'preset', 'seed', 'shape', 'src']
    >>> Augment("wave")
    Traceback (most recent call last):
    ...
    ValueError: unknown preset 'wave'; expected one of grid, text-distort, text-stretch, ...
    """

    def __init__(
        self,
        preset: object,
        *,
        seed: int = 0,
        warp_options: Mapping[str, object] | None = None,
        box_step: float = 2.0,
        densify: float | None = None,
        clip_polygons: bool = True,
        **preset_options: object,
    ) -> None:
        seed = check_seed(seed)
        labels = check_label_options(
            {"box_step": box_step, "densify": densify, "clip_polygons": clip_polygons}
        )
        if warp_options is not None and not isinstance(warp_options, Mapping):
            raise TypeError(f"warp_options must be a mapping or None, got {warp_options!r}")
        given = dict(warp_options or {})
        check_warp_options(given)
        self.preset = preset_from(preset, preset_options)
        self.seed = seed
        packed = given.pop("options", None)  # a WarpOptions: its fields, JSON in the params
        chosen = {**({} if packed is None else dataclasses.asdict(packed)), **given}
        own = preset_defaults(self.preset, chosen)
        self.warp_options = {**DEFAULT_WARP_OPTIONS, **own, **chosen}
        check_warp_options(self.warp_options)  # what the options make together
        self.box_step: float = labels["box_step"]  # type: ignore[assignment]
        self.densify: float | None = labels["densify"]  # type: ignore[assignment]
        self.clip_polygons: bool = labels["clip_polygons"]  # type: ignore[assignment]

    @property
    def label_options(self) -> dict[str, object]:
        """``box_step``, ``densify`` and ``clip_polygons``: what shapes the labels.

        Recorded in each draw (its ``label_options``).

        Returns
        -------
        dict
            The three options, JSON-able.

        Examples
        --------
        >>> from glmls.augment import Augment
        >>> Augment("grid", box_step=4).label_options
        {'box_step': 4.0, 'densify': None, 'clip_polygons': True}
        """
        return {name: getattr(self, name) for name in LABEL_OPTIONS}

    def __repr__(self) -> str:
        # the keywords that differ from their defaults too: the repr makes this Augment again
        base = {**DEFAULT_WARP_OPTIONS, **preset_defaults(self.preset, self.warp_options)}
        warp = {k: self.warp_options[k] for k in differing_options(self.warp_options, base)}
        given = inspect.signature(Augment.__init__).parameters
        labels = {k: v for k, v in self.label_options.items() if v != given[k].default}
        keywords = {"seed": self.seed, **({"warp_options": warp} if warp else {}), **labels}
        return f"Augment({self.preset!r}, {', '.join(f'{k}={v!r}' for k, v in keywords.items())})"

    def draw(
        self,
        shapes: Sequence[tuple[int, int]],
        *,
        indices: Sequence[int] | None = None,
        landmarks: Sequence[np.ndarray] | None = None,
    ) -> list[dict]:
        """Each sample's random draw, without deforming anything.

        Parameters
        ----------
        shapes : sequence of (int, int) or numpy.ndarray
            Each image's (H, W); an (N, 2) integer array is read row by row.
        indices : sequence of int or None, default None
            Each sample's index (>= 0); None: 0 .. N - 1.
        landmarks : sequence of array_like or None, default None
            Each image's (P, 2) landmarks (the ``landmarks`` preset's handles): arrays, or
            torch tensors (an (N, P, 2) one, or a list of them).

        Returns
        -------
        list of dict
            The params (see :class:`AugmentResult`).

        Raises
        ------
        ValueError
            For indices of the wrong count or value, a shape that is not (H, W) integers
            >= 1 (or an image's (H, W, C)), or missing landmarks.
        TypeError
            For ``shapes`` or ``indices`` that is no sequence (a generator).

        Examples
        --------
        >>> from glmls.augment import Augment
        >>> aug = Augment("grid", rows=2, cols=2)
        >>> first = aug.draw([(8, 8), (8, 8)])
        >>> again = aug.draw([(8, 8)], indices=[1])
        >>> first[1] == again[0], len(first[0]["src"])
        (True, 4)
        """
        return self._draw(shapes, indices, landmarks)[0]

    def _draw(
        self,
        shapes: Sequence[tuple[int, int]],
        indices: Sequence[int] | None,
        landmarks: Sequence[np.ndarray] | None,
    ) -> tuple[list[dict], list[tuple[np.ndarray, np.ndarray]]]:
        """:meth:`draw`'s params, and each sample's (src, dst) as the float64 arrays they
        record (as lists: the same numbers)."""
        if isinstance(shapes, np.ndarray) and shapes.ndim == 2:  # rows (H, W) or (H, W, C)
            shapes = [tuple(row) for row in shapes]
        if isinstance(shapes, (str, bytes)) or not isinstance(shapes, Sequence):
            raise TypeError(f"shapes must be a sequence of (H, W), got {type(shapes).__name__}")
        index_list = _index_list(indices, len(shapes))
        if landmarks is not None:  # torch tensors too, as __call__'s keypoints
            landmarks = _landmark_list(tensors.to_numpy(landmarks), len(shapes))
        params = []
        # what every sample records alike, made JSON-able once (each sample its own copy)
        config = jsonable(dataclasses.asdict(self.preset))
        options = jsonable({k: v for k, v in self.warp_options.items() if k not in _UNRECORDED})
        reaches: dict[tuple[int, int], float] = {}  # without landmarks, by the image's shape
        drawn: list[tuple[np.ndarray, np.ndarray]] = []
        for i, (given, index) in enumerate(zip(shapes, index_list, strict=True)):
            try:
                shape = tuple(as_shape(given))
            except (TypeError, ValueError) as error:
                raise type(error)(f"shapes[{i}]: {error}") from None
            rng = sample_rng(self.seed, index)
            marks = None if landmarks is None else landmarks[i]
            try:
                src, dst = self.preset.draw(rng, shape, marks)
            except ValueError as error:
                raise ValueError(f"images[{i}]: {error}") from None
            reach = reaches.get(shape) if marks is None else None
            if reach is None:
                reach = self.preset.reach(shape, marks)
                if marks is None:
                    reaches[shape] = reach
            check_reach(self.preset, reach, i)
            drawn.append((np.asarray(src, np.float64), np.asarray(dst, np.float64)))
            params.append(
                {
                    "preset": self.preset.name,
                    "config": fresh(config),
                    "seed": self.seed,
                    "index": index,
                    "shape": [int(shape[0]), int(shape[1])],
                    "src": None,  # below, of every sample at once
                    "dst": None,
                    "options": fresh(options),
                    "label_options": self.label_options,
                }
            )
        for draw, (src, dst) in zip(params, as_lists(drawn), strict=True):
            draw["src"], draw["dst"] = src, dst
        return params, drawn

    def __call__(
        self,
        images: object,
        *,
        keypoints: object = None,
        masks: object = None,
        boxes: object = None,
        polygons: object = None,
        indices: object = None,
    ) -> AugmentResult:
        """Deform a batch at random, with its labels.

        Parameters
        ----------
        images : array_like or sequence of array_like or torch.Tensor
            (N, H, W[, C]) or N images (H, W[, C]) (the dtypes of :func:`glmls.warp`); a torch
            tensor (N, C, H, W) or (N, H, W), or a list of (C, H, W) or (H, W) tensors, comes
            back as one, of its dtype and device (a CUDA tensor through the host's memory;
            float16 and bfloat16 through float32).
        keypoints : array_like or sequence of array_like, optional
            (N, P, 2) or per image (P_i, 2) points (x, y); the ``landmarks`` preset's
            handles.
        masks : array_like or sequence of array_like, optional
            Per image, an (H, W) integer or bool label image, warped with nearest sampling.
        boxes : array_like or sequence of array_like, optional
            (N, B, 4) or per image (B_i, 4) boxes ``(x_min, y_min, x_max, y_max)``.
        polygons : sequence, optional
            Per image, a sequence of (V, 2) polygons (or a (P, V, 2) array of them).
        indices : sequence of int, optional
            Each sample's index (>= 0); None: 0 .. N - 1.

        Returns
        -------
        AugmentResult
            The images, the labels given, and ``params``. Each comes back in the kind it
            came in, whatever the others': a label given as a torch tensor (or a list of
            them, per image; an image's polygons as a list of them) as a tensor of its
            device, and of its dtype where that is a floating-point one (float64 for
            integer points, as the moved points lie between pixel centres), with numpy
            images too; a label given as numpy (or lists) as numpy, with tensor images too.

        Raises
        ------
        ValueError
            For an empty batch, a wrong shape or a value that is not finite, naming the
            item's index (``images[3]``, ``boxes[1]``).

        Examples
        --------
        >>> import numpy as np
        >>> from glmls.augment import Augment
        >>> images = np.zeros((2, 20, 20), np.uint8)
        >>> out = Augment("grid", seed=3)(images, boxes=[[[4, 4, 12, 12]], []])
        >>> out.boxes[0].shape, out.boxes[1].shape, out.boxes_valid[0].tolist()
        ((1, 4), (0, 4), [True])
        """
        if tensors.any_tensors(images, keypoints, masks, boxes, polygons, indices):
            return tensors.call_on_tensors(self, images, keypoints, masks, boxes, polygons, indices)
        items = _images(images)
        marks, _ = _keypoint_list(keypoints, len(items))
        if self.preset.name == "landmarks" and marks is None:
            raise ValueError("the landmarks preset needs each image's landmarks (keypoints)")
        shapes = [image.shape[:2] for image in items]
        # only the landmarks preset draws from them (the others' draws and reaches ignore
        # them, and take each shape's reach once without)
        landmarks = marks if self.preset.name == "landmarks" else None
        params, drawn = self._draw(shapes, indices, landmarks)
        # the draws' own arrays: what replay reads back from their lists, without its checks
        src, dst = [p for p, _ in drawn], [q for _, q in drawn]
        labels = (keypoints, masks, boxes, polygons)
        return self._warp(images, items, params, src, dst, labels)

    def replay(
        self,
        images: object,
        params: Sequence[Mapping],
        *,
        keypoints: object = None,
        masks: object = None,
        boxes: object = None,
        polygons: object = None,
    ) -> AugmentResult:
        """Make recorded draws again: each image deformed by its params' handles and options.

        Parameters
        ----------
        images : array_like or sequence of array_like
            As for :meth:`__call__`, one per params.
        params : sequence of mapping
            The ``params`` of an earlier result (as they are, or through JSON). Boxes and
            polygons move with each draw's ``label_options`` (``box_step``, ``densify``,
            ``clip_polygons``), whatever this Augment's; a record without them (or without
            one of them) takes this Augment's.
        keypoints, masks, boxes, polygons : optional
            As for :meth:`__call__`.

        Returns
        -------
        AugmentResult
            Equal to the result that recorded the params (for the same inputs).

        Raises
        ------
        ValueError, TypeError
            For params of another count, a draw without its ``shape``, ``src``, ``dst`` or
            ``options``, a bad entry (``params[1]['label_options']: box_step must be a finite
            number > 0, got -1``), or of an image of another shape, naming the index.

        Examples
        --------
        >>> import json
        >>> import numpy as np
        >>> from glmls.augment import Augment
        >>> aug = Augment("text-stretch", seed=2)
        >>> images = np.random.default_rng(0).integers(0, 255, (2, 16, 40), dtype=np.uint8)
        >>> first = aug(images)
        >>> params = json.loads(json.dumps(first.params))
        >>> bool((aug.replay(images, params).images == first.images).all())
        True
        """
        if tensors.any_tensors(images, keypoints, masks, boxes, polygons, None):
            return tensors.replay_on_tensors(
                self, images, params, keypoints, masks, boxes, polygons
            )
        items = _images(images)
        count = len(items)
        params = check_params(params, count)
        for i, (image, p) in enumerate(zip(items, params, strict=True)):
            if tuple(p["shape"]) != image.shape[:2]:
                raise ValueError(
                    f"params[{i}] was drawn for shape {tuple(p['shape'])}, images[{i}] has "
                    f"{image.shape[:2]}"
                )
        labels = (keypoints, masks, boxes, polygons)
        return self._warp(images, items, params, None, None, labels)

    def _warp(self, images, items, params, src, dst, labels) -> AugmentResult:
        """The checked ``params``' deformation of ``images`` (``items``: as arrays), with
        ``labels`` (keypoints, masks, boxes, polygons): by the handles ``src`` and ``dst``
        where given (the draws' own arrays), else the params' (checked)."""
        keypoints, masks, boxes, polygons = labels
        count = len(items)
        marks, stacked_marks = _keypoint_list(keypoints, count)
        box_list, stacked_boxes = (None, False) if boxes is None else lab.check_boxes(boxes, count)
        polygon_list = None if polygons is None else lab.check_polygons(polygons, count)
        options = dict(params[0]["options"])
        check_one_options(params)  # one warp_batch call: one set of options
        grid = mesh_grid(options)
        meshes = [None if grid is None else (grid, tuple(p["shape"])) for p in params]
        labels = [label_options_of(p, self.label_options) for p in params]
        shapes = [tuple(p["shape"]) for p in params]
        points, parts = self._points(marks, box_list, polygon_list, meshes, labels, shapes)
        options |= {k: v for k, v in self.warp_options.items() if k in _UNRECORDED}
        if src is None:
            src, dst = param_handles(params)
        result = warp_batch(images, src, dst, keypoints=points, masks=masks, **options)
        if not isinstance(result, BatchResult):
            result = BatchResult(images=result)
        return self._assemble(result, params, parts, stacked_marks, stacked_boxes, labels)

    @staticmethod
    def _points(marks, box_list, polygon_list, meshes, labels, shapes):
        """Every image's points to move: its keypoints, box outlines (with the crossings of
        ``meshes[i]``, its ``quads`` mesh where it has one; ``box_step`` of ``labels[i]``;
        sparse far past its ``shapes[i]``) and polygons (densified as they say), one after
        another; ``parts`` records where each kind lies."""
        if marks is None and box_list is None and polygon_list is None:
            return None, None
        points, parts = [], []
        if box_list is not None:  # the images of one step and mesh at once
            steps = [chosen["box_step"] for chosen in labels]
            outlines = lab.outline_sets(box_list, steps, meshes, shapes)
        for i, chosen in enumerate(labels):
            densify = chosen["densify"]
            pieces, part = [], {}
            if marks is not None:
                pieces.append(marks[i])
                part["keypoints"] = len(marks[i])
            if box_list is not None:
                outline, part["boxes"] = outlines[i]
                b = box_list[i]  # a line or a point stays invalid however it bends
                part["areas"] = (b[:, 2] > b[:, 0]) & (b[:, 3] > b[:, 1])
                pieces.append(outline)
            if polygon_list is not None:
                try:
                    dense = [lab.densify_polygon(poly, densify) for poly in polygon_list[i]]
                except ValueError as error:
                    given = "" if densify is None else f" with densify={densify:g}"
                    raise ValueError(f"polygons[{i}]{given}: {error}") from None
                pieces += dense
                part["polygons"] = [len(poly) for poly in dense]
            points.append(np.concatenate(pieces) if pieces else np.zeros((0, 2)))
            parts.append(part)
        return points, parts

    @staticmethod
    def _assemble(result, params, parts, stacked_marks, stacked_boxes, labels):
        fields = {}
        if parts is not None:
            moved_all = result.keypoints
            valid_all = result.keypoints_valid
            out_shapes = [np.asarray(image).shape[:2] for image in result.images]
            kps, kvs, bxs, bvs, pls = [], [], [], [], []
            for i, part in enumerate(parts):
                moved, valid, start = np.asarray(moved_all[i]), np.asarray(valid_all[i]), 0
                if "keypoints" in part:
                    n = part["keypoints"]
                    kps.append(moved[:n])
                    kvs.append(valid[:n])
                    start = n
                if "boxes" in part:
                    n = int(part["boxes"].sum())
                    box, ok = lab.boxes_from_outlines(
                        moved[start : start + n], part["boxes"], out_shapes[i]
                    )
                    bxs.append(box)
                    bvs.append(ok & part["areas"])
                    start += n
                if "polygons" in part:
                    one = []
                    for n in part["polygons"]:
                        poly = moved[start : start + n]
                        one.append(
                            lab.clip_polygon(poly, out_shapes[i])
                            if labels[i]["clip_polygons"]
                            else poly
                        )
                        start += n
                    pls.append(one)
            if kps:
                fields.update(
                    keypoints=_stack(kps, stacked_marks), keypoints_valid=_stack(kvs, stacked_marks)
                )
            if bxs:
                fields.update(
                    boxes=_stack(bxs, stacked_boxes), boxes_valid=_stack(bvs, stacked_boxes)
                )
            if pls:
                fields["polygons"] = pls
        return AugmentResult(
            images=result.images,
            masks=result.masks,
            maps=result.maps,
            valid=result.valid,
            params=[dict(p) for p in params],
            **fields,
        )
