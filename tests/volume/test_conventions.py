"""The 3D conventions against the tools users bring data from: voxel centres at integer
coordinates (a translation by whole voxels is scipy.ndimage.shift of the array), points
(x, y, z) on a (z, y, x) array, a NIfTI written by nibabel moved in its world, and a Fiji
stack moved by BigWarp landmarks in its physical units."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.ndimage as ndi
import tifffile
from numpy.testing import assert_array_equal

import glmls
from glmls.cli.main import main
from glmls.files import volume_to_world, world_to_volume

SHAPE = (6, 7, 8)  # D, H, W


def _volume() -> np.ndarray:
    return np.random.default_rng(0).integers(1, 250, SHAPE).astype(np.float32)


def _corners(shape=SHAPE, scale=(1.0, 1.0, 1.0)) -> np.ndarray:
    d, h, w = shape
    box = [[x, y, z] for x in (0, w - 1) for y in (0, h - 1) for z in (0, d - 1)]
    return np.array(box, dtype=np.float64) * scale


@pytest.mark.parametrize("method", ["quads", "backward"])
@pytest.mark.parametrize("step", [(1, 0, 0), (0, 1, 0), (0, 0, 1), (-2, 1, 0)])
def test_a_whole_voxel_translation_is_ndimage_shift(gl, method, step):
    """(x, y, z) = (column, row, slice): a move by (1, 0, 0) shifts the columns, as
    ndimage.shift of the (z, y, x) array by (0, 0, 1); the first voxel's centre is 0."""
    volume = _volume()
    src = _corners()
    out = glmls.warp(volume, src, src + step, transform="affine", method=method)
    assert_array_equal(out, ndi.shift(volume, step[::-1], order=0, mode="constant", cval=0))


def test_a_half_voxel_translation_is_linear_interpolation(gl):
    """Trilinear sampling halfway between two voxel centres: their mean, as ndimage's."""
    volume = _volume()
    src = _corners()
    out = glmls.warp(
        volume,
        src,
        src + [0.5, 0, 0],
        transform="affine",
        method="backward",
        interpolation="linear",
    )
    expected = ndi.shift(volume, (0, 0, 0.5), order=1, mode="constant", cval=0)
    assert np.abs(out[:, :, 1:] - expected[:, :, 1:]).max() < 1e-3


@pytest.mark.parametrize("flip", [1.0, -1.0])
def test_a_nibabel_volume_moves_in_its_world(gl, tmp_path, flip):
    """A NIfTI written by nibabel from an (i, j, k) array: 2 mm along the world's x is one
    voxel (dx = 2) along i, the other way where the affine flips x (LAS)."""
    nib = pytest.importorskip("nibabel")
    array = np.random.default_rng(1).integers(1, 250, SHAPE[::-1]).astype(np.float32)
    affine = np.diag([2.0 * flip, 1.0, 3.0, 1.0])
    affine[:3, 3] = [-5.0, 10.0, 20.0]
    nib.save(nib.Nifti1Image(array, affine), tmp_path / "scan.nii.gz")
    scan = glmls.read_volume(tmp_path / "scan.nii.gz")
    assert_array_equal(scan.data, array.transpose(2, 1, 0))
    world = volume_to_world(_corners(scale=(2.0, 1.0, 3.0)), scan.affine)
    src = world_to_volume(world, scan.affine)
    dst = world_to_volume(world + [2.0, 0.0, 0.0], scan.affine)
    out = glmls.warp(scan.data, src, dst, transform="affine", spacing=scan.spacing)
    expected = ndi.shift(array, (flip, 0, 0), order=0, mode="constant", cval=0)
    assert_array_equal(out.transpose(2, 1, 0), expected)
    glmls.write_volume(tmp_path / "out.nii.gz", glmls.Volume(out, affine=scan.affine))
    back = nib.load(tmp_path / "out.nii.gz")
    np.testing.assert_allclose(back.affine, affine)
    assert_array_equal(back.get_fdata(), expected)


