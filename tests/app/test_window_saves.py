"""The window's saves (``s``, ``j``, ``S``) never replace a file the window read, and its
readout panel keeps the width the layout gives it, whatever the lengths of its lines."""

from __future__ import annotations

import numpy as np
import pytest

from glmls.app import App, Key
from glmls.app.hud import PANEL_CHARS, readout_quads
from glmls.app.text import glyph_atlas
from glmls.app.view import TEXT_SIZE

SRC = [[10.0, 10.0], [30.0, 12.0], [20.0, 25.0]]
DST = [[11.0, 10.0], [30.0, 13.0], [19.0, 25.0]]


def window(out_dir, **options) -> App:
    """An image window named "img", saving into ``out_dir`` (not opened)."""
    return App(np.zeros((32, 48), np.uint8), SRC, DST, name="img", out_dir=out_dir, **options)


def said(app: App) -> str:
    return " ".join(" ".join(app.readout()).split())


@pytest.mark.parametrize(
    ("key", "name"),
    [("j", "img-handles.json"), ("s", "img-warped.png"), ("S", "img-screenshot.png")],
)
def test_a_save_over_a_file_read_is_refused_and_said(gl, tmp_path, key, name):
    read = tmp_path / name
    read.write_text("kept")
    app = window(tmp_path, read_files={read: "the --reference file"})
    app.feed(Key(key))
    assert read.read_text() == "kept"
    assert f"{name} is the --reference file, which saving would replace" in said(app)
    assert app._want_screenshot is None  # S: no screenshot waits to be written there


def test_the_handles_file_is_saved_over_and_other_saves_go_through(gl, tmp_path):
    """``j`` writes the edited handles over the --handles file (not a file read and kept);
    a read file elsewhere stops nothing (the window's own saves of its image need it open:
    tests/app/test_window.py)."""
    handles = tmp_path / "img-handles.json"
    handles.write_text("{}")
    other = tmp_path / "elsewhere.json"
    app = window(tmp_path, handles_path=handles, read_files={other: "the --reference file"})
    app.feed(Key("j"))
    assert '"src"' in handles.read_text()
    assert "saved" in said(app)


@pytest.mark.parametrize("long", ["a_rather_long_file_name_" * 4, "x" * 200])
def test_long_readout_lines_wrap_within_the_panel(long):
    atlas = glyph_atlas(TEXT_SIZE)
    lines = [f"glmls  {long}  96x96", "fps  0.0", f"weight     idw, radius {10**30}   (w, +/-)"]
    _, _, width = readout_quads(atlas, lines, 2000)
    pad = atlas.cell[1] // 2
    assert width <= atlas.width("M" * PANEL_CHARS) + 2 * pad
    _, _, short = readout_quads(atlas, ["fps  0.0"], 2000)
    assert short == atlas.width("fps  0.0") + 2 * pad  # short lines stay as they are
