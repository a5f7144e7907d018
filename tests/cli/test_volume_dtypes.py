"""``glmls analyze`` takes every volume dtype ``glmls warp`` takes: a mask (bool) or an
int64 volume is warped as float32 and analysed, never a traceback or a silently missing
deformed volume."""

from __future__ import annotations

import json

import numpy as np
import pytest
from helpers import run_glmls

SRC = [[2, 2, 2], [11, 2, 2], [2, 9, 2], [2, 2, 7], [11, 9, 7], [6, 6, 4]]
DST = [*SRC[:5], [7, 5, 4]]


@pytest.mark.parametrize("dtype", ["bool", "int64", "int16", "float64"])
def test_analyze_takes_the_dtypes_that_warp_takes(tmp_path, dtype):
    rng = np.random.default_rng(0)
    volume = rng.integers(0, 2 if dtype == "bool" else 200, (10, 12, 14)).astype(dtype)
    np.save(tmp_path / "v.npy", volume)
    (tmp_path / "h3.json").write_text(json.dumps({"src": SRC, "dst": DST}))
    warped = run_glmls("warp", "v.npy", "w.npy", "--handles", "h3.json", cwd=tmp_path)
    assert warped.returncode == 0, warped.stderr
    assert np.load(tmp_path / "w.npy").dtype == volume.dtype
    result = run_glmls(
        "analyze", "v.npy", "--handles", "h3.json", "--out", "rep", cwd=tmp_path, module="glmls.cli"
    )
    assert result.returncode == 0, result.stderr
    assert "Traceback" not in result.stderr
    assert "no deformed volume" not in result.stderr
    summary = json.loads((tmp_path / "rep" / "report.json").read_text())
    assert summary["deformed"] is True
    assert (tmp_path / "rep" / "deformed.png").exists()


@pytest.mark.parametrize("content", [b"II*\x00garbage", b"II*\x00\x08\x00\x00\x00\x00\x00"])
@pytest.mark.parametrize("command", ["warp", "analyze"])
def test_an_unreadable_tiff_is_one_line(tmp_path, content, command):
    """A corrupt TIFF given with 3D handles: one line naming the file (not tifffile's log
    lines), as unreadable where it has no page (not as a file of images)."""
    (tmp_path / "v.tif").write_bytes(content)
    (tmp_path / "h3.json").write_text(json.dumps({"src": SRC, "dst": DST}))
    out = ["w.tif"] if command == "warp" else ["--out", "rep"]
    result = run_glmls(command, "v.tif", *out, "--handles", "h3.json", cwd=tmp_path)
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert "v.tif" in lines[0], lines[0]
    if content.endswith(b"garbage"):  # no page at all (the other's first page is an image's)
        assert "not a readable TIFF" in lines[0], lines[0]


@pytest.mark.parametrize("command", ["warp", "analyze"])
def test_a_complex_volume_is_refused_in_one_line(tmp_path, command):
    """Complex voxels are no real volume: refused, not warped with their imaginary parts
    silently dropped."""
    np.save(tmp_path / "v.npy", np.full((4, 5, 6), 1 + 2j, np.complex64))
    (tmp_path / "h3.json").write_text(json.dumps({"src": SRC, "dst": DST}))
    out = ["w.npy"] if command == "warp" else ["--out", "rep"]
    result = run_glmls(command, "v.npy", *out, "--handles", "h3.json", cwd=tmp_path)
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "complex64" in lines[0], result.stderr


def test_a_volume_of_one_slice_is_not_written_as_a_tiff(tmp_path):
    """A TIFF of one page reads back as an image: a (1, H, W) volume is refused as a TIFF
    output, in one line, and nothing is written."""
    np.save(tmp_path / "v.npy", np.zeros((1, 12, 14), np.uint8))
    (tmp_path / "h3.json").write_text(json.dumps({"src": SRC, "dst": DST}))
    result = run_glmls("warp", "v.npy", "w.tif", "--handles", "h3.json", cwd=tmp_path)
    assert result.returncode == 2, result.stderr
    assert len(result.stderr.strip().splitlines()) == 1, result.stderr
    assert "one slice" in result.stderr
    assert not (tmp_path / "w.tif").exists()


@pytest.mark.parametrize(
    ("volume", "named"),
    [
        (np.full((4, 5, 6), 2**31 - 1, np.int32), "would round 2147483647"),
        (np.full((4, 5, 6), 2**24 + 1, np.int64), "would round 16777217"),
    ],
)
@pytest.mark.parametrize("command", ["warp", "analyze"])
def test_values_float32_would_change_are_refused_in_one_line(tmp_path, volume, named, command):
    """An int32 volume's largest value was written back as its smallest and 2**24 + 1 as
    2**24: each is refused, naming the file and the value."""
    np.save(tmp_path / "v.npy", volume)
    (tmp_path / "h3.json").write_text(json.dumps({"src": SRC, "dst": SRC}))
    out = ["w.npy"] if command == "warp" else ["--out", "rep"]
    result = run_glmls(command, "v.npy", *out, "--handles", "h3.json", cwd=tmp_path)
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "v.npy" in lines[0] and named in lines[0], result.stderr
    assert not (tmp_path / "w.npy").exists()


@pytest.mark.parametrize(
    ("dtype", "background"),
    [
        ("int16", "nan"),
        ("int16", "40000"),
        ("bool", "2"),
        ("float16", "1e5"),
        ("int32", "16777217"),
    ],
)
def test_a_background_the_volume_s_dtype_cannot_hold_is_refused(tmp_path, dtype, background):
    """The volume is warped as float32: these would be written back as 0, as 32767, as
    True, as inf and as 16777216."""
    np.save(tmp_path / "v.npy", np.ones((4, 5, 6), dtype))
    (tmp_path / "h3.json").write_text(json.dumps({"src": SRC, "dst": DST}))
    result = run_glmls(
        "warp", "v.npy", "w.npy", "--handles", "h3.json", "--background", background, cwd=tmp_path
    )
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and f"v.npy: background {float(background)}" in lines[0], lines
    assert not (tmp_path / "w.npy").exists()


def test_an_int32_volume_keeps_its_largest_value_as_the_background(tmp_path):
    np.save(tmp_path / "v.npy", np.full((4, 5, 6), 7, np.int32))
    moved = [[x + 3, y, z] for x, y, z in SRC]  # the first columns uncovered
    (tmp_path / "h3.json").write_text(json.dumps({"src": SRC, "dst": moved}))
    top = str(2**31 - 1)
    result = run_glmls(
        "warp", "v.npy", "w.npy", "--handles", "h3.json", "--background", top, cwd=tmp_path
    )
    assert result.returncode == 0, result.stderr
    assert "Warning" not in result.stderr
    warped = np.load(tmp_path / "w.npy")
    assert set(np.unique(warped)) == {7, 2**31 - 1}
