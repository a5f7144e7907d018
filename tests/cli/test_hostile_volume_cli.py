"""Hostile files to ``glmls warp`` and ``glmls analyze`` on volumes and meshes: one line
naming the file and the fault, exit status 2, no traceback, no output written."""

from __future__ import annotations

import json

import numpy as np
import pytest
from helpers import run_glmls as cli

import glmls


@pytest.fixture
def files(tmp_path):
    volume = (np.random.default_rng(0).random((6, 7, 8)) * 250).astype(np.uint8)
    np.save(tmp_path / "v.npy", volume)
    glmls.write_mesh(
        tmp_path / "m.ply", [[0, 0, 0], [4, 0, 0], [0, 4, 0], [0, 0, 4]], faces=[[0, 1, 2]]
    )
    (tmp_path / "none.json").write_text(json.dumps({"src": [], "dst": []}))
    (tmp_path / "out").mkdir()
    return tmp_path


@pytest.mark.parametrize(
    "args",
    [
        ("warp", "v.npy", "out/o.npy"),
        ("warp", "m.ply", "out/o.ply", "--radius", "10", "--weight", "gaussian"),
        ("analyze", "v.npy", "--out", "out/a"),
    ],
)
def test_a_handle_file_of_no_handles_is_named_as_such_not_as_2d(files, args):
    result = cli(*args, "--handles", "none.json", cwd=files)
    assert result.returncode == 2, result.stderr
    assert "Traceback" not in result.stderr
    lines = result.stderr.strip().splitlines()
    assert lines == ["glmls " + args[0] + ": none.json: content: no handles"], lines
    assert not list((files / "out").iterdir())


@pytest.mark.parametrize(
    "args",
    [
        ("warp", "folder.nii.gz", "out/o.nii.gz", "--handles", "h3.json"),
        ("warp", "folder.ply", "out/o.ply", "--handles", "h3.json"),
        ("analyze", "folder.nii.gz", "--out", "out/a", "--handles", "h3.json"),
        ("analyze", "folder.ply", "--out", "out/a", "--handles", "h3.json"),
    ],
)
def test_an_input_that_is_a_folder_is_named_a_folder_not_missing(files, args):
    (files / args[1]).mkdir()
    src = [[1, 1, 1], [5, 1, 1], [1, 5, 1], [1, 1, 4]]
    (files / "h3.json").write_text(json.dumps({"src": src, "dst": src}))
    result = cli(*args, cwd=files)
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert lines == [f"glmls {args[0]}: {args[1]}: a folder, not a file"], lines
    assert not list((files / "out").iterdir())


@pytest.mark.parametrize("command", ["warp", "analyze"])
@pytest.mark.parametrize("grid", ["1048577", "99999999999"])
def test_a_grid_beyond_the_largest_is_one_line_not_a_warning_before_it(files, command, grid):
    # a grid not smaller than the volume warns that its lattice is one cell; beyond the
    # largest grid the warp refuses it, and that refusal is the only line
    src = [[1, 1, 1], [6, 1, 1], [1, 5, 1], [1, 1, 4]]
    (files / "h3.json").write_text(json.dumps({"src": src, "dst": src}))
    out = ["out/o.npy"] if command == "warp" else ["--out", "out/a"]
    result = cli(command, "v.npy", *out, "--handles", "h3.json", "--grid", grid, cwd=files)
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert lines == [
        f"glmls {command}: v.npy: grid must be an integer from 1 to 1048576 (voxels), got {grid}"
    ], lines
    assert not list((files / "out").iterdir())
