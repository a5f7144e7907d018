"""imread / imwrite keep dtypes and channels, 16-bit PNGs included."""

from __future__ import annotations

import struct
import zlib

import numpy as np
import pytest
from numpy.testing import assert_array_equal

import glmls
from glmls.files.images import _PNG_SIGNATURE, _chunk


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
@pytest.mark.parametrize("shape", [(5, 6), (5, 6, 2), (5, 6, 3), (5, 6, 4)])
def test_png_round_trip(tmp_path, rng, dtype, shape):
    img = rng.integers(0, np.iinfo(dtype).max, shape, endpoint=True).astype(dtype)
    path = tmp_path / "image.png"
    glmls.imwrite(path, img)
    back = glmls.imread(path)
    assert back.dtype == dtype
    assert_array_equal(back, img)


def _encode_with_every_filter(img: np.ndarray, color_type: int) -> bytes:
    """A 16-bit PNG whose rows cycle through the five filter types (as libpng may write)."""
    height, width, channels = img.shape
    bpp = 2 * channels
    rows = img.astype(">u2").reshape(height, width * channels).view(np.uint8).astype(int)
    out, prev = [], np.zeros(width * bpp, int)
    for r in range(height):
        kind, line, filtered = r % 5, rows[r], np.zeros(width * bpp, int)
        for x in range(width * bpp):
            left = line[x - bpp] if x >= bpp else 0
            up, upleft = prev[x], prev[x - bpp] if x >= bpp else 0
            if kind == 4:
                p = left + up - upleft
                pa, pb, pc = abs(p - left), abs(p - up), abs(p - upleft)
                pred = left if pa <= pb and pa <= pc else (up if pb <= pc else upleft)
            else:
                pred = (0, left, up, (left + up) // 2)[kind]
            filtered[x] = (line[x] - pred) % 256
        out.append(bytes([kind]) + filtered.astype(np.uint8).tobytes())
        prev = line
    header = struct.pack(">IIBBBBB", width, height, 16, color_type, 0, 0, 0)
    return (
        _PNG_SIGNATURE
        + _chunk(b"IHDR", header)
        + _chunk(b"IDAT", zlib.compress(b"".join(out)))
        + _chunk(b"IEND", b"")
    )


def test_16_bit_colour_png_with_every_filter(tmp_path, rng):
    img = rng.integers(0, 65535, (11, 6, 4), endpoint=True).astype(np.uint16)
    path = tmp_path / "filtered.png"
    path.write_bytes(_encode_with_every_filter(img, 6))
    assert_array_equal(glmls.imread(path), img)


def test_imwrite_rejects_what_it_cannot_keep(tmp_path):
    with pytest.raises(TypeError, match="float32"):
        glmls.imwrite(tmp_path / "a.png", np.zeros((2, 2), np.float32))
    with pytest.raises(ValueError, match="PNG"):
        glmls.imwrite(tmp_path / "a.jpg", np.zeros((2, 2, 3), np.uint16))
    with pytest.raises(ValueError, match="empty"):
        glmls.imwrite(tmp_path / "a.png", np.zeros((0, 2), np.uint8))


def test_reads_the_bundled_photograph():
    from importlib import resources

    img = glmls.imread(resources.files("glmls") / "data" / "astronaut.jpg")
    assert img.shape == (512, 512, 3) and img.dtype == np.uint8
