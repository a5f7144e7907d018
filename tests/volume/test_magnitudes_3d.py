"""Float volumes of extreme magnitude (1e300 and 1e-300 in float64, float32's subnormals and
its largest values): the warp of ``2**k * volume`` is ``2**k`` times the warp of ``volume``,
bit for bit, with nearest and linear sampling, both methods; the background goes along or is
named."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_array_equal

import glmls

SRC = np.array([[1.0, 1, 1], [6, 1, 1], [1, 5, 1], [1, 1, 4], [6, 5, 4]])
DST = SRC + [[0.4, -0.3, 0.2], [-0.5, 0.3, 0.1], [0.2, 0.4, -0.3], [0.3, 0.1, 0.5], [0, 0, 0]]
SHAPE = (6, 7, 8)


def _volume(dtype=np.float64) -> np.ndarray:
    return (np.random.default_rng(5).random(SHAPE) + 0.5).astype(dtype)


@pytest.fixture(scope="module")
def mls3():
    with glmls.MLS(SRC, DST) as m:
        yield m


@pytest.mark.parametrize("interpolation", ["nearest", "linear"])
@pytest.mark.parametrize("method", ["quads", "backward"])
def test_a_scaled_volume_warps_to_the_scaled_warp_bit_for_bit(gl, mls3, method, interpolation):
    """float64 beyond float32's range was refused (1e300) or came back 0 (1e-300); float32
    subnormals were flushed to 0 by linear blends."""
    options = {"method": method, "interpolation": interpolation}
    volume = _volume()
    base = mls3.warp(volume, background=0.75, **options)
    for k in (1000, -1000, 65, -65):
        out = mls3.warp(np.ldexp(volume, k), background=np.ldexp(0.75, k), **options)
        assert out.dtype == np.float64
        assert_array_equal(out, np.ldexp(base, k), err_msg=f"2**{k}")
    ints = np.random.default_rng(6).integers(0, 1 << 12, SHAPE).astype(np.float32)
    tiny = mls3.warp(np.ldexp(ints, -149), **options)  # subnormals, exactly
    assert tiny.dtype == np.float32
    assert_array_equal(tiny, np.ldexp(mls3.warp(ints, **options), -149))
    top = np.ldexp(_volume(np.float32), 126) * np.float32(1.3)  # up to 3.3e38
    top[:, ::2] *= -1
    out = mls3.warp(top, **options)
    assert np.isfinite(out).all()
    assert_array_equal(out, np.ldexp(mls3.warp(np.ldexp(top, -126), **options), 126))


def test_a_volume_s_background_goes_with_the_values_or_is_named(gl):
    volume = np.ldexp(_volume(), 1000)
    with glmls.MLS(SRC, SRC + [2.0, 0, 0], ctx=gl) as m:  # the first 2 columns uncovered
        out = m.warp(volume[..., None], background=(2.0**1001,))
        assert (out[..., :2, 0] == 2.0**1001).all()
        assert np.isnan(m.warp(volume, background=np.nan)[..., :2]).all()
        refused = [
            (volume, 1.0, r"background 1\.0 is beyond float32's range beside the values"),
            (_volume(), 1e-300, r"background 1e-300 is beyond float32's range .*become 0"),
            (_volume(), 1e300, r"background 1e\+300 is beyond float32's range .*become inf"),
            (_volume(np.float32), -1e39, r"background -1e\+39 is beyond float32's range"),
            (volume, (1.0, 2.0), r"background must be a scalar or 1 value .*\(1\.0, 2\.0\)"),
            (np.stack([volume] * 2, -1), (0.0, 1.0, 2.0), r"scalar or 2 values"),
        ]
        for values, background, message in refused:
            with pytest.raises(ValueError, match=message):
                m.warp(values, background=background)
