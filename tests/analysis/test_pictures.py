"""Offscreen GPU pictures: colour mapping like the CPU, top-down, geometry where it belongs."""

from __future__ import annotations

import numpy as np
import pytest

import glmls
from glmls.analysis.canvas import Canvas, as_rgb8
from glmls.analysis.shapes import arrow_triangles


def test_field_matches_cpu_colouring_and_is_top_down(gl, rng):
    values = rng.gamma(2.0, 5.0, (37, 53))
    values[0, :] = 0.0  # top row: the minimum colour
    values[5, 7] = np.nan
    for options in ({}, {"percentile": 90.0}, {"cmap": ((0, 0, 255), (255, 0, 0))}):
        gpu = glmls.analysis.render_field(values, nan_color=(255, 0, 255), ctx=gl, **options)
        cpu = glmls.analysis.apply_colormap(values, nan_color=(255, 0, 255), **options)
        assert gpu.shape == (37, 53, 3) and gpu.dtype == np.uint8
        # float32 on the GPU may round a value at an entry boundary to the neighbour entry
        differ = (gpu != cpu).any(axis=2)
        assert differ.mean() < 0.01
        assert np.abs(gpu.astype(int) - cpu).max() <= 3
        assert gpu[5, 7].tolist() == [255, 0, 255]
    assert (glmls.analysis.render_field(values, ctx=gl)[0] == glmls.analysis.VIRIDIS[0]).all()


def test_image_round_trip_is_exact(gl, rng):
    image = rng.integers(0, 256, (31, 45, 3), dtype=np.uint8)
    for samples in (0, 4):
        with Canvas(image.shape, samples=samples, ctx=gl) as canvas:
            assert (canvas.image(image).read() == image).all()
    grey = rng.random((6, 5))
    with Canvas((6, 5), ctx=gl) as canvas:
        assert (canvas.image(grey).read() == as_rgb8(grey)).all()


def test_canvases_released_in_any_order(gl, rng):
    image = rng.integers(0, 256, (6, 5, 3), dtype=np.uint8)
    first, second = Canvas((6, 5), ctx=gl), Canvas((6, 5), ctx=gl)
    first.image(image)
    first.release()  # the one the second came after
    assert np.array_equal(second.image(image).read(), image)
    second.release()
    with Canvas((6, 5), ctx=gl) as third:  # and the context draws on
        assert np.array_equal(third.image(image).read(), image)


def test_geometry_lands_on_its_pixels(gl):
    with Canvas((40, 60), samples=0, ctx=gl) as canvas:
        # upper-left triangle: rows near 0, columns near 0
        canvas.triangles([[[0, 0], [30, 0], [0, 20]]], [(255, 0, 0)])
        canvas.disks([[50, 30]], color=(0, 255, 0), radius=3)
        canvas.lines([[0, 35]], [[59, 35]], color=(0, 0, 255), width=3)
        picture = canvas.read()
    assert picture[2, 2].tolist() == [255, 0, 0]
    assert picture[18, 28].tolist() == [0, 0, 0]  # beyond the hypotenuse
    assert picture[30, 50].tolist() == [0, 255, 0]
    assert picture[35, 10].tolist() == [0, 0, 255]
    assert picture[33, 10].tolist() == [0, 0, 0]


def test_handles_point_from_p_to_q(gl):
    image = np.zeros((50, 80, 3), np.uint8)
    picture = glmls.analysis.render_handles(
        image, [[10, 25]], [[70, 25]], source_color=(0, 0, 255), color=(255, 0, 0), ctx=gl
    )
    assert picture[25, 10].tolist() == [0, 0, 255]  # the disk at p
    assert picture[25, 40].tolist() == [255, 0, 0]  # the shaft
    head = (picture[:, 60:71, 0] > 0).sum(axis=0)
    assert head[0] > head[-2] > 0  # the head narrows towards q
    assert len(arrow_triangles(np.zeros((1, 2)), np.zeros((1, 2)), 2.0, 10.0)) == 0


def test_triangle_errors_fill_with_their_colour(gl, rng):
    r = np.array([[5.0, 5.0], [90.0, 5.0], [5.0, 60.0], [90.0, 60.0]])
    errors = glmls.analysis.triangle_errors(lambda v: v + 0.1 * v[:, ::-1], r)
    background = np.full((70, 100, 3), 255, np.uint8)
    picture = glmls.analysis.render_triangle_errors(
        background, errors, which="distance", opacity=1.0, edge_color=None, ctx=gl
    )
    colours = glmls.analysis.apply_colormap(errors.distance)
    for tri, colour in zip(errors.simplices, colours, strict=True):
        cx, cy = errors.deformed_points[tri].mean(axis=0)
        assert picture[round(cy), round(cx)].tolist() == colour.tolist()
    assert picture[1, 1].tolist() == [255, 255, 255]  # outside: the background
    outline = glmls.analysis.render_triangulation(background, r, errors.simplices, ctx=gl)
    assert outline[5, 50].tolist() != [255, 255, 255]  # on the top edge


