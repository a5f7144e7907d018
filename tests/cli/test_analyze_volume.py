"""``glmls analyze`` on a volume with 3D handles, end to end."""

from __future__ import annotations

import json

import numpy as np
import pytest
from helpers import run_glmls, write_elastix_points
from numpy.testing import assert_allclose

import glmls
from glmls.analysis import ReferenceDeformation, cell_jacobians, error_stats, volume_error_field
from glmls.files.volumes import write_volume

SHAPE = (10, 12, 14)
SRC = [[2, 2, 2], [11, 2, 2], [2, 9, 2], [2, 2, 7], [11, 9, 7], [4, 6, 4], [9, 6, 4]]
DST = [*SRC[:5], [9, 6, 4], [4, 6, 4]]  # the last two swap places: the map folds
REFERENCE = [[3, 3, 3], [10, 3, 3], [3, 8, 3], [3, 3, 6], [10, 8, 6], [6, 6, 5]]


@pytest.fixture
def inputs(tmp_path):
    _, y, x = np.mgrid[0 : SHAPE[0], 0 : SHAPE[1], 0 : SHAPE[2]]
    volume = (100 + 80 * np.sin(x / 2.0) * np.cos(y / 3.0)).astype(np.uint8)
    np.save(tmp_path / "v.npy", volume)
    (tmp_path / "h3.json").write_text(json.dumps({"src": SRC, "dst": DST}))
    (tmp_path / "h2.json").write_text(
        json.dumps({"src": [[1, 2], [3, 4]], "dst": [[1, 2], [3, 5]]})
    )
    (tmp_path / "r3.json").write_text(json.dumps({"points": REFERENCE}))
    flat = [[3, 3, 3], [10, 3, 3], [3, 8, 3], [10, 8, 3]]  # all on the plane z = 3
    (tmp_path / "flat.json").write_text(json.dumps({"points": flat}))
    (tmp_path / "far.json").write_text(json.dumps({"points": [*REFERENCE, [3, 3, 1e30]]}))
    return tmp_path


def analyze(*args, cwd):
    return run_glmls("analyze", *args, cwd=cwd, module="glmls.cli")


def test_analyze_a_volume_writes_the_report_and_pictures(inputs):
    result = analyze(
        "v.npy", "--handles", "h3.json", "--reference", "r3.json", "--transform", "affine",
        "--analysis-grid", "2", "--out", "rep", cwd=inputs,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert "Traceback" not in result.stderr
    assert "voxel^2" in result.stderr  # no spacing: the handles are in voxels
    summary = json.loads((inputs / "rep" / "report.json").read_text())
    assert summary["input"] == "v.npy"
    assert summary["volume"] == {
        "depth": 10,
        "height": 12,
        "width": 14,
        "channels": 1,
        "nan_voxels": 0,
        "infinite_voxels": 0,
    }
    assert summary["configuration"]["src"] == np.array(SRC, float).tolist()
    m = ReferenceDeformation(SRC, DST, transform="affine", shape=SHAPE)
    field = volume_error_field(m, SHAPE, grid=2)
    # the GPU (float32) where glmls.MLS takes 3D handles, else the reference itself
    found = summary["error_field"]
    expected = error_stats(field)
    assert_allclose(found["mean"], expected["mean"], rtol=1e-3)
    assert_allclose(found["max"], expected["max"], rtol=1e-3)
    cells = cell_jacobians(m, SHAPE, grid=2)
    assert summary["jacobians"]["folds"] == cells.count > 0
    assert summary["tetrahedra"]["tetrahedra"] + summary["tetrahedra"]["slivers"] > 0
    assert summary["analysis"]["reference_points"] == "given"
    for name in ("input_handles", "error_field", "jacobian_det", "folds"):
        assert (inputs / "rep" / f"{name}.png").stat().st_size > 0, name
    # the deformed volume where the deformation warps volumes (glmls.volume)
    assert (inputs / "rep" / "deformed.png").exists() == summary["deformed"]
    assert (
        str(inputs / "rep" / "report.json") in result.stdout or "rep/report.json" in result.stdout
    )
    assert "folds" in result.stderr and "E_MLS median" in result.stderr


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (
            ["v.npy", "--handles", "h2.json"],
            "h2.json: 2D handles (x, y), but v.npy is a volume: it takes 3D handles (x, y, z)",
        ),
        (["v.npy"], "missing --handles"),
        (["v.npy", "--handles", "h3.json", "--fit"], "--fit: for images, not for a volume (v.npy)"),
        (
            ["v.npy", "--handles", "h3.json", "--max-pixels", "9"],
            "--max-pixels: for images, not for a volume (v.npy)",
        ),
        (
            ["v.npy", "--handles", "h3.json", "--tolerance", "0.1"],
            "--tolerance: for images, not for a volume (v.npy)",
        ),
        (["v.npy", "--handles", "h3.json", "--reference", "h2.json"], 'missing the key "points"'),
        (["missing.npy", "--handles", "h3.json"], "no such file"),
        (
            ["v.npy", "--handles", "h3.json", "--reference", "flat.json"],
            "flat.json: reference_points all lie on one plane",
        ),
        (
            ["v.npy", "--handles", "h3.json", "--reference", "far.json"],
            "far.json: reference_points must lie within ±1e+06",
        ),
    ],
)
def test_bad_volume_inputs_exit_2_with_one_line(inputs, args, message):
    result = analyze(*args, "--out", "rep", cwd=inputs)
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and message in lines[0], result.stderr
    assert not (inputs / "rep" / "report.json").exists()


