"""Hostile files and options on the command line: one line naming the file and the fault,
exit status 2 (1 for failures while running), no traceback, no partial or temporary file."""

from __future__ import annotations

import io
import json
import struct
import time
import zlib
from pathlib import Path

import numpy as np
import pytest
from helpers import run_glmls as cli

import glmls
from glmls.cli.options import fit_background, handle_warnings
from glmls.cli.progress import Ticker
from glmls.files.atomic import atomic_write

SRC = [[4, 4], [36, 6], [20, 30], [6, 26]]
DST = [[6, 5], [34, 8], [24, 28], [6, 26]]
PNG = b"\x89PNG\r\n\x1a\n"


def chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))


def one_line_error(result, status: int, *parts: str) -> None:
    assert result.returncode == status, result.stderr
    assert "Traceback" not in result.stderr, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    for part in parts:
        assert part in lines[0], (part, lines[0])


def leftovers(folder: Path) -> list[str]:
    """Temporary files of atomic writes (".name.xxxx.ext") left behind."""
    return [p.name for p in folder.rglob(".*") if p.is_file()]


@pytest.fixture
def files(tmp_path):
    rng = np.random.default_rng(5)
    glmls.imwrite(tmp_path / "a.png", rng.integers(0, 256, (32, 40, 3), dtype=np.uint8))
    glmls.imwrite(tmp_path / "deep16.png", rng.integers(0, 65535, (32, 40, 3)).astype(np.uint16))
    half = (tmp_path / "deep16.png").read_bytes()
    (tmp_path / "half16.png").write_bytes(half[: len(half) // 2])
    (tmp_path / "signature.png").write_bytes(PNG)
    bomb = struct.pack(">IIBBBBB", 20000, 20000, 8, 2, 0, 0, 0)
    (tmp_path / "bomb.png").write_bytes(PNG + chunk(b"IHDR", bomb) + chunk(b"IEND", b""))
    (tmp_path / "h.json").write_text(json.dumps({"src": SRC, "dst": DST}))
    (tmp_path / "deep.json").write_text("[" * 100_000 + "]" * 100_000)
    (tmp_path / "wide.csv").write_text("src_x,src_y,dst_x,dst_y\n1,2,3," + "9" * 200_000 + "\n")
    return tmp_path


@pytest.mark.parametrize(
    "args, parts",
    [
        (("warp", "half16.png", "o.png"), ("half16.png", "corrupt or truncated 16-bit PNG")),
        (("warp", "signature.png", "o.png"), ("signature.png", "truncated PNG")),
        (("warp", "bomb.png", "o.png"), ("bomb.png", "400,000,000 pixels", "--max-pixels")),
        (("warp", "deep16.png", "o.jpg"), ("o.jpg", ".jpg cannot hold uint16", ".png, .tif or")),
        (("warp", "a.png", "o.xyz"), ("o.xyz", "unknown image format .xyz")),
        (("warp", "a.png", "o.png", "--handles", "deep.json"), ("deep.json", "nested too deeply")),
        (("warp", "a.png", "o.png", "--handles", "wide.csv"), ("wide.csv", "field limit")),
    ],
)
def test_bad_input_is_one_line_and_exit_2(files, args, parts):
    if "--handles" not in args:
        args = (*args, "--handles", "h.json")
    result = cli(*args, cwd=files)
    one_line_error(result, 2, *parts)
    assert not (files / "o.png").exists() and not (files / "o.jpg").exists()
    assert not leftovers(files)


def test_the_window_refuses_a_bad_image_in_one_line(files):
    result = cli("demo", "signature.png", "--frames", "1", cwd=files)
    one_line_error(result, 2, "signature.png", "truncated PNG")


def test_float_tiff_in_and_out(files):
    image = np.random.default_rng(1).random((32, 40, 3)).astype(np.float32)
    glmls.imwrite(files / "f.tif", image)
    result = cli("warp", "f.tif", "out.tif", "--handles", "h.json", cwd=files)
    assert result.returncode == 0, result.stderr
    out = glmls.imread(files / "out.tif")
    assert out.dtype == np.float32 and out.shape == image.shape
    np.testing.assert_array_equal(out, glmls.warp(image, SRC, DST))


def test_outputs_into_folders_that_do_not_exist_yet(files):
    for output, expected in (("new/deeper/o.png", "new/deeper/o.png"), ("made/", "made/a.png")):
        result = cli("warp", "a.png", output, "--handles", "h.json", cwd=files)
        assert result.returncode == 0, result.stderr
        assert (files / expected).is_file()
        assert result.stdout.strip() == expected


def test_outputs_have_the_users_umask(files):
    for mask, mode in ((0o022, 0o644), (0o027, 0o640)):
        result = cli("warp", "a.png", f"o{mask}.png", "--handles", "h.json", cwd=files, umask=mask)
        assert result.returncode == 0, result.stderr
        assert (files / f"o{mask}.png").stat().st_mode & 0o777 == mode


def test_write_failures_name_the_output_not_the_temporary(tmp_path):
    target = tmp_path / "out.png"
    with pytest.raises(OSError, match=f"^{target}: cannot write: No space left on device$"):
        with atomic_write(target) as tmp:
            raise OSError(28, "No space left on device", str(tmp))
    assert not leftovers(tmp_path) and not target.exists()
    blocker = tmp_path / "file"
    blocker.write_text("")
    with pytest.raises(OSError, match=f"^{blocker / 'o.png'}: cannot write"):
        with atomic_write(blocker / "o.png"):
            pass


def test_a_batch_keeps_going_past_a_bad_image(files):
    batch = files / "batch"
    batch.mkdir()
    for name in ("a.png", "signature.png", "deep16.png"):
        (batch / name).write_bytes((files / name).read_bytes())
    grey = np.random.default_rng(2).integers(0, 255, (32, 40), dtype=np.uint8)
    glmls.imwrite(batch / "grey.png", grey)
    common = ("--handles", "h.json", "--background", "255,0,0")
    stopped = cli("warp", "batch", "out", *common, cwd=files)
    assert stopped.returncode == 2 and "signature.png" in stopped.stderr
    result = cli("warp", "batch", "out2", *common, "--keep-going", cwd=files)
    assert result.returncode == 1, result.stderr
    assert "skipped" in result.stderr and "1 of 4 images failed" in result.stderr
    assert sorted(p.name for p in (files / "out2").iterdir()) == ["a.png", "deep16.png", "grey.png"]
    # the grey image took the colour's first value as its background
    out = glmls.imread(files / "out2" / "grey.png")
    expected = glmls.warp(grey, SRC, DST, background=255)
    np.testing.assert_array_equal(out, expected)
    assert not leftovers(files)


def test_fit_background_per_image():
    assert fit_background((255, 0, 0), 1) == 255
    assert fit_background((255, 0, 0, 9), 2) == (255, 9)
    assert fit_background((1, 2, 3, 4), 3) == (1, 2, 3)
    assert fit_background((1, 2, 3), 4) == (1, 2, 3)
    assert fit_background(7.0, 3) == 7.0


def test_suspicious_handles_warn_without_failing(files):
    (files / "unit.json").write_text(json.dumps({"src": [[0.1, 0.2], [0.5, 0.5]], "dst": DST[:2]}))
    result = cli("warp", "a.png", "o.png", "--handles", "unit.json", cwd=files)
    assert result.returncode == 0, result.stderr
    assert "warning: every handle lies within [0, 1] x [0, 1]" in result.stderr
    rows_first = [[10, 35], [20, 38], [5, 36], [25, 39]]  # (row, column) in a 32 x 40 image
    assert handle_warnings(np.array(rows_first, float), (32, 40)) == [
        "4 of 4 handles lie outside the 40 x 32 image; (row, column) order? glmls takes "
        "(x, y) = (column, row)"
    ]
    assert handle_warnings(np.array(SRC, float), (32, 40)) == []


def test_every_option_shows_its_default(files):
    for command, options in (
        ("warp", ("--transform", "--weight", "--method", "--interpolation", "--max-pixels")),
        ("tune", ("--trials", "--seed", "--rank-by", "--magnitudes")),
        ("demo", ("--method", "--interpolation", "--out", "--grid")),
        ("augment", ("--rows", "--cols", "--displacement", "--units", "--segments", "--radius")),
        ("augment", ("--transform", "--interpolation", "--border")),
        ("bench", ("--sizes", "--handles", "--grids", "--transforms", "--repeat", "--tools")),
    ):
        text = cli(command, "--help", cwd=files).stdout
        for option in options:
            start = text.index(f"\n  {option} ")  # its entry, not the usage line
            block = " ".join(text[start + 1 :].split("\n  -")[0].split())  # unwrapped
            assert block.count("(default: ") == 1, (command, option, block)
            assert "['" not in block, (command, option, block)  # not a Python list


def test_the_window_takes_the_same_option_names(files):
    from glmls.cli.main import build_parser

    args = build_parser().parse_args(
        ["demo", "--method", "backward", "--interpolation", "nearest", "--out", "saved", "--s", "0"]
    )
    assert (args.method, args.interpolation, str(args.out), args.s) == (
        "backward",
        "nearest",
        "saved",
        0.0,
    )
    old = build_parser().parse_args(["demo", "--construction", "splat", "--out-dir", "x"])
    assert old.construction == "splat" and str(old.out) == "x"


def test_a_long_step_shows_that_it_works():
    stream = io.StringIO()
    ticker = Ticker("analyze", after=0.0, every=0.05, stream=stream)
    ticker.stage("error field")
    with ticker:
        time.sleep(0.12)
        ticker.stage("pictures")
        time.sleep(0.1)
    lines = stream.getvalue().splitlines()
    assert lines and lines[0].startswith("analyze: error field ... 0:00")
    assert any("pictures" in line for line in lines)
    quiet = io.StringIO()
    with Ticker("warp", quiet=True, after=0.0, stream=quiet):
        time.sleep(0.05)
    assert quiet.getvalue() == ""


def test_usage_mistakes_exit_2_with_argparses_message(files):
    result = cli("warp", "a.png", "o.png", "--handles", "h.json", "--grid", "0", cwd=files)
    assert result.returncode == 2 and "Traceback" not in result.stderr
    assert result.stderr.strip().splitlines() == [
        "glmls warp: argument --grid: expected an integer >= 1, got 0 (see glmls warp --help)"
    ]


@pytest.mark.parametrize("command", ["tune", "analyze"])
def test_reference_points_that_make_no_triangle_are_named_before_any_work(files, command):
    (files / "two.json").write_text(json.dumps({"points": [[5, 5], [20, 5]]}))
    args = ("a.png", "--handles", "h.json", "--reference", "two.json", "--out", "report")
    result = cli(command, *args, "--trials", "1", cwd=files) if command == "tune" else None
    result = result or cli(command, *args, cwd=files)
    # tune said its plan, then "reference_points: ..." with no file, after starting
    one_line_error(result, 2, f"glmls {command}: two.json: a triangulation needs at least 3")
    assert not (files / "report").exists()


@pytest.mark.parametrize("command", ["tune", "analyze"])
def test_images_the_analysis_takes_and_refuses(files, command):
    grey_alpha = np.random.default_rng(2).integers(0, 256, (32, 40, 2), dtype=np.uint8)
    glmls.imwrite(files / "ga.png", grey_alpha)
    glmls.imwrite(files / "nan.tif", np.full((32, 40), np.nan, np.float32))
    (files / "r.json").write_text(json.dumps({"points": [[8, 8], [30, 8], [18, 24], [8, 22]]}))
    more = ("--handles", "h.json", "--reference", "r.json", "--quiet")
    more += ("--trials", "1") if command == "tune" else ()
    for name in ("deep16.png", "ga.png"):  # a traceback (tune: after the whole tuning)
        result = cli(command, name, "--out", f"out_{name}", *more, cwd=files)
        assert result.returncode == 0, result.stderr
    result = cli(command, "nan.tif", "--out", "nan_out", *more, cwd=files)
    one_line_error(result, 2, f"glmls {command}: nan.tif holds NaN or infinite values")
    assert not (files / "nan_out").exists()
