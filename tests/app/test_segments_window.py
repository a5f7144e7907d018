"""End to end under ``xvfb-run``: segment handles drawn and dragged by a replay change the
picture, are saved and loaded as handle files; the zoomed view; the help at the default
window size; a live session recorded with ``--record`` replays to the same picture."""

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
from glmls.app.zoom import Zoom, zoom_at
from glmls.files.landmarks import read_handle_set

XVFB = shutil.which("xvfb-run")
pytestmark = pytest.mark.skipif(
    XVFB is None, reason="xvfb-run is not installed (scripts/setup.sh installs xvfb xauth)"
)
WINDOW = (800, 300)
SIZE = f"{WINDOW[0]}x{WINDOW[1]}"
SHAPE = (100, 100)
BLUE = (0, 0, 160)
PANEL = round(PANEL_CHARS * GlyphAtlas(TEXT_SIZE).advance["M"]) + 24
ENV = child_env()


def demo(*args: str) -> subprocess.CompletedProcess:
    command = [XVFB, "-a", sys.executable, "-m", "glmls", "demo", *args]  # type: ignore[list-item]
    return subprocess.run(command, capture_output=True, text=True, env=ENV, timeout=120)


def at(shot: np.ndarray, x: float, y: float) -> np.ndarray:
    """The screenshot's colour at image point (x, y), unzoomed."""
    fx, fy = layout(WINDOW, SHAPE, PANEL).to_framebuffer(x, y)
    return shot[int(fy), int(fx)].astype(int)


#: Segment mode, a segment drawn from (20, 40) to (60, 40) (source = target).
DRAW = [
    {"type": "key", "key": "d"},
    {"type": "press", "x": 20, "y": 40},
    {"type": "move", "x": 40, "y": 40},
    {"type": "move", "x": 60, "y": 40},
    {"type": "release", "x": 60, "y": 40},
]
#: Its target dragged by the middle, by (15, 15): one segment is then a translation.
MOVE = [
    {"type": "press", "x": 40, "y": 40},
    {"type": "move", "x": 50, "y": 50},
    {"type": "move", "x": 55, "y": 55},
    {"type": "release", "x": 55, "y": 55},
]


@pytest.fixture(scope="module")
def square(tmp_path_factory) -> Path:
    """A blue 100 x 100 image with a white 20 x 20 square at rows and columns 30..49."""
    image = np.zeros((*SHAPE, 3), np.uint8)
    image[:] = BLUE
    image[30:50, 30:50] = 255
    path = tmp_path_factory.mktemp("segments") / "square.png"
    glmls.imwrite(path, image)
    return path


def replay(path: Path, entries: list[dict], shot: Path, *args: str):
    path.write_text(json.dumps({"events": [*entries, {"type": "wait", "frames": 2}]}))
    return demo(*args, "--replay", str(path), "--screenshot", str(shot), "--window-size", SIZE)


def test_a_segment_edit_moves_the_image_and_is_saved_and_loaded(tmp_path, square):
    drawn, moved = tmp_path / "drawn.png", tmp_path / "moved.png"
    result = replay(tmp_path / "a.json", DRAW, drawn, str(square))
    assert result.returncode == 0, result.stderr
    shot = glmls.imread(drawn)
    assert (at(shot, 40, 35) > 240).all()  # source = target: the square where it was
    # the segment drawn over the image: yellow along (20..60, 40)
    assert at(shot, 30, 40)[0] > 200 and at(shot, 30, 40)[2] < 80

    saved = tmp_path / "saved"
    events = [*DRAW, *MOVE, {"type": "key", "key": "j"}]
    result = replay(tmp_path / "b.json", events, moved, str(square), "--out", str(saved))
    assert result.returncode == 0, result.stderr
    shot = glmls.imread(moved)
    assert (at(shot, 52, 47) > 240).all() and (at(shot, 62, 62) > 240).all()  # moved (15, 15)
    np.testing.assert_allclose(at(shot, 35, 33), BLUE, atol=8)  # where the square was
    assert (at(shot, 5, 5) < 8).all()  # uncovered: background
    handles = read_handle_set(saved / "square-handles.json")
    assert handles.points == 0
    np.testing.assert_array_equal(handles.src_segments, [[[20, 40], [60, 40]]])
    np.testing.assert_array_equal(handles.dst_segments, [[[35, 55], [75, 55]]])

    loaded = tmp_path / "loaded.png"  # --handles with segments: the same picture
    result = demo(str(square), "--handles", str(saved / "square-handles.json"),
                  "--screenshot", str(loaded), "--window-size", SIZE)  # fmt: skip
    assert result.returncode == 0, result.stderr
    np.testing.assert_array_equal(glmls.imread(loaded)[:, PANEL:], shot[:, PANEL:])  # image


