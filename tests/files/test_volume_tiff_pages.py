"""TIFF stacks whose pages are not all slices of one kind, and stacks of colours that are
not grey or RGB: refused, not read as a stack that lacks a slice or as RGB. Stacks of slices
one voxel wide: written as slices."""

from __future__ import annotations

import numpy as np
import pytest
import tifffile
from PIL import Image, ImageOps

from glmls.errors import InputFileError
from glmls.files import read_volume
from glmls.files.volumes import is_volume_file, write_volume

_SLICES = np.arange(4 * 6 * 7, dtype=np.uint16).reshape(4, 6, 7)


def _pages(path, pages, **options):
    with tifffile.TiffWriter(path) as tiff:
        for page in pages:
            tiff.write(page, metadata=None, **options)


@pytest.mark.parametrize(
    ("odd", "words"),
    [
        (_SLICES[2, :5], "page 2 of the TIFF stack is 5 x 7 uint16"),
        (_SLICES[2].astype(np.float32), "page 2 of the TIFF stack is 6 x 7 float32"),
        (np.stack([_SLICES[2]] * 3, axis=-1), "page 2 of the TIFF stack is 6 x 7 x 3 uint16"),
    ],
)
def test_a_page_unlike_the_others_is_refused_not_dropped(tmp_path, odd, words):
    path = tmp_path / "stack.tif"
    photometric = "rgb" if odd.ndim == 3 else "minisblack"
    with tifffile.TiffWriter(path) as tiff:
        for index in range(4):
            page = odd if index == 2 else _SLICES[index]
            tiff.write(page, metadata=None, photometric=photometric if index == 2 else None)
    with pytest.raises(InputFileError, match=words):
        read_volume(path)


def test_a_min_is_white_page_among_min_is_black_ones_is_refused(tmp_path):
    path = tmp_path / "stack.tif"
    with tifffile.TiffWriter(path) as tiff:
        for index in range(4):
            white = index == 3
            tiff.write(_SLICES[index], metadata=None, photometric="miniswhite" if white else None)
    with pytest.raises(InputFileError, match=r"page 3 .*\(miniswhite\)"):
        read_volume(path)


def test_a_thumbnail_page_is_not_a_slice(tmp_path):
    path = tmp_path / "stack.tif"
    with tifffile.TiffWriter(path) as tiff:
        for index in range(4):
            tiff.write(_SLICES[index], metadata=None)
        tiff.write(_SLICES[0, ::2, ::2], metadata=None, subfiletype=1)
    np.testing.assert_array_equal(read_volume(path).data, _SLICES)


@pytest.mark.parametrize(
    ("photometric", "name"),
    [("ycbcr", "YCbCr"), ("cielab", "CIE L\\*a\\*b\\*"), ("separated", "CMYK")],
)
def test_a_stack_of_colours_other_than_rgb_is_refused(tmp_path, photometric, name):
    samples = 4 if photometric == "separated" else 3
    pages = np.random.default_rng(0).integers(0, 255, (3, 6, 8, samples), dtype=np.uint8)
    options = {"subsampling": (1, 1)} if photometric == "ycbcr" else {}
    _pages(tmp_path / "colours.tif", pages, photometric=photometric, **options)
    with pytest.raises(InputFileError, match=f"{name} colours"):
        read_volume(tmp_path / "colours.tif")


def test_a_jpeg_ycbcr_stack_reads_as_rgb(tmp_path):
    pages = np.zeros((3, 16, 16, 3), np.uint8)
    pages[..., 0] = 200  # red: far from its YCbCr numbers (76, 85, 255)
    _pages(tmp_path / "jpeg.tif", pages, photometric="rgb", compression="jpeg")
    with tifffile.TiffFile(tmp_path / "jpeg.tif") as tiff:
        assert tiff.pages[0].photometric == tifffile.PHOTOMETRIC.YCBCR  # as JPEG stores it
    data = read_volume(tmp_path / "jpeg.tif").data
    assert data.shape == (3, 16, 16, 3)
    np.testing.assert_allclose(data.mean(axis=(0, 1, 2)), [200, 0, 0], atol=4)


@pytest.mark.parametrize(
    ("axes", "shape"),
    [("TZYX", (3, 4, 6, 7)), ("TZCYX", (3, 4, 2, 6, 7)), ("ZTYX", (4, 3, 6, 7))],
)
def test_a_time_series_of_volumes_is_refused_naming_its_time_points(tmp_path, axes, shape):
    data = np.arange(np.prod(shape), dtype=np.uint16).reshape(shape)
    path = tmp_path / "series.ome.tif"
    tifffile.imwrite(path, data, metadata={"axes": axes})
    with pytest.raises(InputFileError, match=f"axes {axes} .*3 time points of a volume"):
        read_volume(path)


def test_ome_channels_before_slices_read_as_channels(tmp_path):
    data = np.arange(2 * 4 * 6 * 7, dtype=np.uint16).reshape(2, 4, 6, 7)  # (C, Z, Y, X)
    path = tmp_path / "czyx.ome.tif"
    tifffile.imwrite(path, data, metadata={"axes": "CZYX", "PhysicalSizeZ": 2.0})
    volume = read_volume(path)
    np.testing.assert_array_equal(volume.data, np.moveaxis(data, 0, -1))
    assert volume.spacing == (2.0, 1.0, 1.0)


