"""The volume window's default size and layout (no display): every view, its frame lines
included, lies inside the framebuffer, for isotropic and highly anisotropic spacings."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from glmls.app.hud import PANEL_CHARS
from glmls.app.text import GlyphAtlas
from glmls.app.view import TEXT_SIZE
from glmls.app.volume_controller import AXES, SliceGrid, VolumeController
from glmls.app.volume_view import (
    label_quads,
    montage_layout,
    view_labels,
    view_viewport,
    window_size,
)

PANELS = (0, 342, 368, 448)  # the panel's widths at text sizes 12, 13 and 16
SHAPES = ((16, 64, 64), (5, 48, 17), (40, 101, 90), (3, 200, 32), (64, 64, 64))
SPACINGS = ((2.0, 0.5, 0.5), (1.0, 1.0, 1.0), (5.0, 1.0, 1.0), (0.7, 0.3, 0.3), (1.0, 3.0, 0.5))


@pytest.mark.parametrize(("shape", "spacing"), list(itertools.product(SHAPES, SPACINGS)))
def test_every_view_and_its_frame_fit_the_default_window(shape, spacing):
    grid = SliceGrid(shape, spacing=spacing)
    for panel in PANELS:
        size = window_size(grid, panel)
        layout = montage_layout(size, grid, panel)
        width, height = layout.framebuffer
        for view in range(3):
            x0, y0, w, h = view_viewport(layout, grid, view)
            assert x0 >= layout.panel and y0 >= 0, (panel, view, size, (x0, y0, w, h))
            assert x0 + w <= width and y0 + h <= height, (panel, view, size, (x0, y0, w, h))
            (ox, oy), (columns, rows) = grid.offset(view), grid.size(view)
            # the frame lines, drawn half a montage pixel beyond the view's pixel centres
            for x, y in ((ox - 0.5, oy - 0.5), (ox + columns - 0.5, oy + rows - 0.5)):
                fx, fy = layout.to_framebuffer(x, y)
                assert 0.5 <= fx <= width - 0.5 and 0.5 <= fy <= height - 0.5, (
                    panel, view, size, (fx, fy)
                )  # fmt: skip


def test_the_default_size_is_the_montage_at_its_scale_beside_the_panel():
    grid = SliceGrid((16, 64, 64), spacing=(2.0, 0.5, 0.5))
    assert grid.montage_shape == (132, 132)  # 64 + 4 + 64 both ways: z spans 16 x 4 pixels
    width, height = window_size(grid, 368)
    assert height >= 560 and width >= 368 + 560
    layout = montage_layout((width, height), grid, 368)
    assert layout.scale == pytest.approx(560 / 132, rel=0.02)  # the views keep their size


@pytest.mark.parametrize(
    ("shape", "spacing"), [((64, 64, 64), (0.01, 1.0, 1.0)), ((300, 1024, 1024), (1.0, 1.0, 1.0))]
)
def test_the_default_window_of_a_large_montage_fits_a_screen(shape, spacing):
    # it was never scaled down: 6846 x 6470 for the phantom with --spacing 0.01,1,1
    grid = SliceGrid(shape, spacing=spacing)
    width, height = window_size(grid, 368)
    assert width <= 368 + 1600 and height <= 1000
    layout = montage_layout((width, height), grid, 368)
    for view in range(3):
        x0, y0, w, h = view_viewport(layout, grid, view)
        assert x0 >= 368 and y0 >= 0 and x0 + w <= width and y0 + h <= height


@pytest.mark.parametrize(
    "shape", [(64, 64, 1), (1, 64, 64), (64, 256, 64), (3, 200, 32), (1, 1, 1), (64, 64, 64)]
)
def test_the_default_window_keeps_the_readout_beside_the_views(shape):
    # a montage narrower than the panel got a window so narrow that the panel was dropped:
    # the readout covered the axial view
    grid = SliceGrid(shape)
    panel = round(PANEL_CHARS * GlyphAtlas(TEXT_SIZE).advance["M"]) + 24
    size = window_size(grid, PANEL_CHARS * 8 + 24)  # the window's estimate of the panel
    layout = montage_layout(size, grid, panel)
    assert layout.panel == panel
    assert min(view_viewport(layout, grid, view)[0] for view in range(3)) >= panel


@pytest.mark.parametrize("shape", [(2, 3, 400), (1, 1, 50), (1, 2, 5000), (300, 2, 2)])
def test_the_default_window_of_a_flat_montage_holds_the_readout(shape):
    # a volume of 2 x 3 x 400 voxels got a window 25 pixels tall: the readout and the help
    # were cut to their first line
    grid = SliceGrid(shape)
    panel = round(PANEL_CHARS * GlyphAtlas(TEXT_SIZE).advance["M"]) + 24
    width, height = window_size(grid, panel)
    assert height >= 20 * GlyphAtlas(TEXT_SIZE).line_height  # 20 lines of the readout
    assert width <= panel + 1600 and height <= 1000
    layout = montage_layout((width, height), grid, panel)
    for view in range(3):  # the views still fit, letterboxed
        x0, y0, w, h = view_viewport(layout, grid, view)
        assert x0 >= panel and y0 >= 0 and x0 + w <= width and y0 + h <= height


@pytest.mark.parametrize(
    ("shape", "spacing"),
    [((1, 32, 40), (1.0, 1.0, 1.0)), ((30, 48, 6), (1.0, 1.0, 1.0)), ((3, 200, 32), (1.0,) * 3),
     ((64, 64, 64), (1.0, 1.0, 1.0)), ((16, 64, 64), (0.7, 0.3, 0.3)), ((2, 3, 400), (1.0,) * 3)],
)  # fmt: skip
def test_every_view_label_lies_inside_its_view(shape, spacing):
    # a 1-slice volume's sagittal label ran past the window ("sa"), a thin axial view's over
    # the sagittal view's
    grid = SliceGrid(shape, spacing=spacing)
    c = VolumeController(np.zeros((0, 3)), np.zeros((0, 3)), shape, spacing=spacing)
    atlas = GlyphAtlas(TEXT_SIZE)
    panel = round(PANEL_CHARS * atlas.advance["M"]) + 24
    for size in (window_size(grid, panel), (700, 400), (panel + 200, 150)):
        layout = montage_layout(size, grid, panel)
        height = layout.framebuffer[1]
        boxes = []
        for view in range(3):
            x0, y0, w, h = view_viewport(layout, grid, view)
            boxes.append((x0, height - y0 - h, x0 + w, height - y0))  # y down
        labelled = {view: text for view, text, _, _ in view_labels(layout, c, atlas)}
        for _, parts in label_quads(layout, c, atlas):
            for part in parts:
                xs, ys = part[:, 0], part[:, 1]
                inside = [
                    left <= xs.min()
                    and xs.max() <= right
                    and top <= ys.min()
                    and ys.max() <= bottom
                    for left, top, right, bottom in boxes
                ]
                assert any(inside), (size, part[:, :2].min(0), part[:, :2].max(0), boxes)
        for view, text in labelled.items():  # the plane, at least
            normal = AXES[view][2]
            assert text.replace(" ", "").endswith(f"{'xyz'[normal]}={c.point[normal]}"), text
        if min(grid.size(0)) >= 40 and min(size) >= 400:  # room for the whole label
            assert labelled[0] == f"axial z = {c.point[2]}", labelled
