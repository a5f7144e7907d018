"""BigWarp's landmark files as BigWarp writes them (LandmarkTableModel): every CSV field
quoted (so a name may hold a comma), numbers as Java's Double.toString gives them
(``1.0E-4``), unpaired landmarks inactive with ``Infinity`` for their missing point, in the
CSV and as JSON's bare ``Infinity``; the moving points are the sources."""

from __future__ import annotations

import json

import numpy as np
import pytest
from numpy.testing import assert_array_equal

from glmls.errors import InputFileError
from glmls.files.landmarks import read_handle_set, read_handles


def test_a_bigwarp_3d_csv_as_bigwarp_writes_it(tmp_path):
    path = tmp_path / "landmarks.csv"
    path.write_text(
        '"Pt-0","true","1.0","2.0","3.0","1.5","2.0","3.0"\n'
        '"left, upper","true","4.0E-1","5.0","6.0","4.0","5.0","6.0"\n'
        '"Pt-2","false","7.0","8.0","9.0","Infinity","Infinity","Infinity"\n'
    )
    src, dst = read_handles(path, ndim=3)
    assert_array_equal(src, [[1.0, 2.0, 3.0], [0.4, 5.0, 6.0]])
    assert_array_equal(dst, [[1.5, 2.0, 3.0], [4.0, 5.0, 6.0]])


def test_a_bigwarp_2d_csv_is_2d_handles(tmp_path):
    path = tmp_path / "landmarks.csv"
    path.write_text(
        '"Pt-0","true","10.0","12.0","11.0","12.5"\n"Pt-1","true","3.0","4.0","3.0","5.0"\n'
    )
    handles = read_handle_set(path)
    assert_array_equal(handles.src, [[10.0, 12.0], [3.0, 4.0]])
    assert_array_equal(handles.dst, [[11.0, 12.5], [3.0, 5.0]])


def test_a_bigwarp_csv_written_by_hand_with_spaces_after_the_commas(tmp_path):
    path = tmp_path / "landmarks.csv"
    path.write_text(
        '"Pt-0", "true", 1.0 , 2.0, 3.0, 1.5, 2.0, 3.0\n"a, b", "true", 4, 5, 6, 4, 5, 7\n'
    )
    src, dst = read_handles(path, ndim=3)
    assert_array_equal(src, [[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]])
    assert_array_equal(dst, [[1.5, 2.0, 3.0], [4.0, 5.0, 7.0]])


@pytest.mark.parametrize("wrapped", [False, True])
def test_bigwarp_json_with_an_unpaired_landmark(tmp_path, wrapped):
    """BigWarp's JSON serialises the missing point of an unpaired landmark as Infinity."""
    landmarks = (
        '{"type": "BigWarpLandmarks", "numDimensions": 3, '
        '"movingPoints": [[1.0, 2.0, 3.0], [7.0, 8.0, 9.0]], '
        '"fixedPoints": [[1.5, 2.0, 3.0], [Infinity, Infinity, Infinity]], '
        '"active": [true, false], "names": ["Pt-0", "Pt-1"]}'
    )
    path = tmp_path / "landmarks.json"
    path.write_text(f'{{"landmarks": {landmarks}}}' if wrapped else landmarks)
    src, dst = read_handles(path)
    assert_array_equal(src, [[1.0, 2.0, 3.0]])
    assert_array_equal(dst, [[1.5, 2.0, 3.0]])
    assert np.isfinite(dst).all()


def test_a_bigwarp_row_with_a_mistyped_flag_names_the_flag(tmp_path):
    path = tmp_path / "landmarks.csv"
    path.write_text("Pt-0,maybe,10,10,12,8\n")
    with pytest.raises(InputFileError, match=r"line 1: expected true/false, got 'maybe'"):
        read_handles(path)


def test_bigwarp_json_without_active_flags_takes_every_landmark(tmp_path):
    path = tmp_path / "landmarks.json"
    moving, fixed = [[1, 2], [5, 6], [9, 1]], [[1, 2], [5, 7], [9, 1]]
    path.write_text(
        json.dumps(
            {
                "type": "BigWarpLandmarks",
                "numDimensions": 2,
                "movingPoints": moving,
                "fixedPoints": fixed,
            }
        )
    )
    src, dst = read_handles(path)
    assert src.tolist() == moving and dst.tolist() == fixed
