"""Images on their way to the GPU: validation, the form they are uploaded in, the background
of uncovered pixels, and the conversion back to the caller's dtype and shape.

uint8 images stay 8-bit: an RGBA8 texture sampled as value / 255, an RGBA8 target and a uint8
read-back (:attr:`SourceImage.normalized`); other dtypes go through float32 (raw values).
Float images of extreme magnitude reach the GPU scaled by a power of two
(:mod:`glmls.core.magnitudes`).
"""

from __future__ import annotations

import sys
from dataclasses import dataclass

import numpy as np

from ..core.config import check_choice, check_real, counted
from ..core.magnitudes import (
    integer_background,
    scaled_background,
    scaled_down,
    scaled_up,
    value_exponent,
)
from ..core.mesh import check_grid
from ..errors import DtypeError

__all__ = [
    "BORDERS",
    "DTYPES",
    "INTERPOLATIONS",
    "METHODS",
    "SourceImage",
    "as_float32",
    "as_rgba8",
    "background_color",
    "check_background",
    "check_image",
    "check_options",
    "native_order",
    "prepare_image",
    "prepare_images",
    "texture_data",
    "texture_form",
]

#: How the deformed image is built (see :meth:`glmls.MLS.warp`).
METHODS = ("quads", "splat", "backward", "backward-swap", "paper-quads")
INTERPOLATIONS = ("nearest", "linear")
#: What lies beyond the source image, with numpy.pad's (and scikit-image's) meanings:
#: ``constant`` the background; ``edge`` the edge pixel repeated; ``symmetric`` mirrored with
#: the edge pixel (a b c | c b a); ``reflect`` mirrored about it (a b c | b a); ``wrap`` the
#: image repeated. A mode's index is its ``WARP_BORDER`` code in the shaders.
BORDERS = ("constant", "edge", "symmetric", "reflect", "wrap")
DTYPES = (np.uint8, np.uint16, np.float32, np.float64)


@dataclass(frozen=True)
class SourceImage:
    """An image prepared for the GPU: float32 (H, W, C) raw values plus what to restore."""

    data: np.ndarray
    dtype: np.dtype
    squeeze: bool  # the input was (H, W)
    #: ``data`` is the uint8 image itself: uploaded as an 8-bit texture (sampled as value /
    #: 255), drawn into an 8-bit target and read back as uint8 (4x less to convert, upload,
    #: clear and read than float32).
    normalized: bool = False
    #: ``data`` is the image divided by 2**exponent (:func:`value_exponent`).
    exponent: int = 0

    @property
    def shape(self) -> tuple[int, int]:
        return self.data.shape[0], self.data.shape[1]

    @property
    def channels(self) -> int:
        return self.data.shape[2]

    def restore(self, values: np.ndarray) -> np.ndarray:
        """float32 (H, W, C) (uint8 if ``normalized``) back to the input's dtype and shape."""
        if self.normalized:
            out = np.ascontiguousarray(values)
            return out[..., 0] if self.squeeze else out
        if np.issubdtype(self.dtype, np.integer):
            top = np.iinfo(self.dtype).max
            values = np.clip(np.rint(values), 0, top)
        out = scaled_up(values.astype(self.dtype), self.exponent)
        return out[..., 0] if self.squeeze else out


def native_order(array: np.ndarray) -> np.ndarray:
    """``array`` with its bytes in this machine's order: big-endian data (some TIFF readers,
    ``np.dtype(">u2")``) as the same values in native order, any other array as it is."""
    if array.dtype.isnative:
        return array
    return array.astype(array.dtype.newbyteorder("="))


def check_image(image: object, name: str = "image") -> np.ndarray:
    """``image`` as an array, H x W or H x W x C with C in 1..4, of a dtype of
    :data:`DTYPES` and not empty; ``TypeError``/``ValueError`` naming it as ``name``."""
    array = native_order(np.asarray(image))
    if array.dtype not in DTYPES:
        names = ", ".join(np.dtype(d).name for d in DTYPES)
        hint = ""
        if not isinstance(image, np.ndarray) and np.issubdtype(array.dtype, np.integer):
            hint = f" (Python ints become int64 in numpy: pass np.asarray({name}, np.uint8))"
        raise DtypeError(f"{name} dtype must be one of {names}; got {array.dtype}{hint}")
    if array.ndim not in (2, 3) or (array.ndim == 3 and not 1 <= array.shape[2] <= 4):
        hint = "; volumes (D x H x W) are warped by a 3D MLS, (N, 3) handles"
        raise ValueError(
            f"{name} must be H x W or H x W x C with C in 1..4, got {array.shape}"
            + (hint if array.ndim in (3, 4) else "")
        )
    if array.size == 0:
        raise ValueError(f"{name} is empty: shape {array.shape}")
    return array


