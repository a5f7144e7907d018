"""``glmls warp`` on float64 files of extreme magnitude (1e300, 1e-300): .npy, NIfTI and TIFF
volumes and TIFF images come back as ``2**k`` times the warp of the file scaled to 1, bit for
bit; a ``--background`` that cannot be held is one line naming it."""

from __future__ import annotations

import json

import nibabel as nib
import numpy as np
import pytest
import tifffile
from helpers import run_glmls

SRC3 = [[1, 1, 1], [6, 1, 1], [1, 5, 1], [1, 1, 4], [6, 5, 4]]
DST3 = [[1.4, 0.7, 1.2], [5.5, 1.3, 1.1], [1.2, 5.4, 0.7], [1.3, 1.1, 4.5], [6, 5, 4]]
SRC2 = [[2, 2], [13, 3], [3, 10]]
DST2 = [[3, 2.5], [12, 4], [3.5, 9]]


def _write(path, data) -> None:
    if path.suffix == ".npy":
        np.save(path, data)
    elif path.name.endswith(".nii.gz"):
        nib.save(nib.Nifti1Image(data.transpose(2, 1, 0), np.eye(4)), path)
    else:
        tifffile.imwrite(path, data)


def _read(path) -> np.ndarray:
    if path.suffix == ".npy":
        return np.load(path)
    if path.name.endswith(".nii.gz"):
        return np.asarray(nib.load(path).dataobj).transpose(2, 1, 0)
    return tifffile.imread(path)


@pytest.mark.parametrize(
    ("suffix", "shape", "handles"),
    [(".npy", (6, 7, 8), (SRC3, DST3)), (".nii.gz", (6, 7, 8), (SRC3, DST3))]
    + [(".tif", (6, 7, 8), (SRC3, DST3)), (".tif", (12, 16), (SRC2, DST2))],
)
def test_float64_files_beyond_float32_warp_as_their_scaled_copy(tmp_path, suffix, shape, handles):
    """The volumes were refused (1e300: "values must lie within float32's range") or came
    back 0 (1e-300), as did the images."""
    data = np.random.default_rng(7).random(shape) + 0.5
    src, dst = handles
    (tmp_path / "h.json").write_text(json.dumps({"src": src, "dst": dst}))
    warped = {}
    for k in (0, 1000, -1000):
        name = f"in{k}{suffix}"
        _write(tmp_path / name, np.ldexp(data, k))
        args = ("warp", name, f"out{k}{suffix}", "--handles", "h.json")
        result = run_glmls(*args, "--interpolation", "linear", cwd=tmp_path)
        assert result.returncode == 0, result.stderr
        warped[k] = _read(tmp_path / f"out{k}{suffix}")
        assert warped[k].dtype == np.float64 and warped[k].shape == shape
    assert np.isfinite(warped[0]).all() and (warped[0] > 0).any()
    for k in (1000, -1000):
        np.testing.assert_array_equal(warped[k], np.ldexp(warped[0], k))


@pytest.mark.parametrize(
    ("k", "background", "message"),
    [
        (0, "1e400", "1e400 is outside float64's range (it would be inf)"),
        (0, "0,1e-400", "1e-400 is outside float64's range (it would be 0)"),
        (1000, "1", "background 1.0 is beyond float32's range beside the values"),
        (0, "1e300", "background 1e+300 is beyond float32's range"),
    ],
)
def test_a_background_that_cannot_be_held_is_one_line(tmp_path, k, background, message):
    """1e400 was read as inf and 1e-400 as 0 without a word."""
    data = np.ldexp(np.random.default_rng(8).random((6, 7, 8, 2)) + 0.5, k)
    np.save(tmp_path / "v.npy", data)
    (tmp_path / "h.json").write_text(json.dumps({"src": SRC3, "dst": DST3}))
    args = ("warp", "v.npy", "w.npy", "--handles", "h.json", "--background", background)
    result = run_glmls(*args, cwd=tmp_path)
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and message in lines[0], result.stderr
    assert not (tmp_path / "w.npy").exists()
