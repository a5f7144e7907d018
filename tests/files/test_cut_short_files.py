"""Volume files cut short, misnamed or repaired on reading: a TIFF stack whose chain of pages
breaks off is refused (not read as its first pages, or as an image), an empty ``.tif`` is
named as empty, a gzip stream named ``.nii`` and a plain NIfTI named ``.nii.gz`` are named
as such, and nibabel's header repairs are not printed."""

from __future__ import annotations

import gzip
import logging
import struct

import nibabel as nib
import numpy as np
import pytest
import tifffile

from glmls.errors import InputFileError
from glmls.files import read_volume
from glmls.files.volumes import is_volume_file

#: Byte offsets of NIfTI-1 header fields.
PIXDIM, SFORM_CODE, QFORM_CODE = 76, 254, 252
STACK = (np.arange(6 * 20 * 30) % 251).astype(np.uint8).reshape(6, 20, 30)


def _stack(path, layout: str) -> bytes:
    """A 6-slice uint8 stack as ImageJ's layout, tifffile's shaped one, or a page at a time
    with no metadata; its bytes."""
    if layout == "imagej":
        tifffile.imwrite(path, STACK, imagej=True, metadata={"axes": "ZYX"})
    elif layout == "shaped":
        tifffile.imwrite(path, STACK)
    else:
        with tifffile.TiffWriter(path) as tiff:
            for page in STACK:
                tiff.write(page, photometric="minisblack", metadata=None)
    return path.read_bytes()


@pytest.mark.parametrize("layout", ["imagej", "shaped", "plain"])
@pytest.mark.parametrize("kept", [0.2, 0.5, 0.9])
def test_a_stack_cut_short_is_refused(tmp_path, layout, kept):
    content = _stack(tmp_path / "whole.tif", layout)
    path = tmp_path / "cut.tif"
    path.write_bytes(content[: int(len(content) * kept)])
    # read before as one page (an image) or fewer slices; now it names the file and the cut
    with pytest.raises(InputFileError, match=r"cut\.tif: not a readable") as info:
        if is_volume_file(path):
            read_volume(path)
    assert "\n" not in str(info.value)
    if layout != "plain" or kept > 0.2:  # a plain stack cut in its first page: no IFD
        assert "cut short or damaged" in str(info.value) or "failed to read" in str(info.value)


