"""3D handle files and the landmarks of other tools: JSON and CSV point tables in 3D,
BigWarp's CSV (2D and 3D, with and without the id column) and JSON, elastix point-file
pairs; the dimension expected; bad files named by the line."""

from __future__ import annotations

import json

import numpy as np
import pytest
from helpers import assert_bad_handle_file, write_text
from numpy.testing import assert_allclose

from glmls.core.handleset import HandleSet
from glmls.errors import InputFileError
from glmls.files import read_handle_set, read_handles, write_handle_set, write_handles
from glmls.files.landmarks import elastix_indices

SRC = np.array([[1.0, 2.0, 3.0], [4.5, 5.0, 6.0], [7.0, 8.0, 9.25]])
DST = np.array([[1.5, 2.0, 3.0], [4.0, 5.5, 6.0], [7.0, 8.0, 10.0]])


@pytest.mark.parametrize("name", ["h.json", "h.csv"])
def test_3d_round_trip(tmp_path, name):
    write_handles(tmp_path / name, SRC, DST)
    src, dst = read_handles(tmp_path / name)
    assert src.shape == (3, 3)
    assert_allclose(src, SRC, rtol=0, atol=0)
    assert_allclose(dst, DST, rtol=0, atol=0)
    if name == "h.csv":
        assert (tmp_path / name).read_text().startswith("src_x,src_y,src_z,dst_x,dst_y,dst_z\n")


def _bigwarp_rows(ndim, ident):
    rows = []
    for k, (p, q) in enumerate(zip(SRC, DST, strict=True)):
        extra = [str(k)] if ident else []
        rows.append([f"Pt-{k}", "true", *extra, *map(str, p[:ndim]), *map(str, q[:ndim])])
    # an unpaired landmark: inactive, its fixed point infinite, as BigWarp saves it
    extra = ["3"] if ident else []
    rows.insert(1, ["Pt-x", "false", *extra, *["9"] * ndim, *["Infinity"] * ndim])
    return "\n".join(",".join(f'"{v}"' for v in row) for row in rows) + "\n"


@pytest.mark.parametrize("ndim", [2, 3])
@pytest.mark.parametrize("ident", [False, True])
def test_bigwarp_csv_variants(tmp_path, ndim, ident):
    path = write_text(tmp_path, "landmarks.csv", _bigwarp_rows(ndim, ident))
    src, dst = read_handles(path)
    assert_allclose(src, SRC[:, :ndim])  # moving points are the sources
    assert_allclose(dst, DST[:, :ndim])  # fixed points the targets
    if ndim == 2:
        assert read_handle_set(path).points == 3


def _bigwarp_json(ndim=3, active=(True, False, True, True)):
    moving = [*SRC[:1, :ndim].tolist(), [0.0] * ndim, *SRC[1:, :ndim].tolist()]
    fixed = [*DST[:1, :ndim].tolist(), [float("inf")] * ndim, *DST[1:, :ndim].tolist()]
    return {
        "type": "BigWarpLandmarks",
        "numDimensions": ndim,
        "movingPoints": moving,
        "fixedPoints": fixed,
        "active": list(active),
        "names": [f"Pt-{k}" for k in range(4)],
    }


@pytest.mark.parametrize("ndim", [2, 3])
@pytest.mark.parametrize("wrapped", [False, True])
def test_bigwarp_json(tmp_path, ndim, wrapped):
    document = _bigwarp_json(ndim)
    if wrapped:  # BigWarp's settings file keeps them under "landmarks"
        document = {"landmarks": document, "Sources": {}}
    path = write_text(tmp_path, "landmarks.json", json.dumps(document))  # Infinity, as Gson writes
    src, dst = read_handles(path)
    assert_allclose(src, SRC[:, :ndim])
    assert_allclose(dst, DST[:, :ndim])


def _pts(kind, points):
    return f"{kind}\n{len(points)}\n" + "".join(" ".join(map(str, p)) + "\n" for p in points)


@pytest.mark.parametrize("kind", ["index", "point"])
def test_elastix_pair(tmp_path, kind):
    moving = write_text(tmp_path, "moving.pts", _pts(kind, SRC.tolist()))
    fixed = write_text(tmp_path, "fixed.pts", _pts(kind, DST.tolist()))
    src, dst = read_handles(moving, dst=fixed)
    assert_allclose(src, SRC)
    assert_allclose(dst, DST)


