"""Volume files as the tools that make them write them: an ImageJ (Fiji) stack's calibration
as ImageJ writes it (no ``spacing=`` line where the slices are 1 unit apart), ImageJ
hyperstacks of channels, and NIfTI headers as nibabel and ITK read them (the qform beside
the sform)."""

from __future__ import annotations

import nibabel as nib
import numpy as np
import pytest
import tifffile
from numpy.testing import assert_allclose, assert_array_equal

from glmls.files.volumes import read_volume, write_volume

DATA = np.arange(4 * 5 * 6, dtype=np.uint16).reshape(4, 5, 6)  # (z, y, x)


def _imagej_stack(path, *, resolution=None, spacing=None, unit="um"):
    """A stack as ImageJ's FileSaver writes it: ``unit=`` and the X/Y resolutions where it is
    calibrated, ``spacing=`` only where the voxel depth is neither 0 nor 1."""
    metadata: dict = {"axes": "ZYX"}
    if unit is not None:
        metadata["unit"] = unit
    if spacing is not None:
        metadata["spacing"] = spacing
    options = {} if resolution is None else {"resolution": resolution}
    tifffile.imwrite(path, DATA, imagej=True, metadata=metadata, **options)


def test_a_fiji_stack_one_unit_deep_keeps_its_pixel_size(tmp_path):
    """Fiji leaves ``spacing=`` out where the voxel depth is 1: 0.25 x 0.25 x 1 um voxels."""
    path = tmp_path / "fiji.tif"
    _imagej_stack(path, resolution=(4.0, 4.0))
    with tifffile.TiffFile(path) as tiff:
        assert "spacing" not in tiff.imagej_metadata
    volume = read_volume(path)
    assert volume.spacing == (1.0, 0.25, 0.25)
    assert_array_equal(volume.data, DATA)


def test_a_fiji_stack_of_voxel_depth_alone(tmp_path):
    """Calibrated in z alone (Image > Properties, voxel depth 3): the pixels are 1 x 1."""
    path = tmp_path / "depth.tif"
    _imagej_stack(path, spacing=3.0)
    assert read_volume(path).spacing == (3.0, 1.0, 1.0)


def test_an_uncalibrated_fiji_stack_has_no_spacing(tmp_path):
    path = tmp_path / "plain.tif"
    _imagej_stack(path, unit=None)
    assert read_volume(path).spacing is None


def test_an_imagej_hyperstack_of_channels_reads_as_channels_last(tmp_path):
    data = np.arange(4 * 2 * 5 * 6, dtype=np.uint16).reshape(4, 2, 5, 6)  # (Z, C, Y, X)
    path = tmp_path / "hyper.tif"
    tifffile.imwrite(
        path, data, imagej=True, resolution=(2.0, 2.0), metadata={"axes": "ZCYX", "spacing": 3.0}
    )
    volume = read_volume(path)
    assert volume.spacing == (3.0, 0.5, 0.5)
    assert_array_equal(volume.data, np.moveaxis(data, 1, -1))


def test_odd_spacings_survive_the_tiff_rationals(tmp_path):
    path = tmp_path / "odd.tif"
    write_volume(path, DATA, spacing=(0.7, 0.3, 0.1234))
    assert_allclose(read_volume(path).spacing, (0.7, 0.3, 0.1234), rtol=1e-6)


def _sheared() -> np.ndarray:
    return np.array(
        [[1.0, 0.3, 0.0, -4.0], [0.0, 1.2, 0.0, 2.0], [0.0, 0.0, 2.0, 5.0], [0, 0, 0, 1]]
    )


def test_a_sheared_affine_is_not_written_as_a_different_qform(tmp_path):
    """A qform is a rotation, scaling and translation: a sheared affine has none equal to it.
    A tool that reads the qform first (ITK where qform_code > 0) must not be handed another
    geometry than the sform's; where the qform can hold the affine, both say it."""
    path = tmp_path / "sheared.nii"
    write_volume(path, DATA, affine=_sheared())
    image = nib.load(path)
    assert_allclose(image.affine, _sheared(), atol=1e-6)
    qform, qcode = image.get_qform(coded=True)
    assert qcode == 0 or np.allclose(qform, _sheared(), atol=1e-5), qform
    assert image.get_sform(coded=True)[1] > 0
    assert_allclose(read_volume(path).affine, _sheared(), atol=1e-6)


