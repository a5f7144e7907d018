"""NIfTI header fields carried through a read and a write (the codes, units, description,
a time series's layout), and TIFFs of one 2D image's channels or time points refused."""

from __future__ import annotations

import re

import nibabel as nib
import numpy as np
import pytest
import tifffile
from numpy.testing import assert_allclose, assert_array_equal

from glmls.errors import InputFileError
from glmls.files import NiftiHeader, Volume, read_volume, write_volume
from glmls.files.volumes import is_volume_file

AFFINE = np.array(
    [[-0.9, 0.0, 0.0, 40.0], [0.0, 1.2, 0.0, -10.0], [0.0, 0.0, 1.5, 5.0], [0, 0, 0, 1]]
)


def _mni(path, data=None):
    data = np.arange(60, dtype=np.int16).reshape(5, 4, 3) if data is None else data
    image = nib.Nifti1Image(data, AFFINE)
    image.set_sform(AFFINE, code=4)
    image.set_qform(AFFINE, code=2)
    image.header.set_xyzt_units("mm", "sec")
    image.header["descrip"] = b"an atlas"
    nib.save(image, path)


@pytest.mark.parametrize("suffix", [".nii", ".nii.gz"])
def test_codes_units_and_description_are_written_back(tmp_path, suffix):
    _mni(tmp_path / f"in{suffix}")
    volume = read_volume(tmp_path / f"in{suffix}")
    assert volume.nifti == NiftiHeader(4, 2, 2 + 8, "an atlas")
    write_volume(tmp_path / f"out{suffix}", volume)
    header = nib.load(tmp_path / f"out{suffix}").header
    assert (int(header["sform_code"]), int(header["qform_code"])) == (4, 2)
    assert header.get_xyzt_units() == ("mm", "sec") and header["descrip"] == b"an atlas"
    assert_array_equal(read_volume(tmp_path / f"out{suffix}").affine, volume.affine)


def test_codes_of_zero_stay_zero(tmp_path):
    """A file of no sform (code 0) and a qform: written back so, not as a scanner sform."""
    image = nib.Nifti1Image(np.zeros((3, 4, 5), np.uint8), AFFINE)
    image.set_sform(AFFINE, code=0)
    image.set_qform(AFFINE, code=1)
    nib.save(image, tmp_path / "q.nii")
    write_volume(tmp_path / "out.nii", read_volume(tmp_path / "q.nii"))
    header = nib.load(tmp_path / "out.nii").header
    assert (int(header["sform_code"]), int(header["qform_code"])) == (0, 1)


def test_another_affine_or_no_header_is_written_with_code_1(tmp_path):
    _mni(tmp_path / "in.nii")
    volume = read_volume(tmp_path / "in.nii")
    write_volume(tmp_path / "moved.nii", volume, affine=np.eye(4))
    write_volume(tmp_path / "bare.nii", volume.data)
    for name in ("moved.nii", "bare.nii"):
        header = nib.load(tmp_path / name).header
        assert (int(header["sform_code"]), int(header["qform_code"])) == (1, 1)
    assert nib.load(tmp_path / "moved.nii").header["descrip"] == b"an atlas"


def test_a_sheared_affine_of_no_sform_code_keeps_its_world_in_the_sform(tmp_path):
    shear = np.array([[1.0, 0.3, 0, 2], [0, 1, 0, 3], [0, 0, 2, 1], [0, 0, 0, 1]])
    volume = Volume(np.zeros((3, 4, 5), np.uint8), affine=shear, nifti=NiftiHeader(0, 2))
    write_volume(tmp_path / "s.nii", volume)
    header = nib.load(tmp_path / "s.nii").header
    assert (int(header["sform_code"]), int(header["qform_code"])) == (2, 0)
    assert_allclose(read_volume(tmp_path / "s.nii").affine, shear, rtol=0, atol=1e-6)


def test_a_time_series_is_written_back_as_it_was_read(tmp_path):
    """(i, j, k, T), pixdim[4] the time step: T channels, written back 4D with that step,
    not as a 5D vector image of T channels."""
    series = np.arange(12 * 10 * 8 * 6, dtype=np.int16).reshape(12, 10, 8, 6)
    image = nib.Nifti1Image(series, AFFINE)
    image.header.set_xyzt_units("mm", "sec")
    image.header["pixdim"][4] = 2.5
    nib.save(image, tmp_path / "bold.nii.gz")
    volume = read_volume(tmp_path / "bold.nii.gz")
    assert volume.shape == (8, 10, 12, 6) and volume.nifti.time_step == 2.5
    write_volume(tmp_path / "out.nii.gz", volume)
    back = nib.load(tmp_path / "out.nii.gz")
    assert back.header["dim"][:6].tolist() == [4, 12, 10, 8, 6, 1]
    assert back.header["pixdim"][4] == 2.5 and back.header.get_intent()[0] == "none"
    assert back.header.get_xyzt_units() == ("mm", "sec")
    assert_array_equal(np.asanyarray(back.dataobj), series)


def test_channels_stay_the_vector_dimension(tmp_path):
    write_volume(tmp_path / "v.nii", np.zeros((3, 4, 5, 2), np.float32))
    volume = read_volume(tmp_path / "v.nii")
    assert volume.nifti.time_step is None
    write_volume(tmp_path / "w.nii", volume)
    header = nib.load(tmp_path / "w.nii").header
    assert header["dim"][:6].tolist() == [5, 5, 4, 3, 1, 2]
    assert header.get_intent()[0] == "vector"


