"""report(): JSON-ready summary, pictures, optional warp and fold-overs; the demo runs."""

from __future__ import annotations

import json
import runpy
import sys

import numpy as np
import pytest
from PIL import Image
from scipy.spatial import Delaunay

import glmls
from glmls import reference
from glmls.analysis.reporting import picture_names

SRC = [[10.0, 10.0], [50.0, 12.0], [30.0, 40.0], [12.0, 44.0]]
DST = [[14.0, 8.0], [50.0, 12.0], [33.0, 36.0], [12.0, 44.0]]
REFERENCE = [[5.0, 5.0], [55.0, 6.0], [30.0, 25.0], [8.0, 42.0], [52.0, 40.0]]


def formula_field(points, shape):
    """E_MLS (eq. 7) at ``points`` with M, T of the float64 reference (similarity, idw)."""
    p, q = np.array(SRC), np.array(DST)
    _, big_m, t = reference.mls(p, q, points, transform="similarity", shape=shape)
    mapped = np.einsum("ni,kij->knj", p, big_m) + t[:, None, :]
    return ((mapped - q[None]) ** 2).sum(axis=(1, 2))


def angle_errors(points, deformed, eps=1e-6):
    """Eq. (11) per Delaunay triangle, written out here."""
    out = []
    for tri in Delaunay(points).simplices:
        errors = []
        for k in range(3):
            corners = [points[tri[(k + j) % 3]] for j in range(3)]
            moved = [deformed[tri[(k + j) % 3]] for j in range(3)]
            cos = []
            for a, b, c in (corners, moved):
                u, w = b - a, c - a
                cos.append(u @ w / np.linalg.norm(u) / np.linalg.norm(w))
            errors.append((abs(cos[0] - cos[1]) + eps) / (abs(cos[0]) + eps))
        out.append(np.mean(errors))
    return np.array(out)


def test_summary_and_pictures(gl, rng, tmp_path):
    shape = (48, 60)
    image = rng.integers(0, 256, (*shape, 3), dtype=np.uint8)
    with glmls.MLS(SRC, DST, transform="similarity", ctx=gl) as m:
        result = glmls.analysis.report(image, m, REFERENCE, grid=1, angle="paper", out_dir=tmp_path)
        deformed = m.warp(image)
        folds = glmls.analysis.foldovers(m, shape).count
    summary = json.loads((tmp_path / "report.json").read_text())
    assert summary == json.loads(result.to_json())
    assert summary["configuration"]["transform"] == "similarity"
    assert summary["configuration"]["handles"] == 4
    assert summary["analysis"]["grid"] == 1
    # the statistics against the float64 formula at every pixel (eqs. 7-9)
    pixels = np.stack(np.meshgrid(np.arange(60.0), np.arange(48.0)), -1).reshape(-1, 2)
    field = formula_field(pixels, shape)
    stats = summary["error_field"]
    assert stats["count"] == 48 * 60 and stats["nan_count"] == 0 and stats["unit"] == "px^2"
    for key, value in (("mean", field.mean()), ("std", field.std()), ("max", field.max())):
        assert stats[key] == pytest.approx(value, rel=1e-4), key
    assert stats["min"] == pytest.approx(field.min(), rel=1e-3, abs=1e-4)
    within = [np.mean(np.abs(field - field.mean()) <= k * field.std()) for k in (1, 2, 3)]
    assert stats["within"] == pytest.approx(within, abs=2 / field.size)
    # the triangles against eq. (11) written out, with f from the float64 reference
    points = np.array(REFERENCE)
    f, _, _ = reference.mls(SRC, DST, points, transform="similarity")
    angles = angle_errors(points, f)
    assert summary["triangles"]["triangles"] == len(angles)
    assert summary["triangles"]["angle"]["mean"] == pytest.approx(angles.mean(), rel=1e-3)
    assert summary["triangles"]["angle"]["max"] == pytest.approx(angles.max(), rel=1e-3)
    assert set(summary["timings_s"]) >= {"error_field", "triangle_errors", "render", "total"}
    assert summary["warp"] == {
        "method": "quads",
        "interpolation": "nearest",
        "grid": 1,
        "tolerance": None,
        "border": "constant",
        "output_shape": [48, 60],
        "origin": [0.0, 0.0],
    }
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
        "construction_errors",
        "construction_errors_colorbar",
    }
    assert set(result.images) == expected
    assert list(result.images) == picture_names()  # what the command line checks first
    assert summary["analysis"]["angle"] == "paper"
    assert summary["construction"]["count"] + summary["construction"]["nan_count"] == len(REFERENCE)
    for name, picture in result.images.items():
        assert picture.dtype == np.uint8 and picture.ndim == 3
        saved = np.asarray(Image.open(tmp_path / f"{name}.png"))
        assert (saved == picture).all()
        if "colorbar" not in name:
            assert picture.shape == (*shape, 3)


