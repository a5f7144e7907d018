"""Volume files cut short or damaged given to ``glmls warp`` and ``glmls analyze``: a TIFF
stack cut short is one line naming the file and the cut, exit status 2, nothing written (not
warped as its first page, an image, nor as fewer slices); an empty ``.tif`` is named empty,
whatever the handles; a NIfTI file whose header nibabel repairs on reading is warped with
nothing on stderr (nibabel logs its repairs there)."""

from __future__ import annotations

import json
import struct
import subprocess
import sys

import nibabel as nib
import numpy as np
import pytest
import tifffile
from helpers import child_env
from helpers import run_glmls as cli

#: Byte offsets of NIfTI-1 header fields.
PIXDIM, SFORM_CODE, QFORM_CODE = 76, 254, 252


@pytest.fixture
def files(tmp_path):
    stack = (np.arange(6 * 20 * 30) % 251).astype(np.uint8).reshape(6, 20, 30)
    tifffile.imwrite(tmp_path / "whole.tif", stack, imagej=True, metadata={"axes": "ZYX"})
    content = (tmp_path / "whole.tif").read_bytes()
    (tmp_path / "cut.tif").write_bytes(content[: len(content) // 2])  # a copy cut short
    (tmp_path / "empty.tif").write_bytes(b"")
    src3 = [[2, 2, 1], [20, 2, 1], [2, 15, 1], [2, 2, 4]]
    (tmp_path / "h3.json").write_text(json.dumps({"src": src3, "dst": src3}))
    src2 = [[2, 2], [20, 2], [2, 15]]
    (tmp_path / "h2.json").write_text(json.dumps({"src": src2, "dst": src2}))
    (tmp_path / "out").mkdir()
    return tmp_path


@pytest.mark.parametrize(
    "args",
    [
        ("warp", "cut.tif", "out/o.tif", "--handles", "h3.json"),
        ("warp", "cut.tif", "out/o.tif", "--handles", "h2.json"),  # was warped as an image
        ("analyze", "cut.tif", "--out", "out/a", "--handles", "h3.json"),
        ("analyze", "cut.tif", "--out", "out/a", "--handles", "h2.json"),
    ],
)
def test_a_stack_cut_short_is_one_line_and_nothing_written(files, args):
    result = cli(*args, cwd=files)
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith(f"glmls {args[0]}: cut.tif: not a readable TIFF file: cut short")
    assert "page 0 links to a next page" in lines[0]
    assert not list((files / "out").iterdir())


@pytest.mark.parametrize("handles", ["h3.json", "h2.json"])
def test_an_empty_tif_is_named_empty_not_an_image_for_3d_handles(files, handles):
    result = cli("warp", "empty.tif", "out/o.tif", "--handles", handles, cwd=files)
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert lines == ["glmls warp: empty.tif: an empty file (0 bytes), not a TIFF file"], lines
    assert not list((files / "out").iterdir())


def _repaired_nifti(path) -> None:
    """An int16 NIfTI file of pixdim[1] 0 and no sform or qform, which nibabel reads with a
    voxel size of 1, logging the repair."""
    data = np.arange(8 * 10 * 12, dtype=np.int16).reshape(8, 10, 12)  # (i, j, k)
    content = bytearray(nib.Nifti1Image(data, np.eye(4)).to_bytes())
    struct.pack_into("<f", content, PIXDIM + 4, 0.0)
    struct.pack_into("<h", content, SFORM_CODE, 0)
    struct.pack_into("<h", content, QFORM_CODE, 0)
    path.write_bytes(bytes(content))


def test_nibabel_s_repairs_are_not_printed_by_read_volume(tmp_path):
    _repaired_nifti(tmp_path / "repaired.nii")
    code = (
        "from glmls.files import read_volume\n"
        "for _ in range(2):\n"
        "    assert read_volume('repaired.nii').spacing == (1.0, 1.0, 1.0)\n"
    )
    result = subprocess.run(
        [sys.executable, "-c", code],
        cwd=tmp_path,
        env=child_env(),
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 0, result.stderr
    assert result.stderr == ""  # not "pixdim[1,2,3] should be non-zero; setting 0 dims to 1"


def test_a_repaired_nifti_is_warped_quietly(files):
    _repaired_nifti(files / "repaired.nii")
    result = cli("warp", "repaired.nii", "out/o.nii", "--handles", "h3.json", "--quiet", cwd=files)
    assert result.returncode == 0, result.stderr
    assert result.stderr == ""
    assert nib.load(files / "out" / "o.nii").shape == (8, 10, 12)  # (i, j, k) as read
