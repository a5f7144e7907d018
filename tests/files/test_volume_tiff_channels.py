"""TIFF stacks of channels as written and read: one channel as a stack that reads back
(D, H, W, 1), as .npy and NIfTI keep it, bool channels as planes (1-bit samples side by side
do not read back), a stack of separate planes as channels."""

from __future__ import annotations

import numpy as np
import pytest
import tifffile

from glmls.files import read_volume
from glmls.files.volumes import write_volume


@pytest.mark.parametrize("dtype", ["uint8", "float32", "int32", "bool"])
def test_one_channel_is_written_to_tiff_as_a_stack_and_reads_back_4d(tmp_path, dtype):
    data = (np.random.default_rng(1).random((3, 4, 5, 1)) * 100).astype(dtype)
    write_volume(tmp_path / "one.tif", data, spacing=(2.0, 1.0, 1.0))
    back = read_volume(tmp_path / "one.tif")
    assert back.shape == (3, 4, 5, 1) and back.spacing == (2.0, 1.0, 1.0)
    np.testing.assert_array_equal(back.data, data)
    with tifffile.TiffFile(tmp_path / "one.tif") as tiff:  # as other programs open it
        assert tiff.series[0].shape == (3, 4, 5)


@pytest.mark.parametrize("suffix", [".tif", ".npy", ".nii.gz"])
@pytest.mark.parametrize("dtype", ["uint8", "uint16", "float32"])
@pytest.mark.parametrize("channels", [None, 1, 3])
def test_every_volume_format_keeps_the_channel_axis(tmp_path, suffix, dtype, channels):
    shape = (3, 4, 5) if channels is None else (3, 4, 5, channels)
    data = (np.random.default_rng(4).random(shape) * 200).astype(dtype)
    write_volume(tmp_path / f"v{suffix}", data)
    back = read_volume(tmp_path / f"v{suffix}").data
    assert back.shape == shape and back.dtype == data.dtype
    np.testing.assert_array_equal(back, data)


@pytest.mark.parametrize("description", [None, '{"spacing": [2.0, 1.0, 1.0]}'])
def test_a_stack_without_the_mark_reads_as_3d(tmp_path, description):
    data = np.arange(60, dtype=np.uint16).reshape(3, 4, 5)
    tifffile.imwrite(tmp_path / "ij.tif", data, imagej=True, metadata={"axes": "ZYX"})
    assert read_volume(tmp_path / "ij.tif").shape == (3, 4, 5)
    with tifffile.TiffWriter(tmp_path / "plain.tif") as tiff:
        for index, page in enumerate(data):
            first = description if index == 0 else None
            tiff.write(page, photometric="minisblack", metadata=None, description=first)
    assert read_volume(tmp_path / "plain.tif").shape == (3, 4, 5)


@pytest.mark.parametrize("channels", [2, 3, 4])
def test_bool_channels_in_tiff_read_back_as_written(tmp_path, channels):
    data = np.random.default_rng(2).random((3, 4, 9, channels)) > 0.5
    write_volume(tmp_path / "mask.tif", data)
    back = read_volume(tmp_path / "mask.tif").data
    assert back.dtype == np.bool_
    np.testing.assert_array_equal(back, data)


def test_a_stack_of_separate_planes_reads_as_channels(tmp_path):
    data = np.random.default_rng(3).integers(0, 65535, (3, 4, 5, 3), dtype=np.uint16)
    planes = np.moveaxis(data, 3, 1)
    tifffile.imwrite(tmp_path / "planar.tif", planes, photometric="rgb", planarconfig="separate")
    np.testing.assert_array_equal(read_volume(tmp_path / "planar.tif").data, data)


def test_tifffiles_shaped_stack_of_one_channel_reads_back_4d(tmp_path):
    data = np.arange(60, dtype=np.uint16).reshape(3, 4, 5, 1)
    tifffile.imwrite(tmp_path / "shaped.tif", data, photometric="minisblack")
    back = read_volume(tmp_path / "shaped.tif").data
    assert back.shape == (3, 4, 5, 1)
    np.testing.assert_array_equal(back, data)
