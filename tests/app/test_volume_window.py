"""The volume window: its controller and session headless, the real window under Xvfb."""

from __future__ import annotations

import json
import math
import shutil
import subprocess
import sys
import types

import numpy as np
import pytest
from helpers import child_env

import glmls
from glmls.app.events import Key, Move, Press, Release, Scroll
from glmls.app.hud import PANEL_CHARS
from glmls.app.text import GlyphAtlas
from glmls.app.view import TEXT_SIZE
from glmls.app.volume_controller import (
    AXES,
    VOLUME_BINDINGS,
    SliceGrid,
    VolumeController,
    VolumeSettings,
)
from glmls.app.volume_session import VolumeSession, display_volume
from glmls.app.volume_view import BACKGROUND, help_text, montage_layout, scene_geometry
from glmls.app.volume_window import VolumeApp

SHAPE = (16, 20, 24)  # D, H, W
SRC = np.array([[4.0, 4, 8], [18, 15, 8], [12, 10, 3], [12, 10, 13], [6, 16, 12]])


def make() -> VolumeController:
    return VolumeController(SRC, SRC, SHAPE, pick_radius=2.0)


def drag(c, a, b) -> None:
    c.feed(Press(*a))
    c.feed(Move(*b))
    c.feed(Release(*b))


def test_the_montage_places_three_views_and_locates_points():
    grid = SliceGrid(SHAPE)
    assert grid.montage_shape == (20 + 4 + 16, 24 + 4 + 16)
    for view in range(3):
        ox, oy = grid.offset(view)
        columns, rows = grid.size(view)
        assert grid.locate(ox + columns - 1, oy + rows - 1) == (view, columns - 1, rows - 1)
    assert grid.locate(30.0, 30.0) is None  # the empty corner
    np.testing.assert_array_equal(grid.to_montage(2, [[1.0, 2.0, 3.0]]), [[28 + 3, 2]])


def test_dragging_a_target_moves_it_within_the_plane():
    c = make()
    drag(c, (4, 4), (7, 2))  # axial view, z = 8: handle 0
    np.testing.assert_array_equal(c.dst[0], [7, 2, 8])
    np.testing.assert_array_equal(c.src, SRC)
    oy = c.grid.offset(1)[1]  # coronal, y = 10: handle 2 at (x, z) = (12, 3)
    drag(c, (12, oy + 3), (14, oy + 5))
    np.testing.assert_array_equal(c.dst[2], [14, 10, 5])
    assert c.active == 1 and c.undo_depth == 2
    c.feed(Key("u"))
    np.testing.assert_array_equal(c.dst[2], SRC[2])
    c.feed(Key("U"))
    np.testing.assert_array_equal(c.dst[2], [14, 10, 5])


@pytest.mark.parametrize("key", ["u", "Ctrl+Z"])
def test_undo_during_a_drag_undoes_that_drag(key):
    # as in the image window: the drag ends as one edit, which undo takes back; undo
    # dropped the drag instead and undid the edit before it (or nothing, the drag kept)
    c = make()
    drag(c, (4, 4), (7, 2))  # one edit: q_0 to (7, 2)
    c.feed(Press(18, 15))  # handle 1's target
    c.feed(Move(15, 12))
    assert c.dragging
    c.feed(Key(key))  # the button still down
    np.testing.assert_array_equal(c.dst[0], [7, 2, 8])  # the edit before stays
    np.testing.assert_array_equal(c.dst[1], SRC[1])
    assert not c.dragging and c.undo_depth == 1
    c.feed(Move(10, 14))  # a move after the undo drags nothing
    c.feed(Release(10, 14))
    np.testing.assert_array_equal(c.dst[1], SRC[1])
    c.feed(Key("U"))
    np.testing.assert_array_equal(c.dst[1], [15, 12, 8])


def test_restore_with_the_handles_as_loaded_leaves_no_undo_step():
    c = make()
    drag(c, (4, 4), (7, 2))
    c.feed(Key("u"))
    c.feed(Key("R"))  # as loaded already
    assert c.undo_depth == 0
    c.feed(Key("U"))  # the redo kept, too
    np.testing.assert_array_equal(c.dst[0], [7, 2, 8])
    c.feed(Key("u"))
    c.feed(Press(4, 4))  # a target grabbed, not moved: R ends the drag
    c.feed(Key("R"))
    assert not c.dragging and c.undo_depth == 0


