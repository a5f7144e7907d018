"""End to end: the real window under ``xvfb-run``, driven by a replay file, checked on its
screenshots; and the message when there is no display."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from helpers import child_env

import glmls
from glmls.app.layout import layout
from glmls.app.text import GlyphAtlas
from glmls.app.window import PANEL_CHARS, TEXT_SIZE

XVFB = shutil.which("xvfb-run")
needs_xvfb = pytest.mark.skipif(
    XVFB is None, reason="xvfb-run is not installed (scripts/setup.sh installs xvfb xauth)"
)
WINDOW = (800, 300)
SHAPE = (100, 100)
BLUE = (0, 0, 160)


def _env(**changes: str | None) -> dict[str, str]:
    env = child_env()
    for key, value in changes.items():
        if value is None:
            env.pop(key, None)
        else:
            env[key] = value
    return env


def demo(*args: str, xvfb: bool = True, env: dict | None = None, cwd=None):
    command = [sys.executable, "-m", "glmls", "demo", *args]
    if xvfb:
        command = [XVFB, "-a", *command]
    return subprocess.run(
        command, capture_output=True, text=True, env=env or _env(), timeout=120, cwd=cwd
    )


@pytest.fixture(scope="module")
def square(tmp_path_factory) -> Path:
    """A blue 100 x 100 image with a white 20 x 20 square at rows and columns 30..49."""
    image = np.zeros((*SHAPE, 3), np.uint8)
    image[:] = BLUE
    image[30:50, 30:50] = 255
    path = tmp_path_factory.mktemp("window") / "square.png"
    glmls.imwrite(path, image)
    return path


def events(path: Path, *keys: str) -> Path:
    """Press on empty space at (40, 40) (adds a handle there), drag it to (60, 55), then keys."""
    entries = [
        {"type": "press", "x": 40, "y": 40},
        {"type": "move", "x": 50, "y": 48},
        {"type": "move", "x": 60, "y": 55},
        {"type": "release", "x": 60, "y": 55},
        *({"type": "key", "key": key} for key in keys),
        {"type": "wait", "frames": 2},
    ]
    path.write_text(json.dumps({"events": entries}))
    return path


def at(shot: np.ndarray, x: float, y: float) -> np.ndarray:
    """The screenshot's colour at image point (x, y)."""
    panel = round(PANEL_CHARS * GlyphAtlas(TEXT_SIZE).advance["M"]) + 24
    lay = layout(WINDOW, SHAPE, panel)
    fx, fy = lay.to_framebuffer(x, y)
    return shot[int(fy), int(fx)].astype(int)


def image_area(shot: np.ndarray) -> np.ndarray:
    panel = round(PANEL_CHARS * GlyphAtlas(TEXT_SIZE).advance["M"]) + 24
    vx, vy, vw, vh = layout(WINDOW, SHAPE, panel).viewport
    top = WINDOW[1] - (vy + vh)
    return shot[top : top + vh, vx : vx + vw].astype(int)


