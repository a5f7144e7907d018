"""Image-level statistics of an error (paper eqs. 8, 9)."""

from __future__ import annotations

import numpy as np

__all__ = ["error_stats"]


def error_stats(values: object) -> dict[str, float | int | list[float] | None]:
    """Image-level statistics of an error field or per-triangle errors (paper eqs. 8, 9).

    NaN values (where an error is undefined) are left out and counted in ``nan_count``;
    ``count`` is the number of values used. Returns a JSON-ready dict: ``mean`` (eq. 8),
    ``std`` (eq. 9, the population standard deviation), ``min``, ``max``, ``within`` (the
    shares of values with |x - mean| <= 1, 2 and 3 std, in that order), ``count``,
    ``nan_count``. With no values left, the statistics are ``None``. Infinite values raise
    ``ValueError``.
    """
    array = np.asarray(values)
    if not (np.issubdtype(array.dtype, np.floating) or np.issubdtype(array.dtype, np.integer)):
        raise TypeError(f"values must be real numbers, got dtype {array.dtype}")
    array = array.astype(np.float64, copy=False).ravel()
    nan = np.isnan(array)
    if np.isinf(array).any():
        raise ValueError(f"values must be finite or NaN; {int(np.isinf(array).sum())} are infinite")
    finite = array[~nan]
    stats: dict[str, float | int | list[float] | None] = {
        "count": int(finite.size),
        "nan_count": int(nan.sum()),
    }
    if finite.size == 0:
        return stats | {"mean": None, "std": None, "min": None, "max": None, "within": None}
    # in units of the largest magnitude: sums of values near the float64 limit do not overflow
    unit = float(np.abs(finite).max()) or 1.0
    scaled = finite / unit
    mean = float(scaled.mean())
    deviation = np.abs(scaled - mean)
    std = float(np.sqrt(np.mean(deviation**2)))
    within = [float(np.count_nonzero(deviation <= k * std)) / finite.size for k in (1, 2, 3)]
    mean, std = mean * unit, std * unit
    return stats | {
        "mean": mean,
        "std": std,
        "min": float(finite.min()),
        "max": float(finite.max()),
        "within": within,
    }