@pytest.mark.parametrize("key", ["R", "r"])
def test_restore_or_reset_during_a_drag_ends_the_drag_first(key):
    # a handle added with shift + click and still dragged, then R: the drag held the index
    # of a handle R had removed, and the next move raised IndexError out of the event loop
    c = make()
    oy = c.grid.offset(1)[1]
    c.feed(Press(20, oy + 3, mods=frozenset({"shift"})))  # coronal: a sixth handle
    c.feed(Move(21, oy + 4))
    c.feed(Key(key))  # the button still down
    assert not c.dragging
    c.feed(Move(22, oy + 6))  # drags nothing
    c.feed(Release(22, oy + 6))
    assert len(c.src) == (5 if key == "R" else 6)
    np.testing.assert_array_equal(c.dst, c.src)
    c.feed(Key("u"))  # undo takes back the restore (or reset), then the drag
    assert len(c.src) == 6 and c.dst[5].tolist() == [21, 10, 4]
    c.feed(Key("u"))
    assert len(c.src) == 5


def test_only_handles_near_the_plane_are_picked():
    c = make()
    c.feed(Key("Up"))  # z = 9: handle 4 (z = 12) is 3 away, handle 0 (z = 8) 1
    assert set(c.near_plane(0)) == {0, 1, 4}
    for _ in range(3):
        c.feed(Key("PageUp"))  # z = 12: handle 0 is out of reach
    revision = c.revision
    drag(c, (4, 4), (6, 6))
    assert c.revision == revision and c.point[:2] == (4, 4)  # the slice point moved instead


def test_fractions_of_a_wheel_notch_add_up():
    # a touchpad sends fractions of a notch: each was rounded to 0 and the slice never moved
    c = make()
    for _ in range(4):
        c.feed(Scroll(5, 5, 0.25))
    assert c.point == (12, 10, 9)
    c.feed(Scroll(5, 5, 0.4))
    c.feed(Scroll(5, 5, -0.4))  # back and forth: no move
    assert c.point == (12, 10, 9)
    c.feed(Scroll(5, 5, -1.0))
    assert c.point == (12, 10, 8)
    c.feed(Scroll(5, 5, 1e300))  # any finite dy: the last slice
    assert c.point == (12, 10, 15)


def test_fractions_of_a_wheel_notch_stay_with_their_view():
    c = make()
    sagittal = c.grid.offset(2)
    c.feed(Scroll(5, 5, 0.75))  # over the axial view: z waits for a quarter notch
    c.feed(Scroll(sagittal[0] + 5, 5, 0.5))  # half a notch over the sagittal view
    assert c.point == (12, 10, 8)  # x does not take the axial view's three quarters
    c.feed(Scroll(sagittal[0] + 5, 5, 0.5))
    assert c.point == (13, 10, 8)
    c.feed(Scroll(5, 5, 0.25))  # back over the axial view: its fraction is gone
    assert c.point == (13, 10, 8)


def test_the_slice_point_moves_along_the_active_normal_and_stays_inside():
    c = make()
    assert c.point == (12, 10, 8)
    c.feed(Key("3"))  # sagittal: x
    c.feed(Key("Down"))
    c.feed(Key("Left"))
    assert c.point == (3, 10, 8)
    for _ in range(5):
        c.feed(Key("Left"))
    assert c.point == (0, 10, 8)
    c.feed(Key("Tab"))  # axial
    c.feed(Scroll(5, 5, 100))  # the wheel over the axial view: z, up to the last slice
    assert c.point == (0, 10, 15) and c.point_revision == 4
    c.feed(Key("0"))
    assert c.point == (12, 10, 8)


def test_overlays_toggle_and_keys_change_the_settings():
    c = make()
    c.feed(Key("e"))
    assert c.overlay == "error"
    c.feed(Key("f"))
    assert c.overlay == "folds"
    c.feed(Key("f"))
    assert c.overlay == "none"
    revision = c.revision
    for key in "tcgG":
        c.feed(Key(key))
    assert c.revision == revision + 4
    assert c.settings == VolumeSettings(
        config=glmls.MLSConfig(transform="similarity"), method="backward", grid=4
    )
    c.feed(Key("b"))
    assert c.settings.border == "symmetric" and c.revision == revision + 5
    assert c.parameter() == "alpha 1"
    c.feed(Key("+"))
    assert c.parameter() == "alpha 1.25"
    c.feed(Key("w"))  # cressman: a radius, the volume's diagonal at first
    assert c.parameter() == f"R {np.linalg.norm(SHAPE):.0f} vox"
    c.feed(Key("-"))
    assert c.settings.config.radius == pytest.approx(np.linalg.norm(SHAPE) / 1.25)
    assert c.feed(Key("j")) == ["save_handles"] and c.feed(Key("q")) == ["quit"]
    assert len({key for keys, _, _ in VOLUME_BINDINGS for key in keys}) == sum(
        len(keys) for keys, _, _ in VOLUME_BINDINGS
    )  # no key bound twice
    assert any("folds" in line for line in help_text())


