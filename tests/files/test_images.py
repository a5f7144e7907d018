"""imread / imwrite: dtypes and channels kept (16-bit PNG, 16-bit and float TIFF), EXIF
orientation, animations, and every corrupt or oversized file a ValueError naming it."""

from __future__ import annotations

import struct
import zlib
from importlib import resources

import imagecodecs
import numpy as np
import pytest
import tifffile
from numpy.testing import assert_array_equal
from PIL import Image, ImageOps

import glmls
from glmls.errors import ImageWarning
from glmls.files.images import check_writable

PNG = b"\x89PNG\r\n\x1a\n"


def chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
@pytest.mark.parametrize("shape", [(5, 6), (5, 6, 2), (5, 6, 3), (5, 6, 4)])
def test_png_round_trip(tmp_path, rng, dtype, shape):
    img = rng.integers(0, np.iinfo(dtype).max, shape, endpoint=True).astype(dtype)
    path = tmp_path / "image.png"
    glmls.imwrite(path, img)
    back = glmls.imread(path)
    assert back.dtype == dtype
    assert_array_equal(back, img)


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.float32, np.float64])
@pytest.mark.parametrize("shape", [(5, 6), (5, 6, 2), (5, 6, 3), (5, 6, 4)])
def test_tiff_round_trip(tmp_path, rng, dtype, shape):
    if np.issubdtype(dtype, np.integer):
        img = rng.integers(0, np.iinfo(dtype).max, shape, endpoint=True).astype(dtype)
    else:
        img = rng.normal(0, 100, shape).astype(dtype)
    path = tmp_path / "image.tif"
    glmls.imwrite(path, img)
    back = glmls.imread(path)
    assert back.dtype == dtype
    assert_array_equal(back, img)


def encode_with_every_filter(img: np.ndarray, color_type: int) -> bytes:
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
    idat = zlib.compress(b"".join(out))
    return PNG + chunk(b"IHDR", header) + chunk(b"IDAT", idat) + chunk(b"IEND", b"")


def test_16_bit_colour_png_with_every_filter(tmp_path, rng):
    img = rng.integers(0, 65535, (11, 6, 4), endpoint=True).astype(np.uint16)
    path = tmp_path / "filtered.png"
    path.write_bytes(encode_with_every_filter(img, 6))
    assert_array_equal(glmls.imread(path), img)


