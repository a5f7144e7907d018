"""The command line as a demanding user drives it: outputs never destroy the inputs."""

from __future__ import annotations

import json
from types import SimpleNamespace

import numpy as np
import pytest

import glmls
from glmls.cli.main import main

SRC = [[4, 4], [36, 6], [20, 30], [6, 26]]
DST = [[6, 5], [34, 8], [24, 28], [6, 26]]
SRC3 = [[1, 1, 1], [6, 1, 1], [1, 6, 2], [4, 4, 3]]
DST3 = [[1, 2, 1], [6, 1, 1], [2, 6, 2], [4, 4, 3]]


@pytest.fixture
def inputs(tmp_path, monkeypatch):
    rng = np.random.default_rng(3)
    glmls.imwrite(tmp_path / "a.png", rng.integers(0, 256, (32, 40, 3), dtype=np.uint8))
    (tmp_path / "frames").mkdir()
    for name in ("f1.png", "f2.png"):
        glmls.imwrite(tmp_path / "frames" / name, rng.integers(0, 256, (32, 40), dtype=np.uint8))
    np.save(tmp_path / "v.npy", rng.integers(0, 256, (4, 8, 8), dtype=np.uint8))
    (tmp_path / "h.json").write_text(json.dumps({"src": SRC, "dst": DST}))
    (tmp_path / "h3.json").write_text(json.dumps({"src": SRC3, "dst": DST3}))
    (tmp_path / "link.png").symlink_to(tmp_path / "a.png")
    monkeypatch.chdir(tmp_path)
    return tmp_path


def contents(folder):
    return {p.relative_to(folder): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.mark.parametrize(
    "args, named",
    [
        (("warp", "a.png", "a.png", "--handles", "h.json"), "a.png"),
        (("warp", "a.png", "./a.png", "--handles", "h.json"), "a.png"),
        (("warp", "a.png", "link.png", "--handles", "h.json"), "link.png"),
        (("warp", "a.png", ".", "--handles", "h.json"), "a.png"),
        (("warp", "frames", "frames", "--handles", "h.json"), "frames/f1.png"),
        (("warp", "frames/*.png", "frames/", "--handles", "h.json"), "frames/f1.png"),
        (("warp", "v.npy", "v.npy", "--handles", "h3.json"), "v.npy"),
        (("warp", "v.npy", "./", "--handles", "h3.json"), "v.npy"),
    ],
)
def test_warp_refuses_to_overwrite_its_inputs(inputs, capsys, args, named):
    before = contents(inputs)
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"glmls warp: {named}: the output is "), err
    assert "overwrite" in err[0]
    assert contents(inputs) == before


@pytest.mark.parametrize(
    "extra, fault",
    [
        (
            ("--construction", "--construction-methods", "bogus"),
            "--construction-methods bogus: unknown method 'bogus'",
        ),
        (
            ("--construction", "--construction-methods", "quads:cubic"),
            "--construction-methods quads:cubic: unknown interpolation 'cubic'",
        ),
        (("--construction-methods", "splat"), "--construction-methods: for --construction"),
        (("--construction-radius", "3"), "--construction-radius: for --construction"),
    ],
)
def test_tune_checks_the_construction_options_before_any_work(inputs, capsys, extra, fault):
    (inputs / "r.json").write_text(json.dumps({"points": SRC}))
    args = ("tune", "a.png", "--handles", "h.json", "--reference", "r.json", "--out", "out")
    args += ("--configs", "rigid:idw:alpha=1", "--trials", "1", "--quiet", *extra)
    assert main(args) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"glmls tune: {fault}"), lines
    assert not (inputs / "out").exists()


def test_the_tune_winner_s_report_measures_the_angle_asked_for(inputs, capsys):
    (inputs / "r.json").write_text(json.dumps({"points": SRC}))
    args = ("tune", "a.png", "--handles", "h.json", "--reference", "r.json", "--out", "out")
    args += ("--configs", "rigid:idw:alpha=1", "--trials", "1", "--quiet", "--angle", "paper")
    assert main(args) == 0
    capsys.readouterr()
    ranking = json.loads((inputs / "out" / "ranking.json").read_text())
    winner = json.loads((inputs / "out" / "winner" / "report.json").read_text())
    assert ranking["settings"]["angle"] == winner["analysis"]["angle"] == "paper"
    assert winner["triangles"]["angle_measure"] == "paper"


@pytest.mark.parametrize("name", ["shot.gif", "shot"])
def test_demo_refuses_a_screenshot_it_cannot_write_before_the_window_opens(
    inputs, capsys, monkeypatch, name
):
    """Without a display the window would fail first (exit 1); with one, it rendered and
    then failed naming its temporary file."""
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    assert main(("demo", "a.png", "--handles", "h.json", "--screenshot", name)) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"glmls demo: --screenshot: {name}:")
    assert not list(inputs.glob(".shot*"))


@pytest.mark.parametrize("method", ["splat", "backward-swap", "paper-quads"])
def test_analyze_refuses_a_method_the_volume_warp_lacks(inputs, capsys, method):
    """It went on without the deformed volume, exit 0, where glmls warp refuses it."""
    args = ("analyze", "v.npy", "--handles", "h3.json", "--out", "out", "--method", method)
    assert main(args) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1, lines
    assert lines[0] == (
        f"glmls analyze: v.npy: unknown method '{method}' for a volume; choose one of quads, "
        "backward"
    )
    assert not (inputs / "out").exists()


