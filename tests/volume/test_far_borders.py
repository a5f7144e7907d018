"""With a border mode other than ``constant``, every output voxel shows the input extended by
the mode's rule (numpy.pad's), sampled at f's inverse: also where f moves the volume off
the canvas (along an axis, or diagonally so that no face of its image lies across the
canvas) or shrinks it to a tenth, with both methods. Where the lattice that would cover the
canvas is larger than allowed, a BorderWarning says so."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from glmls.core.config import MLSConfig
from glmls.errors import BorderWarning
from glmls.volume import VolumeOptions, margins, volume_coordinate_map, warp_volume
from glmls.volume.fields import ReferenceField, newton_inverse
from glmls.volume.frame import CornerLattice, VolumeFrame
from glmls.volume.margins import border_margin3, search_margins3

SHAPE = (6, 6, 6)
CORNERS = np.array([[x, y, z] for z in (0, 5) for y in (0, 5) for x in (0, 5)], float)
CENTRE = np.array([2.5, 2.5, 2.5])
SHEAR_41 = np.array([[0.384, 0.134, -0.004], [0.251, 0.337, 0.554], [0.047, -0.585, 0.321]])
SHEAR_28 = np.array([[0.397, 0.066, -0.116], [-0.262, 1.146, 0.464], [-0.005, -0.59, 1.205]])
MAPS = {
    "shift x 20": CORNERS + [20.0, 0.0, 0.0],
    "shift x -20": CORNERS + [-20.0, 0.0, 0.0],
    "shift diagonal": CORNERS + [9.0, -8.0, 5.0],
    "zoom out 10": (CORNERS - CENTRE) * 0.1 + CENTRE,
    "zoom out 10, shifted": (CORNERS - CENTRE) * 0.1 + CENTRE + [7.0, 0.0, -3.0],
    "squeeze z 8": (CORNERS - CENTRE) * [1.0, 1.0, 0.125] + CENTRE,
    # sheared shrinks (singular values 0.74, 0.67, 0.32; 1.37, 1.25, 0.39): faces far larger
    # than the canvas cross it between their samples, and one side's growth moves another's
    "shear, shrink to a third": CORNERS @ SHEAR_41 + [-3.92, -2.15, 3.56],
    "shear, squeeze": CORNERS @ SHEAR_28 + [-1.38, 2.99, -1.01],
}
BORDERS = ("edge", "wrap", "reflect", "symmetric")


def _reference(volume, dst, border):
    """The volume numpy.pad-extended by ``border``, sampled trilinearly at f's float64
    inverse (glmls.reference, Newton from each voxel) at every voxel of its own canvas."""
    field = ReferenceField(CORNERS, dst, MLSConfig(transform="affine"), shape=SHAPE)
    k, j, i = np.meshgrid(*(np.arange(n) for n in SHAPE), indexing="ij")
    u = np.stack([i, j, k], axis=-1).reshape(-1, 3).astype(np.float64)
    s, residual = newton_inverse(field, u, u, steps=200)
    assert residual.max() < 1e-6
    pad = math.ceil(np.abs(s).max()) + 2
    extended = np.pad(volume.astype(np.float64), pad, mode=border)
    s = s + pad
    base = np.floor(s).astype(np.int64)
    t = s - base
    out = np.zeros(len(s))
    for corner in np.ndindex(2, 2, 2):
        c = np.array(corner)  # (x, y, z)
        weight = np.prod(np.where(c == 1, t, 1 - t), axis=1)
        x, y, z = (base + c).T
        out += weight * extended[z, y, x]
    return out.reshape(SHAPE)


@pytest.mark.parametrize("name", sorted(MAPS))
@pytest.mark.parametrize("method", ["quads", "backward"])
def test_far_maps_show_the_extended_volume(kernel3, name, method):
    volume = np.random.default_rng(0).uniform(1, 100, SHAPE).astype(np.float32)
    m = kernel3(CORNERS, MAPS[name], SHAPE, transform="affine")
    for border in BORDERS:
        options = VolumeOptions(method=method, border=border, interpolation="linear")
        with warnings.catch_warnings():
            warnings.simplefilter("error", BorderWarning)
            out = warp_volume(m, volume, options=options)
        expected = _reference(volume, MAPS[name], border)
        np.testing.assert_allclose(out, expected, atol=0.05, err_msg=border)


def test_the_backward_map_reaches_far_preimages(kernel3):
    """The coordinate map of a shift by 20 voxels: every voxel's preimage, 20 voxels off."""
    m = kernel3(CORNERS, MAPS["shift x 20"], SHAPE, transform="affine")
    points, residual, covered = volume_coordinate_map(m, SHAPE, border="wrap")
    k, j, i = np.meshgrid(*(np.arange(n) for n in SHAPE), indexing="ij")
    expected = np.stack([i - 20.0, j, k], axis=-1)
    assert covered.all() and residual.max() < 0.01
    np.testing.assert_allclose(points, expected, atol=0.01)