@pytest.mark.parametrize("dtype", ["uint16", "float32", "float64", "bool"])
@pytest.mark.parametrize(
    "shape", [(3, 4, 1), (2, 1, 1), (3, 1, 4), (2, 1, 1, 2), (2, 3, 1, 2), (3, 2, 1, 5)]
)
def test_slices_one_voxel_wide_are_written_as_slices(tmp_path, shape, dtype):
    data = (np.arange(np.prod(shape)).reshape(shape) % 7).astype(dtype)
    write_volume(tmp_path / "thin.tif", data, spacing=(2.0, 1.0, 0.5))
    back = read_volume(tmp_path / "thin.tif")
    assert back.data.shape == shape
    assert back.data.dtype == data.dtype
    np.testing.assert_array_equal(back.data, data)
    assert back.spacing == (2.0, 1.0, 0.5)


def _turned(page: np.ndarray, code: int) -> np.ndarray:
    """Pillow's view of a page stored with EXIF/TIFF orientation ``code``."""
    image = Image.fromarray(page)
    image.getexif()[0x0112] = code
    return np.asarray(ImageOps.exif_transpose(image))


@pytest.mark.parametrize("channels", [0, 3])
@pytest.mark.parametrize("code", range(1, 9))
def test_the_orientation_of_the_pages_turns_every_slice_as_an_image(tmp_path, code, channels):
    rng = np.random.default_rng(code)
    shape = (4, 6, 7, channels) if channels else (4, 6, 7)
    slices = rng.integers(0, 256, shape, dtype=np.uint8)
    path = tmp_path / "stack.tif"
    _pages(
        path,
        slices,
        photometric="rgb" if channels else None,
        extratags=[(274, "H", 1, code, False)],
    )
    expected = np.stack([_turned(page, code) for page in slices])
    read = read_volume(path).data
    np.testing.assert_array_equal(read, expected)
    assert read.shape[1:3] == (shape[2], shape[1]) if code >= 5 else shape[1:3]


def test_a_turned_imagej_stack_swaps_its_pixel_width_and_height(tmp_path):
    path = tmp_path / "stack.tif"
    slices = _SLICES.astype(np.uint16)
    options = {
        "resolution": (1 / 0.5, 1 / 0.25),
        "metadata": {"axes": "ZYX", "spacing": 2.0, "unit": "um"},
    }
    tifffile.imwrite(path, slices, imagej=True, extratags=[(274, "H", 1, 8, False)], **options)
    volume = read_volume(path)
    np.testing.assert_array_equal(volume.data, np.rot90(slices, 1, axes=(1, 2)))
    assert volume.spacing == pytest.approx((2.0, 0.5, 0.25))  # (dz, dy, dx) of the slices shown


def test_pages_of_different_orientations_are_refused(tmp_path):
    path = tmp_path / "stack.tif"
    with tifffile.TiffWriter(path) as tiff:
        for index, page in enumerate(_SLICES):
            tiff.write(
                page, metadata=None, extratags=[(274, "H", 1, 3 if index == 2 else 1, False)]
            )
    with pytest.raises(
        InputFileError, match=r"page 2 of the TIFF stack has orientation 3 .* page 0 has 1"
    ):
        read_volume(path)


@pytest.mark.parametrize(
    ("second", "words"),
    [
        # two volumes of one shape: the second was dropped, read as the first alone
        (_SLICES + 1000, r"2 images or stacks \(\(4, 6, 7\) QYX, \(4, 6, 7\) QYX; page 4 "),
        (_SLICES[0, :3], r"2 images or stacks \(\(4, 6, 7\) QYX, \(3, 7\) YX; page 4 "),
    ],
)
def test_a_tiff_of_several_stacks_is_refused_not_read_as_its_first(tmp_path, second, words):
    path = tmp_path / "two.tif"
    with tifffile.TiffWriter(path) as tiff:  # shaped: each write a series of its own
        tiff.write(_SLICES, photometric="minisblack")
        tiff.write(second, photometric="minisblack")
    with pytest.raises(InputFileError, match=rf"two\.tif: a TIFF of {words}.*file of its own"):
        read_volume(path)


@pytest.mark.parametrize("rgb", [False, True])
def test_a_stack_written_one_slice_a_write_reads_as_its_slices(tmp_path, rgb):
    """``for s in volume: writer.write(s)``: tifffile makes each page a series of its own,
    ImageJ reads the pages as one stack, and so does glmls (with a thumbnail after them
    too); a volume to the command line, not its first page."""
    volume = np.stack([_SLICES] * 3, axis=-1).astype(np.uint8) if rgb else _SLICES
    path = tmp_path / "slices.tif"
    with tifffile.TiffWriter(path) as tiff:
        for page in volume:
            tiff.write(page, photometric="rgb" if rgb else "minisblack")
        tiff.write(volume[0, ::2, ::2], subfiletype=1)  # a thumbnail: not a slice
    with tifffile.TiffFile(path) as tiff:
        assert len(tiff.series) == 4 and tifffile.imread(path).shape == volume.shape[1:]
    assert is_volume_file(path)
    read = read_volume(path)
    assert read.data.dtype == volume.dtype
    np.testing.assert_array_equal(read.data, volume)


def test_one_page_images_of_different_shapes_are_refused_as_several_images(tmp_path):
    path = tmp_path / "mixed.tif"
    with tifffile.TiffWriter(path) as tiff:
        for page in (_SLICES[0], _SLICES[1], _SLICES[2, :5]):
            tiff.write(page, photometric="minisblack")
    assert is_volume_file(path) is False  # its first page is an image (glmls.imread warns)
    with pytest.raises(InputFileError, match=r"a TIFF of 3 images or stacks .* file of its own"):
        read_volume(path)


def test_a_tiff_of_one_stack_and_its_thumbnail_reads_as_the_stack(tmp_path):
    path = tmp_path / "thumb.tif"
    with tifffile.TiffWriter(path) as tiff:
        tiff.write(_SLICES, photometric="minisblack")
        tiff.write(_SLICES[0, ::2, ::2], subfiletype=1)
    np.testing.assert_array_equal(read_volume(path).data, _SLICES)
