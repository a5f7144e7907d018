"""A volume of a dtype the warp does not take (int16, as CT scans are stored) is a TypeError
that says what to do: warp it as float32 and round back."""

from __future__ import annotations

import numpy as np
import pytest

from glmls.volume.source import check_volume


@pytest.mark.parametrize("dtype", [np.int16, np.int32, np.bool_, np.float16])
def test_another_numeric_dtype_says_to_warp_it_as_float32(dtype):
    with pytest.raises(TypeError, match=r"got .*warp volume\.astype\(np\.float32\)"):
        check_volume(np.zeros((2, 3, 4), dtype))


def test_a_non_numeric_dtype_gets_no_such_advice():
    with pytest.raises(TypeError, match=r"got <U1$"):
        check_volume(np.full((2, 3, 4), "a"))