def _field(dst, shape=SHAPE, src=CORNERS):
    return ReferenceField(src, dst, MLSConfig(transform="affine"), shape=shape)


def test_the_diagonal_shift_takes_margins_where_its_preimage_lies():
    """No face of the shifted volume lies across its canvas: the margins take in the canvas's
    preimage (x 9 and z 5 voxels before the volume, y 8 past it, a voxel each more)."""
    found, covered = search_margins3(
        _field(MAPS["shift diagonal"]), CornerLattice(SHAPE), VolumeFrame(SHAPE), cover=True
    )
    assert covered
    (x_low, x_high), (y_low, y_high), (z_low, z_high) = found
    assert x_low >= 10 and y_high >= 9 and z_low >= 6
    assert x_high == y_low == z_high == 0


@pytest.mark.parametrize("name", ["shear, shrink to a third", "shear, squeeze"])
def test_a_sheared_shrink_takes_the_margins_its_preimage_needs(name):
    """The canvas's preimage under these affine maps lies within 16 voxels of the volume: the
    margins cover it and stay near that, not at the lattice's budget along some sides."""
    dst = MAPS[name]
    found, covered = search_margins3(
        _field(dst), CornerLattice(SHAPE), VolumeFrame(SHAPE), cover=True
    )
    assert covered
    fit = np.linalg.lstsq(np.c_[CORNERS, np.ones(8)], dst, rcond=None)[0]
    matrix, offset = fit[:3], fit[3]
    k, j, i = np.meshgrid(*(np.arange(n) for n in SHAPE), indexing="ij")
    u = np.stack([i, j, k], axis=-1).reshape(-1, 3)
    preimage = np.linalg.solve(matrix.T, (u - offset).T).T
    reach = np.stack([-0.5 - preimage.min(axis=0), preimage.max(axis=0) - 5.5], axis=1)
    assert np.all(np.array(found) >= np.ceil(reach))
    assert np.array(found).max() <= 2 * np.ceil(reach).max() + 8, found


def test_moderate_maps_keep_their_margins():
    """Where f moves the faces a few voxels, the margins that cover the canvas are those
    of the backward method's guesses with ``constant``: no wider."""
    shape = (10, 12, 14)
    rng = np.random.default_rng(3)
    d, h, w = shape
    src = np.array([[x, y, z] for z in (0, d - 1) for y in (0, h - 1) for x in (0, w - 1)], float)
    for _ in range(5):
        dst = src + rng.uniform(-3, 3, src.shape)
        field = _field(dst, shape, src)
        for grid in (1, 2):
            lattice = CornerLattice(shape, grid)
            for frame in (VolumeFrame(shape), VolumeFrame((d + 3, h, w + 4), (-4.0, 0.0, 0.0))):
                guess = border_margin3(field, lattice, frame)
                assert search_margins3(field, lattice, frame, cover=True) == (guess, True)


@pytest.mark.parametrize("method", ["quads", "backward"])
def test_a_lattice_past_its_budget_warns(kernel3, monkeypatch, method):
    """With a budget of 1,000 lattice points (at grid 1) a shift by 20 voxels cannot be covered: the
    voxels left keep the background, and a BorderWarning names the caller's line."""
    monkeypatch.setattr(margins, "MARGIN_POINTS3", 1000)
    volume = np.random.default_rng(0).uniform(1, 100, SHAPE).astype(np.float32)
    m = kernel3(CORNERS, MAPS["shift x 20"], SHAPE, transform="affine")
    with pytest.warns(BorderWarning, match="does not cover the whole canvas") as caught:
        out = warp_volume(m, volume, method=method, border="edge", grid=1)
    assert caught[0].filename == __file__
    assert np.any(out == 0)
    with warnings.catch_warnings():
        warnings.simplefilter("error", BorderWarning)
        warp_volume(m, volume, method=method, border="constant", grid=1)  # nothing to cover