@pytest.mark.parametrize("layout", ["imagej", "shaped"])
def test_the_break_in_the_chain_is_named(tmp_path, layout):
    content = _stack(tmp_path / "whole.tif", layout)
    path = tmp_path / "cut.tif"
    path.write_bytes(content[: len(content) // 2])
    message = r"cut\.tif: .*cut short or damaged: page 0 links to a next page at byte \d+, "
    with pytest.raises(InputFileError, match=message + r"past the file's end \(\d+ bytes\)"):
        is_volume_file(path)


def _plain_stack_and_ifds(path) -> tuple[bytearray, list[int]]:
    _stack(path, "plain")
    with tifffile.TiffFile(path) as tiff:
        offsets = [page.offset for page in tiff.pages]
    return bytearray(path.read_bytes()), offsets


def test_a_page_of_tags_past_the_end_is_refused(tmp_path):
    path = tmp_path / "damaged.tif"
    content, offsets = _plain_stack_and_ifds(path)
    struct.pack_into("<H", content, offsets[1], 0xFFFF)  # its tag count: past the end
    path.write_bytes(bytes(content))
    with pytest.raises(InputFileError, match=r"the tags of page 1 run past the file's end"):
        is_volume_file(path)
    with pytest.raises(InputFileError, match=r"the tags of page 1 run past"):
        read_volume(path)


def test_a_loop_of_pages_is_refused(tmp_path):
    path = tmp_path / "loop.tif"
    content, offsets = _plain_stack_and_ifds(path)
    (count,) = struct.unpack_from("<H", content, offsets[-1])
    struct.pack_into("<I", content, offsets[-1] + 2 + 12 * count, offsets[2])
    path.write_bytes(bytes(content))
    with pytest.raises(InputFileError, match=r"loop\.tif: .*page 5 links back to page 2"):
        read_volume(path)


@pytest.mark.parametrize("layout", ["imagej", "shaped", "plain"])
def test_a_whole_stack_still_reads(tmp_path, layout):
    path = tmp_path / "whole.tif"
    _stack(path, layout)
    assert is_volume_file(path)
    np.testing.assert_array_equal(read_volume(path).data, STACK)


def test_a_single_page_tiff_is_still_an_image(tmp_path):
    path = tmp_path / "one.tif"
    tifffile.imwrite(path, STACK[0])
    assert not is_volume_file(path)


def test_an_empty_tif_is_named_empty(tmp_path):
    path = tmp_path / "empty.tif"
    path.write_bytes(b"")
    with pytest.raises(InputFileError, match=r"empty\.tif: an empty file \(0 bytes\)"):
        is_volume_file(path)


def _nifti_bytes() -> bytes:
    data = np.arange(24, dtype=np.int16).reshape(4, 3, 2)
    return nib.Nifti1Image(data, np.diag([2.0, 3.0, 4.0, 1.0])).to_bytes()


def test_a_gzip_stream_named_nii_is_named_so(tmp_path):
    path = tmp_path / "volume.nii"
    path.write_bytes(gzip.compress(_nifti_bytes()))
    with pytest.raises(InputFileError, match=r"volume\.nii: a gzip-compressed file named \.nii"):
        read_volume(path)


def test_a_plain_nifti_named_nii_gz_is_named_so(tmp_path):
    path = tmp_path / "volume.nii.gz"
    path.write_bytes(_nifti_bytes())
    with pytest.raises(InputFileError, match=r"volume\.nii\.gz: not gzip-compressed"):
        read_volume(path)


def test_other_content_named_nii_gz_keeps_nibabel_s_reason(tmp_path):
    path = tmp_path / "text.nii.gz"
    path.write_text("not a volume\n")
    with pytest.raises(InputFileError, match=r"text\.nii\.gz: not a NIfTI file: .*not a gzip"):
        read_volume(path)


def _repaired(fields: dict) -> bytes:
    """A NIfTI file of header fields that nibabel repairs on reading (and logs)."""
    content = bytearray(_nifti_bytes())
    for offset, (form, values) in fields.items():
        struct.pack_into(form, content, offset, *values)
    return bytes(content)


@pytest.mark.parametrize(
    ("fields", "spacing"),
    [
        # pixdim 0 (set to 1), no sform or qform: the voxel size nibabel reads
        ({PIXDIM + 4: ("<f", (0.0,)), SFORM_CODE: ("<h", (0,)), QFORM_CODE: ("<h", (0,))}, 1.0),
        ({PIXDIM + 4: ("<f", (-2.0,)), SFORM_CODE: ("<h", (0,)), QFORM_CODE: ("<h", (0,))}, 2.0),
        ({SFORM_CODE: ("<h", (-1,))}, None),  # an invalid code, set to 0
    ],
)
@pytest.mark.parametrize("suffix", [".nii", ".nii.gz"])
def test_nibabel_s_repairs_are_not_printed(tmp_path, capfd, fields, spacing, suffix):
    content = _repaired(fields)
    path = tmp_path / f"repaired{suffix}"
    path.write_bytes(gzip.compress(content) if suffix == ".nii.gz" else content)
    logger = nib.imageglobals.logger
    handlers = list(logger.handlers)
    for _ in range(2):  # the second read as quiet as the first
        volume = read_volume(path)
        assert capfd.readouterr().err == ""
    if spacing is not None:
        assert volume.spacing[2] == spacing  # dx, pixdim[1]
    # nibabel's logger is left as it was: its handlers, and enabled
    assert logger.handlers == handlers and not logger.disabled


def test_nibabel_s_logger_is_its_own_after_a_read(tmp_path, caplog):
    path = tmp_path / "repaired.nii"
    path.write_bytes(_repaired({PIXDIM + 4: ("<f", (0.0,)), SFORM_CODE: ("<h", (0,))}))
    read_volume(path)
    with caplog.at_level(logging.WARNING, logger=nib.imageglobals.logger.name):
        nib.imageglobals.logger.warning("its own message")
    assert "its own message" in caplog.text
