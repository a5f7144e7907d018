"""Float images and volumes of extreme magnitude on their way to the GPU, which computes in
float32: divided by a power of two there (:func:`scaled_down`, exact: an exponent shift) and
multiplied by it back (:func:`scaled_up`).

An array whose largest finite magnitude lies within [2**-64, 2**64] reaches the GPU as it is;
one beyond (1e30, float32's largest 3.4e38, a float64 array's 1e300; 1e-30, subnormals, 1e-300)
is divided by the power of two that brings it within (2**63, 2**64] (:func:`value_exponent`).
The GPU's blends then run far from float32's overflow and from the subnormals that GPUs flush
to zero, and a float64 array beyond float32's range is held at all. Warping with nearest or
linear sampling is linear in the values, so the result is the warp of the array itself:
``warp(2**k * a) == 2**k * warp(a)`` bit for bit. What float32 cannot hold beside the largest
values (those more than 2**189 below them once divided) becomes 0, as float32 always makes it.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "SCALE_LIMIT",
    "integer_background",
    "scaled_background",
    "scaled_down",
    "scaled_up",
    "value_exponent",
]

#: Float values whose largest finite magnitude lies within [2**-SCALE_LIMIT, 2**SCALE_LIMIT]
#: reach the GPU as they are; others are divided by the power of two that brings it within.
SCALE_LIMIT = 64
_FLOAT32_MAX = float(np.finfo(np.float32).max)


def value_exponent(array: np.ndarray) -> int:
    """The power of two ``e`` that the float ``array`` is divided by on its way to the GPU: 0
    where its largest finite magnitude lies within [2**-64, 2**64] (or it holds no finite
    value but 0, or it is no float array), else the one that brings that magnitude within
    (2**63, 2**64].

    Bringing the largest value to 2**64 rather than to 1 keeps as many of the smallest values
    beside it as float32 can hold (189 powers of two down to its smallest normal value,
    2**-126, whatever the magnitude) and leaves 2**64 above it, so that a blend of values
    next to it does not round past float32's largest.
    """
    if array.dtype.kind != "f" or array.size == 0:
        return 0
    low, high = array.min(), array.max()  # NaN where the array holds one: the slow path
    if np.isfinite(low) and np.isfinite(high):
        top = max(float(high), -float(low))
    else:
        finite = array[np.isfinite(array)]
        top = float(np.abs(finite).max()) if finite.size else 0.0
    if top == 0.0 or 2.0**-SCALE_LIMIT <= top <= 2.0**SCALE_LIMIT:
        return 0
    mantissa, exponent = math.frexp(top)  # 2**(exponent - 1) <= top < 2**exponent
    ceiling = exponent - 1 if mantissa == 0.5 else exponent  # ceil(log2(top))
    return ceiling - SCALE_LIMIT  # top within (2**63, 2**64]


def scaled_down(array: np.ndarray, exponent: int, dtype: object = None) -> np.ndarray:
    """``array`` divided by ``2**exponent`` (:func:`value_exponent`), as a new C-contiguous
    array of ``dtype`` (None: its own), without a copy of ``array``'s dtype on the way (a
    float64 volume's float32 copy is all that is made): exact but for the rounding to
    ``dtype`` and values it then holds as subnormals or 0 (those float32 could not hold beside
    the largest ones either); ``array`` itself for an exponent of 0."""
    if exponent == 0:
        return array
    out = np.empty(array.shape, array.dtype if dtype is None else dtype)
    with np.errstate(under="ignore"):
        np.ldexp(array, -exponent, out=out, casting="same_kind")
    return out


def scaled_up(out: np.ndarray, exponent: int) -> np.ndarray:
    """``out``, float values of an array divided by ``2**exponent`` as the GPU gave them
    back, multiplied by ``2**exponent`` in place: exact, but a finite value that float32's
    rounding took past the largest of ``out``'s dtype (a blend of values next to it) is that
    largest value, not inf. Returns ``out``."""
    if exponent == 0:
        return out
    beyond = None
    top = np.finfo(out.dtype).max
    if exponent > 0:  # inf in the source stays inf; a finite value rounded past the top not
        beyond = np.abs(out) > np.ldexp(top, -exponent)
        beyond &= np.isfinite(out)
    with np.errstate(over="ignore", under="ignore"):
        np.ldexp(out, exponent, out=out)
    if beyond is not None and beyond.any():
        out[beyond] = np.copysign(top, out[beyond])
    return out


def integer_background(
    values: list[float], background: object, dtype: np.dtype, *, name: object = None
) -> list[float]:
    """The float ``values`` of ``background`` for an array of integer or bool ``dtype``:
    ``ValueError`` naming ``background`` (after ``name:`` where given, a file's name) where a
    value is no value of the dtype: NaN, outside its range (0..1 for bool), or not a whole
    number (1.5 has no nearest uint8 to pick without a rounding rule the caller did not ask
    for). The integer images and volumes that glmls warps are uint8 and uint16, whose values
    float32 holds exactly."""
    dtype = np.dtype(dtype)
    low, high = (0, 1) if dtype == np.bool_ else (np.iinfo(dtype).min, np.iinfo(dtype).max)
    prefix = "" if name is None else f"{name}: "
    for value in values:
        if not low <= value <= high:
            raise ValueError(
                f"{prefix}background {background!r} is outside {low}..{high} of {dtype}"
            )
        if value != math.floor(value):
            raise ValueError(
                f"{prefix}background {background!r} is not a value of {dtype}: {value:g} is "
                f"no whole number (give one of {low}..{high})"
            )
    return [float(value) for value in values]


def scaled_background(
    values: list[float], background: object, dtype: np.dtype, exponent: int
) -> list[float]:
    """The float ``values`` of ``background`` (NaN and ±inf kept) for an array of float
    ``dtype`` divided by ``2**exponent`` (:func:`value_exponent`), as the GPU holds them:
    ``ValueError`` naming ``background`` where a finite value is beyond ``dtype``'s range (the
    output cannot hold it), or where float32 cannot hold it beside the array's values: beyond
    its range (it would become inf) or, not 0, below it (it would become 0)."""
    top = float(np.finfo(dtype).max)
    out = []
    for value in values:
        if not math.isfinite(value):
            out.append(value)
            continue
        if abs(value) > top:
            raise ValueError(f"background {background!r} is beyond {dtype}'s range (±{top:.4g})")
        scaled = math.ldexp(value, -exponent)
        held = float(np.float32(scaled)) if abs(scaled) <= _FLOAT32_MAX else math.inf
        if math.isinf(held) or (held == 0.0 and value != 0.0):
            where = (
                f" beside the values (the GPU holds both divided by 2**{exponent})"
                if exponent
                else " (the GPU's)"
            )
            raise ValueError(
                f"background {background!r} is beyond float32's range{where}: it would become "
                f"{held:g} (float32 holds ±3.4e38 down to 1.4e-45)"
            )
        out.append(scaled)
    return out