def test_shift_click_adds_and_right_click_deletes_reset_restores():
    c = make()
    c.feed(Press(20, 3, mods=frozenset({"shift"})))
    c.feed(Release(20, 3))
    np.testing.assert_array_equal(c.src[-1], [20, 3, 8])
    assert len(c.src) == 6
    c.feed(Press(20, 3, "right"))
    assert len(c.src) == 5
    drag(c, (4, 4), (5, 5))
    c.feed(Key("r"))
    np.testing.assert_array_equal(c.dst, c.src)
    c.feed(Key("R"))
    np.testing.assert_array_equal(c.dst, SRC)


def test_scene_geometry_draws_frames_crosshairs_and_nearby_handles():
    c = make()
    triangles, lines = scene_geometry(c, 4.0)
    assert lines.shape == (3 * (8 + 4), 6) and triangles.shape[1] == 6 and len(triangles)
    c.feed(Key("h"))
    triangles, _ = scene_geometry(c, 4.0)
    assert len(triangles) == 0


def test_display_volume_is_grey_uint8():
    rgb = np.zeros((2, 3, 4, 3), np.float32)
    rgb[1] = 1.0
    grey = display_volume(rgb)
    assert grey.shape == (2, 3, 4) and grey.dtype == np.uint8
    assert grey[0].max() == 0 and grey[1].min() == 255
    with pytest.raises(ValueError, match="D x H x W"):
        display_volume(np.zeros((3, 4)))


def test_a_volume_with_nan_voxels_is_shown_from_its_finite_values():
    # one NaN voxel (a masked region of a statistical map) made every percentile NaN: the
    # whole volume was shown black, with a RuntimeWarning for the cast
    ramp = np.linspace(0.0, 100.0, 2 * 3 * 4, dtype=np.float32).reshape(2, 3, 4)
    holes = ramp.copy()
    holes[0, 0, :3] = [np.nan, np.inf, -np.inf]
    grey = display_volume(holes)
    assert grey[0, 0, :3].tolist() == [0, 255, 0]  # NaN black, infinities at the ends
    finite = np.isfinite(holes)
    np.testing.assert_array_equal(
        grey[finite], display_volume(ramp[finite].reshape(1, 1, -1))[0, 0]
    )


@pytest.mark.parametrize(
    "volume",
    [
        np.linspace(1e300, 2e300, 24),  # beyond float32: every voxel an infinity, white
        np.linspace(1e-300, 2e-300, 24),  # below it: every voxel 0, black
        1000.0 + np.linspace(0.0, 1e-4, 24),  # finer than float32's steps there: 3 greys
        np.linspace(-3e38, 3e38, 24, dtype=np.float32),
        np.linspace(0, 2**40, 24).astype(np.int64) + 2**60,  # a narrow band, far from 0
    ],
)
def test_a_volume_of_any_range_is_shown_as_a_ramp(volume):
    ramp = display_volume(np.linspace(0.0, 1.0, 24).reshape(2, 3, 4))
    grey = display_volume(volume.reshape(2, 3, 4))
    assert grey.dtype == np.uint8
    np.testing.assert_allclose(grey.astype(int), ramp.astype(int), atol=1)


@pytest.mark.parametrize(
    ("volume", "shown"),
    [
        (np.full((2, 3, 4), 7.0, np.float32), 255),  # was black: its percentiles are equal
        (np.ones((2, 3, 4), bool), 255),  # a mask of one label
        (np.full((2, 3, 4), 0.25), 64),  # within [0, 1]: as it is
        (np.zeros((2, 3, 4), np.int16), 0),
        (np.full((2, 3, 4), -5.0), 0),
    ],
)
def test_a_constant_volume_is_shown_as_an_image_of_its_value(volume, shown):
    grey = display_volume(volume)
    assert grey.dtype == np.uint8 and set(grey.ravel().tolist()) == {shown}
    mostly = np.zeros((1, 10, 100), np.float32)  # 0.1 % of the voxels at 3: both
    mostly[0, 0, 0] = 3.0  # percentiles 0, that voxel white as before
    assert display_volume(mostly)[0, 0, 0] == 255 and display_volume(mostly)[0, 1].max() == 0