def test_elastix_indices_and_coordinates_do_not_mix(tmp_path):
    """An ``index`` file (voxel indices) with a ``point`` file (coordinates) is a mistake that
    would go unseen (they agree only for a spacing of 1): refused, naming both."""
    moving = write_text(tmp_path, "moving.pts", _pts("index", SRC.tolist()))
    fixed = write_text(tmp_path, "fixed.pts", _pts("point", DST.tolist()))
    with pytest.raises(InputFileError, match=r"fixed\.pts: line 1: 'point' coordinates, but"):
        read_handles(moving, dst=fixed)
    assert elastix_indices(moving, dst=moving)
    assert not elastix_indices(fixed, dst=fixed) and not elastix_indices(moving)


def test_elastix_needs_both_files(tmp_path):
    moving = write_text(tmp_path, "moving.pts", _pts("index", SRC.tolist()))
    with pytest.raises(InputFileError, match=r"moving\.pts: content: an elastix point file holds"):
        read_handles(moving)
    json_file = write_text(
        tmp_path, "h.json", json.dumps({"src": SRC.tolist(), "dst": DST.tolist()})
    )
    with pytest.raises(InputFileError, match=r"moving\.pts: a file of targets goes with"):
        read_handles(json_file, dst=moving)


def test_dimension_expected(tmp_path):
    three = write_text(tmp_path, "h3.json", json.dumps({"src": SRC.tolist(), "dst": DST.tolist()}))
    two = write_text(tmp_path, "h2.csv", "src_x,src_y,dst_x,dst_y\n1,2,3,4\n")
    assert read_handles(three, ndim=3)[0].shape == (3, 3)
    with pytest.raises(InputFileError, match=r"h2.csv: content: 2D handles \(x, y\), where 3D"):
        read_handles(two, ndim=3)
    with pytest.raises(InputFileError, match=r"h3.json: content: 3D handles \(x, y, z\), where 2D"):
        read_handles(three, ndim=2)
    with pytest.raises(InputFileError, match="read_handles reads 3D point handles"):
        read_handle_set(three)


def test_write_3d_refuses_bad_handles(tmp_path):
    with pytest.raises(ValueError, match="segment handles are 2D"):
        write_handles(tmp_path / "h.json", SRC, DST, src_segments=[[[0, 0], [1, 1]]])
    with pytest.raises(ValueError, match="same length"):
        write_handles(tmp_path / "h.json", SRC, DST[:2])
    with pytest.raises(ValueError, match="finite"):
        write_handles(tmp_path / "h.json", SRC, DST * np.nan)
    assert list(tmp_path.iterdir()) == []