@pytest.mark.parametrize("suffix", [".tif", ".nii.gz"])
def test_a_tiff_stack_or_nifti_volume_gives_the_npy_report(inputs, suffix):
    if suffix == ".nii.gz":
        pytest.importorskip("nibabel")
    write_volume(inputs / f"v{suffix}", np.load(inputs / "v.npy"))
    reports = {}
    for name in ("v.npy", f"v{suffix}"):
        result = analyze(
            name, "--handles", "h3.json", "--analysis-grid", "3", "--out", name + ".out", cwd=inputs
        )
        assert result.returncode == 0, result.stderr
        summary = json.loads((inputs / (name + ".out") / "report.json").read_text())
        for key in ("timings_s", "input"):
            summary.pop(key)
        reports[name] = summary
    assert reports["v.npy"] == reports[f"v{suffix}"]


def test_3d_handles_on_an_image_exit_2_with_one_line(inputs):
    glmls.imwrite(inputs / "a.png", np.zeros((20, 20), np.uint8))
    result = analyze("a.png", "--handles", "h3.json", "--out", "rep", cwd=inputs)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert (
        len(lines) == 1
        and "3D handles (x, y, z), but a.png is an image: it takes 2D handles (x, y)" in lines[0]
    ), result.stderr


def test_the_spacing_of_the_file_or_the_option_is_glmls_warps(inputs):
    glmls.imwrite(inputs / "a.png", np.zeros((20, 20), np.uint8))
    """Handles in physical units on an anisotropic stack: analyze evaluates f where glmls warp
    puts the voxels, (i dx, j dy, k dz), as --spacing or the file says, and takes elastix
    pairs (--targets) as warp does."""
    spacing = (2.0, 1.0, 0.5)
    scale = np.array(spacing[::-1])
    src, dst = np.array(SRC, float) * scale, np.array(DST, float) * scale
    write_volume(inputs / "v.tif", np.load(inputs / "v.npy"), spacing=spacing)
    for name, points in (("moving.pts", src), ("fixed.pts", dst)):
        write_elastix_points(inputs / name, "point", points)
    z, y, x = np.mgrid[0 : SHAPE[0], 0 : SHAPE[1], 0 : SHAPE[2]]
    voxels = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1) * scale
    expected = error_stats(glmls.reference.mls_error(src, dst, voxels, transform="affine"))
    handles = ["--handles", "moving.pts", "--targets", "fixed.pts", "--transform", "affine"]
    for given in (["v.tif"], ["v.npy", "--spacing", "2,1,0.5"]):
        result = analyze(*given, *handles, "--out", "rep", cwd=inputs)
        assert result.returncode == 0, result.stderr
        summary = json.loads((inputs / "rep" / "report.json").read_text())
        assert summary["analysis"]["spacing"] == list(spacing)
        assert summary["configuration"]["src"] == src.tolist()
        for key in ("mean", "median", "max"):
            assert_allclose(summary["error_field"][key], expected[key], rtol=2e-3)
        # E_MLS in the handles' units, not voxels, said so on stderr
        assert "(handle units)^2" in result.stderr and "voxel^2" not in result.stderr
        assert summary["error_field"]["unit"] == "(handle units)^2"
    for name, points in (("moving.pts", SRC), ("fixed.pts", DST)):  # voxel indices
        write_elastix_points(inputs / name, "index", points)
    result = analyze("v.tif", *handles, "--out", "indices", cwd=inputs)
    assert result.returncode == 0, result.stderr
    summary = json.loads((inputs / "indices" / "report.json").read_text())
    assert summary["configuration"]["src"] == src.tolist()
    image = analyze("a.png", "--handles", "h2.json", "--spacing", "2", "--out", "x", cwd=inputs)
    assert image.returncode == 2 and "--spacing: for volumes" in image.stderr