def test_a_fiji_stack_moves_by_bigwarp_landmarks_in_microns(gl, tmp_path, monkeypatch):
    """A stack of 0.5 x 0.5 x 1 um voxels as Fiji saves it (no spacing= line: the depth is
    1), landmarks as BigWarp saves them (quoted, in microns, an unpaired one inactive): a
    move of 0.5 um along x is one column."""
    monkeypatch.chdir(tmp_path)
    volume = _volume().astype(np.uint16)
    tifffile.imwrite(
        "stack.tif",
        volume,
        imagej=True,
        resolution=(2.0, 2.0),
        metadata={"axes": "ZYX", "unit": "micron"},
    )
    moving = _corners(scale=(0.5, 0.5, 1.0))
    rows = [
        ",".join(f'"{v}"' for v in (f"Pt-{n}", "true", *p, *(p + [0.5, 0.0, 0.0])))
        for n, p in enumerate(moving)
    ]
    rows.append('"Pt-x","false","1.0","1.0","1.0","Infinity","Infinity","Infinity"')
    (tmp_path / "landmarks.csv").write_text("\n".join(rows) + "\n")
    argv = ["warp", "stack.tif", "out.tif", "--handles", "landmarks.csv", "--quiet"]
    assert main([*argv, "--transform", "affine"]) == 0
    out = glmls.read_volume(tmp_path / "out.tif")
    assert out.spacing == (1.0, 0.5, 0.5)
    assert_array_equal(out.data, ndi.shift(volume, (0, 0, 1), order=0, mode="constant"))


def test_a_canvas_origin_is_a_shift_of_the_affine(gl):
    """Output voxel (k, j, i) shows the point origin + (i dx, j dy, k dz): written with the
    affine times the shift by origin / (dx, dy, dz) voxels, it keeps its world place."""
    volume = _volume()
    spacing = (3.0, 1.0, 2.0)  # dz, dy, dx
    steps = np.array(spacing[::-1])
    affine = np.diag([*steps, 1.0])
    affine[:3, 3] = [-5.0, 10.0, 20.0]
    src = _corners(scale=steps)
    origin = np.array([2.0, 1.0, 0.0]) * steps  # (x0, y0, z0): voxel (2, 1, 0)
    out = glmls.warp(
        volume,
        src,
        src,
        transform="affine",
        spacing=spacing,
        output_shape=(6, 6, 6),
        origin=tuple(origin),
    )
    assert_array_equal(out[:, :6, :6], volume[:, 1:7, 2:8])
    shift = np.eye(4)
    shift[:3, 3] = origin / steps
    world_out = (affine @ shift) @ [0.0, 0.0, 0.0, 1.0]
    world_in = affine @ [2.0, 1.0, 0.0, 1.0]
    np.testing.assert_allclose(world_out, world_in)


@pytest.mark.parametrize("method", ["quads", "backward"])
def test_two_canvases_show_the_same_voxels_where_they_overlap(gl, method):
    """A canvas over part of another shows its voxels: bit for bit with nearest sampling,
    with linear sampling to float32's rounding of the source points (a level of a 16-bit
    volume), as in 2D."""
    rng = np.random.default_rng(5)
    volume = rng.integers(0, 60000, (12, 14, 16), dtype=np.uint16)
    src = rng.uniform(0, 12, (7, 3))
    dst = src + rng.normal(0.0, 1.0, (7, 3))
    with glmls.MLS(src, dst) as m:
        for interpolation, tolerance in (("nearest", 0), ("linear", 1)):
            options = {"method": method, "interpolation": interpolation, "border": "edge"}
            whole = m.warp(volume, output_shape=(16, 18, 20), origin=(-2, -2, -2), **options)
            part = m.warp(volume, output_shape=(6, 7, 8), origin=(3, 1, 2), **options)
            gap = np.abs(whole[4:10, 3:10, 5:13].astype(np.int64) - part)
            assert gap.max() <= tolerance, (interpolation, gap.max())
