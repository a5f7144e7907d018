"""Zoom and pan: the layout's math (what is shown where, the cursor back to image pixels) and
the controller's events, with picking and drawing still right in image pixels when zoomed."""

from __future__ import annotations

import numpy as np
import pytest

from glmls.app.controller import Controller, Key, Move, Press, Release, Scroll
from glmls.app.layout import layout
from glmls.app.zoom import MAX_PIXEL, ViewLimits, Zoom, clamp, pan, zoom_at

FRAMEBUFFER = (900, 600)
PANEL = 300
SHAPE = (300, 400)  # H, W: 1.5 framebuffer pixels per image pixel unzoomed


def lay(zoom: Zoom | None = None, shape=SHAPE, origin=(0.0, 0.0)):
    return layout(FRAMEBUFFER, shape, PANEL, origin, zoom)


def test_unzoomed_is_the_letterboxed_view():
    plain, zoomed = lay(), lay(Zoom())
    assert plain == zoomed
    assert plain.viewport == (300, 75, 600, 450) and plain.scale == 1.5
    assert plain.frame.shape == SHAPE and plain.frame.origin == (0.0, 0.0)
    assert plain.scissor == plain.viewport
    assert plain.limits == ViewLimits((-0.5, -0.5, 399.5, 299.5), (400.0, 400.0), MAX_PIXEL / 1.5)


def test_zoomed_in_only_the_pixels_in_view_are_drawn():
    lo = lay(Zoom(4.0, (200.0, 150.0)))
    assert lo.scale == pytest.approx(6.0)
    # the area (600 x 600) shows 100 x 100 image pixels around (200, 150), whole pixels
    assert lo.frame.shape == (101, 101) and lo.frame.origin == (150.0, 100.0)
    vx, vy, vw, vh = lo.viewport
    assert vx <= PANEL and vx + vw >= 900 and vy <= 0 and vy + vh >= 600  # covers the area
    assert lo.scissor == (PANEL, 0, 600, 600)  # cut to the area: never over the panel
    assert lo.to_framebuffer(200, 150) == pytest.approx((600, 300), abs=1)  # the middle


def test_cursor_and_image_points_round_trip_when_zoomed():
    for zoom in (Zoom(2.5, (80.0, 200.0)), Zoom(13.0, (399.0, 0.0)), Zoom(1.7)):
        lo = lay(zoom)
        for point in ((100.0, 200.0), (123.25, 77.5), (0.0, 0.0), (399.5, 299.5)):
            assert lo.to_image(*lo.to_framebuffer(*point)) == pytest.approx(point)
            fx, fy = lo.to_framebuffer(*point)
            assert lo.to_image(fx / 2, fy / 2, pixel_ratio=2.0) == pytest.approx(point)


def test_zoom_about_a_point_keeps_it_under_the_cursor():
    lo = lay()
    zoom = Zoom()
    for point, times in (((100.0, 80.0), 1.25**3), ((110.0, 90.0), 1.25**5), ((300, 250), 0.8)):
        before = lo.to_framebuffer(*point)
        zoom = zoom_at(zoom, lo.limits, *point, times)
        lo = lay(zoom)
        assert lo.to_framebuffer(*point) == pytest.approx(before, abs=1.0)
    assert zoom.factor == pytest.approx(1.25**7)


def test_zoom_and_pan_are_clamped_to_the_canvas():
    limits = lay().limits
    assert zoom_at(Zoom(), limits, 10, 10, 0.5) == Zoom()  # not below the whole view
    assert zoom_at(Zoom(), limits, 10, 10, 1e6).factor == limits.max_zoom
    zoom = zoom_at(Zoom(), limits, 0, 0, 4.0)  # about (0, 0): (199.5, 149.5) comes 4x nearer
    assert zoom.center == pytest.approx((199.5 / 4, -0.5 + 50))  # y: the view stays on it
    assert pan(zoom, limits, -100, -100).center == pytest.approx((49.5, 49.5))  # the corner
    far = pan(zoom, limits, 1e4, 1e4)
    assert far.center == pytest.approx((399.5 - 50, 299.5 - 50))
    assert clamp(Zoom(2.0, (-1e3, 1e3)), limits).center == pytest.approx((99.5, 199.5))
    with pytest.raises(ValueError, match="zoom factor"):
        Zoom(0.5)
    # a wide canvas in a square area: zoomed 1.5x, the height still fits, so it stays centred
    wide = layout(FRAMEBUFFER, (100, 400), PANEL, zoom=Zoom(1.5, (10.0, 0.0)))
    assert wide.zoom.center == pytest.approx((-0.5 + 400 / 1.5 / 2, 49.5))
    assert wide.frame.shape[0] == 100


