"""What :func:`glmls.warp_batch` returns when labels or maps are asked for."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.summary import fields_repr

__all__ = ["BatchResult"]


@dataclass(frozen=True, repr=False)
class BatchResult:
    """The warped images of a batch with their labels and maps.

    Each field is an array with the batch's leading dimension N, or a list of N arrays in
    the order of the input; None where it was not asked for: ``images`` an array where the
    input images have one shape, dtype and channel count; ``keypoints`` and
    ``keypoints_valid`` where each image has as many keypoints; ``masks``, ``maps`` and
    ``valid`` where the N arrays have one shape and dtype (every output canvas one height
    and width, the masks one dtype), whatever the images' dtypes and channels. Printed, it
    shows each field's shape and dtype, not its values.

    Parameters
    ----------
    images : numpy.ndarray or list of numpy.ndarray
        The warped images, (N, H, W) or (N, H, W, C), each of its input's dtype and channels.
    keypoints : numpy.ndarray or list of numpy.ndarray or None
        (N, P, 2) float64 output points (x, y) of the ``keypoints`` asked for: where each
        source point lands on the output canvas.
    keypoints_valid : numpy.ndarray or list of numpy.ndarray or None
        (N, P) bool: the point lands on the canvas, inside the warped image (with the
        ``constant`` border; with the other borders the image's surroundings count too), the
        output pixel nearest it shows the image, and the point shows there with its pixel's
        footprint whole (no other part of the image folds over it or over part of that
        footprint, and the map neither folds inside the footprint nor bends strongly
        across it).
    masks : numpy.ndarray or list of numpy.ndarray or None
        (N, H, W) label images warped with nearest sampling, of the input masks' dtype (0
        where nothing is shown).
    maps : numpy.ndarray or list of numpy.ndarray or None
        (N, H, W, 2) float32: for each output pixel the source point (x, y) it shows (the
        convention of :meth:`glmls.MLS.coordinate_map`); for ``splat`` and ``paper-quads``
        f's inverse there, whose nearest source pixel is not always the one that their
        forward pass drew. A pixel that shows nothing (not ``valid``, with the ``constant``
        border) holds no source point of the image: (0, 0) for ``quads`` on the regular
        mesh where no cell covers the pixel, Newton's last iterate for the backward
        methods.
    valid : numpy.ndarray or list of numpy.ndarray or None
        (N, H, W) bool: the output pixels that some source pixel covers (with ``maps``);
        not those that show a border mode's copies past the source image.
    params : object or None
        Per-sample parameters that a caller attaches (e.g. the random draws of an
        augmentation); :func:`glmls.warp_batch` leaves it None.

    Examples
    --------
    >>> import numpy as np
    >>> import glmls
    >>> images = np.zeros((2, 8, 8), np.uint8)
    >>> src = np.array([[[1.0, 1.0], [6.0, 6.0]]] * 2)
    >>> out = glmls.warp_batch(images, src, src + 1, keypoints=[[[2.0, 3.0]]] * 2)
    >>> out.images.shape, out.keypoints.shape, out.masks is None
    ((2, 8, 8), (2, 1, 2), True)
    >>> len(out)
    2
    >>> repr(out)[:54]
    'BatchResult(images=array((2, 8, 8), uint8), keypoints='
    """

    images: np.ndarray | list[np.ndarray]
    keypoints: np.ndarray | list[np.ndarray] | None = None
    keypoints_valid: np.ndarray | list[np.ndarray] | None = None
    masks: np.ndarray | list[np.ndarray] | None = None
    maps: np.ndarray | list[np.ndarray] | None = None
    valid: np.ndarray | list[np.ndarray] | None = None
    params: object = None

    def __len__(self) -> int:
        """The number of images N."""
        return len(self.images)

    def __repr__(self) -> str:
        """The fields' shapes and dtypes (and lists' lengths), not their values."""
        return fields_repr(self)
