"""``glmls demo`` tells a volume from an image as ``glmls warp`` and ``glmls analyze`` do: every
``.npy`` array is a volume (a thin one of 4 slices or fewer along x too), so that a file the
other commands warp as a volume opens in the volume window, never refused as one."""

from __future__ import annotations

import argparse

import numpy as np
import pytest

import glmls
from glmls.cli import demo_volume
from glmls.cli.analyze_volume import is_volume_input
from glmls.cli.demo_volume import volume_inputs
from glmls.cli.main import build_parser, main
from glmls.cli.warp3d import input_kind


def _write(tmp_path, name: str, shape: tuple[int, ...]):
    path = tmp_path / name
    data = np.zeros(shape, np.uint8)
    if name.endswith(".npy"):
        np.save(path, data)
    elif name.endswith((".nii.gz", ".tif")) and len(shape) > 2:
        glmls.write_volume(path, data)
    else:
        glmls.imwrite(path, data)
    return path


FILES = [
    ("thin.npy", (30, 40, 4)),
    ("rgbish.npy", (30, 40, 3)),
    ("one.npy", (30, 40, 1)),
    ("cube.npy", (8, 9, 10)),
    ("channels.npy", (8, 9, 10, 2)),
    ("v.nii.gz", (4, 5, 6)),
    ("stack.tif", (4, 5, 6)),
    ("page.tif", (30, 40)),
    ("photo.png", (30, 40, 3)),
]


@pytest.mark.parametrize(("name", "shape"), FILES)
def test_demo_decides_volume_or_image_as_warp_and_analyze_do(tmp_path, name, shape):
    path = _write(tmp_path, name, shape)
    demo = volume_inputs(build_parser().parse_args(["demo", str(path)])) is not None
    assert demo == (input_kind(str(path)) == "volume")
    assert demo == is_volume_input(argparse.Namespace(example=False, input=str(path)))


@pytest.mark.parametrize("shape", [(30, 40, 4), (30, 40, 3), (30, 40, 1)])
def test_a_thin_npy_volume_opens_in_the_volume_window(tmp_path, shape, capsys, monkeypatch):
    opened = []
    monkeypatch.setattr(
        demo_volume, "run_window", lambda app, args, events: opened.append(app.volume.shape) or 0
    )
    path = _write(tmp_path, "thin.npy", shape)
    assert main(["demo", str(path)]) == 0, capsys.readouterr().err
    assert opened == [shape] and capsys.readouterr().err == ""


def test_a_2d_npy_array_is_refused_in_one_line_as_warp_refuses_it(tmp_path, capsys):
    path = _write(tmp_path, "flat.npy", (30, 40))
    assert main(["demo", str(path)]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert lines == [
        f"glmls demo: {path}: a 2D array (30, 40), but .npy files are volumes, (D, H, W) or "
        "(D, H, W, C): save a 2D image as an image file (e.g. with glmls.imwrite to .png or .tif)"
    ]


def test_a_volume_among_a_batch_of_images_is_named_without_contradiction(tmp_path, capsys):
    (tmp_path / "in").mkdir()
    _write(tmp_path, "in/v.npy", (4, 5, 6))
    handles = tmp_path / "h.json"
    handles.write_text('{"src": [[2, 2], [10, 10], [20, 3]], "dst": [[3, 2], [11, 10], [21, 3]]}')
    main(["warp", str(tmp_path / "in" / "*"), str(tmp_path / "out"), "--handles", str(handles)])
    err = capsys.readouterr().err
    assert (
        "v.npy: a volume; 2D images only here: warp, analyze and demo take a volume named " in err
    )
    assert "this command takes" not in err
