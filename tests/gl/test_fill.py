"""Resources.fill: every texel of a texture (or its first rows) set to a colour, as a
framebuffer clear; the tall textures kept for smaller atlases; and
Resources.staging, the host arrays of read-backs."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_array_equal

import glmls
from glmls.gl import resources as resources_module
from glmls.gl.resources import Resources

SIZES = [(1, 1), (7, 5), (64, 33), (300, 41)]


@pytest.fixture
def resources(gl):
    owned = Resources(gl, "the test's objects")
    with gl.use():
        bound = gl.mgl.fbo or gl.mgl.detect_framebuffer(0)  # bound again after the test
        yield owned
        bound.use()
        owned.release()


def _read(texture, dtype):
    return np.frombuffer(texture.read(alignment=1), dtype).reshape(*texture.size[::-1], 4)


@pytest.mark.parametrize("size", SIZES)
@pytest.mark.parametrize("fill_bytes", [1, 100, resources_module.FILL_BYTES])
def test_fill_sets_every_texel(gl, resources, monkeypatch, size, fill_bytes):
    # fill_bytes 1: a row per copy; 100: a few rows, the last copy shorter
    monkeypatch.setattr(resources_module, "FILL_BYTES", fill_bytes)
    colour = (0.25, -3.5, 1e30, 7.0)
    wide = resources.texture("wide", size, 4, "f4")
    resources.fill(wide, colour)
    expected = np.broadcast_to(np.float32(colour), (*size[::-1], 4))
    assert_array_equal(_read(wide, np.float32), expected)
    narrow = resources.texture("narrow", size, 4, "f1")
    resources.fill(narrow, (10 / 255, 1.0, 0.0, 128 / 255))
    assert_array_equal(
        _read(narrow, np.uint8), np.broadcast_to([10, 255, 0, 128], (*size[::-1], 4))
    )
    resources.fill(narrow, (-1.0, 2.0, 0.3, 0.7))  # clamped, then rounded to 0..255
    assert_array_equal(
        _read(narrow, np.uint8), np.broadcast_to([0, 255, 76, 178], (*size[::-1], 4))
    )


def test_fill_matches_a_framebuffer_clear(gl, resources, rng):
    texture = resources.texture("target", (9, 4), 4, "f1")
    framebuffer = resources.framebuffer("target", (9, 4), "f1")
    for _ in range(20):
        colour = tuple(rng.integers(0, 256, 4) / 255.0)
        framebuffer.use()
        framebuffer.clear(*colour)
        cleared = _read(texture, np.uint8)
        resources.fill(texture, (0.0, 0.0, 0.0, 0.0))
        resources.fill(texture, colour)
        assert_array_equal(_read(texture, np.uint8), cleared)


def test_fill_names_what_it_cannot_fill(gl, resources):
    for components, dtype in ((3, "f1"), (4, "f2"), (1, "f4")):
        texture = resources.texture("other", (3, 3), components, dtype)
        with pytest.raises(ValueError, match="RGBA8 or RGBA32F"):
            resources.fill(texture, (0.0, 0.0, 0.0, 0.0))


def test_pipeline_clear_fills_a_texture_and_clears_anything_else(gl):
    from glmls.imaging.pipeline import WarpPipeline

    pipe = WarpPipeline.of(gl)
    with gl.use():
        bound = gl.mgl.fbo or gl.mgl.detect_framebuffer(0)
        bound.use()
        texture = gl.mgl.texture((5, 3), 4, dtype="f4")
        renderbuffer = gl.mgl.renderbuffer((5, 3), 4)
        on_texture = gl.mgl.framebuffer([texture])
        on_renderbuffer = gl.mgl.framebuffer([renderbuffer])
        try:
            pipe.clear(on_texture, (0.5, -1.0, 2.0, 1.0))
            assert_array_equal(
                _read(texture, np.float32), np.broadcast_to([0.5, -1, 2, 1], (3, 5, 4))
            )
            pipe.clear(on_renderbuffer, (0.0, 1.0, 0.0, 1.0))
            data = np.frombuffer(on_renderbuffer.read(components=4), np.uint8).reshape(3, 5, 4)
            assert_array_equal(data, np.broadcast_to([0, 255, 0, 255], (3, 5, 4)))
            assert gl.mgl.fbo is bound  # the bound framebuffer left as found
        finally:
            for thing in (on_texture, on_renderbuffer, texture, renderbuffer):
                thing.release()


def test_a_framebuffer_over_several_textures_is_made_again_with_them(gl, resources):
    """Resources.attached: one framebuffer whose attachments are the textures of several
    roles (a batch's images and labels drawn together), kept while they are, made again
    when one is made again (its old one released with it), released with the rest."""
    first = resources.framebuffer("a", (8, 4), "f1")
    resources.framebuffer("b", (8, 4), "f4")
    both = resources.attached("a and b", ("a", "b"))
    assert len(both.color_attachments) == 2
    assert both.color_attachments[0].glo == first.color_attachments[0].glo
    assert resources.attached("a and b", ("a", "b")) is both
    remade = resources.framebuffer("b", (8, 4), "f1")  # another dtype: a new texture
    again = resources.attached("a and b", ("a", "b"))
    assert again is not both and type(both.mglo).__name__ == "InvalidObject"  # released
    assert again.color_attachments[1].glo == remade.color_attachments[0].glo
    resources.release()
    assert type(again.mglo).__name__ == "InvalidObject"
    assert gl.mgl.error == "GL_NO_ERROR"


def test_staging_arrays_are_kept_grown_and_dropped(gl):
    """``Resources.staging``: one host array per name, its memory reused by later calls of
    that size or less, grown past it, and dropped with the owner."""
    owner = Resources(gl, "a test cache")
    first = owner.staging("records", (100, 16), np.float32)
    assert first.shape == (100, 16) and first.dtype == np.float32 and first.flags.c_contiguous
    again = owner.staging("records", (50, 4), np.float64)
    assert again.shape == (50, 4) and np.shares_memory(first, again)
    other = owner.staging("other", (10,), np.uint8)
    assert not np.shares_memory(first, other)
    grown = owner.staging("records", (200, 16), np.float32)
    assert grown.shape == (200, 16) and not np.shares_memory(first, grown)
    owner.release()
    with pytest.raises(glmls.ReleasedError, match="a test cache"):
        owner.staging("records", (1,), np.float32)


def test_a_tall_texture_is_kept_while_it_has_rows_enough(gl, resources):
    """``tall``: the texture kept serves a request of its width and fewer rows (a smaller
    chunk's atlas in its first rows); more rows, another width, components or dtype, or a
    request that is not tall make it again, its framebuffer with it."""
    first = resources.framebuffer("atlas", (6, 40), "f1", tall=True)
    texture = first.color_attachments[0]
    assert resources.framebuffer("atlas", (6, 12), "f1", tall=True) is first
    assert resources.texture("atlas", (6, 40), 4, "f1") is texture  # its very size
    assert resources.texture("atlas", (6, 41), 4, "f1", tall=True).size == (6, 41)
    for size, dtype in (((7, 12), "f1"), ((6, 12), "f4")):
        made = resources.texture("atlas", size, 4, dtype, tall=True)
        assert made.size == size and made.dtype == dtype
    resources.texture("atlas", (6, 40), 4, "f4", tall=True)
    exact = resources.texture("atlas", (6, 12), 4, "f4")
    assert exact.size == (6, 12)
    assert gl.mgl.error == "GL_NO_ERROR"


def test_fill_of_the_first_rows_leaves_the_others(gl, resources):
    texture = resources.texture("tall", (5, 9), 4, "f1", tall=True)
    resources.fill(texture, (1.0, 0.0, 0.0, 1.0))
    resources.fill(texture, (0.0, 0.0, 1.0, 0.0), rows=4)
    texels = _read(texture, np.uint8)
    assert_array_equal(texels[:4], np.broadcast_to([0, 0, 255, 0], (4, 5, 4)))
    assert_array_equal(texels[4:], np.broadcast_to([255, 0, 0, 255], (5, 5, 4)))