def test_corrupt_files_are_value_errors_naming_the_file(tmp_path, rng):
    whole = tmp_path / "whole.png"
    glmls.imwrite(whole, rng.integers(0, 65535, (40, 30, 3)).astype(np.uint16))
    jpeg = tmp_path / "photo.jpg"
    Image.fromarray(rng.integers(0, 255, (64, 64, 3)).astype(np.uint8)).save(jpeg)
    cases = {
        "half16.png": whole.read_bytes()[: whole.stat().st_size // 2],
        "signature.png": PNG,
        "empty.png": b"",
        "noise.png": rng.integers(0, 255, 300).astype(np.uint8).tobytes(),
        "half.jpg": jpeg.read_bytes()[: jpeg.stat().st_size // 2],
        "header.tif": b"II*\x00" + b"\x00" * 20,
    }
    for name, data in cases.items():
        path = tmp_path / name
        path.write_bytes(data)
        with pytest.raises(ValueError, match=str(path)):
            glmls.imread(path)
    with pytest.raises(FileNotFoundError):
        glmls.imread(tmp_path / "missing.png")


def test_oversized_images_are_refused_before_decoding(tmp_path):
    """A header that declares 20000 x 20000 pixels: refused at once, not a 1.6 GB decode."""
    for depth in (8, 16):
        header = struct.pack(">IIBBBBB", 20000, 20000, depth, 2, 0, 0, 0)
        path = tmp_path / f"bomb{depth}.png"
        path.write_bytes(PNG + chunk(b"IHDR", header) + chunk(b"IEND", b""))
        with pytest.raises(ValueError, match=r"20000 x 20000 = 400,000,000 pixels exceeds"):
            glmls.imread(path)
    small = tmp_path / "small.png"
    glmls.imwrite(small, np.zeros((10, 10), np.uint8))
    with pytest.raises(ValueError, match="max_pixels"):
        glmls.imread(small, max_pixels=50)
    assert glmls.imread(small, max_pixels=100).shape == (10, 10)
    assert Image.MAX_IMAGE_PIXELS != 50  # Pillow's own limit is left as it was
    # far beyond the limit (where Pillow itself refuses the file): still the limit given
    with pytest.raises(ValueError, match=r"small.png: 100 pixels exceeds the limit of 10 \("):
        glmls.imread(small, max_pixels=10)
    jpeg = tmp_path / "small.jpg"
    glmls.imwrite(jpeg, np.zeros((10, 10, 3), np.uint8))
    with pytest.raises(ValueError, match=r"small.jpg: 100 pixels exceeds the limit of 49 \("):
        glmls.imread(jpeg, max_pixels=49)


def test_exif_orientation_is_applied(tmp_path):
    """A JPEG stored landscape with orientation 6 (rotate 90 clockwise to view) reads
    portrait, its first stored column now its first row."""
    stored = np.zeros((40, 60, 3), np.uint8)
    stored[:, :10] = 255  # a white band on the stored image's left
    image = Image.fromarray(stored)
    exif = image.getexif()
    exif[0x0112] = 6
    path = tmp_path / "rotated.jpg"
    image.save(path, exif=exif, quality=100)
    read = glmls.imread(path)
    assert read.shape == (60, 40, 3)
    assert read[:8].mean() > 200 and read[-8:].mean() < 50  # the band is now on top


def test_animations_give_their_first_frame_with_a_warning(tmp_path):
    frames = [Image.new("L", (8, 6), v) for v in (10, 200)]
    path = tmp_path / "anim.gif"
    frames[0].save(path, save_all=True, append_images=frames[1:])
    with pytest.warns(ImageWarning, match="2 frames; reading the first"):
        first = glmls.imread(path)
    assert first.shape[:2] == (6, 8)


def test_imwrite_refuses_what_it_cannot_keep_before_writing(tmp_path):
    cases = [
        ("a.png", np.zeros((2, 2), np.float32), r"\.png cannot hold float32.*\.tif"),
        ("a.jpg", np.zeros((2, 2, 3), np.uint16), r"write it as \.png, \.tif or \.tiff$"),
        ("a.jpg", np.zeros((2, 2, 4), np.uint8), "no alpha channel"),
        ("a.xyz", np.zeros((2, 2), np.uint8), r"unknown image format \.xyz"),
        ("noext", np.zeros((2, 2), np.uint8), r"unknown image format \(no suffix\)"),
        ("a.png", np.zeros((0, 2), np.uint8), "empty"),
        ("a.tif", np.zeros((2, 2), np.int64), "cannot hold int64"),
        # BMP: Pillow writes no grey-with-alpha, and reads a 32-bit BMP's alpha as nothing
        (
            "a.bmp",
            np.zeros((2, 2, 4), np.uint8),
            r"\.bmp has no alpha.*\.png, \.tif, \.tiff or \.webp",
        ),
        ("a.bmp", np.zeros((2, 2, 2), np.uint8), r"\.bmp has no alpha.*\.png, \.tif or \.tiff$"),
        # WebP: colour only, a grey image would come back RGB
        ("a.webp", np.zeros((2, 2), np.uint8), r"\.webp holds colour.*\.png, \.tif, \.tiff, \.jpg"),
        ("a.webp", np.zeros((2, 2, 2), np.uint8), r"\.webp holds colour.*\.png, \.tif or \.tiff$"),
    ]
    for name, image, message in cases:
        with pytest.raises(ValueError, match=message):
            glmls.imwrite(tmp_path / name, image)
        assert not (tmp_path / name).exists()
    check_writable("out.PNG", np.uint16, 4)  # suffixes in any case
    for name, channels in (("a.webp", 4), ("a.webp", 3), ("a.bmp", 3), ("a.bmp", 1)):
        image = np.arange(2 * 3 * channels, dtype=np.uint8).reshape(2, 3, channels).squeeze()
        glmls.imwrite(tmp_path / name, image)
        read = glmls.imread(tmp_path / name)  # WebP is lossy: its shape, BMP's values too
        assert read.shape == image.shape, (name, channels)
        assert name.endswith(".webp") or (read == image).all(), (name, channels)


def test_reads_the_bundled_photograph():
    img = glmls.imread(resources.files("glmls") / "data" / "astronaut.jpg")
    assert img.shape == (512, 512, 3) and img.dtype == np.uint8


@pytest.mark.parametrize("code", range(1, 9))
def test_every_orientation_reads_as_pillow_shows_it(tmp_path, rng, code):
    """Orientations 1-8, in a TIFF's tag and in a PNG's EXIF (8-bit and 16-bit), read as
    PIL.ImageOps.exif_transpose shows them (what viewers, skimage and imageio show)."""
    stored = rng.integers(0, 256, (5, 7, 3), dtype=np.uint8)
    tagged = Image.fromarray(stored)
    exif = tagged.getexif()
    exif[0x0112] = code
    tagged.save(tmp_path / "tagged.png", exif=exif)
    with Image.open(tmp_path / "tagged.png") as image:
        shown = np.asarray(ImageOps.exif_transpose(image))
    assert_array_equal(glmls.imread(tmp_path / "tagged.png"), shown)
    tifffile.imwrite(tmp_path / "tagged.tif", stored, extratags=[(274, "H", 1, code, True)])
    assert_array_equal(glmls.imread(tmp_path / "tagged.tif"), shown)
    deep = stored.astype(np.uint16) * 257
    Image.fromarray(stored).save(tmp_path / "deep.png", exif=exif)  # an eXIf chunk to copy
    png = (tmp_path / "deep.png").read_bytes()
    at = png.index(b"eXIf") - 4
    size = struct.unpack(">I", png[at : at + 4])[0]
    exif_chunk = png[at : at + 12 + size]
    encoded = imagecodecs.png_encode(deep)
    ihdr_end = 8 + 25
    (tmp_path / "deep.png").write_bytes(encoded[:ihdr_end] + exif_chunk + encoded[ihdr_end:])
    assert_array_equal(glmls.imread(tmp_path / "deep.png"), shown.astype(np.uint16) * 257)


@pytest.mark.parametrize("mode", ["L", "RGB", "P"])
def test_a_transparent_colour_becomes_alpha(tmp_path, mode):
    """A PNG's tRNS colour is an alpha channel in grey and RGB PNGs as in palette ones."""
    grey = np.arange(12, dtype=np.uint8).reshape(3, 4) * 20
    image = Image.fromarray(grey).convert(mode)
    key = {"L": 100, "RGB": (100, 100, 100)}.get(mode, image.getpixel((1, 1)))
    image.save(tmp_path / "keyed.png", transparency=key)
    read = glmls.imread(tmp_path / "keyed.png")
    assert read.shape == (3, 4, 2 if mode == "L" else 4)
    expected = np.where(grey == 100, 0, 255)
    assert_array_equal(read[..., -1], expected)
    assert_array_equal(read[..., 0], grey)


@pytest.mark.parametrize("code", [1, 6, 7])
@pytest.mark.parametrize("mode", ["P", "CMYK", "1"])
def test_tiffs_of_palette_cmyk_and_bilevel_read_as_shown(tmp_path, mode, code):
    """Palette indices, CMYK inks and 1-bit TIFFs read as the colours Pillow shows, as the
    same modes in a PNG or a JPEG do, not as their stored numbers; oriented as any TIFF."""
    grey = np.arange(48, dtype=np.uint8).reshape(6, 8) * 5
    image = Image.fromarray(np.dstack([grey, grey[::-1], grey])).convert(mode)
    image.save(tmp_path / "a.tif", tiffinfo={274: code})
    shown = np.asarray(image.convert("RGB"))
    turned = {1: shown, 6: np.rot90(shown, -1), 7: np.rot90(shown[:, ::-1], -1)}[code]
    assert_array_equal(glmls.imread(tmp_path / "a.tif"), turned)


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
def test_min_is_white_tiffs_read_as_shown(tmp_path, dtype):
    stored = np.arange(12, dtype=dtype).reshape(3, 4) * 20
    tifffile.imwrite(tmp_path / "mw.tif", stored, photometric="miniswhite")
    assert_array_equal(glmls.imread(tmp_path / "mw.tif"), np.iinfo(dtype).max - stored)


def test_16_bit_palette_and_cmyk_tiffs(tmp_path):
    indices = np.arange(12, dtype=np.uint16).reshape(3, 4) * 5000
    colormap = np.stack([np.arange(65536, dtype=np.uint16)] * 3)
    colormap[0] = 7
    tifffile.imwrite(tmp_path / "p.tif", indices, photometric="palette", colormap=colormap)
    read = glmls.imread(tmp_path / "p.tif")
    assert read.dtype == np.uint16
    assert_array_equal(read, np.dstack([np.full_like(indices, 7), indices, indices]))
    tifffile.imwrite(tmp_path / "c.tif", np.zeros((3, 4, 4), np.uint16), photometric="separated")
    with pytest.raises(ValueError, match=r"c.tif: a CMYK TIFF of uint16 x 4; glmls reads 8-bit"):
        glmls.imread(tmp_path / "c.tif")


@pytest.mark.parametrize("channels", [3, 4])
@pytest.mark.parametrize("shape", [(2, 3), (4, 4), (3, 2), (6, 9)])
def test_planar_tiffs_read_as_h_w_c_at_every_size(tmp_path, rng, shape, channels):
    """A TIFF of separate planes reads H x W x C by its planar configuration, also where its
    width is 4 or less (the planes' (C, H, W) looks like an image of C rows then)."""
    image = rng.integers(0, 256, (*shape, channels), dtype=np.uint8)
    extra = ["unassalpha"] if channels == 4 else None
    planes = np.moveaxis(image, -1, 0)
    tifffile.imwrite(
        tmp_path / "planar.tif",
        planes,
        photometric="rgb",
        planarconfig="separate",
        extrasamples=extra,
    )
    assert_array_equal(glmls.imread(tmp_path / "planar.tif"), image)


def test_ycbcr_tiffs_read_as_the_colours_shown(tmp_path, rng):
    """A YCbCr TIFF reads as Pillow shows it (RGB), not as its stored luma and chroma; one
    compressed by JPEG, which its decoder gives as RGB already, is not converted twice."""
    rgb = rng.integers(0, 256, (6, 9, 3), dtype=np.uint8)
    Image.fromarray(rgb).convert("YCbCr").save(tmp_path / "ycc.tif")
    with Image.open(tmp_path / "ycc.tif") as shown:
        assert_array_equal(glmls.imread(tmp_path / "ycc.tif"), np.asarray(shown.convert("RGB")))
    stored = np.zeros((16, 16, 3), np.uint8)
    stored[:8], stored[8:] = [77, 255, 26], [20, 180, 60]
    tifffile.imwrite(tmp_path / "jpeg.tif", stored, photometric="ycbcr", compression="jpeg")
    with Image.open(tmp_path / "jpeg.tif") as shown:
        expected = np.asarray(shown.convert("RGB")).astype(int)
    assert np.abs(glmls.imread(tmp_path / "jpeg.tif").astype(int) - expected).max() <= 2


def test_lab_tiffs_are_refused(tmp_path, rng):
    rgb = rng.integers(0, 256, (4, 5, 3), dtype=np.uint8)
    Image.fromarray(rgb).convert("LAB").save(tmp_path / "lab.tif")
    with pytest.raises(ValueError, match=r"lab.tif: a TIFF of CIE L\*a\*b\* colours"):
        glmls.imread(tmp_path / "lab.tif")


@pytest.mark.parametrize("maxval", [65535, 4095])
def test_16_bit_colour_ppm_keeps_its_depth(tmp_path, rng, maxval):
    """A 16-bit P6 PPM reads as uint16 (Pillow reduces it to 8 bits), scaled to 0..65535 as
    Pillow scales a 16-bit grey P5 of the same maximum value; a truncated one is refused."""
    stored = rng.integers(0, maxval + 1, (5, 7), dtype=np.uint16)
    samples = np.repeat(stored[..., None], 3, axis=2).astype(">u2").tobytes()
    header = f"P6\n# made by a test\n7 5\n{maxval}\n".encode()
    (tmp_path / "c.ppm").write_bytes(header + samples)
    (tmp_path / "g.pgm").write_bytes(
        f"P5\n7 5\n{maxval}\n".encode() + stored.astype(">u2").tobytes()
    )
    read = glmls.imread(tmp_path / "c.ppm")
    assert read.dtype == np.uint16
    with Image.open(tmp_path / "g.pgm") as grey:
        expected = np.asarray(grey).astype(np.uint16)
    for channel in range(3):
        assert_array_equal(read[..., channel], expected)
    (tmp_path / "t.ppm").write_bytes(header + samples[:-4])
    with pytest.raises(ValueError, match=r"t.ppm: corrupt or truncated 16-bit PPM"):
        glmls.imread(tmp_path / "t.ppm")
    with pytest.raises(ValueError, match=r"c.ppm: 7 x 5 = 35 pixels exceeds the limit of 34"):
        glmls.imread(tmp_path / "c.ppm", max_pixels=34)


def test_16_bit_text_ppm_keeps_its_depth(tmp_path):
    (tmp_path / "a.ppm").write_text(
        "P3\n# text\n2 1\n65535\n1000 2000 3000 # a\n40000 50000 60000\n"
    )
    read = glmls.imread(tmp_path / "a.ppm")
    assert read.dtype == np.uint16
    assert read.tolist() == [[[1000, 2000, 3000], [40000, 50000, 60000]]]
    (tmp_path / "b.ppm").write_text("P3\n2 1\n65535\n1 2 3 4 5 99999999999999999999999999\n")
    with pytest.raises(ValueError, match=r"b.ppm: corrupt or truncated 16-bit PPM \(a sample"):
        glmls.imread(tmp_path / "b.ppm")
