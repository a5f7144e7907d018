"""Handle files with segments and polylines: JSON and CSV read and round-trip, and every
malformed file is refused with the file, the place and the fault."""

from __future__ import annotations

import json
import re
from importlib import resources

import numpy as np
import pytest
from helpers import write_text
from numpy.testing import assert_array_equal

import glmls
from glmls.core.handleset import HandleSet
from glmls.core.segments import polyline_segments
from glmls.errors import InputFileError
from glmls.files import read_handle_set, read_handles, write_handle_set, write_handles

POINTS = ([[1.0, 2.0], [30.5, 4.0]], [[1.5, 2.0], [31.0, 5.0]])
SEGMENTS = ([[[0.0, 0.0], [10.0, 0.0]]], [[[0.0, 1.0], [10.0, 1.5]]])
POLYLINE = ([[0.0, 5.0], [5.0, 5.0], [5.0, 10.0]], [[0.0, 6.0], [5.0, 6.5], [5.0, 11.0]])
JSON = {
    "src": POINTS[0],
    "dst": POINTS[1],
    "segments": {"src": SEGMENTS[0], "dst": SEGMENTS[1]},
    "polylines": {"src": [POLYLINE[0]], "dst": [POLYLINE[1]]},
}
CSV = """kind,id,src_x,src_y,dst_x,dst_y
point,,1,2,1.5,2
segment,jaw,0,0,0,1
segment,jaw,10,0,10,1.5
point,p1,30.5,4,31,5
polyline,brow,0,5,0,6
polyline,brow,5,5,5,6.5
polyline,brow,5,10,5,11
"""


def _expected() -> HandleSet:
    a = np.concatenate([SEGMENTS[0], polyline_segments(POLYLINE[0])])
    b = np.concatenate([SEGMENTS[1], polyline_segments(POLYLINE[1])])
    return HandleSet.validate(*POINTS, a, b)


def assert_same(got: HandleSet, expected: HandleSet) -> None:
    for name in ("src", "dst", "src_segments", "dst_segments"):
        assert_array_equal(getattr(got, name), getattr(expected, name), err_msg=name)
        assert getattr(got, name).dtype == np.float64


def test_json_and_csv_with_segments_and_polylines(tmp_path):
    expected = _expected()
    assert expected.segments == 3  # the segment, then the polyline's two
    got = read_handle_set(write_text(tmp_path, "h.json", json.dumps(JSON)))
    assert isinstance(got, HandleSet)
    assert_same(got, expected)
    assert_same(read_handle_set(write_text(tmp_path, "h.csv", CSV)), expected)


def test_segments_alone_and_the_documented_example(tmp_path):
    alone = {"segments": {"src": SEGMENTS[0], "dst": SEGMENTS[1]}}
    got = read_handle_set(write_text(tmp_path, "s.json", json.dumps(alone)))
    assert got.src.shape == (0, 2) and got.segments == 1
    lines = {"polylines": {"src": [POLYLINE[0]], "dst": [POLYLINE[1]]}, "src": [], "dst": []}
    assert read_handle_set(write_text(tmp_path, "l.json", json.dumps(lines))).segments == 2
    # the CSV example of the module's docstring
    doc = glmls.files.landmarks.__doc__
    example = doc.split("For example::")[1].split("\n\n")[1]
    table = "\n".join(line.strip() for line in example.splitlines()) + "\n"
    handles = read_handle_set(write_text(tmp_path, "doc.csv", table))
    assert (handles.points, handles.segments) == (1, 3)


TWO_RUNS = np.concatenate([SEGMENTS[0], polyline_segments(POLYLINE[0])])


