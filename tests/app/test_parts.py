"""The window's parts that need no window: layout, replay files, glyph atlas, overlay geometry,
the command line's input errors."""

from __future__ import annotations

import argparse
import json

import numpy as np
import pytest

import glmls
from glmls.analysis.folding import folded_cells
from glmls.app.commands import save_image, warped_suffix
from glmls.app.events import Key, Move, Press, Release, Wait, read_events, replay_frames
from glmls.app.layout import layout
from glmls.app.overlays import mesh_lines
from glmls.app.settings import Settings
from glmls.app.text import GlyphAtlas
from glmls.app.view import display_image
from glmls.app.volume_window import VolumeApp
from glmls.app.window import PANEL_CHARS, TEXT_SIZE, App
from glmls.app.window_loop import MESSAGE_SECONDS
from glmls.cli.demo import configure, run
from glmls.errors import InputFileError
from glmls.imaging.frame import Frame

# -- layout -------------------------------------------------------------------------------------


def test_layout_letterboxes_beside_the_panel():
    lay = layout((900, 600), (300, 400), panel=300)  # H 300, W 400 in a 600 x 600 area
    assert lay.viewport == (300, 75, 600, 450)
    assert lay.scale == 1.5


@pytest.mark.parametrize("shape", [(1, 1), (128, 128), (1, 300), (300, 1), (512, 512), (300, 3000)])
def test_the_default_window_keeps_the_readout_beside_the_image(shape):
    # an image narrower than the panel got a window so narrow that the panel was dropped:
    # the readout covered the image
    app = App(np.zeros((*shape, 3), np.uint8), np.zeros((0, 2)), np.zeros((0, 2)))
    panel = round(PANEL_CHARS * GlyphAtlas(TEXT_SIZE).advance["M"]) + 24
    lay = layout(app._default_size(), shape, panel)
    assert lay.panel == panel and lay.viewport[0] >= panel


def test_layout_drops_the_panel_when_narrow():
    lay = layout((500, 800), (100, 100), panel=300)
    assert lay.panel == 0
    assert lay.viewport == (0, 150, 500, 500)


def test_cursor_to_image_and_back_with_high_dpi():
    lay = layout((1800, 1200), (300, 400), panel=600)  # a 2x framebuffer
    # image pixel (0, 0)'s centre and the far corner, in window units (half the pixels)
    fx, fy = lay.to_framebuffer(0, 0)
    assert lay.to_image(fx / 2, fy / 2, pixel_ratio=2.0) == pytest.approx((0, 0))
    x, y = lay.to_image((1800 - 0.001) / 2, (1200 - 150 - 0.001) / 2, pixel_ratio=2.0)
    assert (x, y) == pytest.approx((399.5, 299.5), abs=1e-2)


def test_layout_of_a_canvas_from_another_origin():
    """The fit view: a canvas of (H, W) whose pixel (0, 0) is image point (-20, -10)."""
    lay = layout((900, 600), (320, 440), panel=300, origin=(-20.0, -10.0))
    fx, fy = lay.to_framebuffer(-20.5, -10.5)  # the canvas's top left corner
    vx, vy, vw, vh = lay.viewport
    assert (fx, fy) == pytest.approx((vx, 600 - vy - vh))
    assert lay.to_framebuffer(419.5, 309.5) == pytest.approx((vx + vw, 600 - vy))
    for point in ((0.0, 0.0), (123.5, 77.25), (-20.0, 300.0)):
        assert lay.to_image(*lay.to_framebuffer(*point)) == pytest.approx(point)


# -- replay files -------------------------------------------------------------------------------


def test_read_events(tmp_path):
    path = tmp_path / "e.json"
    entries = [
        {"type": "press", "x": 1, "y": 2.5, "button": "right", "mods": ["shift"]},
        {"type": "move", "x": 3, "y": 4},
        {"type": "release", "x": 3, "y": 4},
        {"type": "key", "key": "F1"},
        {"type": "wait", "frames": 4},
    ]
    path.write_text(json.dumps({"events": entries}))
    events = read_events(path)
    assert events == [
        Press(1, 2.5, "right", frozenset({"shift"})),
        Move(3, 4),
        Release(3, 4, "left"),
        Key("F1"),
        Wait(4),
    ]
    assert replay_frames(events) == 8
    path.write_text(json.dumps(entries[:2]))  # a bare list works too
    assert len(read_events(path)) == 2


