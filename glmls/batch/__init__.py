"""Batches of images warped together on the GPU: :func:`warp_batch` and its
:class:`BatchResult` (images, keypoints, masks, maps)."""

from .result import BatchResult
from .run import warp_batch

__all__ = ["BatchResult", "warp_batch"]