@pytest.fixture
def session(gl):
    volume = glmls.data.phantom()
    src, dst = glmls.data.phantom_handles()
    c = VolumeController(src, src, volume.shape, pick_radius=2.0)
    s = VolumeSession(gl, c, display_volume(volume))
    yield c, s, volume, dst
    s.release()


def test_the_session_warps_three_slices_and_follows_a_drag(session):
    c, s, volume, dst = session
    s.sync()
    before = s.slices()
    assert [p.shape for p in before] == [(64, 64), (64, 64), (64, 64)]
    # identity handles: the deformed slices are the volume's own
    x, y, z = c.point
    np.testing.assert_array_equal(before[0], volume[z])
    np.testing.assert_array_equal(before[1], volume[:, y])
    np.testing.assert_array_equal(before[2], volume[:, :, x].T)
    drag(c, tuple(c.src[0, :2]), tuple(dst[0, :2]))  # the large sphere's target
    s.sync()
    after = s.slices()
    assert s.error == "" and not np.array_equal(after[0], before[0])
    m = glmls.MLS(c.src, c.dst, shape=volume.shape, ctx=s.gl)
    whole = m.warp(display_volume(volume), interpolation="linear", grid=4, border="edge")
    m.release()
    np.testing.assert_array_equal(after[0], whole[z])  # one slice of the whole warp
    np.testing.assert_array_equal(after[2], whole[:, :, x].T)
    c.feed(Key("Up"))
    np.testing.assert_array_equal(s.slices()[0], whole[z + 1])


def test_the_session_overlays_error_and_folds(session):
    c, s, _, dst = session
    c.set_handles(c.src, dst)
    s.sync()
    assert s.overlays() is None
    c.feed(Key("e"))
    error = s.overlays()
    assert [p.shape for p in error] == [(64, 64, 4)] * 3
    assert error[0][..., 3].max() > 0 and s.lines[0].startswith("E_MLS")
    c.feed(Key("f"))
    folds = s.overlays()
    assert folds[0][..., 3].max() == 0 and s.lines[0].startswith("folds")  # no fold here
    mirrored = c.src * [-1.0, 1.0, 1.0] + [63.0, 0.0, 0.0]  # x -> 63 - x
    c.set_handles(c.src, mirrored)
    c.feed(Key("t"))
    c.feed(Key("t"))  # affine: f is the mirror, folded everywhere
    s.sync()
    folds = s.overlays()
    assert all((p[..., 3] > 0).mean() > 0.9 for p in folds), s.lines
    c.set_handles(c.src[:1], c.src[:1])  # one handle: f is a translation
    s.sync()
    c.feed(Key("e"))
    assert s.overlays()[0][..., 3].max() > 0


def test_invalid_handles_keep_the_last_valid_deformation(session):
    c, s, _, _ = session
    s.sync()
    mls = s.mls
    c.set_handles(np.zeros((0, 3)), np.zeros((0, 3)))
    s.sync()
    assert s.mls is mls and "no handles" in s.error


XVFB = shutil.which("xvfb-run")


