"""The dtypes volumes are warped in and written back in: ``glmls warp`` and the volume
window's save warp a volume of another dtype (int16 CT values, a bool mask, float64) as
float32 and write the result in the input's own dtype."""

from __future__ import annotations

import numpy as np

__all__ = ["WARPED_AS_IS", "in_dtype", "warped_as"]

#: The dtypes a volume is warped in as it is (``glmls warp``, the volume window's save);
#: the others are warped as float32 (:func:`warped_as`; integers exact within +-2**24) and
#: written back in their own dtype (:func:`in_dtype`). float64 is warped as float32 too: the
#: GPU computes in float32 either way, and the float32 copy holds half the memory.
WARPED_AS_IS = ("uint8", "uint16", "float32")


def warped_as(data: np.ndarray) -> np.ndarray:
    """``data`` (a real-valued volume) in the dtype it is warped in: itself where its dtype
    is one of :data:`WARPED_AS_IS`, else a float32 copy."""
    return data if data.dtype.name in WARPED_AS_IS else data.astype(np.float32)


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
        return np.clip(np.rint(warped), info.min, info.max).astype(dtype)
    return warped.astype(dtype)
