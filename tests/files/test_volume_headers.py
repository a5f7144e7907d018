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


def _tmap(path, data=None):
    """A t statistic of 12 degrees of freedom with a display range, an auxiliary file, a
    time offset, and the acquisition's frequency, phase and slice axes and slice timing."""
    data = np.linspace(-4.5, 5.5, 60, dtype=np.float32).reshape(5, 4, 3) if data is None else data
    image = nib.Nifti1Image(data, AFFINE)
    image.set_sform(AFFINE, code=1)
    image.set_qform(AFFINE, code=1)
    header = image.header
    header.set_intent("t test", (12.0,), name="t-map")
    header["cal_min"], header["cal_max"] = -6.0, 6.0
    header["aux_file"] = b"hot.lut"
    header["toffset"] = 1.25
    header.set_dim_info(freq=0, phase=1, slice=2)
    header["slice_code"], header["slice_start"], header["slice_end"] = 3, 0, 2
    header["slice_duration"] = 0.5
    nib.save(image, path)


@pytest.mark.parametrize("suffix", [".nii", ".nii.gz"])
def test_the_intent_display_range_aux_file_and_time_offset_are_written_back(tmp_path, suffix):
    """Kept: what stays true of the values moved in space. Dropped: the slice axis and the
    slice timing, which a warp's moved slices no longer follow."""
    _tmap(tmp_path / f"in{suffix}")
    volume = read_volume(tmp_path / f"in{suffix}")
    kept = NiftiHeader(
        intent_code=3,
        intent_params=(12.0, 0.0, 0.0),
        intent_name="t-map",
        cal_min=-6.0,
        cal_max=6.0,
        aux_file="hot.lut",
        toffset=1.25,
    )
    assert volume.nifti == kept
    write_volume(tmp_path / f"out{suffix}", volume)
    header = nib.load(tmp_path / f"out{suffix}").header
    assert header.get_intent() == ("t test", (12.0,), "t-map")
    assert (float(header["cal_min"]), float(header["cal_max"])) == (-6.0, 6.0)
    assert header["aux_file"] == b"hot.lut" and float(header["toffset"]) == 1.25
    assert header.get_dim_info() == (None, None, None)
    assert int(header["slice_code"]) == int(header["slice_end"]) == 0
    assert float(header["slice_duration"]) == 0.0
    assert read_volume(tmp_path / f"out{suffix}").nifti == kept


def test_a_statistic_of_channels_keeps_its_intent_over_vector(tmp_path):
    """Channels are the 5th dimension, written with intent vector where the volume has no
    intent of its own; one it has (z scores of two contrasts) is written instead."""
    header = NiftiHeader(intent_code=5, intent_name="z")
    write_volume(tmp_path / "z.nii", Volume(np.zeros((3, 4, 5, 2), np.float32), nifti=header))
    written = nib.load(tmp_path / "z.nii").header
    assert written["dim"][:6].tolist() == [5, 5, 4, 3, 1, 2]
    assert written.get_intent() == ("z score", (), "z")


@pytest.mark.parametrize(
    ("shape", "intent", "written"),
    [
        ((5, 4, 3, 1, 3), "displacement vector", "vector"),  # the channels' own intent
        ((5, 4, 3, 1, 3), "vector", "vector"),
        ((5, 4, 3, 1, 6), "symmetric matrix", "vector"),
        ((5, 4, 3), "vector", "none"),
    ],
)
def test_an_intent_of_components_in_space_is_not_carried(tmp_path, shape, intent, written):
    """A warp moves a vector's or a matrix's voxels without turning its components, so the
    intent would no longer describe them: read as none, with its parameters and name."""
    image = nib.Nifti1Image(np.ones(shape, np.float32), AFFINE)
    image.header.set_intent(intent, name="field")
    image.header["cal_min"], image.header["cal_max"] = -1.0, 1.0
    nib.save(image, tmp_path / "field.nii")
    volume = read_volume(tmp_path / "field.nii")
    assert (volume.nifti.intent_code, volume.nifti.intent_name) == (0, "")
    assert (volume.nifti.cal_min, volume.nifti.cal_max) == (-1.0, 1.0)
    write_volume(tmp_path / "out.nii", volume)
    assert nib.load(tmp_path / "out.nii").header.get_intent() == (written, (), "")


def test_a_header_whose_intent_or_display_range_cannot_hold_reads_as_none(tmp_path):
    """A parameter that is not a number, or a display range upside down, means nothing a
    later tool could use: read as none rather than refused."""
    image = nib.Nifti1Image(np.zeros((5, 4, 3), np.int16), AFFINE)
    image.set_sform(AFFINE, code=1)
    image.set_qform(AFFINE, code=1)
    image.header["intent_code"], image.header["intent_p1"] = 3, np.nan
    image.header["cal_min"], image.header["cal_max"] = 5.0, -5.0
    image.header["toffset"] = np.inf
    nib.save(image, tmp_path / "odd.nii")
    assert read_volume(tmp_path / "odd.nii").nifti == NiftiHeader()


@pytest.mark.parametrize(
    ("fields", "error", "message"),
    [
        ({"intent_code": 40000}, ValueError, r"intent_code must be in 0\.\.32767, got 40000"),
        ({"intent_code": 3.0}, TypeError, r"intent_code must be an integer, got 3\.0"),
        ({"intent_params": (12.0,)}, ValueError, "intent_params must be 3 real numbers, got 1"),
        ({"intent_params": 12.0}, TypeError, "intent_params must be 3 real numbers, got 12"),
        ({"intent_params": (1, np.inf, 0)}, ValueError, "intent_p2 must be a finite number"),
        ({"intent_name": "x" * 17}, ValueError, "intent_name holds at most 16 characters"),
        ({"aux_file": "x" * 25}, ValueError, "aux_file holds at most 24 characters, got 25"),
        ({"aux_file": b"hot.lut"}, TypeError, "aux_file must be a str, got bytes"),
        ({"cal_min": 2.0, "cal_max": 1.0}, ValueError, "cal_min 2.0 is above cal_max 1.0"),
        ({"cal_max": float("nan")}, ValueError, "cal_max must be a finite number"),
        ({"toffset": "1"}, TypeError, "toffset must be a finite number"),
    ],
)
def test_the_kept_fields_are_checked(fields, error, message):
    with pytest.raises(error, match=message):
        NiftiHeader(**fields)
