"""Volume files: NIfTI (the axis order and the affine), TIFF stacks (the spacing), .npy; round
trips of every dtype, and bad files named."""

from __future__ import annotations

import gzip
import re
import warnings

import nibabel as nib
import numpy as np
import pytest
import tifffile
from numpy.testing import assert_allclose, assert_array_equal

import glmls
from glmls.errors import InputFileError
from glmls.files.volume_dtypes import check_file_background, in_dtype, warped_as
from glmls.files.volumes import (
    Volume,
    is_volume_file,
    read_volume,
    volume_suffix,
    write_volume,
)

SUFFIXES = (".nii", ".nii.gz", ".tif", ".npy")
#: an affine with the axes permuted and scaled, and a translation
AFFINE = np.array(
    [[0.0, 0.5, 0.0, 10.0], [2.0, 0.0, 0.0, -3.0], [0.0, 0.0, 1.5, 7.0], [0, 0, 0, 1]]
)


@pytest.mark.parametrize("suffix", SUFFIXES)
@pytest.mark.parametrize("dtype", ["uint8", "uint16", "float32", "int16", "float64"])
@pytest.mark.parametrize("channels", [None, 3])
def test_round_trip_keeps_data_and_dtype(tmp_path, suffix, dtype, channels):
    shape = (4, 5, 6) if channels is None else (4, 5, 6, channels)
    data = (np.random.default_rng(1).random(shape) * 200).astype(dtype)
    path = tmp_path / f"v{suffix}"
    write_volume(path, data)
    volume = read_volume(path)
    assert volume.data.dtype == data.dtype
    assert_array_equal(volume.data, data)


@pytest.mark.parametrize("suffix", [".nii", ".nii.gz"])
def test_nifti_keeps_the_affine_and_gives_the_spacing(tmp_path, suffix):
    path = tmp_path / f"v{suffix}"
    write_volume(path, np.zeros((4, 5, 6), np.float32), affine=AFFINE)
    volume = read_volume(path)
    assert_allclose(volume.affine, AFFINE)
    # the columns i, j, k have lengths 2, 0.5, 1.5: (dz, dy, dx) = (1.5, 0.5, 2)
    assert volume.spacing == (1.5, 0.5, 2.0)
    again = tmp_path / f"again{suffix}"
    write_volume(again, volume)  # a Volume brings its affine
    assert_allclose(read_volume(again).affine, AFFINE)


def test_nifti_axis_order_is_transposed_explicitly(tmp_path):
    """NIfTI's voxel (i, j, k) = (x, y, z) is glmls's data[k, j, i], read and written."""
    nifti = np.zeros((6, 5, 4), np.uint8)  # (x, y, z)
    nifti[5, 1, 2] = 7
    path = tmp_path / "made_by_nibabel.nii"
    nib.save(nib.Nifti1Image(nifti, np.eye(4)), path)
    volume = read_volume(path)
    assert volume.shape == (4, 5, 6)
    assert volume.data[2, 1, 5] == 7 and volume.data.sum() == 7
    written = tmp_path / "written.nii"
    write_volume(written, volume)
    back = np.asanyarray(nib.load(written).dataobj)
    assert back.shape == (6, 5, 4) and back[5, 1, 2] == 7


def test_nifti_affine_maps_glmls_points_to_the_world(tmp_path):
    path = tmp_path / "v.nii.gz"
    write_volume(path, np.zeros((4, 5, 6), np.uint8), affine=AFFINE)
    volume = read_volume(path)
    x, y, z = 5.0, 1.0, 2.0  # the voxel data[2, 1, 5]
    world = nib.load(path).affine @ [x, y, z, 1.0]
    assert_allclose(volume.affine @ [x, y, z, 1.0], world)


def test_nifti_spacing_without_affine(tmp_path):
    path = tmp_path / "v.nii"
    write_volume(path, np.zeros((2, 3, 4), np.uint8), spacing=(3.0, 2.0, 0.5))
    volume = read_volume(path)
    assert volume.spacing == (3.0, 2.0, 0.5)
    assert_allclose(np.diag(volume.affine), [0.5, 2.0, 3.0, 1.0])


def test_nifti_gz_is_gzip(tmp_path):
    path = tmp_path / "v.nii.gz"
    write_volume(path, np.ones((2, 2, 2), np.uint8))
    assert gzip.decompress(path.read_bytes())[344:348] == b"n+1\x00"


@pytest.mark.parametrize("dtype", ["uint8", "uint16", "int16", "float32"])
def test_tiff_stack_keeps_the_spacing(tmp_path, dtype):
    path = tmp_path / "stack.tif"
    write_volume(path, np.ones((3, 4, 5), dtype), spacing=(2.0, 0.25, 0.5))
    volume = read_volume(path)
    assert volume.spacing == (2.0, 0.25, 0.5) and volume.affine is None
    assert is_volume_file(path)