def test_the_deformed_volume_is_built_with_the_construction_options(inputs, monkeypatch, capsys):
    """--method, --interpolation, --border and --grid build the deformed volume that
    deformed.png shows, as glmls warp builds it; an image-only method is refused, as by warp."""
    from glmls.cli.main import main
    from glmls.mls3 import MLS3

    calls = []
    warp = MLS3.warp

    def recording(self, volume, **options):
        calls.append(options)
        return warp(self, volume, **options)

    monkeypatch.setattr(MLS3, "warp", recording)
    monkeypatch.chdir(inputs)
    argv = ["analyze", "v.npy", "--handles", "h3.json", "--analysis-grid", "3", "--out", "rep"]
    options = ["--method", "backward", "--interpolation", "linear", "--border", "edge"]
    assert main([*argv, *options, "--grid", "2"]) == 0
    assert calls[-1] == {
        "method": "backward", "interpolation": "linear", "border": "edge", "grid": 2
    }  # fmt: skip
    # report.json says how deformed.png was made
    assert json.loads((inputs / "rep" / "report.json").read_text())["warp"] == {
        "method": "backward",
        "interpolation": "linear",
        "grid": 2,
        "border": "edge",
        "background": 0.0,
        "output_shape": list(SHAPE),
        "origin": [0.0, 0.0, 0.0],
        "spacing": [1.0, 1.0, 1.0],
    }
    assert main([*argv, "--method", "splat"]) == 2  # refused before any work, as by warp
    assert "unknown method 'splat' for a volume" in capsys.readouterr().err


def test_an_elastix_pair_of_2d_points_on_an_image(inputs):
    glmls.imwrite(inputs / "a.png", np.full((24, 32), 90, np.uint8))
    (inputs / "moving.pts").write_text("index\n4\n4 4\n27 4\n4 19\n27 19\n")
    (inputs / "fixed.pts").write_text("index\n4\n5 4\n27 5\n4 19\n26 19\n")
    argv = ["a.png", "--handles", "moving.pts", "--targets", "fixed.pts", "--out", "rep"]
    result = analyze(*argv, cwd=inputs)
    assert result.returncode == 0, result.stderr
    summary = json.loads((inputs / "rep" / "report.json").read_text())
    assert summary["triangles"]["triangles"] > 0


def test_the_reference_file_may_give_its_own_tetrahedra(inputs):
    """``"tetrahedra"`` in the ``--reference`` JSON: those tetrahedra are measured, not the
    points' Delaunay tetrahedra (more than one here)."""
    own = {"points": REFERENCE, "tetrahedra": [[0, 1, 2, 3]]}
    (inputs / "own.json").write_text(json.dumps(own))
    result = analyze(
        "v.npy", "--handles", "h3.json", "--reference", "own.json", "--out", "rep", cwd=inputs
    )
    assert result.returncode == 0, result.stderr
    summary = json.loads((inputs / "rep" / "report.json").read_text())
    assert summary["tetrahedra"]["tetrahedra"] == 1
