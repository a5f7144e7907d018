"""``glmls demo`` takes an elastix pair as ``glmls warp`` does: ``--handles MOVING.pts
--targets FIXED.pts`` (the arguments and the loading, checked without opening a window)."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

import glmls
from glmls.cli import demo
from glmls.cli.demo_volume import volume_inputs
from glmls.cli.main import build_parser, main

SRC = np.array([[1.0, 2.0, 1.0], [5.0, 2.0, 2.0], [3.0, 6.0, 3.0], [2.0, 4.0, 1.0]])
DST = SRC + [0.5, -0.25, 0.0]


def _pts(path, kind, points):
    rows = "".join(" ".join(map(str, p)) + "\n" for p in points)
    path.write_text(f"{kind}\n{len(points)}\n{rows}")
    return str(path)


@pytest.mark.parametrize(("kind", "scale"), [("point", 1.0), ("index", [0.5, 0.5, 2.0])])
def test_demo_reads_an_elastix_pair_on_a_volume(tmp_path, kind, scale):
    """Point files are in the handles' units; index files are voxel indices, which the
    spacing (dz, dy, dx) = (2, 0.5, 0.5) puts at (i dx, j dy, k dz), as in ``glmls warp``."""
    volume = tmp_path / "v.nii.gz"
    glmls.write_volume(volume, np.zeros((4, 8, 8), np.uint8), spacing=(2.0, 0.5, 0.5))
    moving, fixed = _pts(tmp_path / "m.pts", kind, SRC), _pts(tmp_path / "f.pts", kind, DST)
    args = build_parser().parse_args(["demo", str(volume), "--handles", moving, "--targets", fixed])
    _, _, src, dst = volume_inputs(args)
    assert_allclose(src, SRC * scale)
    assert_allclose(dst, DST * scale)


def test_demo_reads_a_2d_elastix_pair(tmp_path):
    image = tmp_path / "i.png"
    glmls.imwrite(image, np.zeros((8, 8), np.uint8))
    moving = _pts(tmp_path / "m.pts", "point", SRC[:, :2])
    fixed = _pts(tmp_path / "f.pts", "point", DST[:, :2])
    args = build_parser().parse_args(["demo", str(image), "--handles", moving, "--targets", fixed])
    assert volume_inputs(args) is None
    _, _, handles, _ = demo._inputs(args)
    assert_allclose(handles.src, SRC[:, :2])
    assert_allclose(handles.dst, DST[:, :2])


def test_demo_without_targets_names_the_option_it_has(tmp_path, capsys):
    volume = tmp_path / "v.npy"
    np.save(volume, np.zeros((4, 8, 8, 1), np.uint8))
    moving = _pts(tmp_path / "m.pts", "point", SRC)
    assert main(["demo", str(volume), "--handles", moving]) == 2
    message = capsys.readouterr().err
    assert "--targets" in message and message.count("\n") == 1, message