@pytest.mark.parametrize("n, said", [("1", "1 image and"), ("2", "2 images and")])
def test_augment_counts_its_images_in_words(inputs, capsys, n, said):
    assert main(("augment", "a.png", "out", "--n", n)) == 0
    assert f"glmls augment: {said} out/labels.json" in capsys.readouterr().err


@pytest.mark.parametrize(
    "option",
    [
        ("--jobs", "2"),
        ("--scheduler", "local"),
        ("--keep-going",),
        ("--fit",),
        ("--max-pixels", "9"),
    ],
)
def test_warp_refuses_the_batch_options_on_a_volume(inputs, capsys, option):
    """--jobs and --scheduler share out a batch of images; on one volume they did nothing."""
    assert main(("warp", "v.npy", "out.npy", "--handles", "h3.json", *option)) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert lines == [f"glmls warp: {option[0]}: for images, not for a volume (v.npy)"]
    assert not (inputs / "out.npy").exists()


def test_warp_refuses_a_batch_of_inputs_of_one_name(inputs, capsys):
    """A glob over several folders: the second output replaced the first, both printed."""
    (inputs / "other").mkdir()
    glmls.imwrite(inputs / "other" / "f1.png", np.zeros((32, 40), np.uint8))
    assert main(("warp", "*/f1.png", "out", "--handles", "h.json")) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.strip().splitlines() == [
        "glmls warp: frames/f1.png and other/f1.png have one name: their outputs (out/f1.png) "
        "would overwrite each other"
    ]
    assert not (inputs / "out").exists()


def test_the_handle_warning_comes_where_more_than_half_lie_outside():
    """As docs/cli.md says: half outside is no warning, more than half is."""
    from glmls.cli.options import handle_warnings
    from glmls.cli.warp3d import volume_handle_warnings

    half = np.array([[5.0, 5.0], [10.0, 10.0], [100.0, 5.0], [5.0, 100.0]])
    assert handle_warnings(half, (40, 60)) == []
    assert handle_warnings(half[1:], (40, 60)) == ["2 of 3 handles lie outside the 60 x 40 image"]
    args = SimpleNamespace(world=False, handles="h.json", targets=None)
    half3 = np.array([[1.0, 1, 1], [2, 2, 2], [100, 1, 1], [1, 100, 1]])
    assert volume_handle_warnings(args, half3, (8, 8, 8), None, None) == []
    assert volume_handle_warnings(args, half3[1:], (8, 8, 8), None, None) == [
        "2 of 3 handles lie outside the 8 x 8 x 8 volume"
    ]


def test_keep_going_says_what_it_skipped_even_when_quiet(inputs, capsys):
    """--quiet silences progress and messages, not errors: exit 1 said nothing."""
    (inputs / "frames" / "zz.png").write_bytes(b"not a png")
    args = ("warp", "frames", "out", "--handles", "h.json", "--keep-going", "--quiet")
    assert main(args) == 1
    captured = capsys.readouterr()
    assert captured.err.strip().splitlines() == [
        "glmls warp: skipped frames/zz.png: not an image format glmls reads (9 bytes)",
        "glmls warp: 1 of 3 images failed",
    ]
    assert captured.out.split() == ["out/f1.png", "out/f2.png"]


def test_advice_names_the_command_line_options(inputs, capsys):
    """The library's advice for handles on one line speaks the options a user types."""
    line = {"src": [[2, 2], [10, 10], [20, 20]], "dst": [[3, 2], [11, 10], [21, 20]]}
    (inputs / "line.json").write_text(json.dumps(line))
    args = ["warp", "a.png", "out.png", "--handles", "line.json", "--transform", "affine"]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.startswith("glmls warp: handles: affine MLS needs")
    assert "Use --transform similarity or rigid, or add a handle." in err
    assert "transform='" not in err and not (inputs / "out.png").exists()


@pytest.mark.parametrize(
    "argv",
    [
        ("augment", "v.npy", "out", "--n", "1"),
        ("tune", "v.npy", "--handles", "h.json", "--reference", "h.json", "--out", "out"),
    ],
)
def test_a_volume_given_to_an_images_only_command_is_named_a_volume(inputs, capsys, argv):
    assert main(argv) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert lines == [
        f"glmls {argv[0]}: v.npy: a volume; 2D images only here: warp, analyze and demo take a "
        "volume named on its own, with 3D handles"
    ]
    assert not (inputs / "out").exists()


@pytest.mark.parametrize("command", ["analyze", "tune"])
def test_reference_points_off_the_image_or_normalised_get_the_handles_warning(
    inputs, capsys, command
):
    """Reference points mostly outside the image (a row/column mix-up, another image's) or
    all within [0, 1] are measured as given, with a warning as the handles get one."""
    far = {"points": [[300.0, 10.0], [310.0, 20.0], [305.0, 30.0], [10.0, 10.0]]}
    unit = {"points": [[0.1, 0.1], [0.5, 0.2], [0.3, 0.9]]}
    expected = {
        "far.json": "3 of 4 reference points lie outside the 40 x 32 image",
        "unit.json": "every reference point lies within [0, 1] x [0, 1] of a 40 x 32 image",
    }
    extra = ("--trials", "1", "--configs", "rigid:idw:alpha=1") if command == "tune" else ()
    for name, points in (("far.json", far), ("unit.json", unit)):
        (inputs / name).write_text(json.dumps(points))
        code = main(
            (command, "a.png", "--handles", "h.json", "--reference", name, "--out", "o", *extra)
        )
        assert code == 0
        warnings = [line for line in capsys.readouterr().err.splitlines() if "warning" in line]
        assert warnings and warnings[0].startswith(f"glmls {command}: warning: {expected[name]}"), (
            warnings
        )