@pytest.mark.parametrize(
    "affine",
    [
        np.diag([0.5, 0.8, 2.0, 1.0]),
        np.array([[-2.0, 0, 0, 30], [0, 0, 1.5, -8], [0, 1.0, 0, 4], [0, 0, 0, 1]]),  # LSA-ish
    ],
)
def test_an_affine_a_qform_holds_is_written_as_both(tmp_path, affine):
    path = tmp_path / "v.nii.gz"
    write_volume(path, DATA, affine=affine)
    image = nib.load(path)
    qform, qcode = image.get_qform(coded=True)
    sform, scode = image.get_sform(coded=True)
    assert qcode > 0 and scode > 0
    assert_allclose(qform, affine, atol=1e-6)
    assert_allclose(sform, affine, atol=1e-6)
    # nibabel's array is (i, j, k) = (x, y, z): glmls's data transposed
    assert_array_equal(np.asanyarray(image.dataobj), DATA.transpose(2, 1, 0))


@pytest.mark.parametrize(
    ("sizes", "expected"),
    [
        ({"PhysicalSizeX": 0.25, "PhysicalSizeY": 0.25, "PhysicalSizeZ": 2.0}, (2.0, 0.25, 0.25)),
        ({"PhysicalSizeX": 0.5, "PhysicalSizeY": 0.5}, (1.0, 0.5, 0.5)),
        # the units of each axis: the spacing in micrometres where they differ
        (
            {
                "PhysicalSizeX": 250.0,
                "PhysicalSizeXUnit": "nm",
                "PhysicalSizeY": 250.0,
                "PhysicalSizeYUnit": "nm",
                "PhysicalSizeZ": 2.0,
            },
            (2.0, 0.25, 0.25),
        ),
        ({}, None),
    ],
)
def test_an_ome_tiff_stack_gives_its_physical_sizes(tmp_path, sizes, expected):
    """OME-TIFF (Bio-Formats' export, Fiji's among them) says the voxel size in its XML."""
    path = tmp_path / "stack.ome.tif"
    tifffile.imwrite(path, DATA, ome=True, metadata={"axes": "ZYX", **sizes})
    volume = read_volume(path)
    assert_array_equal(volume.data, DATA)
    if expected is None:
        assert volume.spacing is None
    else:
        assert_allclose(volume.spacing, expected, rtol=1e-12)


@pytest.mark.parametrize(
    ("dtype", "channels", "axes"),
    [("uint16", 2, "ZCYX"), ("float32", 4, "ZCYX"), ("uint8", 3, "ZYXS"), ("uint16", 3, "ZCYX")],
)
def test_channels_are_written_as_fiji_reads_them_with_the_spacing(tmp_path, dtype, channels, axes):
    """A volume of channels is an ImageJ hyperstack (Z, C, Y, X), or an RGB stack for 3
    channels of uint8, with its calibration: Fiji opens it as channels of a stack."""
    data = (np.random.default_rng(2).random((4, 5, 6, channels)) * 200).astype(dtype)
    path = tmp_path / "channels.tif"
    write_volume(path, data, spacing=(3.0, 0.5, 0.25))
    with tifffile.TiffFile(path) as tiff:
        assert tiff.is_imagej and tiff.series[0].axes == axes
        assert tiff.imagej_metadata["spacing"] == 3.0
        if axes == "ZCYX":
            assert tiff.imagej_metadata["channels"] == channels
    volume = read_volume(path)
    assert volume.spacing == (3.0, 0.5, 0.25)
    assert volume.data.dtype == data.dtype
    assert_array_equal(volume.data, data)


def test_nifti_channels_are_a_vector_dimension_not_time(tmp_path):
    """NIfTI keeps a voxel's components in its 5th dimension (intent vector, the 4th, time,
    of size 1), as ITK writes and reads vector images; a 4th dimension would be time
    points."""
    data = (np.random.default_rng(3).random((4, 5, 6, 3)) * 200).astype(np.float32)
    path = tmp_path / "vectors.nii.gz"
    write_volume(path, data, spacing=(2.0, 1.0, 0.5))
    image = nib.load(path)
    assert image.shape == (6, 5, 4, 1, 3)
    assert image.header.get_intent()[0] == "vector"
    assert_array_equal(np.asanyarray(image.dataobj)[:, :, :, 0, :], data.transpose(2, 1, 0, 3))
    volume = read_volume(path)
    assert_array_equal(volume.data, data)
    assert volume.spacing == (2.0, 1.0, 0.5)
