"""Volumes on their way to the GPU: validation, the 3D texture they are uploaded as, the image
format of the output slabs, the background, and the conversion back to the caller's form.

Every dtype keeps its values exactly: uint8 and uint16 volumes are integer textures (R8UI,
R16UI, ...), read with ``texelFetch`` (no normalisation, no hardware filtering: trilinear
interpolation is done in float32 in the shader), float32 volumes are R32F textures; float64
volumes are computed as float32 and returned as float64. Float volumes of extreme magnitude
reach the GPU divided by a power of two, as images do (:mod:`glmls.core.magnitudes`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.magnitudes import (
    integer_background,
    scaled_background,
    scaled_down,
    scaled_up,
    value_exponent,
)
from ..errors import DtypeError
from ..files.volumes import Volume
from ..imaging.source import as_float32

__all__ = [
    "VOLUME_DTYPES",
    "SourceVolume",
    "check_volume",
    "prepare_volume",
    "volume_background",
]

#: The dtypes :func:`glmls.volume.warp_volume` takes (float64 is computed as float32).
VOLUME_DTYPES = (np.uint8, np.uint16, np.float32, np.float64)

#: dtype -> (moderngl texture dtype, GLSL image format stem, integer texture?)
_FORMATS = {
    np.dtype(np.uint8): ("u1", "8ui", True),
    np.dtype(np.uint16): ("u2", "16ui", True),
    np.dtype(np.float32): ("f4", "32f", False),
    np.dtype(np.float64): ("f4", "32f", False),
}
_STEMS = {1: "r", 2: "rg", 3: "rgba", 4: "rgba"}  # image load/store has no 3-channel format


def check_volume(volume: object, name: str = "volume") -> np.ndarray:
    """``volume`` as an array, D x H x W or D x H x W x C (C in 1..4), of a dtype of
    :data:`VOLUME_DTYPES` (in either byte order: a big-endian one becomes native), not
    empty; ``TypeError``/``ValueError`` naming it as ``name``."""
    if isinstance(volume, Volume):
        raise TypeError(
            f"{name} is a glmls.Volume: warp its .data (and give its spacing to the MLS, "
            "glmls.MLS(..., spacing=volume.spacing), for handles in its physical units)"
        )
    array = np.asarray(volume)
    if not array.dtype.isnative and array.dtype.newbyteorder("=") in VOLUME_DTYPES:
        array = array.astype(array.dtype.newbyteorder("="))  # big-endian: the native dtype
    if array.dtype not in VOLUME_DTYPES:
        names = ", ".join(np.dtype(d).name for d in VOLUME_DTYPES)
        hint = ""
        if array.dtype.kind in "biuf":  # int16 (CT), int32, bool, float16...: as float32
            hint = (
                f" (warp {name}.astype(np.float32), which holds every value up to 2**24 "
                "exactly, and round the result back to your dtype, as glmls warp does)"
            )
        raise DtypeError(f"{name} dtype must be one of {names}; got {array.dtype}{hint}")
    if array.ndim == 2:
        raise ValueError(
            f"{name} of shape {array.shape} is a 2D image; a 3D MLS ((N, 3) handles) "
            "warps volumes D x H x W or D x H x W x C: give (N, 2) handles for images"
        )
    if array.ndim not in (3, 4) or (array.ndim == 4 and not 1 <= array.shape[3] <= 4):
        raise ValueError(
            f"{name} must be D x H x W or D x H x W x C with C in 1..4, got {array.shape}"
        )
    if array.size == 0:
        raise ValueError(f"{name} is empty: shape {array.shape}")
    return array


@dataclass(frozen=True)
class SourceVolume:
    """A volume prepared for the GPU: (D, H, W, C) data of a texture dtype, and what to
    restore."""

    data: np.ndarray
    dtype: np.dtype
    squeeze: bool  # the input was (D, H, W)
    #: ``data`` is the volume divided by 2**exponent
    #: (:func:`~glmls.core.magnitudes.value_exponent`).
    exponent: int = 0

    @property
    def shape(self) -> tuple[int, int, int]:
        """(D, H, W)."""
        d, h, w = self.data.shape[:3]
        return int(d), int(h), int(w)

    @property
    def channels(self) -> int:
        return int(self.data.shape[3])

    @property
    def integer(self) -> bool:
        """Held in an integer texture (uint8, uint16)."""
        return _FORMATS[self.dtype][2]

    @property
    def texture_dtype(self) -> str:
        """moderngl's dtype of the source texture and of the output slabs."""
        return _FORMATS[self.dtype][0]

    @property
    def target_components(self) -> int:
        """Components of the output slab texture (3 channels are stored as 4)."""
        return 4 if self.channels == 3 else self.channels

    @property
    def image_format(self) -> str:
        """The GLSL image format of the output slab texture, e.g. ``r16ui``."""
        return _STEMS[self.channels] + _FORMATS[self.dtype][1]

    @property
    def voxel_bytes(self) -> int:
        """Bytes of one voxel of the output slab texture."""
        return self.target_components * np.dtype(self.data.dtype).itemsize

    def empty_output(self, shape: tuple[int, int, int]) -> np.ndarray:
        """The output array of ``shape`` (D, H, W) in the caller's dtype and channels."""
        full = (*shape, self.channels)
        return np.empty(full, self.dtype)

    def view(self, out: np.ndarray) -> np.ndarray:
        """``out`` (D, H, W, C), of :meth:`empty_output` and filled with the GPU's values, as
        the caller's form: multiplied back by 2**exponent (in place)."""
        out = scaled_up(out, self.exponent)
        return out[..., 0] if self.squeeze else out


def prepare_volume(volume: object) -> SourceVolume:
    """Validate a volume (:func:`check_volume`) as (D, H, W, C), contiguous, in the dtype of
    its texture (float64 as float32; the others not copied where already contiguous), a
    float volume of extreme magnitude divided by a power of two
    (:func:`~glmls.core.magnitudes.value_exponent`)."""
    array = check_volume(volume)
    squeeze = array.ndim == 3
    data = array[..., None] if squeeze else array
    dtype = np.dtype(array.dtype)
    exponent = value_exponent(data)
    data = scaled_down(data, exponent, np.float32 if dtype.kind == "f" else None)
    if dtype == np.float64:
        return SourceVolume(as_float32(data, "volume"), dtype, squeeze, exponent)
    return SourceVolume(np.ascontiguousarray(data), dtype, squeeze, exponent)


def volume_background(background: object, volume: SourceVolume) -> tuple[float, ...]:
    """The value of uncovered voxels as 4 floats: ``background`` is a scalar (every channel)
    or one value per channel, divided as the volume is by 2**exponent; ``ValueError`` for
    another count, a value outside an integer dtype's range, or a finite one float32 cannot
    hold beside the volume's values (:func:`~glmls.core.magnitudes.scaled_background`)."""
    channels = volume.channels
    values = np.asarray(background, dtype=np.float64)
    if values.ndim == 0:
        values = np.full(channels, float(values))
    if values.ndim != 1 or len(values) != channels:
        raise ValueError(
            f"background must be a scalar or {channels} value{'s' if channels > 1 else ''} "
            f"(one per channel), got {background!r}"
        )
    if np.issubdtype(volume.dtype, np.integer):
        out = integer_background([float(v) for v in values], background, volume.dtype)
    else:
        out = scaled_background(
            [float(v) for v in values], background, volume.dtype, volume.exponent
        )
    return (*out, *[0.0] * (4 - len(out)))