def prepare_image(image: object, max_size: int, *, normalized: bool = False) -> SourceImage:
    """Validate an image (:func:`check_image`) and convert it to float32, or with
    ``normalized`` keep a uint8 image as it is (see :attr:`SourceImage.normalized`)."""
    array = check_image(image)
    height, width = array.shape[:2]
    if max(height, width) > max_size:
        raise ValueError(
            f"image {counted(width, 'pixel')} wide and {height} high exceeds the GL texture "
            f"size limit of {max_size} pixels per side on this device; split it or scale it down"
        )
    squeeze = array.ndim == 2
    if normalized and array.dtype == np.uint8:
        return SourceImage(
            np.ascontiguousarray(array.reshape(height, width, -1)), array.dtype, squeeze, True
        )
    exponent = value_exponent(array)
    data = as_float32(scaled_down(array.reshape(height, width, -1), exponent, np.float32))
    return SourceImage(data, array.dtype, squeeze, exponent=exponent)


def prepare_images(
    images: list, max_size: int, *, normalized: bool = False, names: list[str] | None = None
) -> list[SourceImage]:
    """:func:`prepare_image` of each of ``images`` (a batch's chunk), a ``ValueError`` about
    image k prefixed with ``names[k]`` where given. Where the first is uint8 kept as it is
    (``normalized``) and every other one is a uint8 array of its shape, the others take the
    first's checks (dtype, shape, size limit) and are wrapped as they are: a chunk of
    thousands of small images is not checked image by image."""

    def one(k: int) -> SourceImage:
        try:
            return prepare_image(images[k], max_size, normalized=normalized)
        except ValueError as error:
            if names is None:
                raise
            raise ValueError(f"{names[k]}: {error}") from None

    first = one(0)
    shape = np.shape(images[0])
    alike = first.normalized and all(
        isinstance(a, np.ndarray) and a.dtype == np.uint8 and a.shape == shape for a in images[1:]
    )
    if not alike:
        return [first] + [one(k) for k in range(1, len(images))]
    height, width = first.shape
    return [first] + [
        SourceImage(
            np.ascontiguousarray(a.reshape(height, width, -1)), first.dtype, first.squeeze, True
        )
        for a in images[1:]
    ]


def as_float32(array: np.ndarray, name: str = "image") -> np.ndarray:
    """``array`` as a C-contiguous float32 array, as the GPU holds it; ``ValueError`` naming
    ``name`` where a finite value lies beyond float32's range (it would become inf)."""
    try:
        with np.errstate(over="raise"):
            return np.ascontiguousarray(array, dtype=np.float32)
    except FloatingPointError:
        top = float(np.abs(array[np.isfinite(array)]).max())
        raise ValueError(
            f"{name} values must lie within float32's range (±3.4e38, the GPU's), got {top:g}"
        ) from None


def _background_value(value: object, background: object) -> float:
    """One value of ``background`` as a float (:func:`~glmls.core.config.check_real`, NaN
    and ±inf allowed: a fill value): ``TypeError`` naming the whole ``background`` else."""
    try:
        return check_real("background", value, finite=False)
    except TypeError:
        raise TypeError(
            f"background values must be real numbers, got {background!r} ({type(value).__name__})"
        ) from None


def check_background(background: object) -> float | tuple[float, ...]:
    """``background`` as a float, or a tuple of 1 to 4 floats (one per channel):
    ``TypeError`` unless its values are real numbers (:func:`~glmls.core.config.check_real`;
    NaN and ±inf are values a float image can hold), ``ValueError`` for another count (the
    image's channels decide which counts fit: :func:`background_color`)."""
    values = np.asarray(background, dtype=object)
    if values.ndim == 0:
        # a 0-d array or tensor, as its number (as a 1-value one is)
        return _background_value(background, background)
    if values.ndim != 1 or not 1 <= len(values) <= 4:
        raise ValueError(
            f"background must be a scalar or 1 to 4 values (one per channel), got {background!r}"
        )
    return tuple(_background_value(value, background) for value in values)


