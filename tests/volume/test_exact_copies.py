"""Warps that copy voxels copy them bit for bit, at every lattice step: the identity and whole-
voxel translations, float32 volumes sampled trilinearly included (where the lattice's last
cell is cut short by the volume's side, its barycentric coordinates round in float32), and
their NaN and infinite voxels stay where they are (their neighbours' weight 0 for them)."""

from __future__ import annotations

import numpy as np
import pytest

import glmls

SHAPE = (7, 9, 11)  # no side a multiple of the lattice steps below


@pytest.fixture
def volume(rng):
    out = rng.normal(0, 100, (*SHAPE, 2)).astype(np.float32)
    out[3, 4, 5, 0], out[1, 1, 1, 1], out[5, 7, 2, 0] = np.nan, np.inf, -np.inf
    return out


@pytest.mark.parametrize("grid", [2, 4, 5, 16])
@pytest.mark.parametrize("method", ["quads", "backward"])
@pytest.mark.parametrize("shift", [(0, 0, 0), (2, -1, 3)])
@pytest.mark.parametrize("interpolation", ["nearest", "linear"])
def test_copies_are_exact_at_every_grid(gl, rng, volume, grid, method, shift, interpolation):
    src = rng.uniform(0, 10, (8, 3))
    with glmls.MLS(src, src + shift, transform="rigid", shape=SHAPE) as m:
        for border in glmls.BORDERS:
            out = m.warp(
                volume, method=method, interpolation=interpolation, grid=grid, border=border
            )
            pad = 8
            padded = np.pad(volume, [(pad, pad)] * 3 + [(0, 0)], mode=border)
            dx, dy, dz = shift
            d, h, w = SHAPE
            expected = padded[
                pad - dz : pad - dz + d, pad - dy : pad - dy + h, pad - dx : pad - dx + w
            ]
            np.testing.assert_array_equal(out, expected, err_msg=border, strict=True)


def test_a_bad_grid_of_a_volume_warp_is_in_voxels():
    with pytest.raises(ValueError, match=r"grid must be an integer from 1 to \d+ \(voxels\)"):
        glmls.volume.VolumeOptions(grid=0)


def test_a_glmls_volume_is_named_with_its_data(gl, rng, tmp_path):
    """glmls.read_volume gives a glmls.Volume: a warp given one says to give its .data (and
    its spacing to the MLS), not 'dtype object'."""
    glmls.write_volume(tmp_path / "v.npy", rng.integers(0, 9, SHAPE, dtype=np.uint8))
    volume = glmls.read_volume(tmp_path / "v.npy")
    src = rng.uniform(0, 10, (5, 3))
    with glmls.MLS(src, src + 1) as m:
        with pytest.raises(TypeError, match=r"glmls\.Volume.*\.data"):
            m.warp(volume)
        assert m.warp(volume.data).shape == SHAPE
    with pytest.raises(TypeError, match=r"glmls\.Volume.*\.data"):
        glmls.warp(volume, src, src + 1)