def test_tiff_of_one_page_is_an_image_not_a_volume(tmp_path):
    path = tmp_path / "page.tif"
    tifffile.imwrite(path, np.zeros((4, 5), np.uint8))
    assert not is_volume_file(path)
    with pytest.raises(InputFileError, match=r"page\.tif: a TIFF of one page is an image"):
        read_volume(path)


def test_plain_tiff_stack_has_no_spacing(tmp_path):
    path = tmp_path / "plain.tiff"
    tifffile.imwrite(path, np.zeros((3, 4, 5), np.uint16), photometric="minisblack")
    volume = read_volume(path)
    assert volume.shape == (3, 4, 5) and volume.spacing is None


def test_volume_files_are_told_by_suffix():
    assert volume_suffix("a/b.NII.GZ") == ".nii.gz" and volume_suffix("b.nii") == ".nii"
    assert is_volume_file("x.nii.gz") and is_volume_file("x.npy")
    assert not is_volume_file("missing.tif") and not is_volume_file("x.png")


def test_writing_refuses_before_writing(tmp_path):
    with pytest.raises(ValueError, match=r"unknown volume format \.png"):
        write_volume(tmp_path / "v.png", np.zeros((2, 2, 2)))
    with pytest.raises(ValueError, match="only NIfTI files hold an affine"):
        write_volume(tmp_path / "v.tif", np.zeros((2, 2, 2)), affine=np.eye(4))
    with pytest.raises(ValueError, match=r"\(D, H, W\) or \(D, H, W, C\)"):
        write_volume(tmp_path / "v.npy", np.zeros((2, 2)))
    with pytest.raises(ValueError, match=r"spacing must be positive and finite \(dz, dy, dx\)"):
        write_volume(tmp_path / "v.nii", np.zeros((2, 2, 2)), spacing=(1, 0, 1))
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    ("name", "content", "message"),
    [
        ("v.nii", b"not a nifti file at all", "v.nii: not a"),
        ("v.nii.gz", b"\x1f\x8b\x08broken", "v.nii.gz: not a"),
        ("v.npy", b"\x93NUMPY garbage", "v.npy: not a readable .npy volume"),
        ("v.tif", b"II*\x00garbage", "v.tif: not a readable .tif volume"),
        ("v.vtk", b"", "v.vtk: unknown volume format .vtk"),
    ],
)
def test_bad_files_are_named(tmp_path, name, content, message):
    path = tmp_path / name
    path.write_bytes(content)
    with pytest.raises(InputFileError) as info:
        read_volume(path)
    assert str(info.value).startswith(str(path)) and message in str(info.value)


def test_a_2d_array_is_not_a_volume(tmp_path):
    path = tmp_path / "flat.npy"
    np.save(path, np.zeros((4, 5)))
    with pytest.raises(InputFileError, match=r"flat.npy: a 2D array .* are volumes, \(D, H, W\)"):
        read_volume(path)


def test_missing_file(tmp_path):
    with pytest.raises(InputFileError, match=r"nope\.nii\.gz: no such file"):
        read_volume(tmp_path / "nope.nii.gz")


def test_volume_is_public_and_checked():
    assert glmls.Volume is Volume and glmls.read_volume is read_volume
    with pytest.raises(ValueError, match="affine must be a finite 4 x 4"):
        Volume(np.zeros((2, 2, 2)), affine=np.eye(3))
    volume = Volume(np.zeros((2, 2, 2)), affine=np.eye(4))
    assert not volume.affine.flags.writeable


def test_nifti_rgb_records_become_channels(tmp_path):
    rgb = np.zeros((3, 4, 2), dtype=[("R", "u1"), ("G", "u1"), ("B", "u1")])  # (x, y, z)
    rgb["G"][2, 1, 0] = 9
    path = tmp_path / "rgb.nii"
    nib.save(nib.Nifti1Image(rgb, np.eye(4)), path)
    volume = read_volume(path)
    assert volume.shape == (2, 4, 3, 3) and volume.data.dtype == np.uint8
    assert volume.data[0, 1, 2].tolist() == [0, 9, 0]


def test_nifti_takes_int64_and_the_nearest_dtype_for_bool_and_float16(tmp_path):
    path = tmp_path / "v.nii"
    write_volume(path, np.full((2, 3, 4), 2**40, np.int64))
    assert read_volume(path).data.dtype == np.int64 and read_volume(path).data.max() == 2**40
    write_volume(path, np.ones((2, 3, 4), bool))
    assert read_volume(path).data.dtype == np.uint8
    write_volume(path, np.full((2, 3, 4), 0.5, np.float16))
    assert read_volume(path).data.dtype == np.float32


