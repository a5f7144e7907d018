"""The cells method (``quads``) on volumes, against the float64 reference of its definition."""

from __future__ import annotations

import numpy as np
import pytest
from volume_reference import box_handles, warp_cells

from glmls.core.config import MLSConfig
from glmls.volume import SlabOptions, VolumeOptions, warp_volume
from glmls.volume.construction import VolumeWarper
from glmls.volume.fields import ReferenceField
from glmls.volume.frame import CornerLattice
from glmls.volume.kernel_field import KernelField

SHAPE = (10, 12, 14)


@pytest.fixture
def volume(rng):
    return rng.integers(0, 256, SHAPE, dtype=np.uint8)


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.float32, np.float64])
@pytest.mark.parametrize("channels", [None, 1, 2, 3, 4])
def test_identity_reproduces_the_volume(kernel3, rng, dtype, channels):
    shape = (6, 7, 9) if channels is None else (6, 7, 9, channels)
    volume = (rng.random(shape) * 1000).astype(dtype)
    src, _ = box_handles(shape[:3], rng)
    m = kernel3(src, src, shape[:3])
    for method in ("quads", "backward"):
        out = warp_volume(m, volume, method=method)
        assert out.dtype == volume.dtype and out.shape == volume.shape
        # float64 is computed as float32
        np.testing.assert_array_equal(out, volume.astype(np.float32).astype(dtype))


@pytest.mark.parametrize("dtype", [">u2", ">f4", ">f8"])
def test_big_endian_volumes_are_their_dtypes(kernel3, rng, dtype):
    """A big-endian array (a .npy or FITS file written so) is warped as the native dtype of
    the same name, and returned in that native dtype."""
    volume = (rng.random((6, 7, 9)) * 1000).astype(dtype)
    src, _ = box_handles(volume.shape, rng)
    m = kernel3(src, src, volume.shape)
    out = warp_volume(m, volume)
    native = volume.dtype.newbyteorder("=")
    assert out.dtype == native
    np.testing.assert_array_equal(out, volume.astype(np.float32).astype(native))


@pytest.mark.parametrize("method", ["quads", "backward"])
@pytest.mark.parametrize("interpolation", ["nearest", "linear"])
def test_integer_translation_shifts_exactly(kernel3, rng, volume, method, interpolation):
    src, _ = box_handles(SHAPE, rng)
    shift = np.array([3, -2, 1])  # x, y, z
    m = kernel3(src, src + shift, SHAPE, transform="rigid")
    out = warp_volume(m, volume, method=method, interpolation=interpolation, background=7)
    expected = np.full(SHAPE, 7, np.uint8)
    expected[1:, :-2, 3:] = volume[:-1, 2:, :-3]
    np.testing.assert_array_equal(out, expected)


@pytest.mark.parametrize("interpolation", ["nearest", "linear"])
@pytest.mark.parametrize("grid", [1, 3])
def test_cells_match_the_reference(kernel3, rng, volume, interpolation, grid):
    """Voxels whose centre lies within float32 noise of a tetrahedron's face may go to the
    other side: at most 1% differ, each at most one value of 255 (linear) off beyond."""
    src, dst = box_handles(SHAPE, rng, count=12, spread=2.5)
    config = {"transform": "similarity", "weight": "idw", "alpha": 1.0}
    m = kernel3(src, dst, SHAPE, **config)
    out = warp_volume(m, volume, grid=grid, interpolation=interpolation, background=3)
    field = ReferenceField(src, dst, MLSConfig(**config), shape=SHAPE)
    expected = warp_cells(
        field, volume[..., None], grid=grid, linear=interpolation == "linear", background=3
    )[..., 0]
    expected = np.clip(np.rint(expected), 0, 255)
    off = np.abs(out.astype(float) - expected)
    assert np.mean(off > 1) < 0.01
    assert np.mean(off > 0) < (0.02 if interpolation == "linear" else 0.01)


def test_folds_show_the_first_cell_in_scan_order(gl, rng):
    """A map that folds the volume over itself: the reference keeps the first cell in scan
    order, and so does the GPU (the float64 reference field on both sides, so that only the
    construction is compared)."""
    shape = (8, 9, 10)
    volume = rng.integers(0, 256, shape, dtype=np.uint8)
    src = np.array([[0, 0, 0], [9, 0, 0], [0, 8, 0], [0, 0, 7], [9, 8, 7], [4.5, 4, 3.5]])
    dst = src.copy()
    dst[5] = [8.0, 6.0, 6.0]  # the middle pulled far past the far corner: a fold
    field = ReferenceField(src, dst, MLSConfig(transform="affine"), shape=shape)
    out = VolumeWarper.of(gl).warp(field, volume, VolumeOptions())
    expected = warp_cells(field, volume[..., None])[..., 0]
    assert np.mean(out != expected) < 0.01