@pytest.mark.parametrize(
    ("content", "match"),
    [
        ("{", "line 1: invalid JSON"),
        ("{}", 'missing the key "events"'),
        ('{"events": 3}', "expected a list of events"),
        ('[{"type": "jump"}]', r'events\[0\]: "type" must be one of press'),
        ('[{"type": "move", "x": 1}]', r'events\[0\]: missing "y"'),
        ('[{"type": "move", "x": "1", "y": 2}]', '"x" must be a finite number'),
        ('[{"type": "press", "x": 1, "y": 2, "button": "back"}]', '"button" must be one of'),
        ('[{"type": "press", "x": 1, "y": 2, "mods": ["meta"]}]', '"mods" must be a list'),
        ('[{"type": "key", "key": ""}]', '"key" must be a character typed'),
        ('[{"type": "wait", "frames": -1}]', '"frames" must be an integer in 0..1000000'),
        ('[{"type": "move", "x": 1, "y": 2, "z": 3}]', "unknown field"),
    ],
)
def test_bad_events_files_name_the_fault(tmp_path, content, match):
    path = tmp_path / "bad.json"
    path.write_text(content)
    with pytest.raises(InputFileError, match=match):
        read_events(path)


def test_missing_events_file(tmp_path):
    with pytest.raises(InputFileError, match="no such file"):
        read_events(tmp_path / "none.json")


# -- text, images, geometry ---------------------------------------------------------------------


def test_glyph_atlas_lays_out_text():
    atlas = GlyphAtlas(14)
    assert atlas.image.dtype == np.uint8 and atlas.image.max() == 255
    quads = atlas.quads("ab c\nd", 10, 20)
    assert quads.shape == (4 * 6, 8)  # spaces draw nothing
    assert quads[:, 1].min() == 20
    assert quads[-6:, 1].min() == 20 + atlas.line_height  # "d" on the second line
    assert atlas.width("ab") == pytest.approx(atlas.advance["a"] + atlas.advance["b"])
    assert atlas.quads("", 0, 0).shape == (0, 8)
    assert atlas.rectangle(0, 0, 5, 5, (1, 1, 1, 1)).shape == (6, 8)
    with pytest.raises(ValueError, match="size must be an integer >= 4"):
        GlyphAtlas(2)


def test_display_image_normalises_for_an_8_bit_window():
    grey16 = np.full((2, 3), 65535, np.uint16)
    out = display_image(grey16)
    assert out.shape == (2, 3, 3) and out.dtype == np.float32 and out.max() == 1.0
    rgba = np.zeros((2, 2, 4), np.uint8)
    assert display_image(rgba).shape == (2, 2, 3)
    with pytest.raises(ValueError, match="H x W or H x W x C"):
        display_image(np.zeros((2, 2, 5)))


def test_float_images_outside_0_1_are_shown_from_their_minimum_to_their_maximum():
    # a float image of 0..255 (or -1..2) was clipped to [0, 1]: a white window
    ramp = np.linspace(0.0, 255.0, 6, dtype=np.float32).reshape(2, 3)
    assert display_image(ramp)[..., 0].ravel().tolist() == pytest.approx([0, 0.2, 0.4, 0.6, 0.8, 1])
    signed = np.array([[-1.0, 0.5, 2.0]])
    assert display_image(signed)[0, :, 0].tolist() == pytest.approx([0.0, 0.5, 1.0])
    within = np.array([[0.25, 0.5]], np.float32)  # [0, 1] images are shown as they are
    assert display_image(within)[0, :, 0].tolist() == [0.25, 0.5]
    assert (display_image(np.full((2, 2), 7.0)) == 1.0).all()  # one value: no range


@pytest.mark.parametrize(
    "values",
    [
        np.linspace(-3e38, 3e38, 6, dtype=np.float32),  # its span overflowed float32: top white
        np.linspace(-2e300, 2e300, 6),  # beyond float32: every pixel an infinity, white
    ],
)
def test_float_images_of_any_range_are_shown_as_a_ramp(values):
    shown = display_image(values.reshape(2, 3))
    assert shown.dtype == np.float32
    assert shown[..., 0].ravel().tolist() == pytest.approx([0, 0.2, 0.4, 0.6, 0.8, 1], abs=1e-6)


