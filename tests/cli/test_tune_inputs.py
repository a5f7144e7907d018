"""``glmls tune``'s inputs and outputs: the trial count bounded, reference points of the
wrong dimension refused before any work, and no construction ranking of an earlier run left
beside this run's outputs."""

from __future__ import annotations

import json

import numpy as np
import pytest
from helpers import CLI_REFERENCE, write_cli_handles

import glmls
from glmls.analysis.tuning import MAX_TRIALS
from glmls.cli.main import main

TUNE = ("tune", "a.png", "--handles", "h.json", "--out", "out", "--configs", "rigid:idw:alpha=1")


@pytest.fixture
def inputs(tmp_path, monkeypatch):
    rng = np.random.default_rng(5)
    glmls.imwrite(tmp_path / "a.png", rng.integers(0, 256, (32, 40, 3), dtype=np.uint8))
    write_cli_handles(tmp_path)
    monkeypatch.chdir(tmp_path)
    return tmp_path


def run_main(*args: str) -> int:
    """``glmls ARGS`` in this process: its exit status (argparse's errors exit)."""
    try:
        return main(list(args))
    except SystemExit as done:
        return done.code


def one_line(capsys) -> str:
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert captured.out == "" and len(lines) == 1, captured
    return lines[0]


@pytest.mark.parametrize("trials", ["0", str(MAX_TRIALS + 1), "1000000000"])
def test_a_trial_count_out_of_range_is_refused(inputs, capsys, trials):
    assert run_main(*TUNE, "--reference", "r.json", "--trials", trials) == 2
    expected = f"glmls tune: argument --trials: expected an integer from 1 to {MAX_TRIALS}, "
    assert one_line(capsys).startswith(expected + f"got {trials}")
    assert not (inputs / "out").exists()


@pytest.mark.parametrize("header", ["x,y,z", "X,Y,Z", "z,x,y", "name,x,y,z"])
def test_3d_reference_points_in_a_csv_are_refused_as_in_json(inputs, capsys, header):
    """A JSON file of 3D points is refused; a CSV's z column was dropped without a word."""
    (inputs / "r3.json").write_text(json.dumps({"points": [p + [1] for p in CLI_REFERENCE]}))
    assert run_main(*TUNE, "--reference", "r3.json", "--trials", "1") == 2
    assert one_line(capsys).startswith('glmls tune: r3.json: "points"[0]: expected an [x, y]')
    columns = header.lower().split(",")
    rows = []
    for k, (x, y) in enumerate(CLI_REFERENCE):
        values = {"x": x, "y": y, "z": 2, "name": f"p{k}"}
        rows.append(",".join(str(values[c]) for c in columns))
    (inputs / "r3.csv").write_text("\n".join([header, *rows]) + "\n")
    assert run_main(*TUNE, "--reference", "r3.csv", "--trials", "1") == 2
    assert one_line(capsys) == (
        "glmls tune: r3.csv: line 1: expected 2D points (the header x,y), got 3D points "
        f"(the header {header!r})"
    )
    assert not (inputs / "out").exists()


def test_2d_reference_points_in_a_csv_are_read(inputs, capsys):
    rows = [f"{x},{y},p{k}" for k, (x, y) in enumerate(CLI_REFERENCE)]
    (inputs / "r.csv").write_text("\n".join(["x,y,name", *rows]) + "\n")
    assert run_main(*TUNE, "--reference", "r.csv", "--trials", "1", "--quiet") == 0
    assert (inputs / "out" / "ranking.json").is_file()


def test_an_earlier_runs_construction_ranking_does_not_outlive_it(inputs, capsys):
    """A run without --construction removes the ranking an earlier run with it wrote, which
    would pass for this run's; a file of that name that the tune did not write stays."""
    args = (*TUNE, "--reference", "r.json", "--trials", "1")
    construction = ("--construction", "--construction-methods", "quads")
    assert run_main(*args, *construction, "--quiet") == 0
    out = inputs / "out"
    assert (out / "construction.json").is_file() and (out / "construction.csv").is_file()
    capsys.readouterr()
    assert run_main(*args) == 0
    assert not (out / "construction.json").exists() and not (out / "construction.csv").exists()
    err = capsys.readouterr().err
    assert "tune: removed construction.json and construction.csv of an earlier run" in err
    assert sorted(p.name for p in out.iterdir()) == ["ranking.csv", "ranking.json", "winner"]
    (out / "construction.json").write_text('{"mine": true}')
    (out / "construction.csv").write_text("x,y\n1,2\n")
    assert run_main(*args) == 0
    assert (out / "construction.json").read_text() == '{"mine": true}'
    assert (out / "construction.csv").read_text() == "x,y\n1,2\n"
    assert "removed" not in capsys.readouterr().err


def test_a_construction_ranking_this_run_writes_replaces_the_earlier_one(inputs, capsys):
    args = (*TUNE, "--reference", "r.json", "--trials", "1", "--quiet", "--construction")
    assert run_main(*args, "--construction-methods", "quads", "splat") == 0
    assert run_main(*args, "--construction-methods", "backward:linear") == 0
    ranking = json.loads((inputs / "out" / "construction.json").read_text())["ranking"]
    assert [row["label"] for row in ranking] == ["backward linear"]
    assert "removed" not in capsys.readouterr().err


@pytest.mark.parametrize("shape", [(3, 200), (2, 150)])
def test_an_image_a_few_pixels_across_ranks_in_standard_json(tmp_path, capsys, shape):
    """The mesh of the angle measure had no cell across a strip thinner than its step (NaN,
    numpy's warning on stderr, NaN and Infinity in ranking.json): it has the strip's two
    edges now, and ranking.json is standard JSON whatever a measure is."""
    glmls.imwrite(tmp_path / "thin.png", np.full(shape, 128, np.uint8))
    bottom = shape[0] - 1
    src = [[20, 0], [100, bottom], [140, 0]]
    dst = [[22, bottom], [100, 0], [138, bottom]]
    (tmp_path / "h.json").write_text(json.dumps({"src": src, "dst": dst}))
    points = [[10, 0], [60, bottom], [120, 0], [145, bottom]]
    (tmp_path / "r.json").write_text(json.dumps({"points": points}))
    args = ["tune", str(tmp_path / "thin.png"), "--handles", str(tmp_path / "h.json"),
            "--reference", str(tmp_path / "r.json"), "--trials", "2",
            "--configs", "rigid:idw", "--out", str(tmp_path / "out")]  # fmt: skip
    assert run_main(*args) == 0
    err = capsys.readouterr().err
    assert "RuntimeWarning" not in err and "Mean of empty slice" not in err, err
    text = (tmp_path / "out" / "ranking.json").read_text()
    document = json.loads(text, parse_constant=lambda name: pytest.fail(f"{name} in JSON"))
    row = document["ranking"][0]
    assert np.isfinite(row["mesh_angle_mean"]) and np.isfinite(row["mesh_angle_spread"])