@pytest.mark.skipif(XVFB is None, reason="xvfb-run is not installed")
def test_the_real_window_replays_a_drag_and_saves(tmp_path):
    src, _ = glmls.data.phantom_handles()
    events = {
        "events": [
            {"type": "press", "x": float(src[0, 0]), "y": float(src[0, 1])},
            {"type": "move", "x": 34.0, "y": 24.0},
            {"type": "release", "x": 34.0, "y": 24.0},
            {"type": "key", "key": "e"},
            {"type": "key", "key": "j"},
            {"type": "key", "key": "s"},
        ]
    }
    replay = tmp_path / "drag.json"
    replay.write_text(json.dumps(events))
    volume = tmp_path / "scan.npy"
    np.save(volume, glmls.data.phantom())
    handles = tmp_path / "h.json"
    glmls.files.write_handles(handles, src, src)
    shot = tmp_path / "shot.png"
    command = [XVFB, "-a", sys.executable, "-m", "glmls", "demo", str(volume)]
    command += ["--handles", str(handles), "--replay", str(replay), "--screenshot", str(shot)]
    command += ["--out", str(tmp_path), "--window-size", "700x400"]
    done = subprocess.run(command, capture_output=True, text=True, env=child_env(), timeout=120)
    assert done.returncode == 0, done.stderr
    picture = glmls.imread(shot)
    assert picture.shape == (400, 700, 3) and picture.std() > 10
    saved, moved = glmls.files.read_handles(tmp_path / "scan-handles.json", ndim=3)
    np.testing.assert_array_equal(moved[0], [34, 24, src[0, 2]])
    np.testing.assert_array_equal(saved, src)
    warped = np.load(tmp_path / "scan-warped.npy")
    assert warped.shape == (64, 64, 64) and warped.dtype == np.uint8
    assert not np.array_equal(warped, glmls.data.phantom())
    assert AXES[0][2] == 2


@pytest.mark.skipif(XVFB is None, reason="xvfb-run is not installed")
def test_handles_and_labels_stay_inside_their_views(tmp_path):
    """A handle outside the volume (e.g. loaded with a spacing mistake) was drawn over the
    montage's empty corner, and a thin axial view's label over the sagittal view."""
    shape = (30, 48, 6)  # axial 6 x 48 at (0, 0), sagittal at (10, 0), coronal at (0, 52)
    volume = tmp_path / "thin.npy"
    np.save(volume, np.full(shape, 0.5, np.float32))
    handles = tmp_path / "h.json"
    src = np.array([[3.0, 10, 15], [20, 60, 15]])  # the second: beyond x and y, on z = 15
    glmls.files.write_handles(handles, src, src + [1, 0, 0])
    shot = tmp_path / "shot.png"
    done = _demo(str(volume), "--handles", str(handles), "--screenshot", str(shot),
                 "--window-size", "1000x500", xvfb=True)  # fmt: skip
    assert done.returncode == 0, done.stderr
    picture = glmls.imread(shot).astype(int)
    atlas = GlyphAtlas(TEXT_SIZE)
    grid = SliceGrid(shape)
    layout = montage_layout((1000, 500), grid, round(PANEL_CHARS * atlas.advance["M"]) + 24)

    def region(x0, y0, x1, y1):  # montage points to framebuffer pixels, inside
        (left, top), (right, bottom) = layout.to_framebuffer(x0, y0), layout.to_framebuffer(x1, y1)
        return picture[math.ceil(top) + 1 : int(bottom) - 1, math.ceil(left) + 1 : int(right) - 1]

    background = np.round(np.array(BACKGROUND) * 255)
    corner = region(10.5, 52.5, 39.5, 81.5)  # no view there
    gap = region(5.5, -0.5, 9.5, 10)  # between the axial and sagittal views, under the labels
    for part in (corner, gap):
        assert part.size and np.abs(part - background).max() <= 1, np.unique(
            part.reshape(-1, 3), axis=0
        )
    assert picture.std() > 10


def _demo(*args: str, xvfb: bool = False):
    command = [sys.executable, "-m", "glmls", "demo", *args]
    if xvfb:
        command = [XVFB, "-a", *command]
    return subprocess.run(command, capture_output=True, text=True, env=child_env(), timeout=120)


def test_the_command_refuses_2d_handles_for_a_volume(tmp_path):
    handles = tmp_path / "h2.json"
    glmls.files.write_handles(handles, [[1.0, 2.0]], [[1.0, 3.0]])
    done = _demo("--volume", "--handles", str(handles))
    assert done.returncode == 2 and done.stderr.count("\n") == 1
    assert "h2.json: 2D handles (x, y), but the phantom is a volume: it takes 3D handles" in (
        done.stderr
    )


@pytest.mark.skipif(XVFB is None, reason="xvfb-run is not installed")
def test_3d_handles_without_an_image_open_the_phantom(tmp_path):
    handles = tmp_path / "h3.json"
    src, dst = glmls.data.phantom_handles()
    glmls.files.write_handles(handles, src, dst)
    shot = tmp_path / "shot.png"
    done = _demo("--handles", str(handles), "--screenshot", str(shot), xvfb=True)
    assert done.returncode == 0, done.stderr
    assert glmls.imread(shot).std() > 10