@pytest.mark.parametrize("dtype", [np.int16, np.int32, np.int64, np.uint32, np.int8])
def test_other_integer_images_are_shown_from_their_range(dtype):
    # divided by their dtype's maximum, int32 labels 0..5 showed black (5 / 2^31) and an int16
    # CT slice dim and clipped below 0
    labels = np.arange(6, dtype=dtype).reshape(2, 3)
    assert display_image(labels)[..., 0].ravel().tolist() == pytest.approx(
        [0, 0.2, 0.4, 0.6, 0.8, 1]
    )
    if np.issubdtype(dtype, np.signedinteger):
        signed = np.array([[-100, 0, 100]], dtype)
        assert display_image(signed)[0, :, 0].tolist() == pytest.approx([0.0, 0.5, 1.0])


def test_float_images_with_nan_or_infinite_values_are_shown_from_their_finite_values():
    # a depth map with NaN holes: its range was NaN, the window refused to open ("image
    # holds NaN or infinite values") though glmls.warp warps it
    depth = np.array([[np.nan, 0.0, 50.0, 200.0, np.inf, -np.inf]], np.float32)
    shown = display_image(depth)[0, :, 0]
    assert np.isfinite(shown).all()
    assert shown.tolist() == pytest.approx([0.0, 0.0, 0.25, 1.0, 1.0, 0.0])


@pytest.mark.parametrize("shape", [(0, 0, 3), (0, 5), (5, 0)])
def test_an_empty_image_is_refused_by_name(shape):
    # it raised ZeroDivisionError
    with pytest.raises(ValueError, match="empty"):
        App(np.zeros(shape, np.uint8), np.zeros((0, 2)), np.zeros((0, 2)))


def test_folded_cells_matches_the_fold_rule():
    ys, xs = np.mgrid[0:3, 0:3].astype(float)
    mesh = np.stack([xs, ys], axis=-1)
    assert not folded_cells(mesh).any()
    mesh[1, 1] = [2.5, 2.5]  # pulled across the far corner: cells around it turn over
    folded = folded_cells(mesh)
    assert folded.shape == (2, 2) and folded[1, 1] and folded.any()


def test_mesh_lines_keep_the_border():
    ys, xs = np.mgrid[0:5, 0:4].astype(float)
    lines = mesh_lines(np.stack([xs, ys], axis=-1), stride=2)
    # rows 0, 2, 4 (3 segments each) and columns 0, 2, 3 (4 segments each), 2 vertices each
    assert lines.shape == (2 * (3 * 3 + 3 * 4), 6)


# -- command line -------------------------------------------------------------------------------


def parse(*argv: str) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="glmls demo")
    configure(parser)
    return parser.parse_args(argv)


def test_bad_events_file_exits_2_before_any_window(tmp_path, capsys):
    path = tmp_path / "bad.json"
    path.write_text('[{"type": "move"}]')
    assert run(parse("--replay", str(path))) == 2
    err = capsys.readouterr().err
    assert err.startswith("glmls demo: ") and 'missing "x"' in err
    assert len(err.strip().splitlines()) == 1


def test_missing_image_exits_2(tmp_path, capsys):
    assert run(parse(str(tmp_path / "none.png"))) == 2
    assert "no such file" in capsys.readouterr().err


def test_bad_option_values_are_usage_errors(capsys):
    for argv in (["--frames", "0"], ["--grid", "x"], ["--window-size", "10x10"]):
        with pytest.raises(SystemExit) as exit_:
            parse(*argv)
        assert exit_.value.code == 2
    capsys.readouterr()


def test_readout_lines_are_wrapped_to_the_panel():
    from glmls.app.hud import wrap

    lines = wrap("saved /a/very/long/path/" + "x" * 100 + ".png now", 40)
    assert all(len(line) <= 40 for line in lines)
    assert "".join(line.strip() for line in lines).startswith("saved/a/very")


