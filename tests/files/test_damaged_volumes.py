"""Damaged volume files: NIfTI headers whose shape, dtype or data offset the file cannot
hold are refused naming the file, on one line, before any data is read or allocated."""

from __future__ import annotations

import gzip
import struct

import nibabel as nib
import numpy as np
import pytest

from glmls.errors import InputFileError
from glmls.files import read_volume
from glmls.files.volumes import write_volume

#: Byte offsets of NIfTI-1 header fields.
DIM, DATATYPE, VOX_OFFSET = 40, 70, 108


def _nifti(fields: dict | None = None) -> bytes:
    """A small int16 NIfTI-1 file's bytes, with header fields replaced: offset -> (format,
    values)."""
    data = np.arange(2400, dtype=np.int16).reshape(40, 30, 2)
    content = bytearray(nib.Nifti1Image(data, np.eye(4)).to_bytes())
    for offset, (form, values) in (fields or {}).items():
        struct.pack_into(form, content, offset, *values)
    return bytes(content)


@pytest.mark.parametrize("suffix", [".nii", ".nii.gz"])
@pytest.mark.parametrize(
    ("fields", "message"),
    [
        ({DIM + 2: ("<hhh", (30000, 30000, 30000))}, r"need 54000000000352 bytes"),
        ({DIM + 2: ("<hhh", (300, 300, 300))}, r"\(300, 300, 300\) voxels of int16 need"),
        ({DIM + 2: ("<h", (-5,))}, r"its header's shape \(-5, 30, 2\)"),
        ({VOX_OFFSET: ("<f", (1e9,))}, r"need 1000004800 bytes"),
        ({DATATYPE: ("<h", (77,))}, r"not a NIfTI file: data code 77"),
        ({DIM: ("<h", (9,))}, r"not a NIfTI file"),
    ],
)
def test_a_header_the_file_cannot_hold_is_refused(tmp_path, capfd, suffix, fields, message):
    content = _nifti(fields)
    path = tmp_path / f"damaged{suffix}"
    path.write_bytes(gzip.compress(content) if suffix == ".nii.gz" else content)
    with pytest.raises(InputFileError, match=message) as info:
        read_volume(path)
    assert str(info.value).startswith(f"{path}: ") and "\n" not in str(info.value)
    assert capfd.readouterr().err == ""  # nibabel's repairs are not logged


def test_a_truncated_file_is_named_on_one_line(tmp_path):
    path = tmp_path / "cut.nii"
    path.write_bytes(_nifti()[:1000])
    with pytest.raises(InputFileError, match=r"cut\.nii: .* need 5152 bytes, the file has 1000"):
        read_volume(path)


def test_an_intact_file_still_reads(tmp_path):
    data = np.arange(60, dtype=np.int16).reshape(3, 4, 5)
    for name in ("v.nii", "v.nii.gz"):
        write_volume(tmp_path / name, data)
        np.testing.assert_array_equal(read_volume(tmp_path / name).data, data)


def _sform(affine: np.ndarray, *, qform: bool) -> bytes:
    """An int16 NIfTI-1 file whose sform (code 1) is ``affine``, beside a valid qform or none."""
    header = nib.Nifti1Header()
    header.set_data_dtype(np.int16)
    header.set_data_shape((5, 4, 3))
    header.set_qform(np.diag([2.0, 2.0, 2.0, 1.0]), code=1 if qform else 0)
    header["srow_x"], header["srow_y"], header["srow_z"] = affine[:3]
    header["sform_code"] = 1
    return nib.Nifti1Image(np.zeros((5, 4, 3), np.int16), None, header=header).to_bytes()


@pytest.mark.parametrize("qform", [False, True])
@pytest.mark.parametrize(
    ("column", "message"),
    [
        ([np.nan, 0.0, 0.0], "holds a value that is not finite"),
        ([0.0, 0.0, 0.0], "gives a voxel axis of length 0"),
        ([1.0, 0.0, 0.0], r"is singular \(its voxel axes lie in one plane\)"),  # that of i
    ],
)
def test_an_affine_of_no_world_place_is_refused_naming_its_field(tmp_path, qform, column, message):
    """An sform that is not finite, has an axis of length 0 or is singular is refused on
    one line naming the field, not as a spacing nobody gave, nor after a warp whose output
    could not be written with it."""
    affine = np.eye(4)
    affine[:3, 2] = column
    path = tmp_path / "bad.nii"
    path.write_bytes(_sform(affine, qform=qform))
    expected = rf"bad\.nii: not a readable NIfTI file: the affine of its sform .* {message}$"
    with pytest.raises(InputFileError, match=expected):
        read_volume(path)