def test_other_formats_carry_no_header(tmp_path):
    write_volume(tmp_path / "v.npy", np.zeros((3, 4, 5), np.uint8))
    assert read_volume(tmp_path / "v.npy").nifti is None


@pytest.mark.parametrize(
    ("fields", "error", "message"),
    [
        ({"sform_code": -1}, ValueError, r"sform_code must be in 0\.\.32767"),
        ({"qform_code": 1.0}, TypeError, "qform_code must be an integer"),
        ({"xyzt_units": 256}, ValueError, r"xyzt_units must be in 0\.\.255"),
        ({"descrip": "x" * 81}, ValueError, "at most 80 characters"),
        ({"descrip": "\u2192"}, ValueError, "Latin-1"),
        ({"time_step": float("nan")}, ValueError, "time_step must be a finite number"),
        ({"time_step": "0.5"}, TypeError, "time_step must be a finite number"),
    ],
)
def test_nifti_header_is_checked(fields, error, message):
    with pytest.raises(error, match=message):
        NiftiHeader(**fields)


def test_volume_takes_only_a_nifti_header():
    with pytest.raises(TypeError, match="nifti must be a NiftiHeader, got dict"):
        Volume(np.zeros((2, 2, 2)), nifti={"sform_code": 4})


@pytest.mark.parametrize(
    ("axes", "message"),
    [
        ("CYX", r"axes CYX \(3, 20, 24\), 3 channels of a 2D image, not a volume"),
        ("TYX", r"axes TYX \(3, 20, 24\), 3 time points of a 2D image, not a volume"),
    ],
)
def test_a_tiff_of_one_2d_images_channels_or_time_points_is_refused(tmp_path, axes, message):
    path = tmp_path / f"{axes}.tif"
    tifffile.imwrite(path, np.zeros((3, 20, 24), np.uint8), imagej=True, metadata={"axes": axes})
    for read in (read_volume, is_volume_file):
        with pytest.raises(InputFileError) as info:
            read(path)
        assert str(info.value).startswith(f"{path}: a TIFF of axes")
        assert "\n" not in str(info.value)
        assert re.search(message, str(info.value))


def test_an_ome_tiff_of_channels_and_time_points_is_refused(tmp_path):
    path = tmp_path / "tc.ome.tif"
    tifffile.imwrite(path, np.zeros((2, 3, 20, 24), np.uint8), metadata={"axes": "TCYX"})
    with pytest.raises(InputFileError, match=r"axes TCYX \(2, 3, 20, 24\), 2 time points"):
        read_volume(path)


def test_pages_that_no_metadata_names_stay_a_stack(tmp_path):
    path = tmp_path / "pages.tif"
    with tifffile.TiffWriter(path) as tiff:
        for value in range(3):
            tiff.write(np.full((4, 5), value, np.uint8), metadata=None)
    assert is_volume_file(path)
    assert_array_equal(read_volume(path).data[:, 0, 0], [0, 1, 2])


@pytest.mark.parametrize("suffix", [".nii", ".nii.gz"])
def test_a_qform_other_than_the_sform_is_written_back_as_it_was(tmp_path, suffix):
    """An sform registered to an atlas beside the scanner's qform: both come back."""
    scanner = np.array(
        [[0.0, -1.0, 0.0, 30.0], [1.0, 0.0, 0.0, -20.0], [0.0, 0.0, 2.0, 4.0], [0, 0, 0, 1]]
    )
    image = nib.Nifti1Image(np.arange(60, dtype=np.int16).reshape(5, 4, 3), None)
    image.set_sform(AFFINE, code=4)
    image.set_qform(scanner, code=1)
    nib.save(image, tmp_path / f"in{suffix}")
    volume = read_volume(tmp_path / f"in{suffix}")
    assert_allclose(volume.affine, AFFINE, atol=1e-6)
    assert_allclose(volume.nifti.qform, scanner, atol=1e-6)
    write_volume(tmp_path / f"out{suffix}", volume)
    header = nib.load(tmp_path / f"out{suffix}").header
    sform, scode = header.get_sform(coded=True)
    qform, qcode = header.get_qform(coded=True)
    assert (int(scode), int(qcode)) == (4, 1)
    assert_allclose(sform, AFFINE, atol=1e-6)
    assert_allclose(qform, scanner, atol=1e-6)
    assert read_volume(tmp_path / f"out{suffix}").nifti == volume.nifti


def test_the_qform_goes_with_its_own_affine_only(tmp_path):
    """Another affine given to write_volume is another world: written as both forms."""
    image = nib.Nifti1Image(np.zeros((3, 4, 5), np.uint8), None)
    image.set_sform(AFFINE, code=2)
    image.set_qform(np.eye(4), code=1)
    nib.save(image, tmp_path / "in.nii")
    moved = np.diag([2.0, 2.0, 2.0, 1.0])
    write_volume(tmp_path / "out.nii", read_volume(tmp_path / "in.nii"), affine=moved)
    header = nib.load(tmp_path / "out.nii").header
    assert_allclose(header.get_qform(), moved, atol=1e-6)
    assert_allclose(header.get_sform(), moved, atol=1e-6)


def test_a_file_whose_forms_agree_carries_no_qform(tmp_path):
    _mni(tmp_path / "in.nii")
    assert read_volume(tmp_path / "in.nii").nifti.qform is None


def test_a_qform_must_be_a_finite_4_by_4_matrix():
    with pytest.raises(ValueError, match=r"qform must be a finite 4 x 4 matrix, got \(3, 3\)"):
        NiftiHeader(qform=np.eye(3))
    with pytest.raises(ValueError, match="qform must be a finite"):
        NiftiHeader(qform=np.full((4, 4), np.nan))