def test_slabs_are_invisible(kernel3, rng, volume):
    src, dst = box_handles(SHAPE, rng, count=14, spread=3.0)
    m = kernel3(src, dst, SHAPE, transform="affine")
    # slabs of 3 slices, bands of 2 to 5 layers of cells (the margin of wrap widens them)
    small = SlabOptions(slab_bytes=14 * 12 * 16 * 3, band_bytes=30 * 30 * 12 * 3)
    for method in ("quads", "backward"):
        for border in ("constant", "wrap"):
            options = VolumeOptions(method=method, border=border, interpolation="linear")
            whole = warp_volume(m, volume, options=options)
            sliced = warp_volume(m, volume, options=options, slabs=small)
            np.testing.assert_array_equal(whole, sliced)
            banded = warp_volume(
                m, volume, options=options, slabs=SlabOptions(band_bytes=small.band_bytes)
            )
            np.testing.assert_array_equal(whole, banded)  # one slab, every band

    # bands too small for one layer of cells and its neighbours: the option is named
    with pytest.raises(ValueError, match="give a larger band_bytes or a coarser grid"):
        warp_volume(m, volume, options=VolumeOptions(), slabs=SlabOptions(band_bytes=1024))


def test_kernel_field_fills_the_lattice_as_the_reference(kernel3, gl, rng, volume):
    src, dst = box_handles(SHAPE, rng, count=10, spread=2.0)
    m = kernel3(src, dst, SHAPE, transform="rigid")
    field = ReferenceField(src, dst, MLSConfig(transform="rigid"), shape=SHAPE)
    gpu = VolumeWarper.of(gl).warp(KernelField(m, shape=SHAPE), volume, VolumeOptions())
    cpu = VolumeWarper.of(gl).warp(field, volume, VolumeOptions())
    assert np.mean(gpu != cpu) < 0.01


def test_output_canvas_and_origin(kernel3, rng, volume):
    src, _ = box_handles(SHAPE, rng)
    m = kernel3(src, src, SHAPE)
    out = warp_volume(m, volume, output_shape=(4, 5, 6), origin=(2, 3, 1))
    np.testing.assert_array_equal(out, volume[1:5, 3:8, 2:8])


def test_spacing_puts_voxels_at_physical_positions(kernel3, rng, volume):
    """Voxel (k, j, i) sits at (i dx, j dy, k dz): a translation by whole voxels in physical
    units shifts by whole voxels, and an anisotropic map matches the reference construction
    evaluated in physical units."""
    spacing = (2.5, 1.0, 0.5)
    scale = np.array([spacing[2], spacing[1], spacing[0]])
    src, dst = box_handles(SHAPE, rng, count=10, spread=2.0)
    shifted = kernel3(src * scale, (src + [3, -2, 1]) * scale, SHAPE, transform="rigid")
    expected = np.zeros(SHAPE, np.uint8)
    expected[1:, :-2, 3:] = volume[:-1, 2:, :-3]
    for method in ("quads", "backward"):
        out = warp_volume(shifted, volume, method=method, spacing=spacing)
        np.testing.assert_array_equal(out, expected)
    config = {"transform": "rigid", "weight": "idw"}
    m = kernel3(src * scale, dst * scale, SHAPE, **config)
    out = warp_volume(m, volume, spacing=spacing)
    field = ReferenceField(
        src * scale, dst * scale, MLSConfig(**config), spacing=spacing, shape=SHAPE
    )
    reference = warp_cells(field, volume[..., None])[..., 0]
    assert np.mean(out != reference) < 0.01


def test_volumes_larger_than_a_texture_are_held_by_slices(kernel3, rng, volume):
    """A volume over ``texture_bytes`` is held a range of slices at a time: the same
    volume as from one texture."""
    src, dst = box_handles(SHAPE, rng, count=12, spread=1.5)
    m = kernel3(src, dst, SHAPE, transform="rigid")
    _, h, w = SHAPE
    slices = SlabOptions(
        slab_bytes=h * w * 64,  # one output slice a slab (backward: 64 bytes a voxel)
        band_bytes=(w + 13) * (h + 13) * 12 * 2,  # a layer or a few of cells a band
        texture_bytes=h * w * 8,  # 8 source slices a texture
    )
    for method in ("quads", "backward"):
        for border in ("constant", "reflect"):
            for interpolation in ("nearest", "linear"):
                options = VolumeOptions(method=method, border=border, interpolation=interpolation)
                whole = warp_volume(m, volume, options=options)
                np.testing.assert_array_equal(
                    warp_volume(m, volume, options=options, slabs=slices), whole
                )
    with pytest.raises(ValueError, match="more than one texture holds"):
        warp_volume(m, volume, slabs=SlabOptions(texture_bytes=h * w * 2))