def background_color(background: object, image: SourceImage) -> tuple[float, float, float, float]:
    """The clear colour: ``background`` per channel, and alpha 0 for images with alpha.

    ``background`` is a scalar (every colour channel), or one value per channel (C values,
    alpha included, or C - 1 for an image with alpha, whose alpha is then 0).
    """
    channels = image.channels
    has_alpha = channels in (2, 4)
    values = np.asarray(background, dtype=object)
    if values.ndim == 0:
        values = np.array([background] * (channels - has_alpha), dtype=object)
    if values.ndim != 1 or len(values) not in (channels, channels - has_alpha):
        raise ValueError(
            f"background must be a scalar or {channels} value{'s' if channels > 1 else ''}"
            " (one per channel)"
            + (f" or {channels - 1} (colour only)" if has_alpha else "")
            + f", got {background!r}"
        )
    out = []
    for value in values:
        out.append(_background_value(value, background))
    if np.issubdtype(image.dtype, np.integer):
        out = integer_background(out, background, image.dtype)
    else:
        out = scaled_background(out, background, image.dtype, image.exponent)
    if image.normalized:
        out = [v / 255.0 for v in out]
    if len(out) < channels:
        out.append(0.0)  # transparent where nothing is drawn
    return (*out, *[0.0] * (4 - len(out)))  # type: ignore[return-value]


def check_options(
    method: object, interpolation: object, grid: object, border: object = "constant"
) -> None:
    """``ValueError`` naming a bad ``method``, ``interpolation``, ``grid`` or ``border``
    (``TypeError`` for one of the wrong type: a method that is no string, a float grid)."""
    for name, value, choices in (
        ("method", method, METHODS),
        ("interpolation", interpolation, INTERPOLATIONS),
        ("border", border, BORDERS),
    ):
        check_choice(name, value, choices)
    if check_grid(grid) != 1 and method == "paper-quads":
        # the paper's squares are of adjacent pixels: a coarser lattice would colour pixels
        # with a vertex up to grid / 2 pixels away (a mosaic), which the paper never does
        raise ValueError(
            f"method 'paper-quads' fills the paper's squares of adjacent pixel centres: "
            f"grid must be 1, got {grid!r} (method 'quads' takes a coarser mesh)"
        )


def as_rgba8(data: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """(H, W, C) uint8 as (H, W, 4), channels filled as GL fills them when sampling; written
    into ``out`` ((H, W, 4) uint8, C-contiguous) where given (a batch's pixels converted
    straight into the stack it uploads)."""
    if data.shape[2] == 4 and out is None:
        return data
    if out is None:
        out = np.empty((*data.shape[:2], 4), np.uint8)
    if data.shape[2] == 3 and sys.byteorder == "little" and data.size >= 6:
        _rgb_as_rgba8(np.ascontiguousarray(data), out)
        return out
    flat, target = data.reshape(-1, data.shape[2]), out.reshape(-1, 4)
    target[:, data.shape[2] :] = (0, 0, 0, 255)[data.shape[2] :]
    for channel in range(data.shape[2]):  # one strided copy per channel: 4x faster here
        target[:, channel] = flat[:, channel]
    return out


def _rgb_as_rgba8(data: np.ndarray, out: np.ndarray) -> None:
    """RGB as RGBA in one pass over uint32 words (2.4x faster than per-channel copies, the
    common case of every call's upload): pixel i's word read at byte 3 i holds its R, G, B
    and the next pixel's R, whose bits the alpha of 255 covers (little-endian). The last
    pixel, whose word would run past the data, is set apart."""
    height, width, _ = data.shape
    count = height * width
    flat = data.reshape(-1)
    words_out = out.reshape(-1).view(np.uint32)
    words = np.ndarray((count - 1,), np.uint32, buffer=flat, strides=(3,))
    np.bitwise_or(words, np.uint32(0xFF000000), out=words_out[:-1])
    red, green, blue = (int(v) for v in flat[-3:])
    words_out[-1] = red | green << 8 | blue << 16 | 0xFF000000


def texture_form(image: SourceImage) -> tuple[tuple[int, int], int, str]:
    """(size, components, dtype) of the texture that holds ``image``: RGBA8 for a normalized
    image, whatever its channels (GL samples fewer as missing 0, alpha 1, and texels of one
    uint32 let the fused quads copy them whole), else float32 with its channels."""
    height, width = image.shape
    if image.normalized:
        return (width, height), 4, "f1"
    return (width, height), image.channels, "f4"


def texture_data(image: SourceImage) -> np.ndarray:
    """What to write into the texture of :func:`texture_form`."""
    return as_rgba8(image.data) if image.normalized else image.data
