"""The power of two that float arrays of extreme magnitude are divided by on their way to the
GPU (glmls.core.magnitudes), checked against its definition in float64 numpy."""

from __future__ import annotations

import math

import numpy as np
import pytest

from glmls.core.magnitudes import scaled_background, scaled_down, scaled_up, value_exponent

F32_MAX = float(np.finfo(np.float32).max)


@pytest.mark.parametrize(
    ("top", "exponent"),
    [
        (0.0, 0),
        (1.0, 0),
        (2.0**64, 0),
        (2.0**-64, 0),
        (np.nextafter(2.0**64, math.inf), 1),
        (1e30, 36),
        (F32_MAX, 64),
        (2.0**128, 64),
        (np.nextafter(2.0**128, math.inf), 65),
        (1e300, 933),
        (float(np.finfo(np.float64).max), 960),
        (np.nextafter(2.0**-64, 0.0), -128),
        (2.0**-128, -192),
        (1e-30, -163),
        (1e-300, -1060),
        (5e-324, -1138),
    ],
)
def test_the_exponent_brings_the_largest_magnitude_to_2_to_the_64(top, exponent):
    array = np.array([[0.5 * top, -top], [top / 3, 0.0]])
    assert value_exponent(array) == exponent
    scaled = math.ldexp(top, -exponent)
    if exponent == 0:
        assert top == 0.0 or 2.0**-64 <= top <= 2.0**64
    else:  # the one power of two that takes it within (2**63, 2**64]
        assert 2.0**63 < scaled <= 2.0**64


def test_nan_and_infinities_do_not_count_and_other_dtypes_are_not_divided():
    assert value_exponent(np.array([np.nan, -np.inf, 1e300, np.inf])) == 933
    assert value_exponent(np.array([np.nan, np.inf], np.float32)) == 0
    assert value_exponent(np.array([1e-300, np.nan])) == -1060
    assert value_exponent(np.array([65535], np.uint16)) == 0
    assert value_exponent(np.zeros((0, 3))) == 0


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_down_and_up_again_is_the_identity(dtype):
    rng = np.random.default_rng(0)
    values = (rng.random(1000) - 0.5).astype(dtype)
    values[:3] = [np.inf, -np.inf, np.nan]
    for exponent in (64, -64, -120):  # every value stays a normal float of its dtype
        scaled = scaled_down(values, exponent)
        assert scaled.dtype == dtype
        back = scaled_up(scaled.copy(), exponent)
        np.testing.assert_array_equal(back, values)
    assert scaled_down(values, 0) is values


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_a_finite_value_rounded_past_the_top_is_the_top_not_inf(dtype):
    """A blend of values next to the dtype's largest may round up to 2**128 (2**1024) once
    multiplied back; inf and NaN from the source stay what they are."""
    top = np.finfo(dtype).max
    exponent = 128 if dtype == np.float32 else 1024
    out = np.array([1.0, -1.0, np.inf, -np.inf, np.nan, 0.5], dtype)
    scaled_up(out, exponent)
    np.testing.assert_array_equal(out, [top, -top, np.inf, -np.inf, np.nan, 2.0 ** (exponent - 1)])


def test_the_background_is_divided_with_the_values_or_named():
    out = scaled_background([1e300, np.nan, -np.inf, 0.0], "b", np.dtype(np.float64), 960)
    assert out[0] == math.ldexp(1e300, -960) and math.isnan(out[1]) and out[2:] == [-np.inf, 0.0]
    with pytest.raises(
        ValueError, match=r"background 1 is beyond float32's range beside .*2\*\*960.* become 0"
    ):
        scaled_background([1.0], 1, np.dtype(np.float64), 960)
    with pytest.raises(
        ValueError,
        match=r"background 1e\+300 is beyond float32's range \(the GPU's\): it would become inf",
    ):
        scaled_background([1e300], 1e300, np.dtype(np.float64), 0)
    with pytest.raises(ValueError, match=r"background 1e-300 is beyond float32's range.*become 0"):
        scaled_background([1e-300], 1e-300, np.dtype(np.float64), 0)
    with pytest.raises(
        ValueError, match=r"background 1e\+39 is beyond float32's range \(±3\.403e\+38\)"
    ):
        scaled_background([1e39], 1e39, np.dtype(np.float32), 64)  # the output cannot hold it
    subnormal = float(np.float32(1e-40))  # float32 holds it as it is
    assert scaled_background([subnormal], subnormal, np.dtype(np.float32), 0) == [subnormal]
