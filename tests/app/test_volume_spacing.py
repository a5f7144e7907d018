"""The volume window on a volume of anisotropic voxels: handles in the units of ``glmls warp``
(voxel (i, j, k) at (i dx, j dy, k dz)), views with the physical aspect, warps and saved
files with the spacing."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys

import numpy as np
import pytest
from helpers import child_env

import glmls
from glmls.analysis.colormaps import format_number
from glmls.app.events import Move, Press, Release
from glmls.app.layout import layout
from glmls.app.volume_controller import SliceGrid, VolumeController, VolumeSettings
from glmls.app.volume_session import VolumeSession
from glmls.app.volume_view import scene_geometry, view_viewport

SHAPE = (6, 16, 12)  # D, H, W
SPACING = (3.0, 0.5, 0.5)  # dz, dy, dx: 18 x 8 x 6 units (z, y, x)
#: Handles in units: (x, y, z); the first two in the central axial plane z = 3 dz = 9.
SRC = np.array(
    [[3.0, 4.0, 9.0], [3.0, 2.0, 9.0], [0.5, 0.5, 1.5], [5.5, 0.5, 16.5], [0.5, 7.5, 16.5]]
)


def volume() -> np.ndarray:
    """A smooth uint8 volume with a ball in the middle, in units."""
    z, y, x = np.meshgrid(
        *(np.arange(n) * d for n, d in zip(SHAPE, SPACING, strict=True)), indexing="ij"
    )
    ball = np.hypot(np.hypot(x - 3.0, y - 4.0), (z - 9.0) / 3.0) < 2.5
    return np.clip(40 + 8 * x + 6 * y + 4 * z + 80 * ball, 0, 255).astype(np.uint8)


def drag(c, a, b) -> None:
    c.feed(Press(*a))
    c.feed(Move(*b))
    c.feed(Release(*b))


def test_each_view_spans_its_physical_extent():
    grid = SliceGrid(SHAPE, spacing=SPACING)
    # montage pixels of the smallest voxel size (0.5): x 12, y 16, z 6 * 6 = 36
    assert [grid.pixels(axis) for axis in range(3)] == [12, 16, 36]
    assert grid.size(0) == (12, 16) and grid.size(1) == (12, 36) and grid.size(2) == (36, 16)
    assert grid.montage_shape == (16 + 4 + 36, 12 + 4 + 36)
    assert grid.diagonal == pytest.approx(np.hypot(np.hypot(6.0, 8.0), 18.0))
    # a voxel's centre and the view's edges: voxel k of z spans 6 montage pixels
    corner = grid.to_montage(2, [[0.0, 0.0, 0.0]])[0]
    np.testing.assert_allclose(corner, [12 + 4 + 2.5, 0.0])
    assert grid.locate(12 + 4 + 2.5, 0.0) == (2, 0.0, 0.0)
    assert grid.locate(12 + 4 + 5.4, 0.0)[1] == pytest.approx(5.9 / 6 - 0.5)
    np.testing.assert_allclose(grid.to_voxels(SRC[:1]), [[6.0, 8.0, 3.0]])
    with pytest.raises(ValueError, match="spacing"):
        SliceGrid(SHAPE, spacing=(0.0, 1.0, 1.0))


def test_the_slice_rectangles_on_screen_have_the_physical_aspect():
    c = VolumeController(SRC, SRC, SHAPE, spacing=SPACING)
    grid = c.grid
    shown = layout((900, 700), grid.montage_shape, 0)
    extents = {0: 6.0, 1: 8.0, 2: 18.0}  # units along x, y, z
    for view, (right, down) in enumerate(((0, 1), (0, 2), (2, 1))):
        _, _, width, height = view_viewport(shown, grid, view)
        assert width / height == pytest.approx(extents[right] / extents[down], rel=0.03)
        # one voxel of 0.5 x 3.0 (sagittal: z right) is a 6 : 1 rectangle
    _, _, width, height = view_viewport(shown, grid, 2)
    assert (width / SHAPE[0]) / (height / SHAPE[1]) == pytest.approx(6.0, rel=0.03)
    # the frames and the handles drawn where they lie in units
    triangles, lines = scene_geometry(c, shown.scale)
    frames = lines[:8, :2]  # the axial view's frame, then its crosshairs
    np.testing.assert_allclose(frames.min(axis=0), [-0.5, -0.5])
    np.testing.assert_allclose(frames.max(axis=0), [11.5, 15.5])
    sagittal = lines[24:32, :2]
    np.testing.assert_allclose(sagittal.min(axis=0), [15.5, -0.5])
    np.testing.assert_allclose(sagittal.max(axis=0), [15.5 + 36, 15.5])
    assert len(triangles)


def test_dragging_moves_a_handle_by_the_physical_distance():
    c = VolumeController(SRC, SRC, SHAPE, spacing=SPACING, pick_radius=2.0)
    assert c.point == (6, 8, 3)
    axial = c.grid.to_montage(0, SRC[:1])[0]
    np.testing.assert_allclose(axial, [6.0, 8.0])
    drag(c, tuple(axial), tuple(axial + [4.0, 2.0]))  # 4 and 2 montage pixels of 0.5 units
    np.testing.assert_allclose(c.dst[0], SRC[0] + [2.0, 1.0, 0.0])
    # the sagittal view (z to the right): 6 montage pixels are one voxel of z, 3 units
    sagittal = c.grid.to_montage(2, SRC[1:2])[0]
    np.testing.assert_allclose(sagittal, [16 + 3.5 * 6 - 0.5, 4.0])
    drag(c, tuple(sagittal), tuple(sagittal + [12.0, -2.0]))
    np.testing.assert_allclose(c.dst[1], SRC[1] + [0.0, -1.0, 6.0])
    np.testing.assert_array_equal(c.src, SRC)
    # shift + click adds a handle where it is in units; the slice point stays in voxels
    c.feed(Press(2.0, 4.0, mods=frozenset({"shift"})))
    c.feed(Release(2.0, 4.0))
    np.testing.assert_allclose(c.src[-1], [1.0, 2.0, 9.0])
    assert c.parameter() == "alpha 1"
    c.feed(glmls.app.events.Key("w"))  # a radius weight: the diagonal in units
    assert c.radius == pytest.approx(c.grid.diagonal) and c.parameter().startswith("R 20")


def test_only_handles_within_near_voxels_of_the_plane_are_shown():
    c = VolumeController(SRC, SRC, SHAPE, spacing=SPACING)
    # z = 3 voxels (9 units): the first two; 1.5 and 16.5 units are 2.5 voxels away
    assert set(c.near_plane(0)) == {0, 1, 2, 3, 4}
    c.near = 2.0
    assert set(c.near_plane(0)) == {0, 1}


def test_the_session_warps_with_the_spacing(gl):
    data = volume()
    c = VolumeController(SRC, SRC, SHAPE, spacing=SPACING)
    s = VolumeSession(gl, c, data)
    try:
        dst = SRC + [[1.0, 0.5, 0.0], [0, 0, 3.0], [0, 0, 0], [0, 0, 0], [0, 0, 0]]
        c.set_handles(SRC, dst)
        s.sync()
        assert s.error == "" and (s.mls.shape, s.mls.spacing) == (SHAPE, SPACING)  # as glmls warp
        slices = s.slices()
        assert [p.shape for p in slices] == [(16, 12), (6, 12), (16, 6)]
        with glmls.MLS(SRC, dst, transform="rigid", shape=SHAPE, spacing=SPACING, ctx=gl) as m:
            whole = m.warp(data, interpolation="linear", grid=4, border="edge")
        x, y, z = c.point
        np.testing.assert_array_equal(slices[0], whole[z])
        np.testing.assert_array_equal(slices[1], whole[:, y])
        np.testing.assert_array_equal(slices[2], whole[:, :, x].T)
        c.feed(glmls.app.events.Key("e"))
        assert s.overlays() is not None and "units^2" in s.lines[0]
        c.feed(glmls.app.events.Key("f"))
        assert (
            s.overlays() is not None and s.lines[0].startswith("folds") and ": 0 of" in s.lines[0]
        )
    finally:
        s.release()


XVFB = shutil.which("xvfb-run")


def _glmls(*args: str, xvfb: bool = False):
    command = [sys.executable, "-m", "glmls", *args]
    if xvfb:
        command = [XVFB, "-a", *command]
    return subprocess.run(command, capture_output=True, text=True, env=child_env(), timeout=180)


@pytest.mark.skipif(XVFB is None, reason="xvfb-run is not installed")
@pytest.mark.parametrize("suffix", [".nii.gz", ".tif"])
def test_the_window_warps_and_saves_as_glmls_warp_does(tmp_path, suffix):
    path = tmp_path / f"scan{suffix}"
    glmls.write_volume(path, volume(), spacing=SPACING)
    assert glmls.read_volume(path).spacing == SPACING
    handles = tmp_path / "h.json"
    glmls.files.write_handles(handles, SRC, SRC)
    # drag the first handle's target 4 and 2 montage pixels: 2 and 1 units
    events = [
        {"type": "press", "x": 6.0, "y": 8.0},
        {"type": "move", "x": 10.0, "y": 10.0},
        {"type": "release", "x": 10.0, "y": 10.0},
        {"type": "key", "key": "j"},
        {"type": "key", "key": "s"},
    ]
    replay = tmp_path / "drag.json"
    replay.write_text(json.dumps({"events": events}))
    shot = tmp_path / "shot.png"
    options = ["--transform", "rigid", "--method", "quads", "--grid", "4"]
    done = _glmls(
        "demo", str(path), "--handles", str(handles), "--replay", str(replay),
        "--screenshot", str(shot), "--out", str(tmp_path), "--window-size", "640x480",
        *options, xvfb=True,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    saved = tmp_path / "scan-handles.json"
    src, dst = glmls.files.read_handles(saved, ndim=3)
    np.testing.assert_array_equal(src, SRC)
    np.testing.assert_allclose(dst[0], SRC[0] + [2.0, 1.0, 0.0])
    np.testing.assert_array_equal(dst[1:], SRC[1:])
    warped = glmls.read_volume(tmp_path / f"scan-warped{suffix}")
    assert warped.spacing == SPACING and warped.data.dtype == np.uint8
    out = tmp_path / f"cli{suffix}"
    done = _glmls(
        "warp", str(path), str(out), "--handles", str(saved), "--interpolation", "linear",
        "--border", "edge", *options,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    np.testing.assert_array_equal(warped.data, glmls.read_volume(out).data)
    if suffix == ".nii.gz":
        np.testing.assert_array_equal(warped.affine, glmls.read_volume(path).affine)
    assert not np.array_equal(warped.data, volume())
    assert glmls.imread(shot).std() > 10


def test_spacing_is_refused_for_images_and_bad_values(tmp_path):
    image = tmp_path / "photo.png"
    glmls.imwrite(image, np.zeros((8, 8, 3), np.uint8))
    done = _glmls("demo", str(image), "--spacing", "2,1,1")
    assert done.returncode == 2 and done.stderr.count("\n") == 1, done.stderr
    assert "--spacing" in done.stderr and "photo.png" in done.stderr
    done = _glmls("demo", "--spacing", "2,1,1")  # the bundled photograph
    assert done.returncode == 2 and done.stderr.count("\n") == 1, done.stderr
    for bad, message in (
        ("0,1,1", "spacing must be positive and finite (dz, dy, dx), got (0.0, 1.0, 1.0)"),
        ("1,2", "spacing must be three numbers (dz, dy, dx)"),
        ("a,b,c", "expected DZ,DY,DX numbers, got 'a,b,c'"),
    ):
        done = _glmls("demo", "--volume", "--spacing", bad)
        assert done.returncode == 2 and message in done.stderr, done.stderr
        assert done.stderr.count("\n") == 1, done.stderr


def test_the_fold_overlay_is_glmls_analysis_cell_jacobians_with_the_spacing(gl):
    # f flattens the volume along z: every cell is flat to f's float32 precision, a fold for
    # cell_jacobians; the overlay judged that flatness in float64 and left some cells out
    rng = np.random.default_rng(1)
    src = rng.uniform(0.0, 1.0, (12, 3)) * [5.5, 7.5, 16.5]
    dst = src * [1.0, 1.0, 0.0] + [0.0, 0.0, 9.0]
    config = glmls.MLSConfig(transform="affine")
    settings = VolumeSettings(config=config)
    c = VolumeController(src, dst, SHAPE, spacing=SPACING, settings=settings)
    s = VolumeSession(gl, c, volume())
    try:
        s.sync()
        c.feed(glmls.app.events.Key("f"))
        shown = s.field() == 255
        cells = glmls.analysis.cell_jacobians(s.mls, SHAPE, grid=4)
        assert cells.count > 0
        np.testing.assert_array_equal(shown, cells.mask)
        assert s.lines == [f"folds (det J <= 0): {cells.count} of {cells.det.size} cells"]
        c.feed(glmls.app.events.Key("e"))
        s.field()
        stats = glmls.analysis.error_stats(glmls.analysis.volume_error_field(s.mls, SHAPE, grid=4))
        mean, std = (format_number(stats[name]) for name in ("mean", "std"))
        assert s.lines[1] == f"  mean {mean} std {std}"
    finally:
        s.release()
