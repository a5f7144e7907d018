"""The command line with segment and polyline handles: the same --handles option, the same
pictures as the API, and a malformed file refused in one line with exit status 2."""

from __future__ import annotations

import argparse
import json

import numpy as np
import pytest
from helpers import run_glmls as cli

import glmls
from glmls.cli.inputs import example_or_files
from glmls.cli.options import handle_warnings
from glmls.core.handleset import HandleSet
from glmls.core.segments import polyline_segments

SRC = [[4.0, 4.0], [36.0, 6.0]]
DST = [[6.0, 5.0], [34.0, 8.0]]
SEGMENT = ([[[6.0, 26.0], [20.0, 28.0]]], [[[6.0, 26.0], [21.0, 24.0]]])
POLYLINE = ([[24.0, 14.0], [30.0, 20.0], [34.0, 28.0]], [[25.0, 12.0], [32.0, 19.0], [34.0, 28.0]])
REFERENCE = [[10, 10], [30, 10], [20, 25], [12, 22], [28, 22]]
A = np.concatenate([SEGMENT[0], polyline_segments(POLYLINE[0])])
B = np.concatenate([SEGMENT[1], polyline_segments(POLYLINE[1])])
CSV = "kind,id,src_x,src_y,dst_x,dst_y\n" + "\n".join(
    f"{kind},{ident},{p[0]},{p[1]},{q[0]},{q[1]}"
    for kind, ident, sources, targets in (
        ("point", "", SRC, DST),
        ("segment", "chin", SEGMENT[0][0], SEGMENT[1][0]),
        ("polyline", "brow", *POLYLINE),
    )
    for p, q in zip(sources, targets, strict=True)
)


def one_line_error(result, *parts: str) -> None:
    assert result.returncode == 2, result.stderr
    assert "Traceback" not in result.stderr, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    for part in parts:
        assert part in lines[0], (part, lines[0])


@pytest.fixture
def files(tmp_path):
    rng = np.random.default_rng(8)
    glmls.imwrite(tmp_path / "a.png", rng.integers(0, 256, (32, 40, 3), dtype=np.uint8))
    document = {
        "src": SRC,
        "dst": DST,
        "segments": {"src": SEGMENT[0], "dst": SEGMENT[1]},
        "polylines": {"src": [POLYLINE[0]], "dst": [POLYLINE[1]]},
    }
    (tmp_path / "h.json").write_text(json.dumps(document))
    (tmp_path / "h.csv").write_text(CSV + "\n")
    only = {"segments": {"src": SEGMENT[0], "dst": SEGMENT[1]}}
    only["polylines"] = document["polylines"]
    (tmp_path / "lines.json").write_text(json.dumps(only))
    (tmp_path / "r.json").write_text(json.dumps({"points": REFERENCE}))
    return tmp_path


@pytest.mark.parametrize("handles", ["h.json", "h.csv"])
def test_warp_with_segments_matches_the_api(files, gl, handles):
    result = cli("warp", "a.png", "out.png", "--handles", handles, "--transform", "similarity",
                 cwd=files)  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert result.stderr == ""  # no warning: every handle lies in the image
    image = glmls.imread(files / "a.png")
    expected = glmls.warp(image, SRC, DST, src_segments=A, dst_segments=B,
                          transform="similarity", ctx=gl)  # fmt: skip
    np.testing.assert_array_equal(glmls.imread(files / "out.png"), expected)
    assert not (expected == image).all()


def test_warp_with_segments_alone(files, gl):
    result = cli("warp", "a.png", "out.png", "--handles", "lines.json", "--method", "backward",
                 cwd=files)  # fmt: skip
    assert result.returncode == 0, result.stderr
    image = glmls.imread(files / "a.png")
    expected = glmls.warp(image, np.zeros((0, 2)), np.zeros((0, 2)), src_segments=A,
                          dst_segments=B, method="backward", ctx=gl)  # fmt: skip
    np.testing.assert_array_equal(glmls.imread(files / "out.png"), expected)


def test_analyze_lists_and_draws_the_segments(files):
    result = cli("analyze", "a.png", "--handles", "h.json", "--out", "rep", cwd=files)
    assert result.returncode == 0, result.stderr
    assert "the source handles (points and segment ends) are the reference points" in (
        result.stderr
    )
    summary = json.loads((files / "rep" / "report.json").read_text())
    config = summary["configuration"]
    assert config["segments"] == 3 and config["handles"] == 2
    np.testing.assert_array_equal(config["src_segments"], A)
    np.testing.assert_array_equal(config["dst_segments"], B)
    # the reference: 2 points and 5 distinct segment ends (the polyline's middle ones shared)
    assert summary["analysis"]["reference_points"] == 7
    drawn = glmls.imread(files / "rep" / "input_handles.png")
    x, y = 13, 27  # the middle of the source segment
    assert drawn[y, x].tolist() == [30, 144, 255]  # drawn in the source colour


