"""The mesh lattice of an image: corners and centres, bands, masks, uniforms (no GPU)."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from glmls.core.handles import Scaling, fit_boxes
from glmls.core.handles3 import fit_scaling3
from glmls.core.mesh import MeshLattice, as_shape


def test_corners_are_pixel_square_corners():
    xs, ys = MeshLattice.corners((3, 5), 2).axes
    assert_allclose(xs, [-0.5, 1.5, 3.5, 4.5])
    assert_allclose(ys, [-0.5, 1.5, 2.5])
    xs, _ = MeshLattice.corners((3, 5), 1).axes
    assert_allclose(xs, np.arange(6) - 0.5)
    lattice = MeshLattice.corners((3, 5), 2)
    assert lattice.dims == (4, 3) and lattice.cells == (3, 2) and lattice.count == 12
    assert lattice.points().shape == (3, 4, 2)
    assert lattice.last == (4.5, 2.5)


def test_centres_are_the_pixel_centres():
    lattice = MeshLattice.centres((3, 5))
    xs, ys = lattice.axes
    assert_array_equal(xs, np.arange(5)) and assert_array_equal(ys, np.arange(3))
    assert lattice.dims == (5, 3) and lattice.band_overlap == 0
    with pytest.raises(ValueError, match="grid 1"):
        MeshLattice((3, 5), 2, "centres")


@pytest.mark.parametrize(
    ("grid", "error"),
    [(0, ValueError), (-1, ValueError), (1.5, TypeError), (2.0, TypeError), (True, TypeError)],
)
def test_bad_grid(grid, error):
    with pytest.raises(error, match="grid must be an integer from 1 to"):
        MeshLattice.corners((4, 4), grid)


def test_bad_shape_and_kind():
    with pytest.raises(ValueError, match="shape"):
        as_shape((0, 4))
    with pytest.raises(TypeError, match="shape"):
        as_shape(5)
    with pytest.raises(ValueError, match="kind"):
        MeshLattice((4, 4), 1, "edges")


@pytest.mark.parametrize("rows_per_band", [2, 3, 5, 100])
def test_bands_cover_every_cell_row_once(rows_per_band):
    """Bands of cells overlap by one row of points: each cell row is in exactly one band."""
    lattice = MeshLattice.corners((37, 10), 3)  # 14 rows of points, 13 of cells
    covered = []
    for first, rows in lattice.bands(rows_per_band):
        assert 2 <= rows <= rows_per_band
        covered += range(first, first + rows - 1)  # the band's cell rows
    assert covered == list(range(lattice.cells[1]))
    assert lattice.one_band(rows_per_band) == (rows_per_band >= lattice.dims[1])


def test_bands_of_centres_do_not_overlap():
    lattice = MeshLattice.centres((7, 4))
    assert list(lattice.bands(3)) == [(0, 3), (3, 3), (6, 1)]


def test_rows_per_band_fit_the_budget():
    lattice = MeshLattice.corners((1000, 1000), 1)  # 1001 points per row, 8 bytes each
    assert lattice.rows_per_band(80_080) == 10
    assert lattice.rows_per_band(80_080, indexed=True) == 4  # 24 bytes per cell of indices
    assert lattice.rows_per_band(16) == 2  # at least one row of cells


def test_cell_mask_marks_the_pixels_of_each_cell():
    lattice = MeshLattice.corners((5, 7), 3)  # cells of 3 x 3, the last ones shorter
    cells = np.zeros(lattice.cells[::-1], bool)
    cells[1, 2] = True
    mask = lattice.cell_mask(cells)
    assert mask.shape == (5, 7)
    assert_array_equal(np.argwhere(mask), [[3, 6], [4, 6]])


def test_uniforms_are_in_scaled_coordinates():
    scaling = Scaling((10.0, 20.0), 4.0)
    values = MeshLattice.corners((8, 12), 2).uniforms(scaling)
    assert_allclose(values["u_lattice_origin"], ((-0.5 - 10) / 4, (-0.5 - 20) / 4))
    assert_allclose(values["u_lattice_step"], (0.5, 0.5))
    assert_allclose(values["u_lattice_last"], ((11.5 - 10) / 4, (7.5 - 20) / 4))
    assert values["u_lattice_dims"] == (7, 5)


@pytest.mark.parametrize("shape", [(1.5, 2), (12, 16.25), (True, 4), (4.0, 4)])
def test_shape_of_non_integer_sizes_is_refused(shape):
    """A size of 1.5 pixels was truncated to 1 (and a bool taken as 1) without a word."""
    with pytest.raises(TypeError, match="shape must be"):
        as_shape(shape)


def test_shape_as_a_string_is_refused():
    """``"12"`` was read as the shape (1, 2)."""
    with pytest.raises(TypeError, match="shape must be"):
        as_shape("12")


def test_shape_of_integral_numbers_is_kept():
    assert as_shape((np.int64(3), np.uint8(4))) == (3, 4)
    assert as_shape((np.array(3), 4)) == (3, 4)
    assert as_shape((3, 4, 3)) == (3, 4)


def test_scaling_into_the_first_columns_of_wider_rows():
    """``to_gpu(out=...)`` writes the scaled points into a view (a vec4 per vertex for the
    GPU), the same values as a new array; another shape or dtype is refused, named."""
    scaling = Scaling((10.0, 20.0, 30.0), 4.0)
    points = np.array([[10.0, 20.0, 30.0], [14.0, 12.0, 31.0]])
    wide = np.full((2, 4), 7.0, np.float32)
    assert scaling.to_gpu(points, out=wide[:, :3]) is not None
    assert np.array_equal(wide[:, :3], scaling.to_gpu(points))
    assert (wide[:, 3] == 7.0).all()
    with pytest.raises(ValueError, match="float32 of shape"):
        scaling.to_gpu(points, out=np.zeros((2, 3)))


@pytest.mark.parametrize("half", [0.1, 1.0, 1.5, 5.5, 112.0, 128.0, 129.0, 1e6, 2.0**40 + 1])
@pytest.mark.parametrize("low", [3.0, -0.5, 0.3, -1e7 - 0.1])
def test_the_gpu_box_is_centred_on_halves_and_scaled_by_a_power_of_two(half, low):
    """2D and 3D scalings centre on a multiple of 1/2 and scale by the least power of two
    that holds the box, so pixel coordinates go to the GPU's frame and back exactly."""
    lo, hi = np.array([[low, -1.0]]), np.array([[low + 2 * half, 0.0]])
    center, scale = (a[0] for a in fit_boxes(lo, hi))
    assert np.array_equal(2 * center, np.round(2 * center))
    assert abs(center[0] - (lo[0, 0] + hi[0, 0]) / 2) <= 0.25
    assert scale == 2.0 ** round(np.log2(scale)) and scale >= 1.0
    reach = max(np.abs(lo - center).max(), np.abs(hi - center).max())
    assert scale >= reach and (scale == 1.0 or scale / 2 < reach)
    fitted = Scaling.fit(np.concatenate([lo, hi]), np.concatenate([lo, hi]))
    assert fitted == Scaling(tuple(center.tolist()), scale)


def test_pixel_coordinates_go_to_the_gpu_and_back_unchanged():
    shape = (100, 37)
    assert Scaling.fit(np.zeros((0, 2)), np.zeros((0, 2)), shape) == Scaling((18.0, 49.5), 64.0)
    scaling3 = fit_scaling3(np.zeros((0, 3)), np.zeros((0, 3)), (5, 100, 37))
    assert scaling3 == Scaling((18.0, 49.5, 2.0), 64.0)
    handles = np.array([[-3.3, 7.1], [50.2, 1e3 / 3]])
    gpu = Scaling.fit(handles, handles + 0.7, shape)
    pixels = np.stack(np.meshgrid(np.arange(-9.0, 60.0), np.arange(-5.0, 340.0)), -1)
    pixels = pixels.reshape(-1, 2)
    assert np.array_equal(gpu.from_gpu(gpu.to_gpu(pixels)), pixels)
