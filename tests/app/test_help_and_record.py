"""The help screen fits the window beside the readout (the default 888 x 512 included), and
recorded events are written in the replay format and read back the same."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import glmls
from glmls.app.controller import BINDINGS, Controller
from glmls.app.events import (
    KEY_NAMES,
    MAX_WAIT_FRAMES,
    Key,
    Move,
    Press,
    Recorder,
    Release,
    Scroll,
    Wait,
    event_entry,
    read_events,
    write_events,
)
from glmls.app.helpscreen import HELP, help_layout
from glmls.app.hud import PANEL_CHARS, help_lines, place_help, readout, text_quads
from glmls.app.text import glyph_atlas
from glmls.app.view import TEXT_SIZE
from glmls.app.volume_controller import VOLUME_BINDINGS
from glmls.app.volume_view import help_groups, help_text, text_groups
from glmls.app.volume_window import VolumeApp
from glmls.core.weights import WEIGHTS
from glmls.imaging.source import BORDERS

DEFAULT_WINDOW = (8 * PANEL_CHARS + 24 + 512, 512)  # the window's default for a 512² image


def test_the_help_covers_every_binding():
    listed = [action for _, entries in HELP for _, _, actions in entries for action in actions]
    assert sorted(listed) == sorted(action for _, action, _ in BINDINGS)
    text = " ".join(" ".join(help_lines()).split())  # wrapped lines joined
    assert all(name in text for name in (*WEIGHTS, *BORDERS, "rigid", "similarity", "affine"))


def key_table(text: str) -> str:
    """The first table of ``text`` whose header is ``| key | effect |``."""
    start = text.index("| key | effect |")
    end = text.find("\n\n", start)
    return text[start:end]


@pytest.mark.parametrize("window", ["image", "volume"])
def test_the_guide_lists_every_key(window):
    # the adaptive mesh's T was missing from the image window's table
    guide = (Path(__file__).parents[2] / "docs" / "window.md").read_text(encoding="utf-8")
    if window == "volume":
        guide = guide[guide.index("## Volumes") :]
    table = key_table(guide)
    bindings = BINDINGS if window == "image" else VOLUME_BINDINGS
    arrows = {"Left", "Right", "Up", "Down"} if window == "image" else set()
    keys = {key for keys, _, _ in bindings for key in keys} - arrows
    assert not [key for key in sorted(keys) if f"`{key}`" not in table]
    assert not arrows or "arrow keys" in table


def readout_lines() -> list[str]:
    src, dst = glmls.data.astronaut_handles()
    c = Controller(src, dst, (512, 512), reference=glmls.data.astronaut_reference_points())
    return readout(
        name="astronaut", shape=(512, 512), controller=c, frame_times=[0.0, 0.01, 0.02],
        timings={}, error="", analysis_lines=[], messages=[],
    )  # fmt: skip


def boxes(parts: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """(low, high) corners of what vertex arrays cover."""
    xy = np.concatenate([p[:, :2] for p in parts])
    return xy.min(axis=0), xy.max(axis=0)


@pytest.mark.parametrize("framebuffer", [DEFAULT_WINDOW, (1200, 700), (1776, 1024)])
def test_the_help_fits_beside_the_readout(framebuffer):
    atlas = glyph_atlas(TEXT_SIZE)
    lines = readout_lines()
    panel = round(PANEL_CHARS * atlas.advance["M"]) + 24
    groups = text_quads(atlas, lines, help_visible=True, panel=panel, framebuffer=framebuffer)
    (readout_size, readout_parts), (help_size, help_parts) = groups
    assert readout_size == TEXT_SIZE
    _, high = boxes(readout_parts)
    assert high[1] <= framebuffer[1]  # the readout itself fits the height
    help_low, help_high = boxes(help_parts)
    assert help_low[0] >= high[0]  # right of the readout: nothing of it covered
    assert (help_low >= 0).all() and (help_high <= framebuffer).all()  # nothing cut off
    assert help_size >= 10  # still legible
    glyphs = sum(len(p) for p in help_parts[1:]) // 6
    assert glyphs == sum(len(line.replace(" ", "")) for line in help_lines())  # every line
    if framebuffer[0] >= 1200:
        assert help_size == TEXT_SIZE


@pytest.mark.parametrize("volume", [False, True])
def test_what_a_key_did_stays_in_view_below_a_long_readout(volume):
    # every error overlay's statistics and three saves: 32 lines, more than the default
    # window's 512 pixels hold at the readout's size; the last ones say what the keys did
    atlas = glyph_atlas(TEXT_SIZE)
    lines = readout_lines() + [f"statistic {k}" for k in range(7)]
    lines += [f"saved out/astronaut-{k}.png" for k in ("warped", "handles", "screenshot")]
    assert len(lines) * atlas.line_height > DEFAULT_WINDOW[1]
    if volume:
        groups = text_groups(atlas, lines, help_visible=True, framebuffer=DEFAULT_WINDOW)
    else:
        panel = round(PANEL_CHARS * atlas.advance["M"]) + 24
        groups = text_quads(
            atlas, lines, help_visible=True, panel=panel, framebuffer=DEFAULT_WINDOW
        )
    (size, parts), (_, help_parts) = groups
    assert 8 <= size < TEXT_SIZE
    _, high = boxes(parts)
    assert high[1] <= DEFAULT_WINDOW[1]  # the last line too
    assert len(parts[1]) // 6 == sum(len(line.replace(" ", "")) for line in lines)
    assert boxes(help_parts)[0][0] >= high[0]  # the help still beside it


def test_the_volume_help_covers_every_binding():
    listed = [a for _, entries in help_groups() for _, _, actions in entries for a in actions]
    assert sorted(listed) == sorted(action for _, action, _ in VOLUME_BINDINGS)


@pytest.mark.parametrize("framebuffer", [(936, 560), (640, 360)])
def test_the_volume_help_is_shown_whole(framebuffer):
    # one column of 41 lines: at 640 x 360 its last 14 keys (edits and files) fell below
    # the window, and it covered the readout at any size (936 x 560: the phantom's default)
    atlas = glyph_atlas(TEXT_SIZE)
    lines = VolumeApp(glmls.data.phantom(), *glmls.data.phantom_handles()).readout()
    groups = text_groups(atlas, lines, help_visible=True, framebuffer=framebuffer)
    (_, readout_parts), (help_size, help_parts) = groups
    help_low, help_high = boxes(help_parts)
    assert (help_low >= 0).all() and (help_high <= framebuffer).all()  # nothing cut off
    glyphs = sum(len(p) for p in help_parts[1:]) // 6
    assert glyphs == sum(len(line.replace(" ", "")) for line in help_text())  # every line
    if framebuffer[0] > 900:
        assert help_low[0] >= boxes(readout_parts)[1][0] and help_size >= 10  # beside it


def test_the_help_takes_the_whole_window_only_where_nothing_else_fits():
    atlas = glyph_atlas(TEXT_SIZE)
    placed = place_help(atlas, 367, (600, 400))
    x, y, width, height = placed.box
    assert x < 367 and x >= 0 and x + width <= 600 and y + height <= 400
    assert [line for line in placed.lines if line] == [line for line in help_lines() if line]
    # one column where it fits, else more, else a smaller size; the last resort is forced
    tall = help_layout([(0, 0, 2000, 2000)], [13], glyph_atlas)
    assert len(tall.columns) == 1 and tall.size == 13
    tiny = help_layout([(0, 0, 50, 50)], [13, 9], glyph_atlas)
    assert tiny.size == 9 and len(tiny.columns) == 3


def test_recorded_events_read_back_the_same(tmp_path):
    recorder = Recorder()
    events = [
        Press(12.5, 40.0),
        Move(13.0, 41.25),
        Release(13.0, 41.25),
        Press(1.0, 2.0, "right"),
        Press(5.0, 6.0, "middle", frozenset({"shift", "ctrl"})),
        Release(5.0, 6.0, "middle"),
        Scroll(100.0, 50.5, -2.0),
        Key("Ctrl+Shift+Z"),
        Key("d"),
    ]
    for event in events:
        recorder.record(event)
    path = tmp_path / "session.json"
    recorder.save(path)
    assert read_events(path) == events
    data = json.loads(path.read_text())
    assert data["events"][0] == {"type": "press", "x": 12.5, "y": 40.0}  # defaults left out
    assert data["events"][4]["mods"] == ["shift", "ctrl"]
    write_events(path, [*events, Wait(3)])
    assert read_events(path)[-1] == Wait(3)
    write_events(path, [])
    assert read_events(path) == []
    with pytest.raises(TypeError, match="unknown event"):
        event_entry("t")  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("entry", "match"),
    [
        ({"type": "scroll", "x": 1, "y": 2}, 'missing "dy"'),
        ({"type": "scroll", "x": 1, "y": 2, "dy": "up"}, '"dy" must be a finite number'),
        ({"type": "scroll", "x": 1, "y": 2, "dy": 1, "button": "left"}, "unknown field"),
    ],
)
def test_bad_scroll_entries(tmp_path, entry, match):
    path = tmp_path / "bad.json"
    path.write_text(json.dumps([entry]))
    with pytest.raises(glmls.errors.InputFileError, match=match):
        read_events(path)


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("[" * 100_000 + "]" * 100_000, "nested too deeply to be events"),
        ('[{"type": "wait", "frames": 99999999999999999999999}]', r"integer in 0\.\.1000000"),
        ('[{"type": "wait", "frames": 1000001}]', r"integer in 0\.\.1000000"),
        ('[{"type": "key", "key": "ctrl+z"}]', "got 'ctrl\\+z'"),
        ('[{"type": "key", "key": "Esc"}]', "got 'Esc'"),
        ('[{"type": "key", "key": "tt"}]', "a character typed, one of F1, Escape"),
        ('[{"type": "key", "key": "Ctrl+Shift+7"}]', "got 'Ctrl\\+Shift\\+7'"),
    ],
)
def test_hostile_replays_are_one_error_each(tmp_path, text, match):
    """A replay that would crash the reader, run for ever, or name a key no window feeds
    (a typo: the window would ignore it unsaid) is refused naming the file and entry."""
    path = tmp_path / "events.json"
    path.write_text(text)
    with pytest.raises(glmls.errors.InputFileError, match=match):
        read_events(path)


def test_every_key_a_window_feeds_reads_back(tmp_path):
    keys = ["t", "?", "+", "]", "0", " ", *KEY_NAMES, "Ctrl+Z", "Ctrl+Shift+Z", "Ctrl+Y"]
    path = tmp_path / "keys.json"
    write_events(path, [Key(k) for k in keys] + [Wait(MAX_WAIT_FRAMES)])
    assert read_events(path) == [Key(k) for k in keys] + [Wait(MAX_WAIT_FRAMES)]
