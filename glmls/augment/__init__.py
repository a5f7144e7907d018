"""Data augmentation by random MLS deformations, with the labels moved along.

:class:`Augment` deforms a batch at random, each sample reproducibly from ``(seed, index)``,
through :func:`glmls.warp_batch`: a jittered control grid, Luo et al.'s text-line
deformations (distortion, stretching, perspective) or each image's landmarks moved. Keypoints,
masks, bounding boxes and polygons go through the same map that placed the pixels.

The adapters for other libraries are modules of their own, imported only when used:
``glmls.augment.albumentations`` (:class:`~glmls.augment.albumentations.MLSDeform`, an
albumentations ``DualTransform``, ``pip install 'glmls[albumentations]'``) and
``glmls.augment.torchvision`` (:class:`~glmls.augment.torchvision.MLSTransform`, a
torchvision v2 ``Transform``, ``pip install 'glmls[torch]'``). :class:`Augment` itself
takes and gives torch tensors too, in torch's layout, of their dtype and on their device
(:doc:`the guide </augment>`, "torch tensors, torchvision and albumentations").
"""

from .core import DEFAULT_WARP_OPTIONS, Augment, AugmentResult
from .labels import box_outlines, boxes_from_outlines, clip_polygon, densify_polygon
from .presets import (
    MAX_HANDLES,
    PRESETS,
    GridPreset,
    LandmarksPreset,
    TextDistortPreset,
    TextPerspectivePreset,
    TextStretchPreset,
)

__all__ = [
    "DEFAULT_WARP_OPTIONS",
    "MAX_HANDLES",
    "PRESETS",
    "Augment",
    "AugmentResult",
    "GridPreset",
    "LandmarksPreset",
    "TextDistortPreset",
    "TextPerspectivePreset",
    "TextStretchPreset",
    "box_outlines",
    "boxes_from_outlines",
    "clip_polygon",
    "densify_polygon",
]
