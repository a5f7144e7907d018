"""The voxel spacing of TIFF stacks: every dtype write_volume writes to TIFF reads back with
its spacing, ImageJ's dtypes as an ImageJ stack, the others as X/Y resolutions and a JSON
description; descriptions of other programs are not taken for one."""

from __future__ import annotations

import json

import numpy as np
import pytest
import tifffile

from glmls.errors import DtypeError
from glmls.files.volumes import Volume, read_volume, write_volume

#: Every dtype a Volume holds that TIFF has a sample format for.
DTYPES = [
    "bool",
    "int8",
    "int16",
    "int32",
    "int64",
    "uint8",
    "uint16",
    "uint32",
    "uint64",
    "float16",
    "float32",
    "float64",
]
SPACING = (2.0, 1.0, 0.5)


@pytest.mark.parametrize("dtype", DTYPES)
@pytest.mark.parametrize("channels", [None, 1, 2, 3, 4])
def test_every_dtype_keeps_its_spacing(tmp_path, dtype, channels):
    shape = (4, 5, 6) if channels is None else (4, 5, 6, channels)
    data = (np.arange(np.prod(shape)).reshape(shape) % 7).astype(dtype)
    path = tmp_path / "v.tif"
    write_volume(path, Volume(data, spacing=SPACING))
    back = read_volume(path)
    assert back.spacing == SPACING
    assert back.data.dtype == data.dtype
    assert back.shape == data.shape
    np.testing.assert_array_equal(back.data, data)


@pytest.mark.parametrize("dtype", ["float64", "int32", "bool"])
def test_the_spacing_of_other_dtypes_is_exact_and_in_the_resolutions(tmp_path, dtype):
    spacing = (0.3, 0.1, 1 / 3)  # no fraction of 32-bit integers holds 1/3 exactly
    path = tmp_path / "v.tif"
    write_volume(path, np.ones((3, 4, 5), dtype), spacing=spacing)
    assert read_volume(path).spacing == spacing
    with tifffile.TiffFile(path) as tiff:  # what other programs read as the pixel size
        for page in tiff.pages:
            x, y = page.tags["XResolution"].value, page.tags["YResolution"].value
            assert x[1] / x[0] == pytest.approx(1 / 3) and y[1] / y[0] == pytest.approx(0.1)
        assert json.loads(tiff.pages[0].description) == {"spacing": list(spacing)}


def test_warp_keeps_the_spacing_of_a_float64_volume_written_as_tiff(tmp_path):
    from glmls.cli.main import main

    data = np.random.default_rng(0).random((6, 7, 8))
    write_volume(tmp_path / "f64.nii.gz", data, spacing=SPACING)
    src = [[1, 1, 1], [3, 1, 1], [1, 4, 1], [1, 1, 8], [3, 4, 8]]
    dst = [*src[:4], [3.5, 4, 8]]
    (tmp_path / "h.json").write_text(json.dumps({"src": src, "dst": dst}))
    out = tmp_path / "out.tif"
    assert (
        main(
            ["warp", str(tmp_path / "f64.nii.gz"), str(out), "--handles", str(tmp_path / "h.json")]
        )
        == 0
    )
    back = read_volume(out)
    assert back.data.dtype == np.float64 and back.spacing == SPACING


def test_a_spacing_beyond_tiff_resolutions_is_kept_in_the_description(tmp_path):
    spacing = (1e-9, 1e9, 1e-12)  # 1e12 pixels a unit: no 32-bit fraction
    write_volume(tmp_path / "v.tif", np.ones((3, 4, 5)), spacing=spacing)
    assert read_volume(tmp_path / "v.tif").spacing == spacing


def test_an_imagej_stack_of_a_spacing_beyond_its_resolutions_is_refused_named(tmp_path):
    path = tmp_path / "v.tif"
    with pytest.raises(ValueError, match=r"v\.tif: spacing \(1\.0, 1\.0, 1e-12\): an ImageJ"):
        write_volume(path, np.ones((3, 4, 5), np.float32), spacing=(1.0, 1.0, 1e-12))
    assert not path.exists()


def test_numbers_of_over_64_bits_are_refused_named_as_tiff(tmp_path):
    path = tmp_path / "v.tif"
    with pytest.raises(DtypeError, match=r"v\.tif: TIFF holds numbers of up to 64 bits, got "):
        write_volume(path, np.ones((3, 4, 5), np.longdouble), spacing=SPACING)
    assert not path.exists()


@pytest.mark.parametrize(
    "metadata",
    [{"spacing": 2.0}, {"spacing": [1.0, 2.0]}, {"spacing": [1.0, 0.0, 1.0]}, {"spacing": "a"}],
)
def test_a_json_spacing_of_another_program_is_no_spacing(tmp_path, metadata):
    path = tmp_path / "v.tif"
    tifffile.imwrite(path, np.zeros((3, 4, 5)), photometric="minisblack", metadata=metadata)
    assert read_volume(path).spacing is None


@pytest.mark.parametrize("description", ["{not json", '{"a": ' * 5000, "[1, 2, 3]"])
def test_a_description_that_is_no_json_object_is_no_spacing(tmp_path, description):
    path = tmp_path / "v.tif"
    with tifffile.TiffWriter(path) as tiff:
        for index in range(3):
            tiff.write(
                np.zeros((4, 5)),
                metadata=None,
                description=description if index == 0 else None,
            )
    assert read_volume(path).spacing is None
