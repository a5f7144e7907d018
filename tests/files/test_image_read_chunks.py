"""16-bit PNGs (decoded by libpng, not Pillow) read as Pillow reads 8-bit ones: the EXIF
orientation of ImageMagick's "Raw profile type exif" text chunk applied, and an animation's
frames warned about; and what imread gives for a folder and for TIFFs of other dtypes."""

from __future__ import annotations

import struct
import zlib

import numpy as np
import pytest
import tifffile
from PIL import Image

import glmls
from glmls.errors import ImageWarning


def _chunk(kind: bytes, body: bytes) -> bytes:
    crc = struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF)
    return struct.pack(">I", len(body)) + kind + body + crc


def _png(grey: np.ndarray, extra: bytes = b"", frames: list[np.ndarray] = ()) -> bytes:
    """A grey PNG of ``grey`` (uint8 or uint16) with ``extra`` chunks before its data, and
    with ``frames``, an APNG of them after it."""
    height, width = grey.shape
    depth = 16 if grey.dtype == np.uint16 else 8

    def data(image: np.ndarray) -> bytes:
        rows = image.astype(">u2") if depth == 16 else image
        return zlib.compress(b"".join(b"\0" + row.tobytes() for row in rows))

    def control(sequence: int) -> bytes:
        return _chunk(
            b"fcTL", struct.pack(">IIIIIHHBB", sequence, width, height, 0, 0, 1, 10, 0, 0)
        )

    header = struct.pack(">IIBBBBB", width, height, depth, 0, 0, 0, 0)
    png = b"\x89PNG\r\n\x1a\n" + _chunk(b"IHDR", header) + extra
    if frames:
        png += _chunk(b"acTL", struct.pack(">II", 1 + len(frames), 0)) + control(0)
    png += _chunk(b"IDAT", data(grey))
    for k, frame in enumerate(frames):
        body = struct.pack(">I", 2 * k + 2) + data(frame)
        png += control(2 * k + 1) + _chunk(b"fdAT", body)
    return png + _chunk(b"IEND", b"")


def _raw_profile(kind: bytes, orientation: int) -> bytes:
    exif = Image.Exif()
    exif[0x0112] = orientation
    encoded = exif.tobytes()
    text = f"\nexif\n{len(encoded):8d}\n{encoded.hex()}\n".encode()
    key = b"Raw profile type exif\0"
    if kind == b"zTXt":
        return _chunk(kind, key + b"\0" + zlib.compress(text))
    if kind == b"iTXt":
        return _chunk(kind, key + b"\1\0" + b"\0\0" + zlib.compress(text))
    return _chunk(kind, key + text)


@pytest.mark.parametrize("kind", [b"tEXt", b"zTXt", b"iTXt"])
def test_a_raw_exif_profile_orients_16_bit_pngs_as_8_bit_ones(tmp_path, kind):
    stored = np.arange(60, dtype=np.uint8).reshape(6, 10)
    (tmp_path / "8.png").write_bytes(_png(stored, _raw_profile(kind, 6)))
    (tmp_path / "16.png").write_bytes(_png(stored.astype(np.uint16) * 257, _raw_profile(kind, 6)))
    eight, sixteen = glmls.imread(tmp_path / "8.png"), glmls.imread(tmp_path / "16.png")
    assert eight.shape == (10, 6)  # Pillow's turn, the one to match
    np.testing.assert_array_equal(sixteen, eight.astype(np.uint16) * 257)


def test_an_exif_chunk_wins_over_a_raw_profile_at_16_bits(tmp_path):
    exif = Image.Exif()
    exif[0x0112] = 3
    extra = _chunk(b"eXIf", exif.tobytes()) + _raw_profile(b"tEXt", 6)
    stored = np.arange(60, dtype=np.uint16).reshape(6, 10)
    (tmp_path / "16.png").write_bytes(_png(stored, extra))
    np.testing.assert_array_equal(glmls.imread(tmp_path / "16.png"), stored[::-1, ::-1])


