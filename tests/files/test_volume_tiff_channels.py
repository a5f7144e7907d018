"""TIFF stacks of channels as written and read: one channel as a stack, bool channels as
planes (1-bit samples side by side do not read back), a stack of separate planes as
channels."""

from __future__ import annotations

import numpy as np
import pytest
import tifffile

from glmls.files import read_volume
from glmls.files.volumes import write_volume


@pytest.mark.parametrize("dtype", ["uint8", "float32", "int32", "bool"])
def test_one_channel_is_written_to_tiff_as_a_stack(tmp_path, dtype):
    data = (np.random.default_rng(1).random((3, 4, 5, 1)) * 100).astype(dtype)
    write_volume(tmp_path / "one.tif", data, spacing=(2.0, 1.0, 1.0))
    np.testing.assert_array_equal(read_volume(tmp_path / "one.tif").data, data[..., 0])


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