def test_no_handles_are_written_to_an_elastix_point_file(tmp_path):
    """A ``.pts`` file holds one side's points in elastix's layout: a table written there
    would not read back, neither alone nor as a pair."""
    handles = HandleSet.validate([[0.0, 0.0]], [[1.0, 0.0]])
    for write in (
        lambda path: write_handles(path, SRC, DST),
        lambda path: write_handles(path, SRC[:, :2], DST[:, :2]),
        lambda path: write_handle_set(path, handles),
    ):
        with pytest.raises(ValueError, match=r"h\.PTS: an elastix point file \(\.pts\) holds"):
            write(tmp_path / "h.PTS")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    ("name", "text", "message"),
    [
        ("h.json", '{"src": [[1, 2, 3]], "dst": [[1, 2, "a"]]}', '"dst"[0]: expected a number'),
        ("h.json", '{"src": [[1, 2, 3], [1, 2]], "dst": [[1, 2, 3]]}', '"src"[1]: expected an (x'),
        ("h.json", '{"src": [[1, 2, 3]], "dst": []}', "1 sources but 0 targets"),
        (
            "h.json",
            '{"src": [[1, 2, 3]], "dst": [[1, 2, 3]], "segments": {}}',
            '"segments": segments and polylines are 2D handles only',
        ),
        ("h.csv", "src_x,src_y,src_z,dst_x,dst_y,dst_z\n1,2,3,4,5\n", "line 2: expected 6 columns"),
        ("h.csv", "src_x,src_y,src_z,dst_x,dst_y,dst_z\n1,2,3,4,x,6\n", "line 2: expected a num"),
        ("h.csv", "src_x,src_y,src_z,dst_x,dst_y,dst_z\n", "content: no handles"),
        (
            "h.csv",
            "src_x,src_y,src_z,dst_x,dst_y,dst_z\n1,2,3,4,5,6\n1,2,3,4,5,7\n",
            "line 2 and line 3 are the same point [1.0, 2.0, 3.0] with different targets",
        ),
        ("h.csv", "src_x,src_y,src_z,dst_x,dst_y,dst_z\n1,2,3e7,4,5,6\n", "line 2: [1.0, 2.0, 3"),
        ("h.csv", '"P","true","1","2","3","4","5","6","7","8"\n', "line 1: expected 6 to 9"),
        ("h.csv", '"P","true","1","2","3","4","5","6"\n"Q","true","1"\n', "line 2: expected 8"),
        ("h.csv", '"P","true","1","2","3","4","5","nan"\n', "line 1: expected a finite number"),
        ("h.csv", '"P","false","1","2","3","4","5","6"\n', "content: no active BigWarp"),
        ("b.json", '{"type": "BigWarpLandmarks", "numDimensions": 4}', 'missing the key "moving'),
        (
            "b.json",
            '{"type": "BigWarpLandmarks", "numDimensions": 4, "movingPoints": [], '
            '"fixedPoints": [], "active": []}',
            '"numDimensions": expected 2 or 3, got 4',
        ),
        (
            "b.json",
            '{"landmarks": {"numDimensions": 3, "movingPoints": [[1, 2, 3]], '
            '"fixedPoints": [[1, 2]], "active": [true]}}',
            '"landmarks"."fixedPoints"[0]: expected an (x, y, z) point',
        ),
        (
            "b.json",
            '{"type": "BigWarpLandmarks", "numDimensions": 3, "movingPoints": [[1, 2, 3]], '
            '"fixedPoints": [[1, 2, Infinity]], "active": [true]}',
            '"fixedPoints"[0]: expected a finite number',
        ),
        (
            "b.json",
            '{"type": "BigWarpLandmarks", "numDimensions": 3, "movingPoints": [[1, 2, 3]], '
            '"fixedPoints": [], "active": [true]}',
            "1 moving point, 0 fixed points and 1 active flag",
        ),
    ],
)
def test_malformed_3d_files(tmp_path, name, text, message):
    assert_bad_handle_file(write_text(tmp_path, name, text), message)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("", "content: expected 'index' or 'point'"),
        ("points\n1\n1 2 3\n", "line 1: expected 'index' or 'point'"),
        ("index\n1 2\n1 2 3\n", "line 2: expected the number of points"),
        ("index\n2\n1 2 3\n", "content: 1 point, but line 2 says 2"),
        ("index\n0\n", "line 2: expected a count >= 1"),
        ("index\n2\n1 2 3\n4 5\n", "line 4: expected 3 coordinates, as the first point, got 2"),
        ("index\n2\n1 2\n4 5 6\n", "line 4: expected 2 coordinates, as the first point, got 3"),
        ("index\n1\n1 2 3 4\n", "line 3: expected 2 or 3 coordinates, got 4"),
        ("point\n1\n1 x 3\n", "line 3: expected a number, got 'x'"),
    ],
)
def test_malformed_elastix_files(tmp_path, text, message):
    moving = write_text(tmp_path, "moving.pts", text)
    fixed = write_text(tmp_path, "fixed.pts", _pts("index", SRC[:1].tolist()))
    with pytest.raises(InputFileError) as info:
        read_handles(moving, dst=fixed)
    assert str(info.value).startswith(str(moving)) and message in str(info.value)


def test_elastix_counts_must_match(tmp_path):
    moving = write_text(tmp_path, "moving.pts", _pts("index", SRC.tolist()))
    fixed = write_text(tmp_path, "fixed.pts", _pts("index", DST[:2].tolist()))
    with pytest.raises(InputFileError, match=r"fixed\.pts: content: 2 points of 3 coordinates"):
        read_handles(moving, dst=fixed)


@pytest.mark.parametrize("ndim", [2, 3])
def test_an_empty_json_is_no_handles_whatever_the_dimension(tmp_path, ndim):
    path = tmp_path / "empty.json"
    path.write_text('{"src": [], "dst": []}')
    with pytest.raises(InputFileError, match=r"empty.json: content: no handles$"):
        read_handles(path, ndim=ndim)


@pytest.mark.parametrize(
    ("src", "dst", "error", "message"),
    [
        (SRC.astype(np.complex128), DST, TypeError, r"src must be real numbers"),
        (SRC * 1e30, DST, ValueError, r"src must lie within ±1e\+06"),
        ([[1, 2, 3], [1, 2, 3]], [[0, 0, 0], [1, 1, 1]], ValueError, r"same point"),
        (np.zeros((0, 3)), np.zeros((0, 3)), ValueError, r"N >= 1"),
    ],
)
@pytest.mark.parametrize("name", ["h.json", "h.csv"])
def test_write_3d_refuses_handles_that_would_not_read_back(
    tmp_path, src, dst, error, message, name
):
    """write_handles writes only what read_handles reads back, as glmls.MLS checks it: no
    imaginary part dropped, no value beyond the coordinate range, no source point with two
    targets; no file is left."""
    with pytest.raises(error, match=message):
        write_handles(tmp_path / name, src, dst)
    assert list(tmp_path.iterdir()) == []


