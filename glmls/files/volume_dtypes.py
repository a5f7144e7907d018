"""The dtypes volumes are warped in and written back in: ``glmls warp`` and the volume
window's save warp a volume of another dtype (int16 CT values, a bool mask, float64) as
float32 and write the result in the input's own dtype."""

from __future__ import annotations

import math

import numpy as np

from ..core.magnitudes import integer_background, value_exponent

__all__ = ["WARPED_AS_IS", "check_file_background", "in_dtype", "warped_as"]

#: The dtypes a volume is warped in as it is (``glmls warp``, the volume window's save);
#: the others are warped as float32 (:func:`warped_as`; integers exact within +-2**24) and
#: written back in their own dtype (:func:`in_dtype`). float64 is warped as float32 too: the
#: GPU computes in float32 either way, and the float32 copy holds half the memory; but not
#: one beyond float32's range, which the warp divides by a power of two on its way there.
WARPED_AS_IS = ("uint8", "uint16", "float32")

_FLOAT32_MAX = float(np.finfo(np.float32).max)
_EXACT = 1 << 24  # float32 holds every integer within +-2**24 exactly


def warped_as(data: np.ndarray, name: object = "volume") -> np.ndarray:
    """``data`` (a real-valued volume) in the dtype it is warped in: itself where its dtype
    is one of :data:`WARPED_AS_IS` or where it is float64 of a magnitude the warp divides by
    a power of two (:func:`~glmls.core.magnitudes.value_exponent`: 1e300, 1e-300), else a
    float32 copy; ``ValueError`` naming ``name`` where that copy would change a value: a
    finite float beyond float32's range (it would become inf), or an integer float32 does
    not hold (some beyond +-2**24, such as 2**24 + 1)."""
    if data.dtype.name in WARPED_AS_IS:
        return data
    if data.dtype == np.float64 and value_exponent(data) != 0:
        return data  # the warp divides it by a power of two into float32's range, exactly
    if data.dtype.kind == "f":
        with np.errstate(over="ignore"):
            copy = data.astype(np.float32)
        beyond = np.isinf(copy) & np.isfinite(data)
        if beyond.any():
            raise ValueError(
                f"{name}: values must lie within float32's range (±3.4e38, the GPU's), got "
                f"{float(data[beyond].flat[0]):g}"
            )
        return copy
    copy = data.astype(np.float32)
    if data.dtype.kind in "iu" and data.size:
        low, high = int(data.min()), int(data.max())
        if low < -_EXACT or high > _EXACT:
            inexact = copy.astype(np.float64) != data.astype(np.float64)
            inexact |= np.abs(data.astype(np.float64)) >= 2.0**53  # float64 may round those
            if inexact.any():
                raise ValueError(
                    f"{name}: {data.dtype} values from {low} to {high}, of which float32 (the "
                    f"GPU's) would round {int(data[inexact].flat[0])}; integers within "
                    "+-2**24 are warped exactly (renumber labels, or rescale the values)"
                )
    return copy


def check_file_background(background: float | tuple[float, ...], dtype: np.dtype, name: object):
    """``ValueError`` naming ``name`` where ``background`` (one value or one per channel) is
    not a value of a volume of ``dtype`` warped as float32 and written back (:func:`in_dtype`):
    outside an integer dtype's range or NaN there, no whole number there, an integer float32
    would round (beyond +-2**24, such as 2**24 + 1: the warp would write another; the dtype's
    largest value is kept), outside 0..1 or no whole number for bool, a finite value beyond
    float32's range (or a float16's) for a float dtype but float64 (the warp checks a float64
    volume's beside its values)."""
    values = background if isinstance(background, tuple) else (background,)
    dtype = np.dtype(dtype)
    if dtype.kind not in "biu":
        top = float(np.finfo(dtype).max)
        if dtype != np.float64:  # float64 may be warped as it is (warped_as), the others not
            top = min(top, _FLOAT32_MAX)
        if any(math.isfinite(v) and abs(v) > top for v in values):
            raise ValueError(
                f"{name}: background {background!r} is beyond the range of {dtype} (±{top:.4g})"
            )
        return
    integer_background([float(v) for v in values], background, dtype, name=name)
    for value in values:
        # what the warp writes (float32, then back in the dtype) against the value itself
        written = in_dtype(np.array([value], np.float32), dtype)[0]
        wanted = in_dtype(np.array([value], np.float64), dtype)[0]
        if written != wanted:
            raise ValueError(
                f"{name}: background {background!r}: float32 (the GPU's) would round "
                f"{wanted} to {written}; an integer background is exact within +-2**24 "
                "(16777216)"
            )


def in_dtype(warped: np.ndarray, dtype: np.dtype) -> np.ndarray:
    """A volume warped in float32 written back in its input's ``dtype`` (``glmls warp``, the
    volume window's save): integers rounded and clipped to the dtype's range, a bool mask
    true where the warped value is at least 1/2, other dtypes cast."""
    if warped.dtype == dtype:
        return warped
    if dtype == np.bool_:
        return warped >= 0.5
    if np.issubdtype(dtype, np.integer):
        info = np.iinfo(dtype)
        low, high = np.float64(info.min), np.float64(info.max)
        if int(high) > info.max:  # int64's and uint64's largest values round up in float64
            high = np.nextafter(high, 0.0)
        return np.clip(np.rint(warped.astype(np.float64)), low, high).astype(dtype)
    return warped.astype(dtype)