def test_mesh_picture_draws_the_deformed_lines(gl):
    """A translation by (5, 2) moves the grid-10 lines of pixel-square corners from x = -0.5,
    9.5, ... to x = 4.5, 14.5, ... (y: 1.5, 11.5, ...): dark there, white inside the cells."""
    with glmls.MLS([[20.0, 20.0]], [[25.0, 22.0]], ctx=gl) as m:
        _, mesh = m.mesh((40, 40), grid=10)
    white = np.full((40, 40, 3), 255, np.uint8)
    picture = glmls.analysis.render_mesh(white, mesh, color=(0, 0, 0), width=2.0, ctx=gl)
    grey = picture.mean(axis=2)
    for x in (4, 5, 14, 15, 24, 25):  # the pixels either side of a vertical line
        assert grey[7, x] < 160, x
    for y in (1, 2, 11, 12, 21, 22):  # either side of a horizontal one
        assert grey[y, 9] < 160, y
    for y, x in ((7, 9), (17, 19), (27, 29), (6, 0)):  # inside the cells, and left of x = 4.5
        assert grey[y, x] == 255, (y, x)


def test_bad_input(gl):
    with pytest.raises(ValueError, match="image must be"):
        as_rgb8(np.zeros((4, 4, 5)))
    with pytest.raises(TypeError, match="dtype"):
        as_rgb8(np.zeros((4, 4), np.int32))
    with pytest.raises(ValueError, match="values must be"):
        glmls.analysis.render_field(np.zeros(5), ctx=gl)
    with Canvas((4, 4), ctx=gl) as canvas:
        with pytest.raises(ValueError, match="canvas"):
            canvas.image(np.zeros((5, 4, 3), np.uint8))
        with pytest.raises(ValueError, match="width"):
            canvas.lines([[0, 0]], [[1, 1]], width=0)
        with pytest.raises(ValueError, match="finite or NaN"):
            canvas.field(np.full((4, 4), np.inf))
    with pytest.raises(glmls.ReleasedError):
        canvas.read()
    errors = glmls.analysis.triangle_errors(lambda v: v, [[0, 0], [3, 0], [0, 3]])
    with pytest.raises(ValueError, match="which"):
        glmls.analysis.render_triangle_errors(np.zeros((4, 4)), errors, which="area", ctx=gl)
    with pytest.raises(TypeError, match="deformed must be True or False, got 1"):
        glmls.analysis.render_triangle_errors(np.zeros((4, 4)), errors, deformed=1, ctx=gl)


@pytest.mark.parametrize("samples", [3, 5, 1000])
def test_a_sample_count_moderngl_refuses_is_taken_down_to_one_it_takes(gl, samples):
    """3 was moderngl's 'the number of samples is invalid' (it takes powers of two)."""
    below = 1 << (samples.bit_length() - 1)
    pictures = []
    for count in (samples, below):
        with Canvas((8, 8), samples=count, ctx=gl) as canvas:
            pictures.append(canvas.disks([[3.5, 4.0]], color=(255, 0, 0), radius=2.5).read())
    np.testing.assert_array_equal(pictures[0], pictures[1])
    assert pictures[0][4, 3].tolist() == [255, 0, 0]


@pytest.mark.parametrize(
    ("samples", "error"),
    [(-1, ValueError), (2.5, TypeError), (True, TypeError), ("4", TypeError), (None, TypeError)],
)
def test_a_sample_count_that_is_no_count_is_named(gl, samples, error):
    with pytest.raises(error, match=rf"^samples must be an integer >= 0, got {samples!r}$"):
        Canvas((4, 4), samples=samples, ctx=gl)


def test_a_mesh_picture_names_the_mesh_not_its_lines(gl):
    """A NaN vertex was named "a", the lines' first ends drawn from it."""
    mesh = np.zeros((3, 3, 2))
    mesh[1, 2] = np.nan
    with pytest.raises(ValueError, match=r"^deformed \(its vertices row by row\) must be finite"):
        glmls.analysis.render_mesh(np.zeros((4, 4), np.uint8), mesh, ctx=gl)
    with pytest.raises(glmls.DtypeError, match=r"^deformed must be real numbers"):
        glmls.analysis.render_mesh(np.zeros((4, 4), np.uint8), mesh.astype(complex), ctx=gl)


def test_a_field_of_complex_values_is_refused_not_cast(gl):
    with pytest.raises(glmls.DtypeError, match=r"^values must be real numbers, got dtype complex"):
        glmls.analysis.render_field(np.full((4, 4), 1 + 1j), ctx=gl)


def test_triangle_errors_made_by_hand_are_checked(gl):
    errors = glmls.analysis.triangle_errors(lambda v: 1.1 * v, [[0, 0], [3, 0], [0, 3], [3, 3]])
    image = np.zeros((4, 4))
    missing = glmls.analysis.TriangleErrors(
        errors.points,
        errors.deformed_points,
        np.array([[0, 1, 7], [1, 2, 3]]),
        errors.distance,
        errors.angle,
        errors.flipped,
        errors.eps,
    )
    for deformed in (True, False):
        with pytest.raises(ValueError, match="simplices refer to points that do not exist"):
            glmls.analysis.render_triangle_errors(image, missing, deformed=deformed, ctx=gl)
    short = glmls.analysis.TriangleErrors(
        errors.points,
        errors.deformed_points,
        errors.simplices,
        errors.distance[:1],
        errors.angle,
        errors.flipped,
        errors.eps,
    )
    with pytest.raises(ValueError, match=r"errors.distance has shape \(1,\)"):
        glmls.analysis.render_triangle_errors(image, short, which="distance", ctx=gl)
    glmls.analysis.render_triangle_errors(image, short, which="angle", ctx=gl)
