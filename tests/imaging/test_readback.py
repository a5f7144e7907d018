"""Reading 8-bit results back: the whole RGBA8 read with channels dropped in numpy gives
the bytes of GL's own read of fewer channels."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_array_equal

from glmls.imaging import readback
from glmls.imaging.readback import drop_channels, read_rgba8

SHAPES = [(1, 1), (1, 2), (2, 1), (3, 5), (7, 1), (1, 7), (64, 33), (257, 1031)]


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("channels", [1, 2, 3])
def test_drop_channels_keeps_the_first_bytes(rng, shape, channels):
    rgba = rng.integers(0, 256, (*shape, 4), dtype=np.uint8)
    out = np.full((*shape, channels), 7, np.uint8)
    drop_channels(rgba, out)
    assert_array_equal(out, rgba[..., :channels])


@pytest.fixture
def framebuffer(gl):
    made = []

    def make(width, height, rng):
        data = rng.integers(0, 256, (height, width, 4), dtype=np.uint8)
        texture = gl.mgl.texture((width, height), 4, data.tobytes())
        fb = gl.mgl.framebuffer([texture])
        made.extend([fb, texture])
        return fb, data

    with gl.use():
        yield make
        for thing in made:
            thing.release()


@pytest.mark.parametrize("size", [(1, 1), (5, 3), (33, 17), (300, 41)])
@pytest.mark.parametrize("strip_bytes", [1, 64, readback.STRIP_BYTES])
def test_read_rgba8_matches_gl_own_read(framebuffer, rng, monkeypatch, size, strip_bytes):
    # strip_bytes 1: one row per strip; 64: a few rows, the last strip shorter
    monkeypatch.setattr(readback, "STRIP_BYTES", strip_bytes)
    fb, data = framebuffer(*size, rng)
    for channels in (1, 2, 3, 4):
        out = read_rgba8(fb, size, channels)
        assert out.shape == (size[1], size[0], channels) and out.dtype == np.uint8
        assert out.flags.writeable and out.flags.c_contiguous
        assert_array_equal(out, data[..., :channels], err_msg=f"{channels} channels")
        own = np.frombuffer(fb.read(components=channels, alignment=1), np.uint8)
        assert_array_equal(out.reshape(-1), own)


def test_read_rgba8_names_bad_channels(framebuffer, rng):
    fb, _ = framebuffer(4, 4, rng)
    for bad in (0, 5):
        with pytest.raises(ValueError, match=f"channels must be 1, 2, 3 or 4, got {bad}"):
            read_rgba8(fb, (4, 4), bad)


def test_read_rgba8_into_a_given_array(framebuffer, rng, monkeypatch):
    monkeypatch.setattr(readback, "STRIP_BYTES", 64)  # several strips
    fb, data = framebuffer(9, 13, rng)
    for channels in (1, 2, 3, 4):
        into = np.full((13, 9, channels), 7, np.uint8)
        assert read_rgba8(fb, (9, 13), channels, into) is into
        assert_array_equal(into, data[..., :channels])
    wrong = [np.empty((13, 9, 2), np.uint8), np.empty((13, 18, 3), np.uint8)[:, ::2]]
    for bad in wrong:
        with pytest.raises(ValueError, match=r"out must be C-contiguous \(13, 9, 3\)"):
            read_rgba8(fb, (9, 13), 3, bad)
