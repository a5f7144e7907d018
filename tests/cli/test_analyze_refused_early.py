"""``glmls analyze`` on a volume or a mesh refuses, before any work and naming the file,
reference points whose tetrahedra are all slivers and a volume of no finite voxel."""

from __future__ import annotations

import json

import numpy as np
import pytest
from helpers import run_glmls

import glmls

SRC = [[1, 1, 1], [6, 1, 1], [1, 5, 1], [1, 1, 4], [6, 5, 4]]
#: four points 1/100 of their extent off one plane: one tetrahedron, of radius ratio ~0.004
THIN = [[0, 0, 0], [6, 0, 0], [0, 6, 0], [6, 6, 0.03]]


@pytest.fixture
def files(tmp_path):
    volume = (np.random.default_rng(0).random((6, 7, 8)) * 250).astype(np.uint8)
    np.save(tmp_path / "v.npy", volume)
    np.save(tmp_path / "nan.npy", np.full((4, 5, 6), np.nan, np.float32))
    glmls.write_mesh(
        tmp_path / "m.ply", [[0, 0, 0], [4, 0, 0], [0, 4, 0], [0, 0, 4]], faces=[[0, 1, 2]]
    )
    (tmp_path / "h3.json").write_text(json.dumps({"src": SRC, "dst": SRC}))
    (tmp_path / "thin.json").write_text(json.dumps({"points": THIN}))
    return tmp_path


@pytest.mark.parametrize("source", ["v.npy", "m.ply"])
def test_reference_points_of_only_slivers_are_refused_before_any_work(files, source):
    result = run_glmls(
        "analyze", source, "--handles", "h3.json", "--reference", "thin.json", "--out", "rep",
        cwd=files, module="glmls.cli",
    )  # fmt: skip
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, lines
    assert lines[0].startswith("glmls analyze: thin.json: no tetrahedron to measure"), lines
    assert "tetrahedron is a sliver" in lines[0] and "min_quality" not in lines[0], lines
    assert not (files / "rep").exists()


def test_reference_points_with_one_good_tetrahedron_are_taken(files):
    points = [*THIN, [3, 3, 5]]  # a fifth point well off the plane
    (files / "good.json").write_text(json.dumps({"points": points}))
    result = run_glmls(
        "analyze", "v.npy", "--handles", "h3.json", "--reference", "good.json", "--out", "rep",
        cwd=files, module="glmls.cli",
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    summary = json.loads((files / "rep" / "report.json").read_text())
    assert summary["tetrahedra"]["tetrahedra"] >= 1


def test_a_volume_of_no_finite_voxel_is_refused_naming_it(files):
    result = run_glmls(
        "analyze", "nan.npy", "--handles", "h3.json", "--out", "rep", cwd=files, module="glmls.cli"
    )
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert lines == ["glmls analyze: nan.npy: no finite voxel: every voxel is NaN or infinite"]
    assert not (files / "rep").exists()