def test_a_volume_of_one_slice_is_refused_as_a_tiff(tmp_path):
    """glmls.read_volume takes a TIFF of one page for an image: writing a (1, H, W) volume
    there would not round-trip."""
    with pytest.raises(ValueError, match="one slice"):
        glmls.write_volume(tmp_path / "one.tif", np.zeros((1, 4, 5), np.uint8))
    assert not (tmp_path / "one.tif").exists()
    glmls.write_volume(tmp_path / "one.npy", np.zeros((1, 4, 5), np.uint8))
    assert glmls.read_volume(tmp_path / "one.npy").shape == (1, 4, 5)


def test_a_singular_affine_is_refused_before_nibabel_sees_it(tmp_path):
    path = tmp_path / "flat.nii"
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # nibabel's warnings must not reach the user either
        with pytest.raises(ValueError, match=r"flat.nii: the affine is singular"):
            glmls.write_volume(path, np.zeros((4, 4, 4), np.uint8), affine=np.diag([1, 1, 0, 1]))
    assert not path.exists()


def test_a_file_without_a_numpy_header_is_named_as_such(tmp_path):
    path = tmp_path / "short.npy"
    path.write_bytes(b"xx")
    with pytest.raises(glmls.InputFileError, match=r"short.npy: not a .npy file"):
        glmls.read_volume(path)


def test_a_volume_is_warped_in_its_dtype_or_float32_and_written_back_in_its_own():
    """``glmls warp`` and the volume window's save warp uint8, uint16 and float32 as they
    are and every other real dtype as float32, which ``in_dtype`` turns back: integers
    rounded and clipped, a mask true from 1/2, float64 cast."""
    for dtype in (np.uint8, np.uint16, np.float32):
        data = np.ones((2, 3, 4), dtype)
        assert warped_as(data) is data
    for dtype in (np.int16, np.int32, np.bool_, np.float64, np.uint32):
        data = np.ones((2, 3, 4), dtype)
        assert warped_as(data).dtype == np.float32
    warped = np.array([-40000.4, -1.5, 0.49, 0.5, 2.5, 70000.0], np.float32)
    np.testing.assert_array_equal(
        in_dtype(warped, np.dtype(np.int16)), [-32768, -2, 0, 0, 2, 32767]
    )
    np.testing.assert_array_equal(
        in_dtype(warped, np.dtype(np.bool_)), [False, False, False, True, True, True]
    )
    assert in_dtype(warped, np.dtype(np.float64)).dtype == np.float64


@pytest.mark.parametrize("dtype", [np.int32, np.int64, np.uint32, np.uint64])
def test_the_largest_integers_are_written_back_clipped_not_wrapped(dtype):
    """float32 rounds int32's largest value up to 2**31: written back it is that largest
    value, not the smallest (the cast of 2**31 to int32 wraps)."""
    info = np.iinfo(dtype)
    warped = np.array([info.max, info.min, 7], np.float32)
    with np.errstate(all="raise"):  # and no overflow on the way
        back = in_dtype(warped, np.dtype(dtype))
    assert back.dtype == dtype
    assert back[0] >= info.max - 2**40 and back[1] == info.min and back[2] == 7


@pytest.mark.parametrize(
    ("values", "dtype", "named"),
    [
        ([0, 2**24 + 1], np.int32, "16777217"),
        ([-(2**31), 5], np.int64, None),  # exact in float32: taken
        ([2**31 - 1], np.int32, "2147483647"),
        ([2**53 + 1], np.int64, "9007199254740993"),
        ([2**64 - 1], np.uint64, "18446744073709551615"),
    ],
)
def test_integers_float32_would_round_are_refused_named(values, dtype, named):
    data = np.array(values, dtype).reshape(1, 1, -1)
    if named is None:
        np.testing.assert_array_equal(warped_as(data, "v.npy"), data)
        return
    with pytest.raises(ValueError, match=rf"v\.npy: .*would round {named}"):
        warped_as(data, "v.npy")


@pytest.mark.parametrize("dtype", [np.float64, np.float16])
def test_floats_beyond_float32_are_kept_for_the_warp_and_infinities_kept(dtype):
    """float64 beyond float32's range was refused; the warp takes it as it is (and divides
    it by a power of two on its way to the GPU)."""
    if dtype == np.float64:
        for extreme in (np.array([[[1.0, -1e300]]]), np.array([[[1e-300, 0.0]]])):
            assert warped_as(extreme, "v.npy") is extreme
    kept = np.array([[[np.inf, -np.inf, np.nan, 1.0]]], dtype)
    np.testing.assert_array_equal(warped_as(kept, "v.npy"), kept.astype(np.float32))