def test_tune_moves_segment_targets(files):
    result = cli("tune", "a.png", "--handles", "h.csv", "--reference", "r.json", "--out", "t",
                 "--trials", "2", "--configs", "rigid:idw", cwd=files)  # fmt: skip
    assert result.returncode == 0, result.stderr
    ranking = json.loads((files / "t" / "ranking.json").read_text())["ranking"]
    assert len(ranking) == 2
    assert all(np.isfinite(row["handle_miss_mean"]) for row in ranking)
    winner = json.loads((files / "t" / "winner" / "report.json").read_text())
    assert winner["configuration"]["segments"] == 3


def test_segment_ends_count_in_the_warnings(files):
    outside = {"segments": {"src": [[[100, 100], [140, 100]]], "dst": [[[100, 90], [140, 90]]]},
               "src": [[5, 5]], "dst": [[6, 6]]}  # fmt: skip
    (files / "out.json").write_text(json.dumps(outside))
    result = cli("warp", "a.png", "o.png", "--handles", "out.json", cwd=files)
    assert result.returncode == 0, result.stderr
    assert (
        "warning: 2 of 3 handle points and segment ends lie outside the 40 x 32 image"
        in result.stderr
    )
    unit = np.array([[0.1, 0.2], [0.5, 0.5], [0.9, 0.1]])
    assert handle_warnings(unit, (32, 40), segment_ends=True)[0].startswith(
        "every handle point and segment end lies within [0, 1] x [0, 1]"
    )


def test_the_example_is_a_handle_set():
    args = argparse.Namespace(example=True)
    image, handles, reference, name = example_or_files(args, need_reference=True)
    assert isinstance(handles, HandleSet) and handles.segments == 0
    assert handles.points == len(glmls.data.astronaut_handles()[0])
    assert image.shape == (512, 512, 3) and len(reference) and "astronaut" in name


SEG = [[0, 0], [10, 0]]


@pytest.mark.parametrize(
    ("text", "name", "parts"),
    [
        (json.dumps({"segments": {"src": [SEG, [[3, 4], [3, 4]]], "dst": [SEG, SEG]}}), "z.json",
         ('z.json: "segments"."src"[1]: a source segment of zero length',)),
        (json.dumps({"segments": {"src": [SEG, SEG], "dst": [SEG]}}), "n.json",
         ('n.json: "segments": 2 source segments but 1 targets',)),
        ('{"segments": {"src": [[[0, NaN], [1, 1]]], "dst": [[[0, 0], [1, 1]]]}}', "f.json",
         ('"segments"."src"[0][0]: expected a finite number, got nan',)),
        (json.dumps({"polylines": {"src": [[[0, 0], [1, 0], [2, 0]]], "dst": [SEG]}}), "p.json",
         ('"polylines"."dst"[0]: 2 vertices, but its source "polylines"."src"[0] has 3',)),
        (json.dumps({"segments": {"src": [[1, 2]], "dst": [SEG]}}), "e.json",
         ('"segments"."src"[0]: expected two [x, y] ends, got [1, 2]',)),
        ("kind,id,src_x,src_y,dst_x,dst_y\nsegment,a,1,2,3,4\n", "k.csv",
         ("k.csv: line 2 (segment 'a'): 1 row; a segment has 2",)),
        ("kind,id,src_x,src_y,dst_x,dst_y\ncurve,a,1,2,3,4\n", "u.csv",
         ("u.csv: line 2: unknown kind 'curve'",)),
    ],
)  # fmt: skip
def test_bad_segment_files_are_one_line_and_exit_2(files, text, name, parts):
    (files / name).write_text(text)
    for command in (["warp", "a.png", "o.png"], ["analyze", "a.png", "--out", "rep"]):
        result = cli(*command, "--handles", name, cwd=files)
        one_line_error(result, f"glmls {command[0]}: ", *parts)
    assert not (files / "o.png").exists() and not (files / "rep").exists()


def test_affine_on_segments_along_one_line_is_a_usage_error(files):
    line = {"segments": {"src": [SEG, [[20, 0], [30, 0]]], "dst": [SEG, [[20, 1], [30, 1]]]}}
    (files / "line.json").write_text(json.dumps(line))
    result = cli("warp", "a.png", "o.png", "--handles", "line.json", "--transform", "affine",
                 cwd=files)  # fmt: skip
    one_line_error(result, "glmls warp: handles: affine MLS needs", "one line")
