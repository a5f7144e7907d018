"""Float images of extreme magnitude (1e300 and 1e-300 in float64, float32's subnormals and
its largest values): warping with nearest or linear sampling is linear in the values, so the
warp of ``2**k * image`` is ``2**k`` times the warp of ``image``, bit for bit, with every
method, one image at a time and batched; the background goes along or is named."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_array_equal

import glmls

SHAPE = (12, 16, 3)
SRC = np.array([[2.0, 2.0], [13.0, 3.0], [3.0, 10.0], [12.0, 9.0]])
DST = SRC + [[1.0, 0.5], [-0.7, 1.0], [0.3, -1.0], [1.2, 0.4]]
# a float64 image within float32's range, and its copies far beyond it either way
POWERS = (1000, 300, 65, -65, -300, -1000)


def _image(dtype=np.float64) -> np.ndarray:
    return (np.random.default_rng(3).random(SHAPE) + 0.5).astype(dtype)


def _ints() -> np.ndarray:
    """Integers below 2**12: times 2**-149 they are float32 subnormals, exactly."""
    return np.random.default_rng(4).integers(0, 1 << 12, SHAPE).astype(np.float32)


def _held(values) -> np.ndarray:
    """float64 ``values`` as float32 holds them where their magnitude is brought within its
    range by a power of two (the float64 numpy reference of what the GPU holds)."""
    values = np.asarray(values, np.float64)
    _, exponents = np.frexp(values)
    return np.ldexp(np.ldexp(values, -exponents).astype(np.float32).astype(np.float64), exponents)


@pytest.mark.parametrize("interpolation", ["nearest", "linear"])
@pytest.mark.parametrize("method", glmls.METHODS)
def test_a_scaled_image_warps_to_the_scaled_warp_bit_for_bit(gl, method, interpolation):
    """float64 beyond float32's range was refused (1e300) or came back 0 (1e-300); float32
    subnormals were flushed to 0 by linear blends."""
    options = {"method": method, "interpolation": interpolation}
    image = _image()
    with glmls.MLS(SRC, DST, ctx=gl) as m:
        base = m.warp(image, **options)
        for k in POWERS:
            out = m.warp(np.ldexp(image, k), **options)
            assert out.dtype == np.float64
            assert_array_equal(out, np.ldexp(base, k), err_msg=f"2**{k}")
        ints = _ints()
        tiny = m.warp(np.ldexp(ints, -149), **options)
        assert tiny.dtype == np.float32
        assert_array_equal(tiny, np.ldexp(m.warp(ints, **options), -149))
        top = np.ldexp(_image(np.float32), 126) * np.float32(1.3)  # up to 3.3e38, finite
        top[::2] *= -1
        out = m.warp(top, **options)
        assert np.isfinite(out).all()
        assert_array_equal(out, np.ldexp(m.warp(np.ldexp(top, -126), **options), 126))


def test_the_background_goes_with_the_values_or_is_named(gl):
    image = np.ldexp(_image(), 1000)
    with glmls.MLS([[0.0, 0.0]], [[2.0, 0.0]], ctx=gl) as m:  # the first 2 columns uncovered
        out = m.warp(image, background=(1e300, -2e301, 0.0))
        # float32's rounding of the background, as of the values (a float64 image's pixels
        # come back rounded to float32's 24 bits)
        assert_array_equal(out[:, :2], np.broadcast_to(_held([1e300, -2e301, 0.0]), (12, 2, 3)))
        assert_array_equal(out[:, 2:], _held(image[:, :-2]))
        tiny = m.warp(np.ldexp(image, -2000), background=3e-301)
        assert (tiny[:, :2] == _held(3e-301)).all()
        assert np.isnan(m.warp(image, background=np.nan)[:, :2]).all()
        refused = [
            (image, 1.0, r"background 1\.0 is beyond float32's range beside the values"),
            (image, 1e-300, r"background 1e-300 is beyond float32's range"),
            (_image(), 1e-300, r"background 1e-300 is beyond float32's range .*become 0"),
            (_image(), 1e300, r"background 1e\+300 is beyond float32's range .*become inf"),
            (_image(np.float32), 1e39, r"background 1e\+39 is beyond float32's range"),
            (image, (1.0, 2.0), r"background must be a scalar or 3 values.*\(1\.0, 2\.0\)"),
            (image[..., 0], (0.0, 1.0, 2.0), r"background must be a scalar or 1 value"),
        ]
        for values, background, message in refused:
            with pytest.raises(ValueError, match=message):
                m.warp(values, background=background)


@pytest.mark.parametrize("interpolation", ["nearest", "linear"])
@pytest.mark.parametrize("method", glmls.METHODS)
def test_a_batch_of_mixed_magnitudes_is_each_image_s_warp(gl, method, interpolation):
    """Each image reaches the GPU divided by its own power of two (the batch's chunks are of
    one), and comes back as its own warp does."""
    options = {"method": method, "interpolation": interpolation, "background": 0.0}
    images = np.stack([_image(), _image()[::-1].copy(), _image()[:, ::-1].copy()])
    mixed = np.stack([np.ldexp(images[0], 300), images[1], np.ldexp(images[2], -1000)])
    src, dst = [SRC] * 3, [DST] * 3
    base = glmls.warp_batch(images, src, dst, ctx=gl, **options)
    out = glmls.warp_batch(mixed, src, dst, ctx=gl, **options)
    assert_array_equal(out, [np.ldexp(base[0], 300), base[1], np.ldexp(base[2], -1000)])
    for image, warped in zip(mixed, out, strict=True):
        assert_array_equal(warped, glmls.warp(image, SRC, DST, ctx=gl, **options))
