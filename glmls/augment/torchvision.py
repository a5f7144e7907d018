"""A torchvision v2 ``Transform`` of :class:`glmls.augment.Augment`:
``pip install 'glmls[torch]'`` (torchvision 0.23 and newer, for ``tv_tensors.KeyPoints``).

This module imports torch and torchvision; :mod:`glmls.augment` does not import this module.
It can be imported before or after glmls's first warp: torchvision loads triton, whose LLVM
crashes a process that already holds Mesa's (the llvmpipe OpenGL driver of a machine
without a GPU driver), and glmls loads triton's library before it makes a GL context. Where
another library's GL context loaded Mesa's LLVM first, this module raises ``ImportError``
saying so rather than let the process crash (:func:`check_import_order`).

``MLSTransform`` follows torchvision's contract: ``make_params`` draws once per call from torch's
random numbers (``torch.manual_seed`` makes it repeat: the transform has no seed of its own), every
input of a call moves by that one draw (two images of one sample, an image and its depth map, as
many masks, keypoints and boxes as the sample has), plain tensors are taken as torchvision takes
them (the first one is the image where there is no ``tv_tensors.Image``, ``Video`` or PIL image, the
others pass through untouched), and ``transform`` deforms each input by type: ``tv_tensors.Image``
(and a plain tensor taken as the image; any number of channels; integers of any dtype rounded back
to it, as torchvision rounds them, bool with nearest sampling), a PIL image (in its mode; a palette
image's indices and a bilevel image's pixels with nearest sampling), ``Video`` (its frames all by
one draw, as torchvision's own transforms move them), ``Mask`` (nearest, never a mixed label),
``KeyPoints`` and ``BoundingBoxes`` (an unrotated box becomes the box around its densely sampled,
moved outline, a rotated one's corners move; clamped to the canvas as their ``clamping_mode`` says).
Tensors stay of their dtype and on their device, detached (no gradient flows back through the
deformation, where torchvision's own geometric transforms keep autograd's graph); the deformation
runs on glmls's OpenGL context, so a CUDA tensor goes through the host's memory.

A batch is an image tensor with leading dimensions, (N, C, H, W) or (N, ..., C, H, W) (a plain
tensor or an ``Image``; torchvision's own transforms take (..., C, H, W)): each sample draws its
own deformation (where torchvision's own transforms draw once for the whole batch), the
dimensions between N and C of a sample (a clip's frames) moving by its one draw. The inputs of a
call have one size (H, W), the ``canvas_size`` of boxes and keypoints too, as torchvision
requires, and are single images or one batch, else ``ValueError``; so is an unrotated box whose
maximum lies below its minimum (boxes of another format than their label, which the deformation
would make into plausible boxes). A batch's masks are (N, H, W) or (N, K, H, W) and its
keypoints (N, ..., 2) (the first dimension the batch; any number of them), or one
``Mask``/``KeyPoints``/``BoundingBoxes`` per sample in order (bounding boxes are two-dimensional
in torchvision: one instance per sample). A label's shape decides which: one whose first
dimension is N is the batch's, so a sample's own masks are (H, W), or (K, H, W) with K other
than N, and its own keypoints (P, 2), or (A, ..., 2) with A other than N. The draws of the
last call are in ``last_params`` (JSON-able dicts, see :class:`glmls.augment.AugmentResult`).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from ..gl.llvm import triton_would_crash


def check_import_order() -> None:
    """``ImportError`` where importing torchvision now would crash the process.

    torchvision imports triton (through ``torch._dynamo``), which carries an LLVM of its own;
    loaded into a process where Mesa's LLVM is already loaded (the llvmpipe OpenGL driver on
    a machine without a GPU driver), its start-up ends in a segmentation fault. Loaded first,
    both work, and glmls loads triton's library before it makes a GL context
    (:mod:`glmls.gl.llvm`); this error is left for a process in which something else loaded
    Mesa's LLVM first (a GL context that another library made).

    Raises
    ------
    ImportError
        Where triton is installed, its library not loaded, and another LLVM library is.

    Examples
    --------
    >>> from glmls.augment.torchvision import check_import_order
    >>> check_import_order()  # triton is loaded by now, or no LLVM is
    """
    if triton_would_crash():
        raise ImportError(
            "torchvision loads triton, whose LLVM crashes a process in which Mesa's LLVM "
            "(the llvmpipe OpenGL driver) is already loaded: import torchvision (or "
            "glmls.augment.torchvision) before the process makes its first OpenGL context"
        )


check_import_order()

import numpy as np  # noqa: E402
import PIL.Image  # noqa: E402
import torch  # noqa: E402
from torchvision import tv_tensors  # noqa: E402
from torchvision.transforms import v2  # noqa: E402
from torchvision.transforms.v2 import functional as F  # noqa: E402

from ..core.magnitudes import integer_background  # noqa: E402
from .core import Augment  # noqa: E402
from .labels import canvas_shape  # noqa: E402
from .presets import preset_from  # noqa: E402
from .replay import replay_boxes, replay_images, replay_labels, replay_masks  # noqa: E402
from .tensors import to_numpy  # noqa: E402

__all__ = ["MLSTransform", "check_import_order"]

_LABELS = (tv_tensors.Mask, tv_tensors.KeyPoints, tv_tensors.BoundingBoxes)


def _is_image(value: object) -> bool:
    return isinstance(value, PIL.Image.Image) or (
        isinstance(value, torch.Tensor) and not isinstance(value, _LABELS)
    )


def _is_label(value: object) -> bool:
    return isinstance(value, _LABELS)


def _size(value: object) -> tuple[int, int, int | None]:
    """(H, W, N): N the batch size of an image tensor of 4 dimensions or more (its first),
    None for one image (H, W) or (C, H, W), or a Video (one clip, its frames alike)."""
    if isinstance(value, PIL.Image.Image):
        return value.height, value.width, None
    tensor: torch.Tensor = value  # type: ignore[assignment]
    if tensor.ndim < 2:  # as torchvision refuses it
        raise ValueError(
            f"an image tensor has at least two dimensions, (H, W), (C, H, W) or "
            f"(N, ..., C, H, W); got shape {tuple(tensor.shape)}"
        )
    height, width = tensor.shape[-2:]
    if isinstance(tensor, tv_tensors.Video) or tensor.ndim <= 3:
        return height, width, None
    return height, width, tensor.shape[0]  # (N, ..., C, H, W): N samples


def _shown(size: tuple[int, int, int | None]) -> tuple[int, ...]:
    """(H, W), or (N, H, W) for a batch, as an error shows it."""
    height, width, batch = size
    return (height, width) if batch is None else (batch, height, width)


def _check_extents(boxes: tv_tensors.BoundingBoxes, xyxy: np.ndarray) -> None:
    """``ValueError`` for a box whose maximum lies below its minimum in x or y, naming it:
    boxes labelled with another format than theirs (XYWH read as XYXY), which a deformation
    would otherwise turn into a plausible box in silence; and for one that is not finite."""
    lost = np.flatnonzero(~np.isfinite(xyxy).all(axis=1))
    if len(lost):
        j = int(lost[0])
        raise ValueError(f"BoundingBoxes[{j}] {boxes[j].tolist()} holds values that are not finite")
    wrong = np.flatnonzero((xyxy[:, 2] < xyxy[:, 0]) | (xyxy[:, 3] < xyxy[:, 1]))
    if len(wrong):
        j = int(wrong[0])
        raise ValueError(
            f"BoundingBoxes[{j}] {boxes[j].tolist()} in {boxes.format.name} has a negative "
            "width or height: boxes in another format than the one they are labelled with?"
        )


def _nearest(samples: list[dict]) -> list[dict]:
    """The draws with nearest sampling (labels, a bilevel image's pixels)."""
    return [{**s, "options": {**s["options"], "interpolation": "nearest"}} for s in samples]


def _warpable(array: np.ndarray) -> np.ndarray:
    """An image as glmls warps it: bool as uint8, integers other than uint8 and uint16
    (int8 to int64, uint32, uint64: torchvision's transforms take them all) as float64."""
    if array.dtype.kind == "b":
        return array.astype(np.uint8)
    if array.dtype.kind == "i" or (array.dtype.kind == "u" and array.dtype.itemsize > 2):
        return array.astype(np.float64)
    return array


def _check_background(dtype: np.dtype, samples: list[dict]) -> None:
    """``ValueError`` where a draw's ``background`` is no value of an integer or bool image's
    own ``dtype``: :func:`_warpable` warps some of them in another dtype (bool as uint8,
    int16 as float64), whose rule would not be theirs (0.5 on int16, 2 on bool)."""
    if dtype.kind not in "biu":
        return
    for sample in samples:
        background = sample["options"].get("background", 0.0)
        values = np.asarray(background, dtype=np.float64).reshape(-1).tolist()
        integer_background(values, background, dtype)


def _of_dtype(out: np.ndarray, dtype: np.dtype) -> np.ndarray:
    """A warped image back in its dtype: integers rounded and clipped to their range, as
    torchvision's own transforms round the integer images they interpolate."""
    if out.dtype == dtype:
        return out
    if dtype.kind == "b":
        return out != 0
    info = np.iinfo(dtype)
    high = float(info.max)
    high = high if int(high) <= info.max else np.nextafter(high, 0.0)  # int64's 2**63 - 1
    return np.clip(np.rint(out), info.min, high).astype(dtype)


def _batch_first(label: torch.Tensor, count: int) -> bool:
    """Whether a Mask or KeyPoints is the batch's own, the batch its first dimension:
    (N, H, W) or (N, K, H, W) masks, (N, ..., 2) keypoints (KeyPoints take any leading
    dimensions: (N, P, 2), or (N, A, B, 2) for A skeletons of B points). Such a shape is
    read so, as torchvision reads a label's leading dimensions: a sample's own masks are
    (H, W), or (K, H, W) with K other than N."""
    if isinstance(label, tv_tensors.Mask):
        return label.ndim in (3, 4) and label.shape[0] == count
    return label.ndim >= 3 and label.shape[0] == count


def _batch_label_error(label: torch.Tensor, count: int) -> ValueError:
    """The error for a batch's one Mask or KeyPoints whose first dimension is not the
    batch's (it would split or merge the samples' labels)."""
    mask = isinstance(label, tv_tensors.Mask)
    expected = f"({count}, H, W) or ({count}, K, H, W)" if mask else f"({count}, ..., 2)"
    return ValueError(
        f"a {type(label).__name__} of shape {tuple(label.shape)} for a batch of {count} "
        f"images: expected {expected}, the batch first, or one per sample"
    )


def _empty(tensor: torch.Tensor, canvas: tuple[int, int]) -> torch.Tensor:
    """An empty ``tensor`` (no channels, no instance masks) on the output's ``canvas``, of
    its dtype and device."""
    shape = (*tensor.shape[:-2], *canvas)
    return torch.zeros(shape, dtype=tensor.dtype, device=tensor.device)


class MLSTransform(v2.Transform):
    """A random MLS deformation as a torchvision v2 transform.

    Parameters
    ----------
    preset : str, default "grid"
        A preset of :data:`glmls.augment.PRESETS`.
    warp_options : mapping or None, default None
        Keywords of :func:`glmls.warp_batch` over :data:`glmls.augment.DEFAULT_WARP_OPTIONS`.
    box_step : float, default 2.0
        Pixels between two points of a box's outline as it is moved.
    **preset_options
        The preset's options.

    Raises
    ------
    ValueError, TypeError
        As :class:`glmls.augment.Augment`; a ``TypeError`` for an option the preset does not
        take (``seed``: torch's random numbers draw; ``densify``, ``clip_polygons``:
        torchvision has no polygons).

    Examples
    --------
    >>> import torch
    >>> from torchvision import tv_tensors
    >>> from glmls.augment.torchvision import MLSTransform
    >>> _ = torch.manual_seed(0)
    >>> images = tv_tensors.Image(torch.zeros(4, 3, 24, 48, dtype=torch.uint8))
    >>> points = tv_tensors.KeyPoints(torch.full((4, 2, 2), 10.0), canvas_size=(24, 48))
    >>> out_images, out_points = MLSTransform("text-stretch")(images, points)
    >>> tuple(out_images.shape), type(out_points).__name__, tuple(out_points.shape)
    ((4, 3, 24, 48), 'KeyPoints', (4, 2, 2))
    """

    def __init__(
        self,
        preset: str = "grid",
        *,
        warp_options: Mapping[str, Any] | None = None,
        box_step: float = 2.0,
        **preset_options: Any,
    ) -> None:
        super().__init__()
        # the preset takes the options: Augment's own (seed, densify, clip_polygons) are not
        # this transform's (torch's random numbers draw; torchvision has no polygons)
        self.augment = Augment(
            preset_from(preset, preset_options), warp_options=warp_options, box_step=box_step
        )
        self.preset = preset
        self.last_params: list[dict] = []

    def extra_repr(self) -> str:
        """What the repr shows: the preset with its options, the warp options and box_step
        (not ``last_params``, the last call's handles).

        Returns
        -------
        str
            The text inside ``MLSTransform(...)``.

        Examples
        --------
        >>> from glmls.augment.torchvision import MLSTransform
        >>> MLSTransform("text-distort", segments=3).extra_repr()
        "preset=TextDistortPreset(segments=3, radius=None), warp_options={...}, box_step=2.0"
        """
        aug = self.augment
        return f"preset={aug.preset!r}, warp_options={aug.warp_options!r}, box_step={aug.box_step}"

    def make_params(self, flat_inputs: list[Any]) -> dict[str, Any]:
        """Draw each sample's handles from torch's random numbers.

        Parameters
        ----------
        flat_inputs : list
            The inputs to transform, as torchvision flattened them.

        Returns
        -------
        dict
            ``samples`` (the draws) and ``owners`` (which sample each input belongs to).

        Raises
        ------
        ValueError
            Without an image, for inputs of different sizes (H, W) (the ``canvas_size`` of
            boxes and keypoints too), single images with a batch, or a batch's labels that
            match neither the batch nor its samples.

        Examples
        --------
        >>> import torch
        >>> from glmls.augment.torchvision import MLSTransform
        >>> params = MLSTransform().make_params([torch.zeros(2, 3, 8, 8)])
        >>> len(params["samples"]), params["samples"][0]["shape"]
        (2, [8, 8])
        """
        images = [x for x in flat_inputs if _is_image(x)]
        if not images:
            raise ValueError("MLSTransform needs an image (tv_tensors.Image or a tensor)")
        sizes = [_size(x) for x in images]
        found = {tuple(F.get_size(x)) for x in flat_inputs if _is_image(x) or _is_label(x)}
        if len(found) > 1:  # as torchvision's own transforms refuse them
            raise ValueError(
                f"the inputs of one call have different sizes (H, W), "
                f"{', '.join(map(str, sorted(found)))} (the canvas_size of boxes and "
                "keypoints): every input of a call moves by the same deformation"
            )
        if len({s[2] is None for s in sizes}) > 1:
            found_shapes = ", ".join(sorted({str(_shown(s)) for s in sizes}))
            raise ValueError(
                f"single images and a batch in one call, {found_shapes}: give one batch "
                "(N, C, H, W) or single images"
            )
        if len({s[2] for s in sizes}) > 1:
            found_shapes = ", ".join(sorted({str(_shown(s)) for s in sizes}))
            raise ValueError(f"batches of different sizes in one call: {found_shapes}")
        height, width, batch = sizes[0]
        count = 1 if batch is None else batch
        # per input object, the owner of each of its places among the inputs in order: one
        # object given for several samples ([boxes] * N) moves with each of them in turn
        owners: dict[int, list[Any]] = {}

        def own(x: object, owner: Any) -> None:
            owners.setdefault(id(x), []).append(owner)

        for x in images:
            own(x, 0 if batch is None else "batch")
        for kind in _LABELS:
            labels = [x for x in flat_inputs if isinstance(x, kind)]
            if batch is None:  # one sample: every label of the call is its own
                for x in labels:
                    own(x, 0)
                continue
            # the batch's own labels (any number: a semantic and an instance mask), by their
            # shape; the others are the samples' own, one each in order
            ours = kind is not tv_tensors.BoundingBoxes
            rest = []
            for x in labels:
                if ours and _batch_first(x, count):
                    own(x, "batch")
                else:
                    rest.append(x)
            if count == 1 or len(rest) == count:
                for k, x in enumerate(rest):
                    own(x, k)
            elif len(rest) == 1 and ours:
                raise _batch_label_error(rest[0], count)
            elif rest:
                # torchvision's boxes are (B, 4): no batch dimension to offer
                other = "or ones with the batch as their first dimension" if ours else "in order"
                raise ValueError(
                    f"{len(rest)} {kind.__name__} for {count} samples: give one per sample, {other}"
                )
        shapes = [(height, width)] * count
        landmarks = None
        if self.augment.preset.name == "landmarks":
            landmarks = self._landmarks(flat_inputs, owners, count)
        indices = torch.randint(0, 2**62, (count,)).tolist()
        samples = self.augment.draw(shapes, indices=indices, landmarks=landmarks)
        self.last_params = samples
        return {"samples": samples, "owners": owners}

    @staticmethod
    def _landmarks(flat_inputs, owners, count) -> list[np.ndarray]:
        """Each sample's landmarks: all its KeyPoints but the NaN (missing) ones, in the
        order of the inputs."""
        marks: list[list[np.ndarray]] = [[] for _ in range(count)]
        seen: dict[int, int] = {}  # the places of each object taken so far
        for x in flat_inputs:
            if isinstance(x, tv_tensors.KeyPoints):
                points = to_numpy(x).astype(np.float64)
                place = seen.get(id(x), 0)
                seen[id(x)] = place + 1
                owner = owners[id(x)][place]
                if owner == "batch":
                    for k, p in enumerate(points.reshape(count, -1, 2)):
                        marks[k].append(p)
                else:
                    marks[owner].append(points.reshape(-1, 2))
        if any(not m for m in marks):
            raise ValueError("the landmarks preset needs KeyPoints for every sample")
        joined = [np.concatenate(m) for m in marks]
        # a NaN landmark is a missing one: no handle (it comes back NaN, as it came)
        return [m[~np.isnan(m).any(axis=1)] for m in joined]

    @staticmethod
    def _owner(inpt: Any, params: dict[str, Any]) -> int | str:
        """The sample (or ``"batch"``) that this place of ``inpt`` belongs to: torchvision
        transforms the inputs in the order :meth:`make_params` saw them, so an object given
        at several places takes their owners in turn (the last one stays)."""
        places = params["owners"][id(inpt)]
        return places.pop(0) if len(places) > 1 else places[0]

    def transform(self, inpt: Any, params: dict[str, Any]) -> Any:
        """Deform one input with the draw of the sample it belongs to.

        Parameters
        ----------
        inpt : object
            An image, mask, keypoints or bounding boxes.
        params : dict
            What :meth:`make_params` returned.

        Returns
        -------
        object
            The input deformed, of its type, dtype and device.

        Examples
        --------
        >>> import torch
        >>> from torchvision import tv_tensors
        >>> from glmls.augment.torchvision import MLSTransform
        >>> t = MLSTransform(displacement=0)
        >>> mask = tv_tensors.Mask(torch.ones(8, 8, dtype=torch.uint8))
        >>> params = t.make_params([torch.zeros(3, 8, 8), mask])
        >>> int(t.transform(mask, params).sum())
        64
        """
        owner = self._owner(inpt, params)
        samples = params["samples"] if owner == "batch" else [params["samples"][owner]]
        if not samples:  # an empty batch (0, C, H, W): empty out, as torchvision's own give
            return self._nothing(inpt)
        if isinstance(inpt, tv_tensors.Mask):
            return tv_tensors.wrap(self._masks(inpt, samples), like=inpt)
        canvas = canvas_shape(samples[0])  # the output's size: output_shape, else the input's
        if isinstance(inpt, tv_tensors.KeyPoints):
            return tv_tensors.wrap(self._keypoints(inpt, samples), like=inpt, canvas_size=canvas)
        if isinstance(inpt, tv_tensors.BoundingBoxes):
            try:
                boxes = self._boxes(inpt, samples[0])
            except ValueError as error:  # a sample's own boxes: which sample's
                several = len(params["samples"]) > 1
                raise ValueError(f"sample {owner}'s {error}" if several else str(error)) from None
            return tv_tensors.wrap(boxes, like=inpt, canvas_size=canvas)
        if isinstance(inpt, PIL.Image.Image):
            return self._pil(inpt, samples)
        return self._images(inpt, samples)

    def _nothing(self, inpt: torch.Tensor) -> torch.Tensor:
        """An input of an empty batch, empty on the output's canvas (``output_shape``, else
        its own size): images and masks reshaped, keypoints and boxes with that
        ``canvas_size``, of their type, dtype and device."""
        size = tuple(F.get_size(inpt))
        canvas = canvas_shape({"options": self.augment.warp_options, "shape": size})
        if isinstance(inpt, (tv_tensors.KeyPoints, tv_tensors.BoundingBoxes)):
            return tv_tensors.wrap(inpt.as_subclass(torch.Tensor).clone(), like=inpt,
                                   canvas_size=canvas)  # fmt: skip
        out = _empty(inpt, canvas)
        return tv_tensors.wrap(out, like=inpt) if isinstance(inpt, tv_tensors.TVTensor) else out

    def _pil(self, image: PIL.Image.Image, samples: list[dict]) -> PIL.Image.Image:
        """A PIL image deformed, in its mode (a palette image's indices and a bilevel image's
        pixels with nearest sampling, the palette kept; 32-bit integers through float64)."""
        array = np.asarray(image)
        _check_background(array.dtype, samples)
        if image.mode in ("P", "PA", "1"):  # indices, or a bilevel image's bools: labels
            samples = _nearest(samples)
        out = np.asarray(self.augment.replay([_warpable(array)], samples).images[0])
        out = _of_dtype(out, array.dtype)
        if image.mode == "1":
            return PIL.Image.fromarray(out)
        size = (out.shape[1], out.shape[0])  # (W, H) of the output's canvas
        result = PIL.Image.frombytes(image.mode, size, np.ascontiguousarray(out).tobytes())
        if image.mode in ("P", "PA"):
            result.putpalette(image.getpalette())
        return result

    def _images(self, images: torch.Tensor, samples: list[dict]) -> torch.Tensor:
        channels = 1 if images.ndim == 2 else images.shape[-3]
        if channels == 0:  # no channels: nothing to warp, empty on the output's canvas
            out = _empty(images, canvas_shape(samples[0]))
            return (
                tv_tensors.wrap(out, like=images)
                if isinstance(images, tv_tensors.TVTensor)
                else out
            )
        frames = images.reshape(-1, channels, *images.shape[-2:])  # a video's frames, one draw
        draws = [s for s in samples for _ in range(len(frames) // len(samples))]
        array = np.moveaxis(to_numpy(frames), 1, -1)
        _check_background(array.dtype, draws)
        if array.dtype.kind == "b":  # a bilevel image, as PIL's mode "1"
            draws = _nearest(draws)
        out = replay_images(self.augment, np.ascontiguousarray(_warpable(array)), draws)
        out = _of_dtype(out, array.dtype)
        tensor = torch.from_numpy(np.ascontiguousarray(np.moveaxis(out, -1, 1)))
        tensor = tensor.reshape(*images.shape[:-2], *tensor.shape[-2:])
        tensor = tensor.to(device=images.device, dtype=images.dtype)
        return (
            tv_tensors.wrap(tensor, like=images)
            if isinstance(images, tv_tensors.TVTensor)
            else tensor
        )

    def _masks(self, masks: torch.Tensor, samples: list[dict]) -> torch.Tensor:
        count = len(samples)
        height, width = masks.shape[-2:]
        if masks.numel() == 0:  # (0, H, W): a sample without instances
            return _empty(masks, canvas_shape(samples[0]))
        array = to_numpy(masks).reshape(count, -1, height, width)
        layers = array.shape[1]
        draws = [s for s in samples for _ in range(layers)]
        out = replay_masks(self.augment, draws, array.reshape(count * layers, height, width))
        tensor = torch.from_numpy(out.reshape(*masks.shape[:-2], *out.shape[-2:]))
        return tensor.to(device=masks.device, dtype=masks.dtype)  # float16 went as float32

    def _keypoints(self, points: torch.Tensor, samples: list[dict]) -> torch.Tensor:
        count = len(samples)
        array = to_numpy(points).astype(np.float64).reshape(count, -1, 2)
        # a NaN point (a missing landmark's usual mark) stays NaN, as torchvision's own
        # transforms carry it; the deformation moves the others
        missing = np.isnan(array).any(axis=-1)
        array = np.where(missing[..., None], 0.0, array)
        moved = np.asarray(replay_labels(self.augment, samples, keypoints=array).keypoints)
        moved = np.where(missing[..., None], np.nan, moved)
        tensor = torch.from_numpy(moved.reshape(points.shape))
        return tensor.to(device=points.device, dtype=points.dtype)

    def _boxes(self, boxes: tv_tensors.BoundingBoxes, sample: dict) -> torch.Tensor:
        """Unrotated boxes: the box around the moved outline; rotated ones: their corners
        moved (a quadrilateral, in XYXYXYXY); clamped as their ``clamping_mode`` says. No box
        (an image without objects; ``torch.tensor([])`` makes shape (1, 0)): the tensor as it
        is, as torchvision's own transforms pass it."""
        if boxes.numel() == 0:
            return boxes.as_subclass(torch.Tensor).clone()
        rotated = tv_tensors.is_rotated_bounding_format(boxes.format)
        middle = (
            tv_tensors.BoundingBoxFormat.XYXYXYXY if rotated else tv_tensors.BoundingBoxFormat.XYXY
        )
        given = F.convert_bounding_box_format(  # integer boxes through float, as torchvision's
            boxes.as_subclass(torch.Tensor).double(), old_format=boxes.format, new_format=middle
        )
        array = to_numpy(given).astype(np.float64) - 0.5  # pixel centres at integers
        if rotated:
            corners = [array.reshape(-1, 2)]
            moved = np.asarray(
                replay_labels(self.augment, [sample], keypoints=corners).keypoints[0]
            )
            moved = moved.reshape(-1, 8) + 0.5
        else:
            _check_extents(boxes, array)
            moved = replay_boxes(self.augment, [sample], [array])[0] + 0.5
        out = F.clamp_bounding_boxes(  # as the boxes' clamping_mode says (None: not at all)
            torch.from_numpy(moved),
            format=middle,
            canvas_size=canvas_shape(sample),
            clamping_mode=boxes.clamping_mode,
        )
        out = F.convert_bounding_box_format(out, old_format=middle, new_format=boxes.format)
        return out.to(device=boxes.device, dtype=boxes.dtype)  # in their format, then their dtype