def test_a_broken_raw_profile_leaves_a_16_bit_png_as_stored(tmp_path):
    extra = _chunk(b"tEXt", b"Raw profile type exif\0\nexif\n   4\nnot hex\n")
    stored = np.arange(60, dtype=np.uint16).reshape(6, 10)
    (tmp_path / "16.png").write_bytes(_png(stored, extra))
    np.testing.assert_array_equal(glmls.imread(tmp_path / "16.png"), stored)


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
def test_an_animated_png_warns_at_either_depth(tmp_path, dtype):
    first = np.full((8, 10), 100, dtype)
    (tmp_path / "anim.png").write_bytes(_png(first, frames=[first + 50, first + 70]))
    with pytest.warns(ImageWarning, match=r"anim\.png: 3 frames; reading the first"):
        image = glmls.imread(tmp_path / "anim.png")
    np.testing.assert_array_equal(image, first)


def test_imread_of_a_folder_is_a_value_error_naming_it(tmp_path):
    (tmp_path / "photos").mkdir()
    with pytest.raises(ValueError, match=r"photos: a folder, not an image file$"):
        glmls.imread(tmp_path / "photos")


@pytest.mark.parametrize("dtype", ["int16", "uint32", "float16"])
def test_imread_gives_other_tiff_dtypes_as_stored(tmp_path, dtype):
    """As its docstring says: for the caller to convert (glmls.warp does not take them)."""
    stored = np.arange(20).reshape(4, 5).astype(dtype)
    tifffile.imwrite(tmp_path / "a.tif", stored, photometric="minisblack")
    image = glmls.imread(tmp_path / "a.tif")
    assert image.dtype == np.dtype(dtype)
    np.testing.assert_array_equal(image, stored)
    assert dtype in glmls.imread.__doc__


def _tiff_turned(path, stored, planar=False):
    data = np.stack([stored] * 3) if planar else stored
    tifffile.imwrite(
        path,
        data,
        photometric="rgb" if planar else "minisblack",
        planarconfig="separate" if planar else None,
        extratags=[(274, "H", 1, 6, True)],
    )


def test_the_shown_shape_is_the_shape_imread_gives(tmp_path):
    """shown_shape reads each format's orientation where imread does: a raw EXIF profile and
    an eXIf chunk at 8 and 16 bits, a JPEG's EXIF, a TIFF's tag (planar too), none in a
    16-bit PPM; no image or no file: None."""
    from glmls.files.images import shown_shape

    stored = np.arange(60, dtype=np.uint8).reshape(6, 10)
    exif = Image.Exif()
    exif[0x0112] = 3
    files = {
        "raw8.png": _png(stored, _raw_profile(b"zTXt", 6)),
        "raw16.png": _png(stored.astype(np.uint16) * 257, _raw_profile(b"tEXt", 8)),
        "exif16.png": _png(stored.astype(np.uint16), _chunk(b"eXIf", exif.tobytes())),
        "plain.png": _png(stored),
    }
    for name, data in files.items():
        (tmp_path / name).write_bytes(data)
    turned = Image.Exif()
    turned[0x0112] = 6
    Image.fromarray(stored).save(tmp_path / "turned.jpg", exif=turned)
    _tiff_turned(tmp_path / "turned.tif", stored)
    _tiff_turned(tmp_path / "planar.tif", stored, planar=True)
    rgb = np.repeat(stored[..., None].astype(">u2") * 300, 3, axis=2)
    (tmp_path / "wide.ppm").write_bytes(b"P6\n10 6\n65535\n" + rgb.tobytes())
    names = [*files, "turned.jpg", "turned.tif", "planar.tif", "wide.ppm"]
    for name in names:
        assert shown_shape(tmp_path / name) == glmls.imread(tmp_path / name).shape[:2], name
    assert sum(shown_shape(tmp_path / n) == (10, 6) for n in names) == 5  # the turned ones
    (tmp_path / "text.png").write_bytes(b"not an image")
    assert shown_shape(tmp_path / "text.png") is None
    assert shown_shape(tmp_path / "missing.png") is None
