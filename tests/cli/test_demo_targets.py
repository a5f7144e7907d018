"""``glmls demo`` takes an elastix pair as ``glmls warp`` does: ``--handles MOVING.pts
--targets FIXED.pts`` (the arguments and the loading, checked without opening a window)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from helpers import write_elastix_points
from numpy.testing import assert_allclose

import glmls
from glmls.cli import demo
from glmls.cli.demo_volume import volume_inputs
from glmls.cli.main import build_parser, main

SRC = np.array([[1.0, 2.0, 1.0], [5.0, 2.0, 2.0], [3.0, 6.0, 3.0], [2.0, 4.0, 1.0]])
DST = SRC + [0.5, -0.25, 0.0]


@pytest.mark.parametrize(("kind", "scale"), [("point", 1.0), ("index", [0.5, 0.5, 2.0])])
def test_demo_reads_an_elastix_pair_on_a_volume(tmp_path, kind, scale):
    """Point files are in the handles' units; index files are voxel indices, which the
    spacing (dz, dy, dx) = (2, 0.5, 0.5) puts at (i dx, j dy, k dz), as in ``glmls warp``."""
    volume = tmp_path / "v.nii.gz"
    glmls.write_volume(volume, np.zeros((4, 8, 8), np.uint8), spacing=(2.0, 0.5, 0.5))
    moving = write_elastix_points(tmp_path / "m.pts", kind, SRC)
    fixed = write_elastix_points(tmp_path / "f.pts", kind, DST)
    args = build_parser().parse_args(["demo", str(volume), "--handles", moving, "--targets", fixed])
    _, _, src, dst = volume_inputs(args)
    assert_allclose(src, SRC * scale)
    assert_allclose(dst, DST * scale)


def test_demo_reads_a_2d_elastix_pair(tmp_path):
    image = tmp_path / "i.png"
    glmls.imwrite(image, np.zeros((8, 8), np.uint8))
    moving = write_elastix_points(tmp_path / "m.pts", "point", SRC[:, :2])
    fixed = write_elastix_points(tmp_path / "f.pts", "point", DST[:, :2])
    args = build_parser().parse_args(["demo", str(image), "--handles", moving, "--targets", fixed])
    assert volume_inputs(args) is None
    _, _, handles, _ = demo._inputs(args)
    assert_allclose(handles.src, SRC[:, :2])
    assert_allclose(handles.dst, DST[:, :2])


def test_demo_without_targets_names_the_option_it_has(tmp_path, capsys):
    volume = tmp_path / "v.npy"
    np.save(volume, np.zeros((4, 8, 8, 1), np.uint8))
    moving = write_elastix_points(tmp_path / "m.pts", "point", SRC)
    assert main(["demo", str(volume), "--handles", moving]) == 2
    message = capsys.readouterr().err
    assert "--targets" in message and message.count("\n") == 1, message


def test_demo_warns_of_handles_outside_the_volume_as_warp_does(tmp_path, capsys, monkeypatch):
    """The volume window says what ``glmls warp`` says of source handles half or more outside
    the volume (the same words, hint included), and opens all the same."""
    from glmls.cli import demo_volume

    monkeypatch.setattr(demo_volume, "run_window", lambda app, args, events: 0)
    np.save(tmp_path / "big.npy", np.zeros((64, 64, 64), np.uint8))
    src, dst = glmls.data.phantom_handles()
    (tmp_path / "h3.json").write_text(json.dumps({"src": src.tolist(), "dst": dst.tolist()}))
    volume, handles = str(tmp_path / "big.npy"), str(tmp_path / "h3.json")
    assert main(["demo", volume, "--handles", handles]) == 0
    assert "warning" not in capsys.readouterr().err  # the phantom's handles, in voxels
    assert main(["demo", volume, "--handles", handles, "--spacing", "0.5"]) == 0
    err = capsys.readouterr().err
    assert err.startswith(
        f"glmls demo: warning: {volume}: 9 of 10 handles lie outside the 64 x 64 x 64 volume "
        "of spacing (dz, dy, dx) = (0.5, 0.5, 0.5); in voxel indices? the handles are in the "
        "units of the spacing"
    ), err
    assert err.count("\n") == 1, err
    assert (
        main(["warp", volume, str(tmp_path / "o.npy"), "--handles", handles, "--spacing", "0.5"])
        == 0
    )
    warned = [line for line in capsys.readouterr().err.splitlines() if "warning" in line]
    assert [line.replace("glmls warp:", "glmls demo:") for line in warned] == [err.strip()]


@pytest.mark.parametrize("window", [["--volume"], []])
def test_demo_refuses_targets_without_handles(tmp_path, capsys, window):
    """--targets is the second file of a pair: without --handles either window would ignore
    it, so it is refused, in one line, exit status 2."""
    fixed = write_elastix_points(tmp_path / "f.pts", "point", DST)
    assert main(["demo", *window, "--targets", fixed]) == 2
    message = capsys.readouterr().err
    assert "--targets: with --handles" in message and message.count("\n") == 1, message


@pytest.mark.parametrize(
    ("option", "name", "what"),
    [
        ("--screenshot", "in.png", "the input"),
        ("--record", "h.json", "the --handles file"),
        ("--record", "r.json", "the --reference file"),
        ("--record", "events.json", "the --replay file"),
    ],
)
def test_demo_refuses_to_save_over_a_file_it_reads(tmp_path, capsys, option, name, what):
    """The screenshot and the recorded events are written on exit: over an input, they
    would replace it. Refused before the window opens (no display is needed to see it)."""
    glmls.imwrite(tmp_path / "in.png", np.zeros((8, 8), np.uint8))
    (tmp_path / "h.json").write_text(json.dumps({"src": [[1, 1]], "dst": [[2, 1]]}))
    (tmp_path / "r.json").write_text(json.dumps({"points": [[1, 1], [6, 1], [3, 6]]}))
    (tmp_path / "events.json").write_text(json.dumps({"events": []}))
    before = (tmp_path / name).read_bytes()
    args = ["demo", str(tmp_path / "in.png"), "--handles", str(tmp_path / "h.json"),
            "--reference", str(tmp_path / "r.json"), "--replay", str(tmp_path / "events.json"),
            option, str(tmp_path / name)]  # fmt: skip
    assert main(args) == 2
    err = capsys.readouterr().err
    assert f"{tmp_path / name}: the output is {what}" in err, err
    assert (tmp_path / name).read_bytes() == before


@pytest.mark.parametrize("spelling", ["out.png", "./sub/../out.png"])
def test_demo_refuses_one_file_for_the_screenshot_and_the_recording(
    tmp_path, capsys, monkeypatch, spelling
):
    """Both are written on exit: the recording would replace the screenshot (or the
    reverse). Refused before the window opens, however the name is spelled."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "sub").mkdir()
    glmls.imwrite(tmp_path / "in.png", np.zeros((8, 8), np.uint8))
    args = ["demo", "in.png", "--screenshot", "out.png", "--record", spelling, "--frames", "1"]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert "two outputs of one file" in err and err.count("\n") == 1, err
    assert not (tmp_path / "out.png").exists()