@needs_xvfb
def test_drag_moves_the_image_and_overlays_appear(tmp_path, square):
    size = f"{WINDOW[0]}x{WINDOW[1]}"
    plain = tmp_path / "plain.png"
    result = demo(
        str(square), "--replay", str(events(tmp_path / "a.json", "h")),
        "--screenshot", str(plain), "--window-size", size,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    shot = glmls.imread(plain)
    assert shot.shape == (WINDOW[1], WINDOW[0], 3)
    # one handle is a translation by (20, 15): the square now covers columns 50..69, rows 45..64
    assert (at(shot, 60, 55) > 240).all()
    assert (at(shot, 52, 47) > 240).all()
    np.testing.assert_allclose(at(shot, 35, 35), BLUE, atol=8)  # where the square was
    np.testing.assert_allclose(at(shot, 80, 80), BLUE, atol=8)
    assert (at(shot, 5, 5) < 8).all()  # uncovered by the shifted image: background
    # the readout is drawn in the window: light text pixels in the panel
    assert (shot[:, :200] > 200).all(axis=2).sum() > 200
    area = image_area(shot)
    mesh_green = (area[..., 1] > 200) & (area[..., 0] < 150) & (area[..., 2] < 200)
    assert mesh_green.sum() == 0

    overlays = tmp_path / "overlays.png"
    result = demo(
        str(square), "--replay", str(events(tmp_path / "b.json", "m", "e", "s", "j")),
        "--screenshot", str(overlays), "--window-size", size, "--frames", "10",
        "--out", str(tmp_path / "saved"),
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    shot = glmls.imread(overlays)
    area = image_area(shot)
    mesh_green = (area[..., 1] > 200) & (area[..., 0] < 150) & (area[..., 2] < 200)
    assert mesh_green.sum() > 500  # the wireframe
    red, green, blue = area[..., 0], area[..., 1], area[..., 2]
    handle = (red > 230) & (green > 170) & (green < 230) & (blue < 60)
    assert handle.sum() > 20  # the handle's target disk
    # the error field (0 everywhere for a translation: the map's low colour, white) lightens
    assert at(shot, 85, 25)[0] > 120
    # s and j saved the deformed image (full resolution, the input's dtype) and the handles
    warped = glmls.imread(tmp_path / "saved" / "square-warped.png")
    assert warped.shape == (*SHAPE, 3) and warped.dtype == np.uint8
    assert (warped[45:65, 50:70] == 255).all() and (warped[:15] == 0).all()
    handles = json.loads((tmp_path / "saved" / "square-handles.json").read_text())
    assert handles == {"src": [[40.0, 40.0]], "dst": [[60.0, 55.0]]}


@needs_xvfb
def test_border_key_and_fit_view(tmp_path, square):
    """The drag translates by (20, 15): b (edge) fills the sliver it leaves; o (fit) shows
    the whole moved image, its canvas (-0.5 .. 119.5, -0.5 .. 114.5) letterboxed."""
    size = f"{WINDOW[0]}x{WINDOW[1]}"
    shots = {}
    for name, keys in {"edge": ["b"], "fit": ["o", "s"]}.items():
        shots[name] = tmp_path / f"{name}.png"
        result = demo(
            str(square), "--replay", str(events(tmp_path / f"{name}.json", *keys)),
            "--screenshot", str(shots[name]), "--window-size", size, "--frames", "8",
            "--out", str(tmp_path / "saved"),
        )  # fmt: skip
        assert result.returncode == 0, result.stderr
    edge = glmls.imread(shots["edge"])
    np.testing.assert_allclose(at(edge, 5, 5), BLUE, atol=8)  # was background
    fit = glmls.imread(shots["fit"])
    panel = round(PANEL_CHARS * GlyphAtlas(TEXT_SIZE).advance["M"]) + 24
    lay = layout(WINDOW, (115, 120), panel, origin=(0.0, 0.0))

    def fit_at(x, y):
        fx, fy = lay.to_framebuffer(x, y)
        return fit[int(fy), int(fx)].astype(int)

    assert (fit_at(52, 47) > 240).all() and (fit_at(67, 62) > 240).all()  # the moved square
    np.testing.assert_allclose(fit_at(115, 110), BLUE, atol=8)  # past the input's frame
    assert (fit_at(5, 5) < 8).all()  # uncovered, the constant border
    # s saved what the view shows: the whole moved image on its canvas
    warped = glmls.imread(tmp_path / "saved" / "square-warped.png")
    assert warped.shape == (115, 120, 3)
    assert (warped[45:65, 50:70] == 255).all() and warped[15:, 20:].any(axis=-1).all()


@needs_xvfb
@pytest.mark.parametrize("option", ["--frames", "--screenshot", "--replay"])
def test_each_option_works_alone(tmp_path, square, option):
    if option == "--frames":
        args = ["--frames", "2", str(square)]
    elif option == "--replay":
        args = ["--replay", str(events(tmp_path / "e.json")), str(square)]
    else:  # the default image
        args = ["--screenshot", str(tmp_path / "shot.png")]
    result = demo(*args, cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    assert result.stderr == ""
    if option == "--screenshot":
        assert glmls.imread(tmp_path / "shot.png").ndim == 3


def test_no_display_is_a_one_line_message(tmp_path):
    env = _env(DISPLAY=None, WAYLAND_DISPLAY=None)
    result = demo("--frames", "1", xvfb=False, env=env, cwd=tmp_path)
    assert result.returncode == 1
    assert "Traceback" not in result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith("glmls demo: no display")
    assert "headless" in lines[0]


@needs_xvfb
def test_the_adaptive_mesh_key_draws_and_saves_on_it(tmp_path, square):
    """T twice (0.05 px), m (the leaves' outlines): the view and the saved image are the
    adaptive mesh's warp, and the panel says so."""
    shot, keys = tmp_path / "adaptive.png", ["T", "T", "s"]
    result = demo(
        str(square), "--replay", str(events(tmp_path / "t.json", *keys)), "--screenshot",
        str(shot), "--window-size", f"{WINDOW[0]}x{WINDOW[1]}", "--frames", "8",
        "--out", str(tmp_path / "saved"),
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    image = glmls.imread(square)
    with glmls.MLS([[40.0, 40.0]], [[60.0, 55.0]], shape=SHAPE) as m:
        expected = m.warp(image, tolerance=0.05)
    assert (glmls.imread(tmp_path / "saved" / "square-warped.png") == expected).all()
    view = glmls.imread(shot)
    assert (at(view, 65, 60) > 240).all()  # the moved square, drawn on the adaptive mesh


@needs_xvfb
def test_the_window_draws_on_the_grid_where_the_adaptive_mesh_gives_up(tmp_path, square):
    """Handles pulled so far apart that the adaptive build exceeds its budget: the window
    keeps running and draws the image on the regular grid."""
    src = [[47.0, 50.0], [53.0, 50.0], [5.0, 5.0], [94.0, 5.0], [5.0, 94.0], [94.0, 94.0]]
    dst = [[-3000.0, 50.0], [3100.0, 50.0], *src[2:]]
    handles = tmp_path / "far.json"
    handles.write_text(json.dumps({"src": src, "dst": dst}))
    shot = tmp_path / "far.png"
    result = demo(
        str(square), "--handles", str(handles), "--tolerance", "0.001", "--frames", "3",
        "--screenshot", str(shot), "--window-size", f"{WINDOW[0]}x{WINDOW[1]}",
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert image_area(glmls.imread(shot)).any()


@needs_xvfb
def test_a_float_image_is_shown_by_its_range_and_saved_as_float(tmp_path):
    # a float image of 0..255 was clipped to [0, 1] (a white window), and s saved an 8-bit
    # PNG of that, though the key table says "input dtype"
    image = np.zeros((*SHAPE, 3), np.float32)
    image[:] = BLUE
    image[30:50, 30:50] = 255.0
    path = tmp_path / "float.tif"
    glmls.imwrite(path, image)
    shot_path = tmp_path / "shot.png"
    result = demo(
        str(path), "--replay", str(events(tmp_path / "e.json", "h", "s")),
        "--screenshot", str(shot_path), "--window-size", f"{WINDOW[0]}x{WINDOW[1]}",
        "--out", str(tmp_path / "saved"),
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    shot = glmls.imread(shot_path)
    np.testing.assert_allclose(at(shot, 80, 80), BLUE, atol=8)  # not white
    assert (at(shot, 60, 55) > 240).all()
    warped = glmls.imread(tmp_path / "saved" / "float-warped.tif")
    expected = glmls.warp(image, [[40.0, 40.0]], [[60.0, 55.0]], grid=4)
    assert warped.dtype == np.float32 and np.array_equal(warped, expected)


@needs_xvfb
def test_handles_never_valid_show_the_input_not_a_black_image(tmp_path, square):
    # affine with every source on one line has no f from the start: the image area was
    # black, and the readout spoke of "the last valid f"
    handles = tmp_path / "line.json"
    handles.write_text(json.dumps({"src": [[10, 10], [20, 20], [30, 30]],
                                   "dst": [[12, 10], [22, 20], [32, 30]]}))  # fmt: skip
    shot_path = tmp_path / "shot.png"
    result = demo(
        str(square), "--handles", str(handles), "--transform", "affine",
        "--screenshot", str(shot_path), "--window-size", f"{WINDOW[0]}x{WINDOW[1]}",
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    shot = glmls.imread(shot_path)
    assert (at(shot, 40, 40) > 240).all()  # the square, where it is in the input
    np.testing.assert_allclose(at(shot, 80, 80), BLUE, atol=8)


TWO_WINDOWS = """
import glfw
import numpy as np
from glmls.app.window import App

none = np.zeros((0, 2))
App(np.zeros((8, 8), np.uint8), none, none).run(frames=1)
errors = []
glfw.set_error_callback(lambda code, text: errors.append(code))
glfw.get_primary_monitor()  # GLFW_NOT_INITIALIZED if the closed window terminated glfw
App(np.zeros((8, 8), np.uint8), none, none).run(frames=1)
print(errors == [])
"""


@needs_xvfb
def test_windows_opened_one_after_another_keep_the_display(tmp_path):
    # closing a window terminated glfw, closing the connection to the display: xvfb-run's X
    # server then resets, and a window opened meanwhile failed ("Failed to open display")
    script = tmp_path / "two.py"
    script.write_text(TWO_WINDOWS)
    result = subprocess.run(
        [XVFB, "-a", sys.executable, str(script)],
        capture_output=True, text=True, env=_env(), timeout=120,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert result.stdout.split() == ["True"]


CLOSED_IN_A_FRAME = """
import numpy as np
from glmls.app.window import App

none = np.zeros((0, 2))
app = App(np.zeros((8, 8), np.uint8), none, none)
app.run(frames=5, on_frame=lambda a: a.close())
print(app.frames, app.window is None)
"""


@needs_xvfb
def test_a_window_closed_by_on_frame_ends_the_run(tmp_path):
    # the run swapped the closed window's buffers: an X error (GLXBadDrawable) killed it
    script = tmp_path / "closed.py"
    script.write_text(CLOSED_IN_A_FRAME)
    result = subprocess.run(
        [XVFB, "-a", sys.executable, str(script)],
        capture_output=True, text=True, env=_env(), timeout=120,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert result.stdout.split() == ["1", "True"]
