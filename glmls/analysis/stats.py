"""Image-level statistics of an error (paper eqs. 8, 9)."""

from __future__ import annotations

import numpy as np

from ..errors import DtypeError

__all__ = ["TRIM", "error_stats"]

#: The share of values cut from each end for ``trimmed_mean``.
TRIM = 0.1
#: Rounding allowed in ``within``'s comparisons, in units of the largest magnitude.
_SLACK = 16 * np.finfo(np.float64).eps


def error_stats(values: object) -> dict[str, float | int | list[float] | None]:
    """Image-level statistics of an error field or per-triangle errors (paper eqs. 8, 9).

    NaN values (where an error is undefined) are left out and counted in ``nan_count``. The
    median and the trimmed mean are the headline: one huge value (a near-degenerate triangle,
    a fold) moves the mean and the std without bound but them hardly at all.

    Parameters
    ----------
    values : array_like
        Real numbers of any shape (flattened), finite or NaN.

    Returns
    -------
    dict
        JSON-ready: ``count`` (the values used), ``nan_count``, ``mean`` (eq. 8), ``std``
        (eq. 9, the population standard deviation), ``median``, ``trimmed_mean`` (the mean of
        the values left after cutting ``TRIM`` = 10 % from each end, as
        ``scipy.stats.trim_mean``), ``min``, ``max``, ``within`` (the shares of values with
        |x - mean| <= 1, 2 and 3 std, in that order, up to float64 rounding: both of
        two values lie at exactly 1 std). With no values left, the statistics
        are None.

    Raises
    ------
    ValueError
        For infinite values.
    TypeError
        For values that are not real numbers.

    Examples
    --------
    >>> stats = glmls.analysis.error_stats([1.0, 2.0, 3.0, np.nan, 10.0])
    >>> stats["count"], stats["nan_count"], stats["mean"], stats["median"], stats["max"]
    (4, 1, 4.0, 2.5, 10.0)
    >>> round(stats["std"], 3), stats["within"]
    (3.536, [0.75, 1.0, 1.0])
    >>> glmls.analysis.error_stats([np.nan])["mean"] is None
    True
    """
    array = np.asarray(values)
    if not (np.issubdtype(array.dtype, np.floating) or np.issubdtype(array.dtype, np.integer)):
        raise DtypeError(f"values must be real numbers, got dtype {array.dtype}")
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
        empty = ("mean", "std", "median", "trimmed_mean", "min", "max", "within")
        return stats | dict.fromkeys(empty)
    # in units of the largest magnitude: sums of values near the float64 limit do not overflow
    unit = float(np.abs(finite).max()) or 1.0
    scaled = finite / unit
    mean = float(scaled.mean())
    deviation = np.abs(scaled - mean)
    std = float(np.sqrt(np.mean(deviation**2)))
    # a value on the boundary (|x - mean| = k std, as both of two values are at 1 std) counts
    # in, whatever the last bits of rounding in the mean and the std say
    slack = _SLACK * (1.0 + std)
    within = [
        float(np.count_nonzero(deviation <= k * std + slack)) / finite.size for k in (1, 2, 3)
    ]
    mean, std = mean * unit, std * unit
    ordered = np.sort(finite)
    cut = int(TRIM * ordered.size)  # scipy.stats.trim_mean's count
    kept = ordered[cut : ordered.size - cut] / unit
    middle = ordered.size // 2
    # halves first (exact): np.median's (a + b) / 2 overflows for values near the float64 limit
    median = ordered[middle] if ordered.size % 2 else ordered[middle - 1] / 2 + ordered[middle] / 2
    return stats | {
        "mean": mean,
        "std": std,
        "median": float(median),
        "trimmed_mean": float(kept.mean()) * unit,
        "min": float(finite.min()),
        "max": float(finite.max()),
        "within": within,
    }
