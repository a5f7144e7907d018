"""error_stats (paper eqs. 8, 9) against numpy."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from numpy.testing import assert_allclose

import glmls


def test_against_numpy_with_nan(rng):
    values = rng.gamma(2.0, 3.0, (40, 50))
    values[rng.random(values.shape) < 0.1] = np.nan
    stats = glmls.analysis.error_stats(values)
    finite = values[~np.isnan(values)]
    assert stats["count"] == finite.size
    assert stats["nan_count"] == values.size - finite.size
    assert_allclose(stats["mean"], np.mean(finite), rtol=1e-14)
    assert_allclose(stats["std"], np.std(finite), rtol=1e-12)  # population (ddof=0), eq. 9
    assert stats["min"] == np.min(finite)
    assert stats["max"] == np.max(finite)
    deviation = np.abs(finite - np.mean(finite))
    expected = [np.mean(deviation <= k * np.std(finite)) for k in (1, 2, 3)]
    assert_allclose(stats["within"], expected, rtol=1e-12)
    json.dumps(stats)  # plain Python numbers


def test_within_shares_on_a_known_set():
    # mean 0, std 1: |x| <= 1 for 4 of 6 values, all within 2
    values = np.array([-1.0, -1.0, 1.0, 1.0, -np.sqrt(2), np.sqrt(2)])
    values = values / np.std(values)
    stats = glmls.analysis.error_stats(values)
    assert stats["mean"] == pytest.approx(0.0, abs=1e-15)
    assert stats["std"] == pytest.approx(1.0)
    assert stats["within"][1:] == [1.0, 1.0]


def test_constant_all_nan_empty_and_integers():
    assert glmls.analysis.error_stats([2.0, 2.0, np.nan])["within"] == [1.0, 1.0, 1.0]
    assert glmls.analysis.error_stats([2.0, 2.0, np.nan])["std"] == 0.0
    empty = glmls.analysis.error_stats([np.nan, np.nan])
    assert empty["count"] == 0 and empty["nan_count"] == 2 and empty["mean"] is None
    assert glmls.analysis.error_stats([])["count"] == 0
    assert glmls.analysis.error_stats(np.arange(5))["mean"] == 2.0


def test_rejects_infinity_and_non_numbers():
    with pytest.raises(ValueError, match="infinite"):
        glmls.analysis.error_stats([1.0, np.inf])
    with pytest.raises(TypeError, match="real numbers"):
        glmls.analysis.error_stats(["a", "b"])


@given(arrays(np.float64, st.integers(1, 60), elements=st.floats(-1e6, 1e6) | st.just(np.nan)))
def test_property_matches_numpy(values):
    stats = glmls.analysis.error_stats(values)
    finite = values[~np.isnan(values)]
    assert stats["count"] + stats["nan_count"] == values.size
    if finite.size:
        assert_allclose(stats["mean"], np.mean(finite), rtol=1e-9, atol=1e-6)
        assert_allclose(stats["std"], np.std(finite), rtol=1e-9, atol=1e-6)
        assert stats["min"] <= stats["mean"] + 1e-6 and stats["mean"] <= stats["max"] + 1e-6
        assert 0.0 <= stats["within"][0] <= stats["within"][1] <= stats["within"][2] <= 1.0


def test_median_and_trimmed_mean_against_scipy(rng):
    from scipy import stats as scipy_stats

    values = rng.gamma(2.0, 3.0, 97)
    values[5] = 1e9  # one wild value: the mean follows it, the headline does not
    result = glmls.analysis.error_stats(np.append(values, np.nan))
    assert result["median"] == np.median(values)
    assert_allclose(result["trimmed_mean"], scipy_stats.trim_mean(values, 0.1), rtol=1e-12)
    assert result["trimmed_mean"] < 20 < result["mean"]
    assert glmls.analysis.error_stats([np.nan])["median"] is None
    assert glmls.analysis.error_stats([3.0])["trimmed_mean"] == 3.0


def test_values_at_exactly_one_std_count_within():
    # two values, or any symmetric pair repeated, lie at exactly 1 std from the mean; the mean
    # and the std in float64 round differently and must not push them out
    for pair in ([0.1, 0.3], [0.7, 1.1], [1e-3, 3e-3], [2.2, 2.6] * 3):
        assert glmls.analysis.error_stats(pair)["within"] == [1.0, 1.0, 1.0], pair
