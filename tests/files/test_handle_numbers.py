"""Coordinates in handle and point files are numbers as their formats write them: a JSON
number (not a string of digits, nor ``true``), a decimal in a text field (not Python's
other spellings, ``1_0`` or other scripts' digits); a fault names the file and the entry."""

from __future__ import annotations

import json

import pytest
from helpers import write_text

from glmls.cli.analyze_volume import read_reference_3d
from glmls.errors import InputFileError
from glmls.files import read_handles, read_points

_2D = {"src": [[1, 2], [5, 6], [9, 1]], "dst": [[3, 4], [7, 8], [2, 3]]}
_3D = {
    "src": [[1, 2, 3], [5, 6, 7], [9, 1, 2], [4, 4, 9]],
    "dst": [[3, 4, 1], [7, 8, 2], [2, 3, 3], [4, 4, 4]],
}


def _with(data: dict, value: object) -> str:
    changed = json.loads(json.dumps(data))
    changed["dst"][1][0] = value
    return json.dumps(changed)


@pytest.mark.parametrize("data", [_2D, _3D], ids=["2d", "3d"])
@pytest.mark.parametrize("value", ["12.5", "7", True, False])
def test_a_json_coordinate_that_is_no_number_is_refused(tmp_path, data, value):
    path = write_text(tmp_path, "h.json", _with(data, value))
    with pytest.raises(
        InputFileError, match=rf'h\.json: "dst"\[1\]: expected a number, got {value!r}'
    ):
        read_handles(path)


def test_json_numbers_are_read(tmp_path):
    path = write_text(tmp_path, "h.json", _with(_2D, 12.5))
    assert read_handles(path)[1][1].tolist() == [12.5, 8.0]


@pytest.mark.parametrize(
    ("name", "text"),
    [
        ("r.json", '{"points": [[1, 2], ["3", 4]]}'),
        ("r3.json", '{"points": [[1, 2, 3], [3, "4", 5]]}'),
    ],
)
def test_reference_points_in_quotes_are_refused(tmp_path, name, text):
    path = write_text(tmp_path, name, text)
    reader = read_reference_3d if name == "r3.json" else read_points
    with pytest.raises(InputFileError, match=rf'{name}: "points"\[1\]: expected a number'):
        reader(path)


def test_bigwarp_json_coordinates_in_quotes_are_refused(tmp_path):
    text = json.dumps(
        {
            "type": "BigWarpLandmarks",
            "numDimensions": 2,
            "movingPoints": [[1, 2], [3, "4"], [5, 9]],
            "fixedPoints": [[1, 2], [3, 4], [5, 6]],
            "active": [True, True, True],
        }
    )
    path = write_text(tmp_path, "bw.json", text)
    with pytest.raises(InputFileError, match=r'bw\.json: "movingPoints"\[1\]: expected a number'):
        read_handles(path)


_CSV = "src_x,src_y,dst_x,dst_y\n1,2,3,4\n5,6,{},8\n9,1,2,3\n"
_BIGWARP = (
    '"Pt-0","true","1","2","3","4"\n"Pt-1","true","5","6","{}","8"\n"Pt-2","true","9","1","2","3"\n'
)
_KINDS = "kind,id,src_x,src_y,dst_x,dst_y\npoint,0,1,2,3,4\npoint,1,5,6,{},8\npoint,2,9,1,2,3\n"
_3D_CSV = (
    "src_x,src_y,src_z,dst_x,dst_y,dst_z\n1,2,3,3,4,1\n5,6,7,{},8,2\n9,1,2,2,3,3\n1,1,9,4,4,4\n"
)


@pytest.mark.parametrize(
    ("cell", "words"),
    [
        ("1_0", "expected a number, got '1_0'"),  # Python's float() reads 10
        ("\uff17", "expected a number, got '\uff17'"),  # a full-width 7: float() reads 7
        ("\u0663", "expected a number, got '\u0663'"),  # an Arabic-Indic 3
        ("", "expected a number, got ''"),
        ("nan", "expected a finite number, got 'nan'"),
        ("-Infinity", "expected a finite number, got '-Infinity'"),
        ("1e999", "expected a finite number, got '1e999'"),
    ],
)
@pytest.mark.parametrize(
    ("name", "table", "line"),
    [
        ("h.csv", _CSV, 3),
        ("bw.csv", _BIGWARP, 2),
        ("k.csv", _KINDS, 3),
        ("h3.csv", _3D_CSV, 3),
    ],
)
def test_a_csv_cell_that_is_no_decimal_number_is_refused(tmp_path, cell, words, name, table, line):
    path = write_text(tmp_path, name, table.format(cell))
    with pytest.raises(InputFileError, match=f"{name}: line {line}: {words}"):
        read_handles(path)


@pytest.mark.parametrize("cell", ["7", "+7", "7.", "7.0", ".7e1", "70E-1", "-7"])
def test_decimal_csv_cells_are_read(tmp_path, cell):
    got = read_handles(write_text(tmp_path, "h.csv", _CSV.format(cell)))[1][1][0]
    assert got == float(cell)


@pytest.mark.parametrize(
    ("word", "words"), [("6_0", "expected a number"), ("nan", "expected a finite number")]
)
def test_an_elastix_coordinate_that_is_no_decimal_number_is_refused(tmp_path, word, words):
    src = write_text(tmp_path, "s.pts", f"point\n3\n1 2 3\n4 5 {word}\n7 8 9\n")
    dst = write_text(tmp_path, "d.pts", "point\n3\n1 2 3\n4 5 6\n7 8 9\n")
    with pytest.raises(InputFileError, match=f"s.pts: line 4: {words}"):
        read_handles(src, dst=dst)
