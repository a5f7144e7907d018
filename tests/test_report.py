"""report(): JSON-ready summary, pictures, optional warp and fold-overs; the demo runs."""

from __future__ import annotations

import json
import runpy
import sys

import numpy as np
import pytest
from PIL import Image

import glmls

SRC = [[10.0, 10.0], [50.0, 12.0], [30.0, 40.0], [12.0, 44.0]]
DST = [[14.0, 8.0], [50.0, 12.0], [33.0, 36.0], [12.0, 44.0]]
REFERENCE = [[5.0, 5.0], [55.0, 6.0], [30.0, 25.0], [8.0, 42.0], [52.0, 40.0]]


def test_summary_and_pictures(gl, rng, tmp_path):
    image = rng.integers(0, 256, (48, 60, 3), dtype=np.uint8)
    with glmls.MLS(SRC, DST, transform="similarity", ctx=gl) as m:
        result = glmls.report(image, m, REFERENCE, grid=4, out_dir=tmp_path)
        field = m.error_field((48, 60), grid=4)
        deformed = m.warp(image)
        folds = glmls.foldovers(m, (48, 60)).count
    summary = json.loads((tmp_path / "report.json").read_text())
    assert summary == json.loads(result.to_json())
    assert summary["configuration"]["transform"] == "similarity"
    assert summary["configuration"]["handles"] == 4
    assert summary["analysis"]["grid"] == 4
    assert summary["error_field"] == json.loads(json.dumps(glmls.error_stats(field)))
    assert summary["triangles"] == json.loads(json.dumps(result.triangles.stats()))
    assert set(summary["timings_s"]) >= {"error_field", "triangle_errors", "render", "total"}
    assert summary["warp"] == {"method": "quads", "interpolation": "nearest", "grid": 1}
    assert summary["foldovers"] == {"grid": 1, "cells": folds}
    assert (result.images["deformed"] == deformed).all()
    expected = {
        "input_handles",
        "deformed",
        "deformed_mesh",
        "error_field",
        "error_field_colorbar",
        "triangulation",
        "triangle_angle",
        "triangle_angle_colorbar",
    }
    assert set(result.images) == expected
    for name, picture in result.images.items():
        assert picture.dtype == np.uint8 and picture.ndim == 3
        saved = np.asarray(Image.open(tmp_path / f"{name}.png"))
        assert (saved == picture).all()
        if "colorbar" not in name:
            assert picture.shape == (48, 60, 3)


def test_distance_errors_and_warp_options(gl, rng):
    image = rng.integers(0, 256, (40, 56, 3), dtype=np.uint8)
    with glmls.MLS(SRC, DST, ctx=gl) as m:
        result = glmls.report(
            image, m, REFERENCE, triangle_error="distance", method="backward", warp_grid=2
        )
        deformed = m.warp(image, method="backward", grid=2)
    assert (result.images["deformed"] == deformed).all()
    assert "triangle_distance" in result.images and "triangle_angle" not in result.images
    assert result.summary["warp"]["method"] == "backward"
    assert "warp" in result.summary["timings_s"]


def test_bad_arguments(gl):
    with glmls.MLS(SRC, DST, ctx=gl) as m:
        with pytest.raises(ValueError, match="triangle_error"):
            glmls.report(np.zeros((8, 8)), m, REFERENCE, triangle_error="area")
        with pytest.raises(ValueError, match="at least 3"):
            glmls.report(np.zeros((8, 8)), m, REFERENCE[:2])


def test_demo_writes_the_figures(gl, tmp_path, monkeypatch):
    argv = ["paper_figures_6_7.py", "--out", str(tmp_path), "--grid", "8"]
    monkeypatch.setattr(sys, "argv", argv)
    runpy.run_path("demos/paper_figures_6_7.py", run_name="__main__")
    for name in ("fig6.png", "fig7.png", "report.json", "error_field.png", "triangle_angle.png"):
        assert (tmp_path / name).is_file()