def test_demo_says_the_spacing_a_file_gives_as_warp_does():
    """``demo`` reads a volume as ``warp`` does (``read_volume``): its --help names the same
    sources of the file's spacing, an OME-TIFF's among them."""
    commands = next(a for a in build_parser()._actions if a.dest == "command").choices

    def file_default(command: str) -> str:
        action = next(a for a in commands[command]._actions if a.dest == "spacing")
        return action.help[action.help.index("default:") :]

    assert "OME" in file_default("warp")
    assert file_default("demo") == file_default("warp")


def test_demo_help_gives_the_window_size_default_and_range():
    """``glmls COMMAND --help`` gives every option's default (docs/cli.md): --window-size's
    is the fitted size, and the range that the option takes."""
    commands = next(a for a in build_parser()._actions if a.dest == "command").choices
    action = next(a for a in commands["demo"]._actions if a.dest == "window_size")
    assert "default: fitted" in action.help and "64 to 16384" in action.help
    with pytest.raises(SystemExit):
        build_parser().parse_args(["demo", "--window-size", "32x600"])


def test_demo_spacing_keeps_a_nifti_files_header_fields(tmp_path):
    """``--spacing`` changes only the spacing: the window's save writes the file's affine,
    codes (an MNI volume stays one) and time step back, as ``glmls warp`` does."""
    path = tmp_path / "mni.nii.gz"
    header = glmls.files.NiftiHeader(sform_code=4, qform_code=4, xyzt_units=10, time_step=2.5)
    affine = np.diag([-2.0, 2.0, 2.0, 1.0])
    volume = glmls.Volume(np.zeros((4, 8, 8, 2), np.int16), affine=affine, nifti=header)
    glmls.write_volume(path, volume)
    args = build_parser().parse_args(["demo", str(path), "--spacing", "1,1,1"])
    given, _, _, _ = volume_inputs(args)
    assert given.spacing == (1.0, 1.0, 1.0)
    assert given.nifti == glmls.read_volume(path).nifti
    assert given.nifti.sform_code == 4 and given.nifti.time_step == 2.5
    assert_allclose(given.affine, affine)
