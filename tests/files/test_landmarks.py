"""Handle and reference-point files: every format, and malformed files named precisely."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from helpers import assert_bad_handle_file, write_text
from numpy.testing import assert_allclose

from glmls.errors import InputFileError
from glmls.files import atomic_write, read_handles, read_points, write_handles


def test_json_csv_and_bigwarp_handles(tmp_path):
    src, dst = np.array([[1.0, 2.0], [3.5, 4.0]]), np.array([[1.5, 2.0], [3.0, 5.0]])
    for name in ("h.json", "h.csv"):
        write_handles(tmp_path / name, src, dst)
        got = read_handles(tmp_path / name)
        assert_allclose(got[0], src)
        assert_allclose(got[1], dst)
    bigwarp = write_text(
        tmp_path,
        "landmarks.csv",
        '"Pt-0","true","1.0","2.0","1.5","2.0"\n'
        '"Pt-1","false","9","9","9","9"\n'
        '"Pt-2","true","3.5","4.0","3.0","5.0"\n',
    )
    got = read_handles(bigwarp)
    assert_allclose(got[0], src)
    assert_allclose(got[1], dst)


def test_reference_points(tmp_path):
    assert_allclose(
        read_points(write_text(tmp_path, "r.json", '{"points": [[1, 2], [3, 4]]}')),
        [[1, 2], [3, 4]],
    )
    assert_allclose(read_points(write_text(tmp_path, "r.csv", "x,y\n1,2\n3,4\n")), [[1, 2], [3, 4]])


@pytest.mark.parametrize(
    ("name", "text", "message"),
    [
        ("h.json", '{"src": [[1, 2]], "dst": [[1, 2]', "line 1: invalid JSON"),
        ("h.json", '{"src": [[1, 2]]}', 'missing the key "dst"'),
        (
            "h.json",
            '{"src": [[1, "a"]], "dst": [[1, 2]]}',
            "\"src\"[0]: expected a number, got 'a'",
        ),
        ("h.json", '{"src": [[1, NaN]], "dst": [[1, 2]]}', '"src"[0]: expected a finite number'),
        ("h.json", '{"src": [[1]], "dst": [[1, 2]]}', '"src"[0]: expected an [x, y] pair'),
        (
            "h.json",
            '{"src": [[1, 2, 3, 4]], "dst": [[1, 2, 3, 4]]}',
            '"src"[0]: expected an [x, y] pair (or [x, y, z] points in every row), '
            "got [1, 2, 3, 4]",
        ),
        ("h.json", '{"src": [[1, 2, 3]], "dst": [[1, 2]]}', '"dst"[0]: expected an (x, y, z)'),
        ("h.json", '{"src": [], "dst": []}', "content: no handles"),
        ("h.json", '{"src": [[1, 2]], "dst": [[1, 2], [3, 4]]}', "1 sources but 2 targets"),
        ("h.json", "[1, 2]", "expected a JSON object"),
        (
            "h.json",
            '{"src": [[1, 2]], "dst": [[1, 2]], "src": [[5, 5]]}',
            'content: the key "src" twice in one object',
        ),
        (
            "h.json",
            '{"segments": {"src": [[[0, 0], [0, 9]]], "dst": [], "dst": [[[0, 0], [1, 9]]]}}',
            'content: the key "dst" twice in one object',
        ),
        ("h.json", "", "content: an empty file"),
        ("h.json", " \n", "content: an empty file"),
        ("h.csv", "src_x,src_y,dst_x\n1,2,3\n", "line 1: the header lacks the column dst_y"),
        ("h.csv", "a,b\n1,2\n", "line 1: expected the header src_x,src_y,dst_x,dst_y"),
        ("h.csv", "src_x,src_y,dst_x,dst_y\n1,2,3,4\n5,6,7\n", "line 3: expected 4 columns, got 3"),
        ("h.csv", "src_x,src_y,dst_x,dst_y\n1,2,x,4\n", "line 2: expected a number, got 'x'"),
        ("h.csv", "src_x,src_y,dst_x,dst_y\n1,2,nan,4\n", "line 2: expected a finite number"),
        ("h.csv", "src_x,src_y,dst_x,dst_y\n", "content: no handles"),
        ("h.csv", "", "content: no handles"),
        ("h.csv", '"P","true","1","2","3"\n', "line 1: expected 6 to 9 BigWarp columns"),
        ("h.csv", '"P","false","1","2","3","4"\n', "no active BigWarp landmarks"),
    ],
)
def test_malformed_handle_files(tmp_path, name, text, message):
    assert_bad_handle_file(write_text(tmp_path, name, text), message)


def test_missing_file(tmp_path):
    path = tmp_path / "nope.json"
    with pytest.raises(InputFileError) as info:
        read_handles(path)
    # said once, plainly: not wrapped as an "invalid JSON" fault of the content
    assert str(info.value) == f"{path}: no such file"


def test_a_folder_given_as_a_file(tmp_path):
    with pytest.raises(InputFileError) as info:
        read_handles(tmp_path)
    assert str(info.value) == f"{tmp_path}: a folder, not a file"


@pytest.mark.skipif(not Path("/dev/zero").exists(), reason="a system without /dev/zero")
def test_an_endless_device_given_as_a_file():
    """/dev/zero never ends: reading it whole would fill the memory."""
    with pytest.raises(InputFileError) as info:
        read_handles(Path("/dev/zero"))
    assert str(info.value) == "/dev/zero: a device, not a file"


@pytest.mark.parametrize(
    ("name", "text", "message"),
    [
        ("r.json", '{"pts": []}', 'missing the key "points"'),
        ("r.csv", "x,y\n1\n", "line 2: expected 2 columns, got 1"),
        ("r.csv", "a,b\n1,2\n", "expected the header x,y"),
        ("r.json", '{"points": []}', "no points"),
        ("r.json", '{"points": [[1, 2], [1e30, 4]]}', r'"points"[1]: [1e\+30, 4.0] lies beyond'),
        ("r.csv", "x,y\n1,2\n\n3,-2e6\n", r"line 4: [3.0, -2000000.0] lies beyond ±1e\+06 px"),
        ("r.json", '{"points": [[1, 2, 3]]}', r'"points"[0]: expected an [x, y] pair'),
        ("r.csv", "x,y,z\n1,2,3\n", r"line 1: expected 2D points .* \(the header 'x,y,z'\)"),
        ("r.csv", "Z,name,X,Y\n3,a,1,2\n", r"got 3D points \(the header 'Z,name,X,Y'\)"),
    ],
)
def test_malformed_point_files(tmp_path, name, text, message):
    with pytest.raises(InputFileError, match=message.replace("[", r"\[")):
        read_points(write_text(tmp_path, name, text))


def test_atomic_write_leaves_nothing_on_failure(tmp_path):
    target = tmp_path / "out.txt"
    with pytest.raises(RuntimeError), atomic_write(target) as tmp:
        tmp.write_text("partial")
        raise RuntimeError("boom")
    assert list(tmp_path.iterdir()) == []
    with atomic_write(target) as tmp:
        tmp.write_text("whole")
    assert target.read_text() == "whole" and len(list(tmp_path.iterdir())) == 1


@pytest.mark.parametrize("text", ["y,x\n20,10\n40,30\n", "name,x,note,y\na,10,b,20\nc,30,d,40\n"])
def test_point_csv_columns_are_read_by_name(tmp_path, text):
    path = write_text(tmp_path, "r.csv", text)
    assert read_points(path).tolist() == [[10.0, 20.0], [30.0, 40.0]]