@pytest.mark.parametrize("name", ["h.json", "h.csv", "h.txt"])
@pytest.mark.parametrize(
    ("segments", "points"),
    [
        # a segment, then a polyline: written as "segments" and "polylines"
        (TWO_RUNS, True),
        (TWO_RUNS, False),
        # a polyline, then a single segment: every run written as a polyline, to keep order
        (TWO_RUNS[[1, 2, 0]], False),
        (np.zeros((0, 2, 2)), True),
    ],
    ids=["segment-polyline", "no-points", "polyline-segment", "points"],
)
def test_files_round_trip(tmp_path, name, segments, points):
    rng = np.random.default_rng(len(segments))
    a = segments + rng.random(1) / 3  # values that need every digit
    b = a + rng.normal(0, 2, a.shape)
    # the target keeps the source's joins, so that runs stay polylines in the target too
    joined = (a[:-1, 1] == a[1:, 0]).all(axis=1)
    b[1:, 0][joined] = b[:-1, 1][joined]
    src = np.array(POINTS[0]) * 1.1 if points else np.zeros((0, 2))
    dst = np.array(POINTS[1]) / 3 if points else np.zeros((0, 2))
    handles = HandleSet.validate(src, dst, a, b)
    write_handle_set(tmp_path / name, handles)
    assert_same(read_handle_set(tmp_path / name), handles)
    text = (tmp_path / name).read_text()
    if name != "h.json":
        header = "kind,id,src_x,src_y,dst_x,dst_y" if len(a) else "src_x,src_y,dst_x,dst_y"
        assert text.splitlines()[0] == header
    elif len(a):
        document = json.loads(text)
        polylines = document["polylines"]["src"]
        assert [len(line) for line in polylines] in ([3], [3, 2])
        assert ("segments" in document) == (len(polylines) == 1)


def test_write_handles_takes_segments_and_refuses_bad_handles(tmp_path):
    write_handles(tmp_path / "w.json", *POINTS, src_segments=SEGMENTS[0], dst_segments=SEGMENTS[1])
    got = read_handle_set(tmp_path / "w.json")
    assert_same(got, HandleSet.validate(*POINTS, *SEGMENTS))
    with pytest.raises(ValueError, match=r"src_segments\[0\] has zero length"):
        write_handles(tmp_path / "x.json", [], [], src_segments=[[[1, 1], [1, 1]]],
                      dst_segments=[[[1, 1], [2, 2]]])  # fmt: skip
    with pytest.raises(TypeError, match="must be a HandleSet"):
        write_handle_set(tmp_path / "x.json", POINTS)
    assert not (tmp_path / "x.json").exists()


@pytest.mark.parametrize(
    ("handles", "error", "message"),
    [
        # HandleSet's constructor keeps what it is given: the NaN was written, and the file
        # was one read_handle_set refuses
        (
            HandleSet(np.array([[np.nan, 0.0]]), np.zeros((1, 2)), *np.zeros((2, 0, 2, 2))),
            ValueError,
            r"src must be finite; row 0",
        ),
        (HandleSet("a", "b", "c", "d"), TypeError, r"src must be real numbers"),  # AttributeError
        # none at all: written, and refused on reading as "no handles"
        (
            HandleSet.validate(np.zeros((0, 2)), np.zeros((0, 2))),
            ValueError,
            r"no handles to write",
        ),
    ],
    ids=["NaN", "strings", "none"],
)
@pytest.mark.parametrize("name", ["h.json", "h.csv"])
def test_write_handle_set_writes_no_file_that_would_not_read_back(
    tmp_path, handles, error, message, name
):
    with pytest.raises(error, match=message):
        write_handle_set(tmp_path / name, handles)
    with pytest.raises(ValueError, match=r"no handles to write; a handle file holds one at least"):
        write_handles(tmp_path / name, [], [])
    assert not (tmp_path / name).exists()


def test_read_handles_is_for_points_only(tmp_path):
    path = write_text(tmp_path, "h.json", json.dumps(JSON))
    with pytest.raises(InputFileError, match=r"3 segment handles .* read it with read_handle_set"):
        read_handles(path)
    points = json.dumps({"src": POINTS[0], "dst": POINTS[1]})
    src, dst = read_handles(write_text(tmp_path, "p.json", points))
    assert_array_equal(src, POINTS[0])
    assert_array_equal(dst, POINTS[1])
    src[0, 0] = 7.0  # a plain writable array, as before


def test_the_bundled_handles_read_the_same():
    path = resources.files("glmls.data").joinpath("astronaut_handles.json")
    handles = read_handle_set(str(path))
    src, dst = glmls.data.astronaut_handles()
    assert_array_equal(handles.src, src)
    assert_array_equal(handles.dst, dst)
    assert handles.segments == 0


