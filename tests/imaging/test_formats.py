"""Image formats: every dtype and channel count, strides, orientation, bad input."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import smooth_handles
from numpy.testing import assert_array_equal

import glmls
from glmls.imaging.source import as_rgba8

DTYPES = [np.uint8, np.uint16, np.float32, np.float64]
SHAPES = [(5, 7), (5, 7, 1), (5, 7, 2), (5, 7, 3), (5, 7, 4), (1, 1), (1, 9), (9, 1, 3)]


def _image(rng, shape, dtype):
    if np.issubdtype(dtype, np.integer):
        return rng.integers(0, np.iinfo(dtype).max, shape, endpoint=True).astype(dtype)
    return rng.normal(0, 100, shape).astype(dtype)


@pytest.mark.parametrize("dtype", DTYPES)
@pytest.mark.parametrize("shape", SHAPES)
def test_identity_returns_the_input_exactly(gl, rng, dtype, shape):
    img = _image(rng, shape, dtype)
    p = np.array([[0, 0], [3, 1], [1, 4.0]])
    expected = img.astype(np.float32).astype(dtype)  # float64 is computed as float32
    with glmls.MLS(p, p, ctx=gl) as m:
        for method in ("quads", "backward", "splat"):
            out = m.warp(img, method=method)
            assert out.dtype == img.dtype and out.shape == img.shape
            assert_array_equal(out, expected, err_msg=method)


@pytest.mark.parametrize("dtype", DTYPES)
def test_every_dtype_and_channel_count_round_trips(gl, rng, dtype):
    p = np.array([[1, 1], [6, 2], [3, 5.0]])
    q = p + np.array([[0.7, 0.2], [-0.4, 0.5], [0.3, -0.6]])
    with glmls.MLS(p, q, ctx=gl) as m:
        for channels in (None, 1, 2, 3, 4):
            shape = (8, 9) if channels is None else (8, 9, channels)
            img = _image(rng, shape, dtype)
            for method in glmls.METHODS:
                for interpolation in glmls.INTERPOLATIONS:
                    out = m.warp(img, method=method, interpolation=interpolation)
                    assert out.dtype == img.dtype and out.shape == img.shape
                    # a result of its own, like any numpy function's: writable, contiguous
                    assert out.flags.writeable and out.flags.c_contiguous
                    assert out.flags.owndata or out.base.flags.writeable
            out = m.warp(img, tolerance=0.05)
            assert out.flags.writeable and out.flags.c_contiguous


def test_strided_and_reversed_arrays(gl, rng):
    base = rng.integers(0, 255, (20, 30, 4), dtype=np.uint8)
    p, q = smooth_handles((10, 15), rng)
    with glmls.MLS(p, q, ctx=gl) as m:
        for view in (base[::2, ::-2], base[::-1, :15, 2], base[:10, :15].transpose(1, 0, 2)):
            assert not view.flags.c_contiguous
            assert_array_equal(m.warp(view), m.warp(np.ascontiguousarray(view)))


@pytest.mark.parametrize("dtype", [">u2", ">f4", ">f8"])
def test_big_endian_images_warp_as_native_ones(gl, rng, dtype):
    """Big-endian uint16 and float64 were refused as an unknown dtype (float32 was taken)."""
    native = rng.integers(0, 1000, (12, 16)).astype(np.dtype(dtype).newbyteorder("="))
    p, q = smooth_handles((12, 16), rng)
    with glmls.MLS(p, q, ctx=gl) as m:
        assert_array_equal(m.warp(native.astype(dtype)), m.warp(native))


def test_float64_values_beyond_float32_are_warped_not_refused(gl):
    """1e300 overflowed the cast to float32 (a RuntimeWarning, inf in the output), then was
    refused; the warp divides it by a power of two into float32's range and back."""
    image = np.full((4, 4), 2.0**990)  # float32 holds both exactly divided by 2**960
    image[1, 2] = -(2.0**1000)
    with glmls.MLS([[0, 0]], [[1, 0]], ctx=gl) as m:
        assert_array_equal(m.warp(image)[:, 1:], image[:, :-1])  # a shift by 1 px: exact
        assert np.isinf(m.warp(np.full((4, 4), np.inf))[:, 1:]).all()  # inf stays inf
        with pytest.raises(ValueError, match=r"background 1e\+300 is beyond float32's range"):
            m.warp(np.ones((4, 2)), background=1e300)
        assert np.isnan(m.warp(np.ones((4, 4)), background=np.nan)[:, 0]).all()


def test_rows_come_back_top_down(gl):
    img = np.zeros((6, 4), np.uint8)
    img[0] = 200  # the top row
    p = np.array([[0, 0], [3, 0], [0, 5.0]])
    q = p + np.array([0, 1])  # everything one row down
    with glmls.MLS(p, q, ctx=gl) as m:
        for method in glmls.METHODS:
            out = m.warp(img, method=method, background=7)
            assert_array_equal(out[:, 0], [7, 200, 0, 0, 0, 0], err_msg=method)