@pytest.mark.parametrize("band_layers", [2, 3, 100])
@pytest.mark.parametrize("piece", [None, 5, 17])
def test_survey_box_is_f_over_the_lattice(kernel3, rng, monkeypatch, band_layers, piece):
    """The bounds' box, reduced on the GPU band by band (each layer in pieces of ``piece``
    points; None: the default, one piece here), is the box of f at every lattice point (f
    evaluated on the host side through the field), NaN-free, whatever the bands."""
    from glmls.volume import bands

    if piece is not None:
        monkeypatch.setattr(bands, "SURVEY_PIECE", piece)
    src, dst = box_handles(SHAPE, rng)
    m = kernel3(src, dst + rng.normal(0, 1.5, dst.shape), SHAPE)
    field = KernelField(m, (1.0, 1.0, 1.0), SHAPE)
    lattice = CornerLattice(SHAPE, 2)
    nx, ny, _ = lattice.dims
    assert (bands.survey_pieces(nx, ny) > 1) == (piece is not None)
    slabs = SlabOptions(band_bytes=nx * ny * 12 * band_layers)  # band_layers - 1 cell layers
    box = VolumeWarper.of(m.gl).bounds(field, SHAPE, 2, slabs)
    points = lattice.layer_points(0, lattice.dims[2]).reshape(-1, 3)
    f = field.evaluate(points)
    np.testing.assert_allclose(box[:3], f.min(axis=0), atol=1e-4)
    np.testing.assert_allclose(box[3:], f.max(axis=0), atol=1e-4)


def test_border_lattice_is_regular_whatever_its_margin():
    """With a margin (every border but ``constant``) the lattice's points are -1/2 + k grid
    on each axis up to its last, whatever the margin: none is clamped to the margin's end
    where ``grid`` does not divide the side."""
    for margin in (5, 10, 20):
        lattice = CornerLattice((11, 13, 14), 5, margin)
        for axis in lattice.axes():
            np.testing.assert_array_equal(np.diff(axis), 5.0)
            assert axis[0] == -margin - 0.5
    sides = CornerLattice((11, 13, 14), 5, ((0, 5), (10, 0), (5, 20)))
    for axis, low in zip(sides.axes(), (0, 10, 5), strict=True):
        np.testing.assert_array_equal(np.diff(axis), 5.0)
        assert axis[0] == -low - 0.5
    constant = CornerLattice((11, 13, 14), 5)
    assert constant.axes()[0][-1] == 13.5  # the volume's last corner, a shorter step


@pytest.mark.parametrize("border", ["edge", "symmetric", "reflect", "wrap"])
def test_border_cells_do_not_depend_on_the_canvas(kernel3, rng, border):
    """The cells of a border mode's extended lattice are those of one regular lattice: a
    canvas that overhangs the volume (so a wider margin) shows the volume's voxels as the
    volume's own canvas does, also where their preimages lie past the far faces and ``grid``
    (5) does not divide the sides (f shrinks the volume about its centre, so the voxels on
    its faces show points past them, and bends it, so that cells matter)."""
    shape = (11, 13, 14)
    volume = rng.uniform(0, 255, shape).astype(np.float32)
    src, _ = box_handles(shape, rng, count=10)
    centre = (np.array(shape[::-1]) - 1) / 2
    dst = centre + 0.75 * (src - centre) + rng.uniform(-1.0, 1.0, src.shape)
    m = kernel3(src, dst, shape, transform="affine")
    options = {"method": "quads", "interpolation": "linear", "border": border, "grid": 5}
    own = warp_volume(m, volume, **options)
    d, h, w = shape
    wide = warp_volume(
        m, volume, output_shape=(d + 8, h + 8, w + 8), origin=(-4.0, -4.0, -4.0), **options
    )
    np.testing.assert_allclose(wide[4 : 4 + d, 4 : 4 + h, 4 : 4 + w], own, atol=2e-3)
