"""The glmls command line, end to end in subprocesses, on small images."""

from __future__ import annotations

import json

import numpy as np
import pytest
from helpers import CLI_DST as DST
from helpers import CLI_SRC as SRC
from helpers import glmls_cli, write_cli_handles

import glmls


@pytest.fixture
def inputs(tmp_path):
    rng = np.random.default_rng(3)
    image = rng.integers(0, 256, (32, 40, 3), dtype=np.uint8)
    glmls.imwrite(tmp_path / "a.png", image)
    glmls.imwrite(tmp_path / "b.png", image[::-1].copy())
    write_cli_handles(tmp_path)
    return tmp_path


def _no_traceback(result):
    assert "Traceback" not in result.stderr, result.stderr


def test_warp_one_image_matches_the_api(inputs, gl):
    result = glmls_cli("warp", "a.png", "out.png", "--handles", "h.json", cwd=inputs)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "out.png"
    image = glmls.imread(inputs / "a.png")
    expected = glmls.warp(image, SRC, DST, ctx=gl)
    assert (glmls.imread(inputs / "out.png") == expected).all()


def test_warp_a_glob_into_a_folder_with_progress(inputs):
    result = glmls_cli(
        "warp", "*.png", "outdir", "--handles", "h.json", "--method", "backward",
        "--background", "255,0,0", cwd=inputs,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert sorted(p.name for p in (inputs / "outdir").iterdir()) == ["a.png", "b.png"]
    assert "warp [" in result.stderr and "2/2" in result.stderr
    quiet = glmls_cli("--quiet", "warp", ".", "q", "--handles", "h.json", cwd=inputs)
    assert quiet.returncode == 0 and quiet.stderr == ""


def test_warp_border_and_fit_match_the_api(inputs, gl):
    image = glmls.imread(inputs / "a.png")
    result = glmls_cli(
        "warp", "a.png", "edge.png", "--handles", "h.json", "--border", "edge",
        "--method", "backward", cwd=inputs,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    expected = glmls.warp(image, SRC, DST, ctx=gl, border="edge", method="backward")
    assert (glmls.imread(inputs / "edge.png") == expected).all()
    result = glmls_cli("warp", "a.png", "fit.png", "--handles", "h.json", "--fit", cwd=inputs)
    assert result.returncode == 0, result.stderr
    with glmls.MLS(SRC, DST, shape=image.shape, ctx=gl) as m:
        b = m.bounds(image.shape)
        expected = m.warp(image, output_shape=b.output_shape, origin=b.origin)
    assert b.output_shape != image.shape[:2]
    fit = glmls.imread(inputs / "fit.png")
    assert fit.shape[:2] == b.output_shape and (fit == expected).all()
    (h, w), (x0, y0) = b.output_shape, b.origin
    assert f"{w} x {h} pixels from ({x0:g}, {y0:g})" in result.stderr
    bad = glmls_cli(
        "warp", "a.png", "x.png", "--handles", "h.json", "--border", "mirror", cwd=inputs
    )
    assert bad.returncode == 2 and "invalid choice: 'mirror'" in bad.stderr
    assert not (inputs / "x.png").exists()


def test_analyze_writes_the_report_and_pictures(inputs):
    result = glmls_cli(
        "analyze", "a.png", "--handles", "h.json", "--reference", "r.json", "--out", "rep",
        "--transform", "similarity", cwd=inputs,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    summary = json.loads((inputs / "rep" / "report.json").read_text())
    assert summary["configuration"]["transform"] == "similarity"
    assert summary["triangles"]["triangles"] >= 3
    assert {"error_field", "triangles", "foldovers", "timings_s"} <= set(summary)
    for name in ("deformed", "error_field", "triangulation", "triangle_angle"):
        assert (inputs / "rep" / f"{name}.png").is_file()
    fit = glmls_cli(
        "analyze", "a.png", "--handles", "h.json", "--out", "fit", "--border", "wrap", "--fit",
        cwd=inputs,
    )  # fmt: skip
    assert fit.returncode == 0, fit.stderr
    warp = json.loads((inputs / "fit" / "report.json").read_text())["warp"]
    assert warp["border"] == "wrap" and warp["output_shape"] != [32, 40]
    for name in ("deformed", "deformed_mesh", "triangle_angle"):
        picture = glmls.imread(inputs / "fit" / f"{name}.png")
        assert list(picture.shape[:2]) == warp["output_shape"], name


def test_tune_is_reproducible_for_a_seed(inputs):
    def run(out):
        result = glmls_cli(
            "tune", "a.png", "--handles", "h.json", "--reference", "r.json", "--out", out,
            "--trials", "2", "--seed", "7", "--configs", "rigid:idw", "*:gaussian:radius=40",
            cwd=inputs,
        )  # fmt: skip
        assert result.returncode == 0, result.stderr
        return result, json.loads((inputs / out / "ranking.json").read_text())

    first, ranking = run("t1")
    _, again = run("t2")
    assert ranking["ranking"] == again["ranking"]
    assert len(ranking["ranking"]) == 5  # rigid idw alpha 1 and 2, 3 gaussians
    assert [row["rank"] for row in ranking["ranking"]] == [1, 2, 3, 4, 5]
    assert "rank  configuration" in first.stdout
    assert (inputs / "t1" / "ranking.csv").read_text().startswith("transform,weight,")
    assert (inputs / "t1" / "winner" / "report.json").is_file()
    assert "left" in first.stderr  # progress with the time left
    assert "warning" not in first.stderr  # every parameter given is used


def test_tune_warns_of_a_configuration_parameter_its_weight_does_not_use(inputs):
    result = glmls_cli(
        "tune", "a.png", "--handles", "h.json", "--reference", "r.json", "--out", "t",
        "--trials", "1", "--configs", "rigid:idw:radius=5", "*:*:s=0.5",
        cwd=inputs,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    warnings = [line for line in result.stderr.splitlines() if "warning" in line]
    assert warnings == [
        "glmls tune: warning: --configs rigid:idw:radius=5: radius=5 is not used by the idw "
        "weight (the radius weights use it: cressman, shepard, gaussian, linear)"
    ]


@pytest.mark.parametrize(
    ("files", "args", "message"),
    [
        ({"bad.json": '{"src": [[1, 2]], "dst": [[1, 2]'}, [], "bad.json: line 1: invalid JSON"),
        ({"bad.json": '{"src": [[1, 2]]}'}, [], 'missing the key "dst"'),
        ({"bad.json": '{"src": [[1, "x"]], "dst": [[1, 2]]}'}, [], "expected a number"),
        ({"bad.json": '{"src": [[1, NaN]], "dst": [[1, 2]]}'}, [], "expected a finite number"),
        ({"bad.json": '{"src": [], "dst": []}'}, [], "no handles"),
        (
            {"bad.csv": "src_x,src_y,dst_x\n1,2,3\n"},
            [],
            "bad.csv: line 1: the header lacks the column dst_y",
        ),
        ({"bad.csv": "src_x,src_y,dst_x,dst_y\n1,2,3,4\n1,2\n"}, [], "line 3: expected 4"),
        ({"bad.json": '{"src": [[1, 1], [1, 1]], "dst": [[2, 2], [3, 3]]}'}, [], "same point"),
        ({}, ["--transform", "projective"], "invalid choice"),
        ({}, ["--alpha", "-1"], "alpha must be a finite number > 0"),
        ({}, ["--grid", "0"], "expected an integer >= 1"),
    ],
)
def test_malformed_input_exits_2_with_a_message(inputs, files, args, message):
    for name, text in files.items():
        (inputs / name).write_text(text)
    handles = next(iter(files), "h.json")
    result = glmls_cli("warp", "a.png", "o.png", "--handles", handles, *args, cwd=inputs)
    assert result.returncode == 2
    assert message in result.stderr
    _no_traceback(result)
    assert not (inputs / "o.png").exists()


def test_usage_errors(inputs):
    (inputs / "h3.json").write_text('{"src": [[1, 2, 3]], "dst": [[2, 2, 3]]}')
    (inputs / "r2.json").write_text('{"points": [[1, 2], [3, 4]]}')
    for args, message in [
        (["warp", "missing.png", "o.png", "--handles", "h.json"], "no such file"),
        (["analyze", "--out", "x"], "missing IN, --handles (or use --example)"),
        (["tune", "a.png", "--handles", "h.json", "--out", "x"], "missing --reference"),
        (["tune", "--example", "--out", "x", "--configs", "rigid"], "expected transform:weight"),
        (["warp", "h.json", "o.png", "--handles", "h.json"], "h.json: not an image format"),
        (["analyze", "a.png", "--example", "--out", "x"], "--example replaces IN, --handles"),
        (["tune", "--example", "--reference", "h.json", "--out", "x"], "out --reference h.json"),
        (["tune", "--example", "--out", "x", "--seed", "-1"], "--seed: expected an integer >= 0"),
        (["study", "--out", "x", "--seed", "-1"], "--seed: expected an integer >= 0, got -1"),
        (
            ["analyze", "a.png", "--handles", "h3.json", "--out", "x"],
            "h3.json: 3D handles (x, y, z), but a.png is an image: it takes 2D handles (x, y)",
        ),
        (
            ["analyze", "a.png", "--handles", "h.json", "--reference", "r2.json", "--out", "x"],
            "glmls analyze: r2.json: a triangulation needs at least 3 points, got 2\n",
        ),
    ]:
        result = glmls_cli(*args, cwd=inputs)
        assert result.returncode == 2, (args, result.stderr)
        assert message in result.stderr, (args, result.stderr)
        _no_traceback(result)


def test_a_bad_option_is_one_line_not_the_usage(inputs):
    """argparse's mistakes (a bad value, a missing argument, an unknown command) are one line
    with the fault and where the options are listed, not the dozen lines of the usage."""
    for args, line in [
        (["warp", "a.png", "o.png", "--handles", "h.json", "--grid", "0"],
         "glmls warp: argument --grid: expected an integer >= 1, got 0 (see glmls warp --help)"),
        (["warp"], "glmls warp: the following arguments are required: IN, OUT, --handles"),
        (["wrap"], "glmls: argument COMMAND: invalid choice: 'wrap'"),
    ]:  # fmt: skip
        result = glmls_cli(*args, cwd=inputs)
        assert result.returncode == 2, (args, result.stderr)
        assert result.stderr.startswith(line), (args, result.stderr)
        assert len(result.stderr.strip().splitlines()) == 1, (args, result.stderr)


def test_an_output_folder_that_is_a_file_is_refused_before_any_work(inputs):
    """--out naming a file (or a path below one) is refused when the options are read, not
    when the report, the ranking or the study is written after all the work."""
    (inputs / "taken").write_text("a file")
    for args, message in [
        (["analyze", "--example", "--out", "taken"], "argument --out: taken: a file, not a folder"),
        (["tune", "--example", "--out", "taken/x"], "taken/x: taken is a file, not a folder"),
        (["study", "--out", "taken"], "taken: a file, not a folder"),
        (["bench", "--quick", "--out", "taken"], "taken: a file, not a folder"),
        (["warp", "a.png", "taken/o.png", "--handles", "h.json"], "taken is a file, not a"),
        (["warp", "a.png", "taken/", "--handles", "h.json"], "taken: a file, not a folder"),
    ]:
        result = glmls_cli(*args, cwd=inputs)
        assert result.returncode == 2, (args, result.stderr)
        assert message in result.stderr, (args, result.stderr)
        assert len(result.stderr.strip().splitlines()) == 1, (args, result.stderr)
        _no_traceback(result)
    assert (inputs / "taken").read_text() == "a file"


def test_version_and_help(inputs):
    assert glmls_cli("--version", cwd=inputs).stdout.strip() == f"glmls {glmls.__version__}"
    for command in ("warp", "analyze", "tune", "demo", "bench"):
        result = glmls_cli(command, "--help", cwd=inputs)
        assert result.returncode == 0 and "examples:" in result.stdout


def test_demo_without_a_display_points_to_the_headless_commands(inputs, monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    result = glmls_cli("demo", "--frames", "1", cwd=inputs)
    assert result.returncode == 1
    assert "no display" in result.stderr and "xvfb-run" in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1
    _no_traceback(result)


def test_warp_and_analyze_take_the_adaptive_tolerance(inputs, gl):
    result = glmls_cli(
        "warp", "a.png", "t.png", "--handles", "h.json", "--tolerance", "0.05", cwd=inputs
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    image = glmls.imread(inputs / "a.png")
    expected = glmls.warp(image, SRC, DST, ctx=gl, tolerance=0.05)
    assert (glmls.imread(inputs / "t.png") == expected).all()
    report = glmls_cli(
        "analyze", "a.png", "--handles", "h.json", "--out", "rep", "--tolerance", "0.25",
        cwd=inputs,
    )  # fmt: skip
    assert report.returncode == 0, report.stderr
    assert json.loads((inputs / "rep" / "report.json").read_text())["warp"]["tolerance"] == 0.25
    for args, message in (
        (("--tolerance", "0.05", "--grid", "4"), "grid and tolerance exclude each other"),
        (("--tolerance", "0.05", "--method", "splat"), "method 'quads'"),
        (("--tolerance", "0"), "expected a finite number > 0"),
        (("--tolerance", "nan"), "expected a finite number > 0"),
        (("--tolerance", "0.0001"), "tolerance must be at least 0.001 px"),
    ):
        bad = glmls_cli("warp", "a.png", "x.png", "--handles", "h.json", *args, cwd=inputs)
        assert bad.returncode == 2 and message in bad.stderr, (args, bad.stderr)
        _no_traceback(bad)


def test_a_grid_as_large_as_the_image_is_warned_about(inputs, gl):
    """A grid not smaller than the image warps it by its four corners alone, every handle
    inside ignored: stderr says so."""
    result = glmls_cli("warp", "a.png", "o.png", "--handles", "h.json", "--grid", "40", cwd=inputs)
    assert result.returncode == 0, result.stderr
    assert "warning: --grid 40 is not smaller than the 40 x 32 image" in result.stderr
    result = glmls_cli("warp", "a.png", "o.png", "--handles", "h.json", "--grid", "39", cwd=inputs)
    assert result.returncode == 0 and "--grid" not in result.stderr, result.stderr


def test_an_output_that_cannot_be_written_is_named_once_with_status_1(
    inputs, gl, monkeypatch, capsys
):
    """A full disk or a refused write is one line naming the output, no batch index before
    it, exit status 1."""
    from glmls.cli import warp
    from glmls.cli.main import main

    def full(path, image, **options):
        raise OSError(f"{path}: cannot write: No space left on device")

    monkeypatch.setattr(warp, "write_image", full)
    monkeypatch.chdir(inputs)
    assert main(["warp", "a.png", "o.png", "--handles", "h.json"]) == 1
    assert capsys.readouterr().err == "glmls warp: o.png: cannot write: No space left on device\n"


def test_an_image_of_a_dtype_glmls_does_not_warp_is_named_not_its_output(inputs):
    """No output suffix takes an int16 image: the message names the input and the dtypes
    glmls warps, not the output's format."""
    import tifffile

    tifffile.imwrite(inputs / "i16.tif", np.zeros((8, 8), np.int16))
    for args in (["warp", "i16.tif", "o.tif", "--handles", "h.json"], ["augment", "i16.tif", "o"]):
        result = glmls_cli(*args, cwd=inputs)
        assert result.returncode == 2, result.stderr
        assert result.stderr.endswith(
            "i16.tif dtype must be one of uint8, uint16, float32, float64; got int16\n"
        ), result.stderr


def test_an_option_the_weight_does_not_use_is_warned_about(inputs, gl):
    """--radius with idw, or --alpha with gaussian, changes nothing: stderr says so."""
    for args, warning in [
        (["--radius", "50"], "warning: --radius 50 is not used by the idw weight"),
        (["--weight", "gaussian", "--alpha", "2"], "warning: --alpha 2 is not used by the"),
        (["--weight", "linear", "--s", "0.5"], "warning: --s 0.5 is not used by the linear"),
    ]:
        result = glmls_cli("warp", "a.png", "o.png", "--handles", "h.json", *args, cwd=inputs)
        assert result.returncode == 0 and warning in result.stderr, (args, result.stderr)
    result = glmls_cli(
        "warp", "a.png", "o.png", "--handles", "h.json", "--weight", "gaussian", "--alpha", "2",
        "--interpolating", cwd=inputs,
    )  # fmt: skip
    assert result.returncode == 0 and "warning" not in result.stderr, result.stderr


def test_tune_says_which_configurations_tie_with_the_best(inputs):
    """One handle: every configuration is the same translation, and the tune, which orders
    them by name, says the best ties with the others instead of naming it alone."""
    (inputs / "one.json").write_text(json.dumps({"src": [[20.0, 20.0]], "dst": [[23.0, 21.0]]}))
    result = glmls_cli(
        "tune", "a.png", "--handles", "one.json", "--reference", "r.json", "--out", "t",
        "--trials", "1", "--configs", "rigid:idw", "similarity:idw",
        cwd=inputs,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert (
        "tune: best by rank: rigid idw a=1 (tied with rigid idw a=2, similarity idw a=1, "
        "similarity idw a=2: first by name)"
    ) in result.stderr
