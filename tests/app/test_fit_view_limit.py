"""The window's fit view at the GL limit (the pipeline's ``max_image_size``, queried): a
canvas exactly that large is shown, one pixel more falls back to the input's frame; the
letterboxed view of such a canvas stays within the framebuffer."""

from __future__ import annotations

import numpy as np
import pytest

from glmls.app.controller import Controller, Settings
from glmls.app.layout import layout
from glmls.app.session import Session
from glmls.core.config import MLSConfig
from glmls.imaging.pipeline import WarpPipeline


@pytest.mark.parametrize(("shift", "fits"), [(10, True), (11, False)])
def test_the_fit_view_takes_a_canvas_exactly_at_the_limit(gl, shift, fits):
    """Handles all moved ``shift`` px right (f a translation): the fit canvas of an image
    10 px narrower than the limit is the limit wide, or one pixel more."""
    limit = WarpPipeline.of(gl).max_image_size
    shape = (3, limit - 10)
    src = np.array([[100.0, 0.0], [limit / 2, 2.0], [limit - 200.0, 1.0]])
    c = Controller(src, src + [shift, 0.0], shape, settings=Settings(fit=True))
    session = Session(gl, c, shape)
    try:
        session.sync()
        if fits:
            assert session.canvas.shape == (3, limit)
            assert session.canvas.origin == (0.0, 0.0)
        else:  # f blows the image up past the GL limit: the input's frame
            assert session.canvas.shape == shape
    finally:
        if session.mls is not None:
            session.mls.release()


def test_the_fit_view_of_an_image_blown_past_the_coordinate_range_is_the_input(gl):
    """An affine map that takes 1 px to 1e6 px: its canvas is no warp's."""
    shape = (32, 32)
    src = np.array([[10.0, 10.0], [11.0, 10.0], [10.0, 11.0]])
    dst = np.array([[0.0, 0.0], [1e6, 0.0], [0.0, 1e6]])
    settings = Settings(config=MLSConfig(transform="affine"), fit=True)
    c = Controller(src, dst, shape, settings=settings)
    session = Session(gl, c, shape)
    try:
        session.sync()
        assert session.mls is not None
        assert session.canvas.shape == shape and session.canvas.origin == (0.0, 0.0)
    finally:
        if session.mls is not None:
            session.mls.release()


@pytest.mark.parametrize("canvas", [(3, 1), (1, 3), (1, 1)])
def test_the_letterboxed_view_of_a_canvas_at_the_limit_fits_the_framebuffer(gl, canvas):
    """Unzoomed, the image's viewport lies within the framebuffer (whose size GL's viewport
    limit takes), however long the canvas."""
    limit = WarpPipeline.of(gl).max_image_size
    shape = tuple(limit if n == 1 else n for n in canvas)
    for framebuffer in ((888, 512), (limit, limit), (limit, 7)):
        view = layout(framebuffer, shape, 240)
        x, y, w, h = view.viewport
        assert 0 <= x and x + w <= framebuffer[0] and 0 <= y and y + h <= framebuffer[1]
        assert view.shape == shape