def test_the_readout_says_what_the_slices_show_after_an_error():
    """Opened without handles there is no f yet: the readout says the slices show the volume
    as it is, not "the last valid f"; after a valid f, that f."""
    volume = glmls.data.phantom()
    empty = np.zeros((0, 3))
    app = VolumeApp(volume, empty, empty)
    app.window = object()  # the readout's error lines are the open window's
    app.session = types.SimpleNamespace(error="no handles: shift + click in a view adds one",
                                        mls=None, lines=[], slice_error="")  # fmt: skip
    assert "  (the volume as it is)" in app.readout()
    app.session.mls = object()
    assert "  (the last valid f)" in app.readout()


def test_saving_no_handles_says_so(tmp_path):
    app = VolumeApp(np.zeros((4, 5, 6), np.uint8), np.zeros((0, 3)), np.zeros((0, 3)))
    with pytest.raises(ValueError, match="no handles to save"):
        app._save_handles(tmp_path / "h.json")
    assert not (tmp_path / "h.json").exists()


def test_the_analysis_time_is_zero_with_no_overlay(session):
    # the readout kept the last overlay's analysis time after the overlay was turned off
    c, s, _, dst = session
    c.set_handles(c.src, dst)
    s.sync()
    c.feed(Key("f"))
    s.overlays()
    assert s.timings["analysis"] > 0
    c.feed(Key("f"))
    assert s.overlays() is None and s.timings["analysis"] == 0


def save_with(app: VolumeApp, m: glmls.MLS) -> None:
    """``s`` in ``app`` as if its window were open and showing ``m``'s deformation."""
    app.window, app.session = object(), types.SimpleNamespace(mls=m, error="")
    app._command("save_volume")


def test_s_keeps_a_nifti_inputs_header_fields(gl, tmp_path):
    # only the affine was kept: the sform/qform codes (MNI here), units and description of
    # the input went, where glmls warp keeps them
    header = glmls.files.NiftiHeader(sform_code=4, qform_code=4, xyzt_units=2, descrip="t1")
    affine = np.diag([2.0, 1.0, 1.5, 1.0])
    data = np.random.default_rng(0).integers(0, 255, SHAPE).astype(np.uint8)
    volume = glmls.Volume(data, affine=affine, nifti=header)
    dst = SRC + [[1.5, 0.5, 0.0], [0, 0, 0], [0, 0, 0], [0, 0, 0], [0, 0, 0]]
    app = VolumeApp(volume, SRC, dst, save_as=".nii.gz", out_dir=tmp_path)
    with glmls.MLS(SRC, dst, transform="rigid", shape=SHAPE, ctx=gl) as m:
        save_with(app, m)
    saved = glmls.files.read_volume(tmp_path / "volume-warped.nii.gz")
    assert saved.nifti == header
    np.testing.assert_allclose(saved.affine, affine)


@pytest.mark.parametrize(
    ("dtype", "suffix"),
    [(np.int16, ".nii.gz"), (np.int16, ".tif"), (np.int32, ".npy"), (np.bool_, ".npy")],
)
def test_s_saves_a_volume_of_any_real_dtype_in_that_dtype(gl, tmp_path, dtype, suffix):
    # an int16 volume (a CT scan) reached the GPU warp as it was: the TypeError closed the
    # window (exit status 2); it is warped as float32 and written back, as glmls warp does
    rng = np.random.default_rng(0)
    data = rng.integers(0, 2, SHAPE) if dtype == np.bool_ else rng.integers(-900, 900, SHAPE)
    data = data.astype(dtype)
    dst = SRC + [[1.5, 0.5, 0.0], [0, 0, 0], [0, 0, 0], [0, 0, 0], [0, 0, 0]]
    app = VolumeApp(data, SRC, dst, save_as=suffix, out_dir=tmp_path)
    with glmls.MLS(SRC, dst, transform="rigid", shape=SHAPE, ctx=gl) as m:
        save_with(app, m)
        expected = m.warp(data.astype(np.float32), interpolation="linear", grid=4, border="edge")
    assert app._shown_messages() == [f"saved {tmp_path / ('volume-warped' + suffix)}"]
    saved = glmls.files.read_volume(tmp_path / f"volume-warped{suffix}").data
    assert saved.dtype == dtype and saved.shape == SHAPE
    if dtype == np.bool_:
        np.testing.assert_array_equal(saved, expected >= 0.5)
    else:
        np.testing.assert_array_equal(saved, np.rint(expected).astype(dtype))