def test_bad_images_and_options(gl):
    with glmls.MLS([[0, 0]], [[1, 1]], ctx=gl) as m:
        for bad in (np.zeros((0, 3)), np.zeros((3, 0, 2))):
            with pytest.raises(ValueError, match="empty"):
                m.warp(bad)
        for dtype in (bool, np.complex64, np.int64):
            with pytest.raises(TypeError, match="dtype"):
                m.warp(np.zeros((2, 2), dtype))
        with pytest.raises(ValueError, match=r"C in 1\.\.4"):
            m.warp(np.zeros((2, 2, 5), np.uint8))
        with pytest.raises(ValueError, match=r"C in 1\.\.4"):
            m.warp(np.zeros(5, np.uint8))
        limit = gl.limits["max_texture_size"]
        with pytest.raises(ValueError, match=f"limit of {limit}"):
            m.warp(np.zeros((1, limit + 1), np.uint8))
        img = np.zeros((3, 3, 4), np.uint8)
        with pytest.raises(ValueError, match="'bilinear'"):
            m.warp(img, interpolation="bilinear")
        with pytest.raises(ValueError, match="'inverse'"):
            m.warp(img, method="inverse")
        with pytest.raises(ValueError, match="grid"):
            m.warp(img, grid=0)
        with pytest.raises(ValueError, match="background"):
            m.warp(img, background=(1, 2))
        with pytest.raises(ValueError, match=r"outside 0\.\.255"):
            m.warp(img, background=256)
        # a value no uint8 holds is refused, not rounded (half to even would give 2 for 1.5)
        for fraction in (1.5, 2.5, 0.4, (0, 0, 0.5)):
            with pytest.raises(ValueError, match=r"is not a value of uint8: .* no whole number"):
                m.warp(img, background=fraction)
        with pytest.raises(TypeError):
            m.warp(img, "quads")  # options are keyword-only


def test_background_per_channel_and_alpha(gl):
    img = np.full((4, 4, 4), 100, np.uint8)
    with glmls.MLS([[0, 0]], [[40, 40]], ctx=gl) as m:  # moves everything out of view
        assert_array_equal(m.warp(img, background=5)[0, 0], [5, 5, 5, 0])
        assert_array_equal(m.warp(img, background=(1, 2, 3))[0, 0], [1, 2, 3, 0])
        assert_array_equal(m.warp(img, background=(1, 2, 3, 4))[0, 0], [1, 2, 3, 4])
        assert_array_equal(m.warp(img[..., :3], background=(1, 2, 3))[0, 0], [1, 2, 3])
        # a 0-d array or tensor is its number, as a 1-value one is
        assert_array_equal(m.warp(img, background=np.array(5))[0, 0], [5, 5, 5, 0])
        assert_array_equal(m.warp(img, background=np.float32(5))[0, 0], [5, 5, 5, 0])
        with pytest.raises(TypeError, match="real numbers"):
            m.warp(img, background=np.array(True))
        with pytest.raises(ValueError, match=r"a scalar or 1 value \(one per channel\)"):
            m.warp(img[..., 0], background=(1, 2))


@pytest.mark.parametrize("shape", [(1, 1, 3), (1, 2, 3), (2, 1, 3), (7, 5, 3), (64, 33, 3)])
@pytest.mark.parametrize("layout", ["contiguous", "strided", "read-only"])
def test_rgb_is_padded_to_rgba_with_opaque_alpha(rng, shape, layout):
    """The upload's RGB -> RGBA (words read across pixel boundaries, the last pixel apart)
    against the per-channel definition, on every layout an image may come in."""
    img = rng.integers(0, 256, shape, dtype=np.uint8)
    if layout == "strided":
        wide = rng.integers(0, 256, (shape[0], 2 * shape[1], 4), dtype=np.uint8)
        wide[:, ::2, :3] = img
        img = wide[:, ::2, :3]
    elif layout == "read-only":
        img = np.frombuffer(img.tobytes(), np.uint8).reshape(shape)
    want = np.concatenate([img, np.full((*shape[:2], 1), 255, np.uint8)], axis=2)
    got = as_rgba8(img)
    assert got.shape == (*shape[:2], 4) and got.dtype == np.uint8
    assert_array_equal(got, want)
    into = np.full((*shape[:2], 4), 7, np.uint8)  # a layer of a batch's stack
    assert as_rgba8(img, into) is into
    assert_array_equal(into, want)


@pytest.mark.parametrize("channels", [1, 2, 3, 4])
def test_any_channels_fill_a_given_rgba_array_as_gl_samples_them(rng, channels):
    img = rng.integers(0, 256, (5, 3, channels), dtype=np.uint8)
    want = np.zeros((5, 3, 4), np.uint8)
    want[..., 3] = 255
    want[..., :channels] = img
    into = np.full((5, 3, 4), 7, np.uint8)
    assert as_rgba8(img, into) is into
    assert_array_equal(into, want)
    assert_array_equal(as_rgba8(img), want)


def test_an_image_of_python_ints_says_how_to_pass_it(gl):
    """A list of ints is int64 to numpy: the error says so and how to give 8 bits."""
    with glmls.MLS([[0, 0]], [[1, 0]], ctx=gl) as m:
        with pytest.raises(
            TypeError, match=r"got int64 \(Python ints .*np\.asarray\(image, np\.uint8\)"
        ):
            m.warp([[1, 2], [3, 4]])
        with pytest.raises(TypeError, match=r"got int64$"):  # an array's dtype is the caller's
            m.warp(np.array([[1, 2], [3, 4]], np.int64))
        assert m.warp(np.asarray([[1, 2], [3, 4]], np.uint8)).dtype == np.uint8
    with pytest.raises(TypeError, match=r"got int64 \(Python ints"):
        glmls.warp([[1, 2], [3, 4]], [[0, 0]], [[1, 0]], ctx=gl)