def test_distance_errors_and_warp_options(gl, rng):
    image = rng.integers(0, 256, (40, 56, 3), dtype=np.uint8)
    with glmls.MLS(SRC, DST, ctx=gl) as m:
        result = glmls.analysis.report(
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
            glmls.analysis.report(np.zeros((8, 8)), m, REFERENCE, triangle_error="area")
        with pytest.raises(ValueError, match="at least 3"):
            glmls.analysis.report(np.zeros((8, 8)), m, REFERENCE[:2])


def test_numpy_options_give_a_summary_json_can_write(gl, tmp_path):
    image = np.zeros((24, 32), np.uint8)
    with glmls.MLS(SRC, DST, ctx=gl) as m:
        for grid in (np.int64(2), np.array(2)):
            result = glmls.analysis.report(
                image,
                m,
                REFERENCE,
                grid=grid,
                angle=np.str_("paper"),
                eps=np.float32(1e-6),
                percentile=np.array(90.0),
                triangle_percentile=np.float64(95),
                mesh_grid=np.int32(8),
                warp_grid=np.int64(2),
                construction_radius=np.int64(2),
                triangle_error=np.str_("distance"),
                out_dir=tmp_path,
            )
            analysis = json.loads((tmp_path / "report.json").read_text())["analysis"]
            assert analysis["grid"] == 2 and type(result.summary["analysis"]["grid"]) is int
            assert analysis["angle"] == "paper" and analysis["triangle_error"] == "distance"


def test_option_types(gl):
    with glmls.MLS(SRC, DST, ctx=gl) as m:
        flags = ({"fit": "no"}, {"construction": 0.0})
        for keywords in ({"grid": 2.0}, {"angle": None}, {"triangle_error": 1}, *flags):
            with pytest.raises(TypeError, match=f"{next(iter(keywords))} must be"):
                glmls.analysis.report(np.zeros((8, 8)), m, REFERENCE, **keywords)


def test_demo_writes_the_figures(gl, tmp_path, monkeypatch):
    argv = ["paper_figures_6_7.py", "--out", str(tmp_path), "--grid", "8"]
    monkeypatch.setattr(sys, "argv", argv)
    runpy.run_path("demos/paper_figures_6_7.py", run_name="__main__")
    for name in ("fig6.png", "fig7.png", "report.json", "error_field.png", "triangle_angle.png"):
        assert (tmp_path / name).is_file()


def test_fit_and_border_draw_on_the_whole_deformed_image(gl, rng):
    shape = (48, 60)
    image = rng.integers(0, 256, (*shape, 3), dtype=np.uint8)
    dst = np.array(DST) + [[-9.0, -6.0], [9.0, -6.0], [9.0, 8.0], [-9.0, 8.0]]  # pushed out
    with glmls.MLS(SRC, dst, transform="similarity", ctx=gl) as m:
        result = glmls.analysis.report(image, m, REFERENCE, border="edge", fit=True)
        b = m.bounds(shape)
        whole = m.warp(image, border="edge", output_shape=b.output_shape, origin=b.origin)
        moved = m(np.array(REFERENCE))
    warp = result.summary["warp"]
    assert warp["border"] == "edge"
    assert warp["output_shape"] == list(b.output_shape) and warp["origin"] == list(b.origin)
    np.testing.assert_array_equal(result.images["deformed"], whole)
    for name in ("deformed_mesh", "triangle_angle"):
        assert result.images[name].shape[:2] == b.output_shape, name
    # the triangles sit at f(r) - origin on the canvas: a vertex's pixel is the edge colour
    picture = result.images["triangle_angle"].astype(int)
    for x, y in moved - b.origin:
        assert picture[round(y), round(x)].sum() < 3 * 90  # dark edge lines meet


def test_pictures_take_the_canvas_origin(gl):
    mesh = np.stack(np.meshgrid(np.linspace(3, 40, 6), np.linspace(5, 30, 5)), -1)
    blank = np.full((40, 50, 3), 255, np.uint8)
    shifted = glmls.analysis.render_mesh(blank, mesh, origin=(-4.0, 2.5))
    np.testing.assert_array_equal(shifted, glmls.analysis.render_mesh(blank, mesh - [-4.0, 2.5]))
    with pytest.raises(ValueError, match="origin"):
        glmls.analysis.render_mesh(blank, mesh, origin=(0.0, np.inf))


def test_report_refuses_a_bad_border_before_any_work(gl):
    with glmls.MLS(SRC, DST, ctx=gl) as m:
        with pytest.raises(ValueError, match="unknown border 'clamp'; choose one of constant"):
            glmls.analysis.report(np.zeros((20, 20), np.uint8), m, REFERENCE, border="clamp")


@pytest.mark.parametrize("made_for", [(24, 30), None])
def test_points_measured_with_the_radius_of_the_analysed_image(gl, rng, made_for):
    # a radius weight given no radius warps an image with that image's diagonal: the
    # triangles and the construction errors measure that f, not the one of the MLS's shape
    shape = (48, 60)
    image = rng.integers(0, 256, (*shape, 3), dtype=np.uint8)
    options = {"transform": "similarity", "weight": "gaussian"}
    points = np.array(REFERENCE)
    with glmls.MLS(SRC, DST, shape=made_for, ctx=gl, **options) as m:
        result = glmls.analysis.report(image, m, points, mesh_grid=8)
        built = glmls.analysis.construction_errors(image, m.warp(image), m, points)
    warped, _, _ = reference.mls(SRC, DST, points, shape=shape, **options)
    radius = result.summary["configuration"]["radius_used"]
    assert radius == pytest.approx(np.hypot(*shape))
    np.testing.assert_allclose(result.triangles.deformed_points, warped, rtol=0, atol=1e-3)
    np.testing.assert_allclose(result.construction.deformed_points, warped, rtol=0, atol=1e-3)
    np.testing.assert_allclose(built.deformed_points, warped, rtol=0, atol=1e-3)