@pytest.mark.parametrize(
    ("background", "dtype", "message"),
    [
        (np.nan, np.int16, r"outside -32768\.\.32767 of int16"),
        (40000.0, np.int16, r"outside -32768\.\.32767 of int16"),
        ((0.0, -1.0), np.uint32, r"outside 0\.\.4294967295 of uint32"),
        (2.0, np.bool_, r"outside 0\.\.1 of bool"),
        (0.5, np.bool_, r"not a value of bool: 0\.5 is no whole number \(give one of 0\.\.1\)"),
        ((1.0, 2.5), np.uint16, r"not a value of uint16: 2\.5 is no whole number"),
        (1e5, np.float16, r"beyond the range of float16"),
        (1e39, np.float32, r"beyond the range of float32 \(±3\.403e\+38\)"),
        (2.0**24 + 1, np.int32, r"float32 \(the GPU's\) would round 16777217 to 16777216"),
        ((0.0, -(2.0**31) + 1), np.int64, r"would round -2147483647 to -2147483648"),
    ],
)
def test_a_background_the_file_s_dtype_cannot_hold_is_refused(background, dtype, message):
    with pytest.raises(ValueError, match=r"v\.npy: background .*" + message):
        check_file_background(background, np.dtype(dtype), "v.npy")


@pytest.mark.parametrize(
    ("background", "dtype"),
    [
        (-32768.0, np.int16),
        ((0.0, 1.0), np.bool_),
        (np.inf, np.float16),
        (np.nan, np.float64),
        (2.0**24, np.int32),
        (2.0**24 + 2, np.int32),  # float32 holds it
        (-(2.0**31), np.int32),
        (2.0**31 - 1, np.int32),  # float32 rounds it up, and the write clips it back
        (2.0**32 - 1, np.uint32),
    ],
)
def test_a_background_the_file_s_dtype_holds_is_taken(background, dtype):
    check_file_background(background, np.dtype(dtype), "v.npy")


@pytest.mark.parametrize("dtype", [np.complex128, bool, object])
def test_an_affine_of_no_real_numbers_is_refused_not_cast(dtype):
    """A complex affine would lose its imaginary part in a cast to float64, a bool one
    would be a 0/1 matrix by accident."""
    with pytest.raises(
        TypeError, match=rf"affine must be real numbers, got dtype {np.dtype(dtype)}"
    ):
        Volume(np.zeros((2, 3, 4), np.uint8), affine=np.eye(4).astype(dtype))


def test_world_points_and_affines_of_any_layout_and_byte_order_map_alike():
    points = np.array([[1.0, 2.0, 3.0], [4.0, -5.0, 6.5]])
    expected = glmls.files.world_to_volume(points, AFFINE)
    given = np.asfortranarray(points.astype(">f8")), AFFINE[::-1][::-1].astype(">f4").tolist()
    assert_allclose(glmls.files.world_to_volume(*given), expected, rtol=0, atol=1e-9)
    back = glmls.files.volume_to_world(expected.astype(">f8"), np.asfortranarray(AFFINE))
    assert_allclose(back, points, rtol=0, atol=1e-9)


@pytest.mark.parametrize("convert", [glmls.files.world_to_volume, glmls.files.volume_to_world])
@pytest.mark.parametrize("row", [[0.0, 0.0, 0.0, 2.0], [0.5, 0.0, 0.0, 1.0]])
def test_world_conversions_refuse_an_affine_of_another_last_row(convert, row):
    """A projective last row was read as (0, 0, 0, 1): the points came back as if it were."""
    affine = AFFINE.copy()
    affine[3] = row
    message = rf"affine's last row must be \(0, 0, 0, 1\), got {re.escape(str(row))}$"
    with pytest.raises(ValueError, match=message):
        convert(np.array([[1.0, 2.0, 3.0]]), affine)


@pytest.mark.parametrize("convert", [glmls.files.world_to_volume, glmls.files.volume_to_world])
@pytest.mark.parametrize(
    ("points", "affine", "lps", "message"),
    [
        ([[1 + 1j, 2, 3]], AFFINE, False, r"points must be real numbers, got dtype complex128"),
        ([[True, False, True]], AFFINE, False, r"points must be real numbers, got dtype bool"),
        ([[1.0, 2, 3]], AFFINE.astype(complex), False, r"affine must be real numbers"),
        ([[1.0, 2, 3]], AFFINE, 1, r"lps must be True or False, got 1"),
        ([[1.0, 2, 3]], AFFINE, "yes", r"lps must be True or False, got 'yes'"),
    ],
)
def test_world_conversions_refuse_what_a_cast_would_change(convert, points, affine, lps, message):
    with pytest.raises(TypeError, match=message):
        convert(np.array(points), affine, lps=lps)
