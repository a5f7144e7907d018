"""An albumentations ``DualTransform`` of :class:`glmls.augment.Augment`:
``pip install 'glmls[albumentations]'`` (albumentations 2.0 and newer).

This module imports albumentations; :mod:`glmls.augment` does not import this module.

``MLSDeform`` follows albumentations' contract: its random draw comes from the transform's
``random_generator`` (seeded by ``A.Compose(..., seed=...)``), the draw is in the params
(``get_applied_params()``, a JSON-able dict under ``"mls"``), and every target of one call
goes through the same map: the image (and ``images``, of any number of channels), masks
(nearest, never a mixed label), keypoints (x, y moved; angle and scale kept, as
albumentations' own distortions ``GridDistortion``, ``ElasticTransform`` and
``ThinPlateSpline`` keep them) and bounding boxes (the box around the densely sampled, moved
outline, left unclipped for albumentations to clip, so that ``min_visibility`` sees what a
deformation pushed out of the image).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import albumentations as A
import numpy as np

from ..batch.inputs import check_batch_image, check_coordinates, check_points
from ..core.config import check_real
from .core import Augment
from .labels import canvas_shape
from .params import check_params
from .presets import preset_from
from .replay import replay_boxes, replay_images, replay_labels, replay_masks

__all__ = ["MLSDeform"]


class MLSDeform(A.DualTransform):
    """A random MLS deformation as an albumentations transform.

    Parameters
    ----------
    preset : str, default "grid"
        A preset of :data:`glmls.augment.PRESETS`.
    preset_options : mapping or None, default None
        The preset's options (``{"rows": 5, "displacement": 0.05}``).
    warp_options : mapping or None, default None
        Keywords of :func:`glmls.warp_batch` over :data:`glmls.augment.DEFAULT_WARP_OPTIONS`.
    box_step : float, default 2.0
        Pixels between two points of a box's outline as it is moved.
    p : float, default 1.0
        The probability of applying the transform.

    Raises
    ------
    ValueError, TypeError
        As :class:`glmls.augment.Augment`; a ``TypeError`` for ``preset_options`` or
        ``warp_options`` that are not mappings, ``preset_options`` that the preset does not
        take (``seed``: the transform's random generator draws), or a ``p`` that is not a
        real number (a bool, a string), a ``ValueError`` for a ``p`` outside [0, 1].

    Examples
    --------
    >>> import albumentations as A
    >>> import numpy as np
    >>> from glmls.augment.albumentations import MLSDeform
    >>> compose = A.Compose(
    ...     [MLSDeform("text-distort")],
    ...     keypoint_params=A.KeypointParams(format="xy"),
    ...     seed=0,
    ... )
    >>> image = np.zeros((32, 96, 3), np.uint8)
    >>> out = compose(image=image, keypoints=[(48.0, 16.0)])
    >>> out["image"].shape, len(out["keypoints"])
    ((32, 96, 3), 1)
    """

    def __init__(
        self,
        preset: str = "grid",
        preset_options: Mapping[str, Any] | None = None,
        warp_options: Mapping[str, Any] | None = None,
        box_step: float = 2.0,
        p: float = 1.0,
    ) -> None:
        # p as glmls takes a real option (albumentations' own check would take True, "0.5")
        p = check_real("p", p, low=0, high=1, what="a probability from 0 to 1")
        super().__init__(p=p)
        for name, value in (("preset_options", preset_options), ("warp_options", warp_options)):
            if value is not None and not isinstance(value, Mapping):
                raise TypeError(f"{name} must be a mapping or None, got {value!r}")
        self.preset = preset
        self.preset_options = dict(preset_options or {})
        self.warp_options = None if warp_options is None else dict(warp_options)
        # the preset takes preset_options: Augment's own keywords (seed, densify...) are none
        self.augment = Augment(
            preset_from(preset, self.preset_options), warp_options=warp_options, box_step=box_step
        )
        self.box_step = self.augment.box_step

    def get_transform_init_args_names(self) -> tuple[str, ...]:
        """The arguments that rebuild the transform (albumentations' serialisation).

        Returns
        -------
        tuple of str
            ``("preset", "preset_options", "warp_options", "box_step")``.

        Examples
        --------
        >>> from glmls.augment.albumentations import MLSDeform
        >>> MLSDeform().get_transform_init_args_names()
        ('preset', 'preset_options', 'warp_options', 'box_step')
        """
        return ("preset", "preset_options", "warp_options", "box_step")

    @property
    def targets_as_params(self) -> list[str]:
        """The targets the draw depends on: the ``landmarks`` preset's keypoints.

        albumentations refuses a call without them (a ``ValueError`` naming them): the
        landmarks preset moves the keypoints it is given, and without them would move
        nothing.

        Returns
        -------
        list of str
            ``["keypoints"]`` for the ``landmarks`` preset, else ``[]``.

        Examples
        --------
        >>> from glmls.augment.albumentations import MLSDeform
        >>> MLSDeform("landmarks").targets_as_params, MLSDeform("grid").targets_as_params
        (['keypoints'], [])
        """
        return ["keypoints"] if self.augment.preset.name == "landmarks" else []

    def get_params_dependent_on_data(
        self, params: dict[str, Any], data: dict[str, Any]
    ) -> dict[str, Any]:
        """Draw the handles for this call's image.

        Parameters
        ----------
        params : dict
            albumentations' params (``shape`` among them).
        data : dict
            The call's targets (``keypoints``: the ``landmarks`` preset's handles).

        Returns
        -------
        dict
            ``{"mls": draw}``, the draw a JSON-able dict (see
            :class:`glmls.augment.AugmentResult`).

        Examples
        --------
        >>> import numpy as np
        >>> from glmls.augment.albumentations import MLSDeform
        >>> t = MLSDeform(preset_options={"rows": 2, "cols": 2})
        >>> t.set_random_seed(0)
        >>> draw = t.get_params_dependent_on_data({"shape": (8, 8, 3)}, {})["mls"]
        >>> draw["preset"], len(draw["src"])
        ('grid', 4)
        """
        shape = tuple(params["shape"][:2])
        index = int(self.random_generator.integers(0, 2**63 - 1))
        landmarks = None
        if self.augment.preset.name == "landmarks":
            points = np.asarray(data["keypoints"], np.float64)
            points = points.reshape(-1, points.shape[-1] if points.size else 2)[:, :2]
            landmarks = [points[~np.isnan(points).any(axis=1)]]  # a NaN one is missing
        return {"mls": self.augment.draw([shape], indices=[index], landmarks=landmarks)[0]}

    def apply(self, img: np.ndarray, mls: dict, **params: Any) -> np.ndarray:
        """The image deformed.

        Parameters
        ----------
        img : numpy.ndarray
            (H, W) or (H, W, C), any C (more than 4 go through the map in groups of 4).
        mls : dict
            The draw.
        **params
            albumentations' other params (not used).

        Returns
        -------
        numpy.ndarray
            The deformed image.

        Examples
        --------
        >>> import numpy as np
        >>> from glmls.augment.albumentations import MLSDeform
        >>> t = MLSDeform()
        >>> t.set_random_seed(0)
        >>> image = np.zeros((16, 16), np.uint8)
        >>> draw = t.get_params_dependent_on_data({"shape": image.shape}, {})
        >>> t.apply(image, **draw).shape
        (16, 16)
        """
        _check_image(img, "image")  # as albumentations names it, not as a batch's item
        return replay_images(self.augment, img[None], [mls])[0]

    def apply_to_mask(self, mask: np.ndarray, mls: dict, **params: Any) -> np.ndarray:
        """A mask deformed with nearest sampling (0 where nothing is shown).

        Parameters
        ----------
        mask : numpy.ndarray
            (H, W) or (H, W, C) labels (integers, bool or floating point; C may be 0).
        mls : dict
            The draw.
        **params
            albumentations' other params (not used).

        Returns
        -------
        numpy.ndarray
            The deformed mask, of its dtype.

        Examples
        --------
        >>> import numpy as np
        >>> from glmls.augment.albumentations import MLSDeform
        >>> t = MLSDeform()
        >>> t.set_random_seed(0)
        >>> mask = np.full((16, 16), 3, np.uint8)
        >>> draw = t.get_params_dependent_on_data({"shape": mask.shape}, {})
        >>> sorted(np.unique(t.apply_to_mask(mask, **draw)).tolist())
        [3]
        """
        layers = mask[..., None] if mask.ndim == 2 else mask
        if layers.shape[2] == 0:  # no layers (no instances): none on the output's canvas
            return np.zeros((*canvas_shape(mls), 0), mask.dtype)
        out = replay_masks(self.augment, [mls] * layers.shape[2], np.moveaxis(layers, 2, 0))
        out = np.moveaxis(out, 0, 2)
        return out[..., 0] if mask.ndim == 2 else out

    def apply_to_keypoints(self, keypoints: np.ndarray, mls: dict, **params: Any) -> np.ndarray:
        """Keypoints moved (x, y; the other columns kept; a NaN one stays NaN).

        Parameters
        ----------
        keypoints : numpy.ndarray
            (K, 2+) keypoints, x and y first.
        mls : dict
            The draw.
        **params
            albumentations' other params (not used).

        Returns
        -------
        numpy.ndarray
            The moved keypoints.

        Examples
        --------
        >>> import numpy as np
        >>> from glmls.augment.albumentations import MLSDeform
        >>> t = MLSDeform(preset_options={"displacement": 0})
        >>> t.set_random_seed(0)
        >>> draw = t.get_params_dependent_on_data({"shape": (16, 16)}, {})
        >>> t.apply_to_keypoints(np.array([[4.0, 5.0, 0.0, 1.0]]), **draw).round(3).tolist()
        [[4.0, 5.0, 0.0, 1.0]]
        """
        if len(keypoints) == 0:
            return keypoints
        # moved points are fractions of pixels: integer keypoints come back as float64
        floating = np.issubdtype(np.asarray(keypoints).dtype, np.floating)
        out = np.array(keypoints, dtype=None if floating else np.float64, copy=True)
        points = np.asarray(keypoints[:, :2], np.float64)
        # a NaN keypoint (a missing one) stays NaN, as albumentations' affine transforms
        # carry it; the deformation moves the others
        missing = np.isnan(points).any(axis=1)
        # checked here, as rows of this image's keypoints (replay_labels's messages would
        # name the image's place in a batch of one)
        points = check_points(np.where(missing[:, None], 0.0, points), "keypoints", rows="K")
        moved = np.asarray(replay_labels(self.augment, [mls], keypoints=[points]).keypoints[0])
        out[:, :2] = np.where(missing[:, None], np.nan, moved)
        return out

    def apply_to_bboxes(self, bboxes: np.ndarray, mls: dict, **params: Any) -> np.ndarray:
        """Boxes around their moved outlines (albumentations clips them and filters them).

        Parameters
        ----------
        bboxes : numpy.ndarray
            (B, 4+) boxes in albumentations' normalised ``(x_min, y_min, x_max, y_max)``.
        mls : dict
            The draw.
        **params
            albumentations' other params (not used).

        Returns
        -------
        numpy.ndarray
            The moved boxes, normalised, the other columns kept; not clipped (albumentations
            clips them, and its ``min_visibility`` compares them with what is left).

        Examples
        --------
        >>> import numpy as np
        >>> from glmls.augment.albumentations import MLSDeform
        >>> t = MLSDeform(preset_options={"displacement": 0})
        >>> t.set_random_seed(0)
        >>> draw = t.get_params_dependent_on_data({"shape": (10, 10)}, {})
        >>> t.apply_to_bboxes(np.array([[0.1, 0.2, 0.5, 0.6]]), **draw).round(3).tolist()
        [[0.1, 0.2, 0.5, 0.6]]
        """
        if len(bboxes) == 0:
            return bboxes
        height, width = check_params([mls], 1)[0]["shape"]
        scale = np.array([width, height, width, height], np.float64)
        boxes = np.asarray(bboxes[:, :4], np.float64) * scale - 0.5  # pixel centres at integers
        boxes = check_coordinates(boxes, "bboxes")  # rows of this image's boxes
        moved = replay_boxes(self.augment, [mls], [boxes])[0]
        out = np.array(bboxes, np.float64, copy=True)
        height, width = canvas_shape(mls)  # fractions of the output's size (output_shape)
        out[:, :4] = (np.asarray(moved) + 0.5) / np.array([width, height, width, height])
        # normalised boxes are fractions: an integer dtype would truncate them to 0 or 1
        floating = np.issubdtype(np.asarray(bboxes).dtype, np.floating)
        return out.astype(bboxes.dtype) if floating else out


def _check_image(image: np.ndarray, name: str) -> None:
    """``ValueError``/``TypeError`` naming ``name`` for an image the batch would refuse (more
    than 4 channels go through in groups of 4: the first group stands for them)."""
    array = np.asarray(image)
    if array.ndim == 3 and array.shape[2] == 0:
        raise ValueError(f"{name} has shape {array.shape}: no channels")
    check_batch_image(array[..., :4] if array.ndim == 3 else array, name)
    if array.dtype.kind == "f" and not np.isfinite(array).all():
        raise ValueError(f"{name} holds values that are not finite (NaN or inf)")