def test_long_analysis_lines_are_wrapped_to_the_panel_whole():
    # "angle error: <why>" was cut at 80 characters and ran past the panel over the image
    from glmls.app.controller import Controller
    from glmls.app.hud import PANEL_CHARS, readout

    why = "reference_points[0] and reference_points[1] are the same point [20.0, 20.0]"
    lines = readout(
        name="x",
        shape=(10, 10),
        controller=Controller(np.zeros((0, 2)), np.zeros((0, 2)), (10, 10)),
        frame_times=[],
        timings={},
        error="",
        analysis_lines=["E_MLS px^2: mean 1 std 2", "  min 0 max 3", f"angle error: {why}"],
        messages=[],
    )
    assert all(len(line) <= PANEL_CHARS for line in lines)
    assert "  min 0 max 3" in lines  # short lines keep their indent
    joined = " ".join(line.strip() for line in lines)
    assert f"angle error: {why}" in joined


@pytest.mark.parametrize("error", ["", "affine MLS needs at least 3 source handles"])
def test_s_says_when_it_saved_the_last_valid_deformation(tmp_path, error):
    # with the handles or settings refused, s saves the last valid f (what the window
    # shows): it said only "saved PATH", though the readout names the refused settings
    from types import SimpleNamespace

    app = App(np.zeros((4, 4), np.uint8), np.zeros((0, 2)), np.zeros((0, 2)))
    app.window, app.session = object(), SimpleNamespace(error=error)
    app._save_warped = lambda: tmp_path / "x.png"
    app._command("save_image")
    [message] = app._shown_messages()
    assert message.startswith(f"saved {tmp_path / 'x.png'}")
    assert ("the last valid f" in message) == bool(error)


@pytest.mark.parametrize("dtype", [np.float16, np.float32])
def test_s_saves_a_float_image_of_any_precision_as_its_values(gl, tmp_path, dtype):
    # a float16 image was saved as the window's display: RGB, stretched to [0, 1]
    image = (np.arange(24 * 32).reshape(24, 32) % 200).astype(dtype)
    src = np.array([[5.0, 5.0], [20.0, 12.0]])
    path = tmp_path / f"x{warped_suffix(image)}"
    with glmls.MLS(src, src, shape=image.shape, ctx=gl) as m:
        save_image(path, m, image, display_image(image), Settings(), Frame(image.shape))
    out = glmls.imread(path)
    assert out.shape == image.shape and out.dtype == np.float32
    np.testing.assert_array_equal(out, image.astype(np.float32))  # f is the identity


@pytest.mark.parametrize("volume", [False, True])
def test_a_message_said_or_expired_redraws_an_idle_window(volume):
    # the view key counted the messages kept (four at most): a fifth message (a failed
    # load after four saves) or one that expired drew no frame in an idle window
    from types import SimpleNamespace

    empty = np.zeros((0, 3 if volume else 2))
    app = (VolumeApp(np.zeros((4, 5, 6), np.uint8), empty, empty) if volume
           else App(np.zeros((4, 4), np.uint8), empty, empty))  # fmt: skip
    app.window = SimpleNamespace(framebuffer_size=(640, 480))
    for n in range(4):
        app.say(f"saved {n}")
    before = app._view_key()
    app.say("load handles failed")
    assert app._view_key() != before
    before = app._view_key()
    app._messages = [(stamp - MESSAGE_SECONDS, text) for stamp, text in app._messages]
    assert app._view_key() != before and app._shown_messages() == []


def test_a_message_of_the_drawing_is_said_after_that_frame():
    # the adaptive mesh giving up is found while a frame is drawn; its message waited in
    # the controller for the next event, so an idle window (or a screenshot) never said it
    from types import SimpleNamespace

    empty = np.zeros((0, 2))
    app = App(np.zeros((4, 4), np.uint8), empty, empty)
    app.window = SimpleNamespace(framebuffer_size=(640, 480))
    app.render = lambda: setattr(app.controller, "message", "adaptive mesh: ...; drawn on the grid")
    app._framed = lambda: None
    app._frame(None)
    assert app._shown_messages() == ["adaptive mesh: ...; drawn on the grid"]
    assert app.controller.message == "" and app._view_key() != app._last_view  # drawn again
