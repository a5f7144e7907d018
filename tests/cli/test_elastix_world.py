"""elastix's ``point`` files hold ITK physical points: for a NIfTI volume, ITK's LPS world,
whose x and y are those of nibabel's RAS+ world negated (ITK's NIfTI reader negates the first
two rows of the affine). ``glmls warp --world`` and ``glmls.files.world_to_volume(...,
lps=True)`` take them so; a volume centred on the world's origin (as brains in a standard
space are) would otherwise be warped mirrored left-right and front-back, every handle still
inside it."""

from __future__ import annotations

import json
from types import SimpleNamespace

import numpy as np
import pytest
from numpy.testing import assert_allclose

import glmls
from glmls.cli.main import main
from glmls.cli.warp3d import volume_handle_warnings
from glmls.files import volume_to_world, world_to_volume
from glmls.files.landmarks import read_handles

SHAPE = (8, 10, 12)  # D, H, W
#: 2 x 1.5 x 1 mm voxels, the volume's centre at the world's origin (RAS+)
AFFINE = np.array(
    [[2.0, 0.0, 0.0, -11.0], [0.0, 1.5, 0.0, -6.75], [0.0, 0.0, 1.0, -3.5], [0, 0, 0, 1]]
)
LPS = np.array([-1.0, -1.0, 1.0])


def _pts(path, points) -> None:
    lines = ["point", str(len(points)), *(" ".join(repr(float(v)) for v in p) for p in points)]
    path.write_text("\n".join(lines) + "\n")


def test_world_to_volume_takes_lps_points():
    units = np.array([[0.0, 0.0, 0.0], [4.0, 3.0, 2.0], [22.0, 13.5, 7.0]])  # (i dx, j dy, k dz)
    ras = volume_to_world(units, AFFINE)
    assert_allclose(world_to_volume(ras * LPS, AFFINE, lps=True), units, atol=1e-12)
    assert_allclose(volume_to_world(units, AFFINE, lps=True), ras * LPS, atol=1e-12)
    # an LPS point taken as RAS lands elsewhere, inside the volume all the same
    assert not np.allclose(world_to_volume(ras * LPS, AFFINE), units)


@pytest.fixture
def scan(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    z, y, x = np.meshgrid(*(np.arange(n, dtype=np.float32) for n in SHAPE), indexing="ij")
    data = (x * 3 + y * 0.5 + np.sin(z)).astype(np.float32)
    glmls.write_volume(tmp_path / "v.nii.gz", data, affine=AFFINE)
    rng = np.random.default_rng(3)
    extent = (np.array(SHAPE[::-1]) - 1) * np.array([2.0, 1.5, 1.0])
    src = rng.uniform(0.1, 0.45, (6, 3)) * extent  # all in the first half of x and y
    dst = src + rng.uniform(-1.0, 1.0, src.shape)
    (tmp_path / "units.json").write_text(json.dumps({"src": src.tolist(), "dst": dst.tolist()}))
    _pts(tmp_path / "moving.pts", volume_to_world(src, AFFINE) * LPS)
    _pts(tmp_path / "fixed.pts", volume_to_world(dst, AFFINE) * LPS)
    return tmp_path


def test_elastix_point_files_with_world_are_itk_lps(scan, gl):
    common = ["--quiet", "--method", "backward", "--interpolation", "linear"]
    assert main(["warp", "v.nii.gz", "units.nii.gz", "--handles", "units.json", *common]) == 0
    argv = ["warp", "v.nii.gz", "lps.nii.gz", "--handles", "moving.pts", "--targets", "fixed.pts"]
    assert main([*argv, "--world", *common]) == 0
    units, lps = (glmls.read_volume(scan / f"{n}.nii.gz").data for n in ("units", "lps"))
    assert np.abs(units - glmls.read_volume(scan / "v.nii.gz").data).max() > 0.05  # moved
    assert_allclose(lps, units, rtol=0, atol=1e-4)


def test_elastix_point_files_without_world_are_told_to_add_it(tmp_path):
    """Taken as they are, the moving points of a volume away from the world's origin lie
    outside its frame: the warning names --world, under which they fall inside as ITK's LPS
    world (as RAS+ they would not)."""
    affine = AFFINE.copy()
    affine[:3, 3] = [40.0, 30.0, 5.0]
    src = np.array([[4.0, 3.0, 2.0], [10.0, 6.0, 3.0], [16.0, 9.0, 5.0]])  # (i dx, j dy, k dz)
    _pts(tmp_path / "moving.pts", volume_to_world(src, affine) * LPS)
    _pts(tmp_path / "fixed.pts", volume_to_world(src + 0.5, affine) * LPS)
    args = SimpleNamespace(
        handles=tmp_path / "moving.pts", targets=tmp_path / "fixed.pts", world=False
    )
    taken, _ = read_handles(args.handles, dst=args.targets)
    spacing = (1.0, 1.5, 2.0)
    [message] = volume_handle_warnings(args, taken, SHAPE, spacing, affine)
    assert message.endswith("add --world"), message