def _seg_json(src, dst, key="segments"):
    return json.dumps({key: {"src": src, "dst": dst}})


SEG = [[0, 0], [10, 0]]
MALFORMED = [
    # JSON segments
    ("h.json", '{"segments": [1, 2]}', '"segments": expected an object {"src": [...], "dst"'),
    ("h.json", '{"segments": {"src": []}}', '"segments": missing the key "dst"'),
    ("h.json", '{"segments": {"src": 3, "dst": []}}', '"segments"."src": expected a list of'),
    ("h.json", _seg_json([SEG, SEG, SEG, [[1, 2]]], [SEG] * 4),
     '"segments"."src"[3]: expected two [x, y] ends, got [[1, 2]]'),
    ("h.json", _seg_json([SEG], [[[0, 0], [1, 2, 3]]]),
     '"segments"."dst"[0][1]: expected an [x, y] pair, got [1, 2, 3]'),
    ("h.json", _seg_json([[[0, "a"], [1, 1]]], [SEG]),
     "\"segments\".\"src\"[0][0]: expected a number, got 'a'"),
    ("h.json", '{"segments": {"src": [[[0, NaN], [1, 1]]], "dst": [[[0, 0], [1, 1]]]}}',
     '"segments"."src"[0][0]: expected a finite number, got nan'),
    ("h.json", '{"segments": {"src": [[[0, 1e999], [1, 1]]], "dst": [[[0, 0], [1, 1]]]}}',
     '"segments"."src"[0][0]: expected a finite number, got inf'),
    ("h.json", _seg_json([SEG, SEG], [SEG]), '"segments": 2 source segments but 1 targets'),
    ("h.json", _seg_json([SEG, [[3, 4], [3, 4]]], [SEG, SEG]),
     '"segments"."src"[1]: a source segment of zero length (both ends at [3.0, 4.0])'),
    ("h.json", _seg_json([SEG, SEG[::-1]], [SEG, [[1, 1], [2, 2]]]),
     '"segments"."src"[0] and "segments"."src"[1] are the same segment'),
    ("h.json", _seg_json([[[0, 0], [2e6, 0]]], [SEG]),
     '"segments"."src"[0]: [[0.0, 0.0], [2000000.0, 0.0]] lies beyond ±1e+06 px'),
    ("h.json", json.dumps({"src": [[1, 1]], "segments": {"src": [SEG], "dst": [SEG]}}),
     'top level: missing the key "dst"'),
    ("h.json", json.dumps({"src": [], "dst": [], "segments": {"src": [], "dst": []}}),
     "content: no handles"),
    # JSON polylines
    ("h.json", _seg_json([[[0, 0]]], [[[0, 0]]], "polylines"),
     '"polylines"."src"[0]: expected a polyline of at least 2 [x, y] vertices, got [[0, 0]]'),
    ("h.json", _seg_json([[[0, 0], [1, 0], 5]], [[[0, 0], [1, 0], [2, 0]]], "polylines"),
     '"polylines"."src"[0][2]: expected an [x, y] pair, got 5'),
    ("h.json", _seg_json([SEG], [], "polylines"), '"polylines": 1 source polylines but 0 targets'),
    ("h.json", _seg_json([SEG, [[0, 0], [1, 0], [2, 0]]], [SEG, SEG], "polylines"),
     '"polylines"."dst"[1]: 2 vertices, but its source "polylines"."src"[1] has 3'),
    ("h.json", _seg_json([[[0, 0], [5, 5], [5, 5], [6, 6]]], [[[0, 0], [1, 1], [2, 2], [3, 3]]],
                         "polylines"),
     '"polylines"."src"[0], vertices 1-2: a source segment of zero length'),
    ("h.json", json.dumps({"segments": {"src": [SEG], "dst": [SEG]},
                           "polylines": {"src": [SEG], "dst": [[[0, 0], [1, 1]]]}}),
     '"segments"."src"[0] and "polylines"."src"[0], vertices 0-1 are the same segment'),
    # CSV with kinds
    ("h.csv", "kind,id,src_x,src_y,dst_x,dst_y\npoint,,1,2,3\n",
     "line 2: expected 6 columns, got 5"),
    ("h.csv", "kind,id,src_x,src_y,dst_x,dst_y\nline,a,1,2,3,4\n",
     "line 2: unknown kind 'line': expected point, segment or polyline"),
    ("h.csv", "kind,id,src_x,src_y,dst_x,dst_y\nsegment,,1,2,3,4\nsegment,,5,6,7,8\n",
     "line 2: a segment row needs an id"),
    ("h.csv", "kind,id,src_x,src_y,dst_x,dst_y\nsegment,a,1,2,3,4\nsegment,a,5,x,7,8\n",
     "line 3: expected a number, got 'x'"),
    ("h.csv", "kind,id,src_x,src_y,dst_x,dst_y\nsegment,a,1,2,3,4\nsegment,a,5,6,7,inf\n",
     "line 3: expected a finite number, got 'inf'"),
    ("h.csv", "kind,id,src_x,src_y,dst_x,dst_y\nsegment,a,1,2,3,4\n",
     "line 2 (segment 'a'): 1 row; a segment has 2, its ends"),
    ("h.csv", "kind,id,src_x,src_y,dst_x,dst_y\nsegment,a,1,2,3,4\nsegment,a,1,3,3,4\n"
     "segment,a,1,4,3,4\n", "lines 2-4 (segment 'a'): 3 rows; a segment has 2"),
    ("h.csv", "kind,id,src_x,src_y,dst_x,dst_y\npolyline,b,1,2,3,4\n",
     "line 2 (polyline 'b'): 1 row; a polyline has at least 2 vertices"),
    ("h.csv", "kind,id,src_x,src_y,dst_x,dst_y\nsegment,a,1,2,3,4\npolyline,a,1,3,3,4\n",
     "line 3: id 'a' is a segment (line 2), not a polyline"),
    ("h.csv", "kind,id,src_x,src_y,dst_x,dst_y\nsegment,a,1,2,3,4\npoint,,0,0,0,0\n"
     "segment,a,1,3,3,4\n", "line 4: id 'a' was used on line 2: the rows of one segment"),
    ("h.csv", "kind,id,src_x,src_y,dst_x,dst_y\npolyline,b,0,0,0,0\npolyline,b,4,4,1,1\n"
     "polyline,b,4,4,2,2\n", "lines 3-4 (polyline 'b'): a source segment of zero length"),
    ("h.csv", "kind,id,src_x,src_y,dst_x,dst_y\npoint,,1,1,2,2\npoint,,1,1,3,3\n",
     "line 2 and line 3 are the same point [1.0, 1.0] with different targets"),
    ("h.csv", "kind,id,src_x,src_y,dst_x,dst_y\n", "content: no handles"),
    ("h.csv", "kind,src_x,src_y,dst_x,dst_y\n",
     "line 1: the header lacks the column id: expected the header kind,id,src_x,src_y,dst_x,"
     "dst_y (its columns in any order, others ignored)"),
    ("h.csv", "id,x,y\n",
     "line 1: expected the header src_x,src_y,dst_x,dst_y, src_x,src_y,src_z,dst_x,dst_y,dst_z "
     "or kind,id,src_x,src_y,dst_x,dst_y"),
    # points: new checks on the old forms
    ("h.csv", "src_x,src_y,dst_x,dst_y\n1,2,3,4\n1,-3e6,3,4\n", "line 3: [1.0, -3000000.0] lies"),
    ("h.json", '{"src": [[1' + "0" * 400 + ", 0]], \"dst\": [[0, 0]]}",
     '"src"[0]: expected a finite number, got 1000'),
    ("h.json", '{"src": [[1' + "0" * 5000 + ", 0]], \"dst\": [[0, 0]]}",
     "content: invalid JSON: Exceeds the limit"),
]  # fmt: skip


@pytest.mark.parametrize(("name", "text", "message"), MALFORMED)
def test_malformed_segment_files(tmp_path, name, text, message):
    path = write_text(tmp_path, name, text)
    with pytest.raises(InputFileError, match=f"^{re.escape(str(path))}: ") as info:
        read_handle_set(path)
    assert message in str(info.value)
    assert len(str(info.value)) < 300  # one readable line, even for hostile values