def test_the_zoomed_view(tmp_path, square):
    shot_path = tmp_path / "zoom.png"
    scroll = [{"type": "scroll", "x": 40, "y": 40, "dy": 4}]
    result = replay(tmp_path / "z.json", scroll, shot_path, str(square))
    assert result.returncode == 0, result.stderr
    shot = glmls.imread(shot_path)
    plain = layout(WINDOW, SHAPE, PANEL)
    zoomed = layout(WINDOW, SHAPE, PANEL, zoom=zoom_at(Zoom(), plain.limits, 40, 40, 1.25**4))
    assert zoomed.scale == pytest.approx(plain.scale * 1.25**4, rel=0.01)

    def zat(x, y):
        fx, fy = zoomed.to_framebuffer(x, y)
        return shot[int(fy), int(fx)].astype(int)

    assert zoomed.to_framebuffer(40, 40) == pytest.approx(plain.to_framebuffer(40, 40), abs=1)
    # the square (pixels 30..49: from 29.5 to 49.5) magnified 7.3x, a fifth of a pixel in
    for x, y in ((29.7, 29.7), (49.3, 49.3), (40, 40)):
        assert (zat(x, y) > 240).all(), (x, y)
    for x, y in ((29.3, 40), (49.7, 40), (40, 29.3), (40, 49.7)):  # a fifth of a pixel out
        np.testing.assert_allclose(zat(x, y), BLUE, atol=8, err_msg=str((x, y)))
    left = zoomed.scissor[0]
    assert left == PANEL
    assert not (np.abs(shot[:, PANEL - 40 : PANEL].astype(int) - BLUE) < 8).all(axis=2).any()


def test_the_help_at_the_default_window_size(tmp_path):
    """The bundled 512 x 512 image opens an 888 x 512 window: the help fits beside the
    readout, its last line in the window, the readout not covered."""
    shots = {}
    for name, key in (("plain", "h"), ("help", "?")):  # h: the same amount of events
        events = tmp_path / f"{name}.json"
        keys = [{"type": "key", "key": key}] * (2 if name == "plain" else 1)
        events.write_text(json.dumps([*keys, {"type": "wait", "frames": 2}]))
        shots[name] = tmp_path / f"{name}.png"
        result = demo("--replay", str(events), "--screenshot", str(shots[name]))
        assert result.returncode == 0, result.stderr
    plain = glmls.imread(shots["plain"]).astype(int)
    shot = glmls.imread(shots["help"]).astype(int)
    assert shot.shape == (512, 888, 3)
    yellow = (shot[..., 0] > 200) & (shot[..., 1] > 180) & (shot[..., 0] - shot[..., 2] > 60)
    yellow &= ~((plain[..., 0] > 200) & (plain[..., 1] > 180))  # not the handles' own
    rows, cols = np.nonzero(yellow)
    assert yellow.sum() > 3000  # the help's text
    assert cols.min() >= PANEL - 24 and rows.max() < 512 - 8
    # the readout is the same but for the numbers that change (fps, timings)
    same = (np.abs(shot[100:, : PANEL - 24] - plain[100:, : PANEL - 24]) < 2).all(axis=2)
    assert same.mean() > 0.995


LIVE = """
import sys
import numpy as np
import glmls
from glmls.app.events import Key, Move, Press, Release, Scroll
from glmls.app.window import App

image, out = glmls.imread(sys.argv[1]), sys.argv[2]
app = App(image, np.zeros((0, 2)), np.zeros((0, 2)), name="square", out_dir=out,
          window_size=(800, 300), record=out + "/session.json")
# what the glfw callbacks feed: cursor positions (framebuffer pixels) through the layout
script = [
    ("scroll", 560, 150, 3), ("key", "d"),
    ("press", 520, 100, "left"), ("move", 560, 130), ("move", 600, 160),
    ("release", 600, 160, "left"),
    ("press", 520, 200, "middle"), ("move", 500, 180), ("release", 500, 180, "middle"),
    ("press", 540, 115, "left"), ("move", 560, 140), ("release", 560, 140, "left"),
    ("key", "u"), ("key", "U"), ("key", "j"),
]

def on_frame(a):
    if a.frames > len(script):
        return
    kind, *rest = script[a.frames - 1]
    if kind == "key":
        a.feed(Key(rest[0]))
        return
    x, y = a.layout.to_image(rest[0], rest[1])
    if kind == "scroll":
        a.feed(Scroll(x, y, rest[2]))
    elif kind == "press":
        a.feed(Press(x, y, rest[2]))
    elif kind == "move":
        a.feed(Move(x, y))
    else:
        a.feed(Release(x, y, rest[2]))

app.run(frames=len(script) + 3, screenshot=out + "/live.png", on_frame=on_frame)
"""


def test_a_recorded_live_session_replays_to_the_same_picture(tmp_path, square):
    live = tmp_path / "live"
    script = tmp_path / "live.py"
    script.write_text(LIVE)
    result = subprocess.run(
        [XVFB, "-a", sys.executable, str(script), str(square), str(live)],
        capture_output=True, text=True, env=ENV, timeout=120,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    recorded = read_json(live / "session.json")
    kinds = [entry["type"] for entry in recorded["events"]]
    assert kinds.count("scroll") == 1 and kinds.count("press") == 3 and "key" in kinds
    replayed = tmp_path / "replayed"
    result = demo(str(square), "--replay", str(live / "session.json"), "--out", str(replayed),
                  "--screenshot", str(replayed / "shot.png"), "--window-size", SIZE,
                  "--record", str(replayed / "again.json"))  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert read_json(replayed / "again.json") == recorded  # replayed events are recorded too
    a, b = glmls.imread(live / "live.png"), glmls.imread(replayed / "shot.png")
    np.testing.assert_array_equal(a[:, PANEL:], b[:, PANEL:])  # the image area, zoomed
    handles = [read_json(d / "square-handles.json") for d in (live, replayed)]
    assert handles[0] == handles[1] and len(handles[0]["segments"]["src"]) == 1


def read_json(path: Path) -> dict:
    return json.loads(path.read_text())