def test_write_3d_takes_any_layout_and_byte_order(tmp_path):
    given = np.asfortranarray(SRC.astype(">f8")), DST[::-1][::-1].astype(">f4")
    write_handles(tmp_path / "h.csv", *given)
    src, dst = read_handles(tmp_path / "h.csv")
    np.testing.assert_array_equal(src, SRC)
    np.testing.assert_array_equal(dst, DST.astype(np.float32))


@pytest.mark.parametrize(
    ("ndim", "error"), [(True, TypeError), ("3", TypeError), (3.0, TypeError), (4, ValueError)]
)
def test_an_ndim_that_is_not_2_or_3_is_named_before_the_file_is_read(tmp_path, ndim, error):
    """Not read as the file's fault ("where TrueD handles of True coordinates are
    expected"): the file need not exist."""
    with pytest.raises(error, match=rf"^ndim must be 2, 3 or None, got {ndim!r}$"):
        read_handles(tmp_path / "missing.json", ndim=ndim)
    write_handles(tmp_path / "h.json", SRC, DST)
    assert read_handles(tmp_path / "h.json", ndim=np.int64(3))[0].shape == SRC.shape


def _table(header, src, dst):
    """A CSV of ``header``'s columns: src_*, dst_* from the points, others a text."""
    points = {"src": src, "dst": dst}
    lines = [",".join(header)]
    for k in range(len(src)):
        fields = []
        for name in header:
            side, _, axis = name.lower().partition("_")
            if side in points and axis in "xyz" and axis:
                fields.append(repr(float(points[side][k]["xyz".index(axis)])))
            else:
                fields.append(f'"note {k}, of {name}"')
        lines.append(",".join(fields))
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize(
    "header",
    [
        ["dst_x", "dst_y", "dst_z", "src_x", "src_y", "src_z"],
        ["name", "src_x", "src_y", "src_z", "dst_x", "dst_y", "dst_z"],
        ["src_z", "DST_X", "name", "src_y", "dst_z", "Src_X", "dst_y", "weight"],
    ],
)
def test_3d_csv_columns_are_read_by_name(tmp_path, header):
    path = write_text(tmp_path, "h.csv", _table(header, SRC, DST))
    src, dst = read_handles(path, ndim=3)
    assert_allclose(src, SRC, rtol=0, atol=0)
    assert_allclose(dst, DST, rtol=0, atol=0)


@pytest.mark.parametrize(
    "header",
    [
        ["dst_x", "dst_y", "src_x", "src_y"],
        ["name", "src_x", "src_y", "dst_x", "dst_y"],
        ["dst_y", "note", "src_y", "src_x", "dst_x"],
    ],
)
def test_2d_csv_columns_are_read_by_name(tmp_path, header):
    path = write_text(tmp_path, "h.csv", _table(header, SRC[:, :2], DST[:, :2]))
    src, dst = read_handles(path, ndim=2)
    assert_allclose(src, SRC[:, :2], rtol=0, atol=0)
    assert_allclose(dst, DST[:, :2], rtol=0, atol=0)


@pytest.mark.parametrize(
    ("header", "message"),
    [
        ("src_x,src_y,src_z,dst_x,dst_y,name", "line 1: the header lacks the column dst_z: "),
        ("dst_z,name,src_z", "line 1: the header lacks the columns src_x, src_y, dst_x, dst_y: "),
        ("src_x,src_y,dst_x,dst_y,src_z,dst_z,src_y", "the header names the column src_y twice"),
        ("src_x,src_y,dst_x,name", "line 1: the header lacks the column dst_y: "),
        ("dst_x,src_x,src_y,dst_y,DST_X", "the header names the column dst_x twice (columns 1, 5)"),
        ("kind,id,src_x,src_y,dst_x,dst_y,src_z", "the header has the column src_z and kind"),
    ],
)
def test_a_header_that_lacks_or_repeats_a_column_is_named(tmp_path, header, message):
    path = write_text(
        tmp_path, "h.csv", header + "\n" + ",".join(["1"] * header.count(",")) + ",1\n"
    )
    with pytest.raises(InputFileError) as info:
        read_handles(path)
    assert message in str(info.value)
    assert "\n" not in str(info.value)


def test_a_row_of_another_width_than_the_header_is_named(tmp_path):
    path = write_text(tmp_path, "h.csv", "name,src_x,src_y,src_z,dst_x,dst_y,dst_z\n1,2,3,4,5,6\n")
    assert_bad_handle_file(path, "line 2: expected 7 columns, got 6")