def test_a_canvas_from_another_origin_zooms_in_its_own_pixels():
    lo = lay(Zoom(3.0, (0.0, 0.0)), shape=(320, 440), origin=(-20.0, -10.0))
    assert lo.frame.origin[0] >= -20 and lo.frame.origin[1] >= -10
    assert lo.to_image(*lo.to_framebuffer(-3.0, 7.0)) == pytest.approx((-3.0, 7.0))
    assert lo.frame.origin == (lo.frame.origin[0] // 1, lo.frame.origin[1] // 1)  # whole px


def window_events(c: Controller, framebuffer_path, *, mods=frozenset(), button="left") -> None:
    """What the window does for a press-drag-release along framebuffer positions: each
    cursor position read through the layout of that moment (re-laid out after a zoom)."""
    lo = lay(c.zoom)
    c.view_limits = lo.limits
    c.pick_radius = 10.0 / lo.scale  # 10 framebuffer pixels
    first, *rest = framebuffer_path
    c.feed(Press(*lo.to_image(*first), button, mods))
    for position in rest:
        lo = lay(c.zoom)
        c.feed(Move(*lo.to_image(*position)))
    lo = lay(c.zoom)
    c.feed(Release(*lo.to_image(*rest[-1]), button))


def test_picking_and_drawing_are_right_when_zoomed():
    c = Controller([[100.0, 100.0], [104.0, 100.0]], [[100.0, 100.0], [104.0, 100.0]], SHAPE)
    lo = lay()
    c.view_limits = lo.limits
    c.feed(Scroll(102.0, 100.0, 8))  # 1.25^8 = 5.96x about the pair
    lo = lay(c.zoom)
    assert lo.scale == pytest.approx(1.5 * 1.25**8, rel=1e-2)
    # the two handles, 4 image px apart, are 36 framebuffer px apart now: each is picked
    q1 = lo.to_framebuffer(104.0, 100.0)
    window_events(c, [(q1[0] - 6, q1[1]), (q1[0] + 30, q1[1] + 30)])
    np.testing.assert_allclose(c.dst[1], lo.to_image(q1[0] + 30, q1[1] + 30))
    np.testing.assert_allclose(c.dst[1], (104.0 + 30 / lo.scale, 100.0 + 30 / lo.scale))
    np.testing.assert_array_equal(c.dst[0], [100.0, 100.0])
    # draw a segment between two screen positions: its ends are those image points
    c.feed(Key("d"))
    a, b = (400.0, 100.0), (700.0, 500.0)
    window_events(c, [a, (550.0, 300.0), b])
    np.testing.assert_allclose(c.src_segments[0], [lo.to_image(*a), lo.to_image(*b)])
    assert c.zoom.factor == pytest.approx(1.25**8)  # editing does not move the view


def test_pan_drags_keep_the_grabbed_point_under_the_cursor():
    c = Controller(np.zeros((0, 2)), np.zeros((0, 2)), SHAPE)
    lo = lay()
    c.view_limits = lo.limits
    c.feed(Scroll(200.0, 150.0, 6))
    lo = lay(c.zoom)
    grabbed = lo.to_image(500.0, 300.0)
    revision, depth = c.revision, c.undo_depth
    for button, mods in (("middle", frozenset()), ("left", frozenset({"ctrl"}))):
        window_events(c, [(500.0, 300.0), (480.0, 290.0), (440.0, 260.0)], button=button,
                      mods=mods)  # fmt: skip
        lo = lay(c.zoom)
        assert lo.to_image(440.0, 260.0) == pytest.approx(grabbed, abs=0.2)
        window_events(c, [(440.0, 260.0), (500.0, 300.0)], button=button, mods=mods)
    assert c.revision == revision and c.undo_depth == depth  # nothing added or moved
    assert len(c.src) == 0 and not c.dragging


def test_zoom_keys():
    c = Controller(np.zeros((0, 2)), np.zeros((0, 2)), SHAPE)
    c.view_limits = lay().limits
    for _ in range(4):
        c.feed(Key("]"))
    assert c.zoom.factor == pytest.approx(1.25**4)
    centre = c.zoom.centre_in(c.view_limits)
    c.feed(Key("Right"))
    c.feed(Key("Down"))
    step = 0.125 * 400 / 1.25**4  # an eighth of the view
    assert c.zoom.center == pytest.approx((centre[0] + step, centre[1] + step))
    c.feed(Key("Left"))
    c.feed(Key("Up"))
    assert c.zoom.center == pytest.approx(centre)
    c.feed(Key("["))
    assert c.zoom.factor == pytest.approx(1.25**3)
    c.feed(Key("0"))
    assert c.zoom == Zoom()
    revision = c.revision
    c.feed(Scroll(10, 10, -3))  # out, past the whole view: stays whole
    assert c.zoom == Zoom() and c.revision == revision


@pytest.mark.parametrize("notches", [1e6, -1e6, 1e308])
def test_a_wheel_turned_past_any_zoom_stops_at_the_limits(notches):
    # a replay may give any finite dy: 1.25 ** 1e6 overflows a float
    c = Controller(np.zeros((0, 2)), np.zeros((0, 2)), SHAPE)
    c.view_limits = lay().limits
    c.feed(Scroll(100, 100, notches))
    wanted = c.view_limits.max_zoom if notches > 0 else 1.0
    assert c.zoom.factor == pytest.approx(wanted)
