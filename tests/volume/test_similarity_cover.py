"""Similarity maps, where the preimage of every output voxel is known exactly: both methods
cover every voxel whose preimage lies in the volume's closed box [-1/2, n - 1/2] (voxel
centres on the deformed lattice's faces, as a scale by 2 puts them, and preimages on the
volume's own faces, as a quarter turn or a scale by 1/2 puts them, included), with the
trilinear value there."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.ndimage import map_coordinates
from scipy.spatial.transform import Rotation

import glmls

SHAPE = (9, 10, 11)
CENTRE = np.array([5.0, 4.5, 4.0])
MAPS = {
    "scale 2": np.eye(3) * 2.0,
    "scale 1/2": np.eye(3) * 0.5,
    "quarter turn": Rotation.from_euler("z", 90, degrees=True).as_matrix(),
    "turn and scale": Rotation.from_euler("xyz", [10, 20, 37], degrees=True).as_matrix() * 1.3,
}


@pytest.mark.parametrize("name", list(MAPS))
@pytest.mark.parametrize("method", ["quads", "backward"])
@pytest.mark.parametrize("grid", [1, 3])
def test_similarities_cover_every_voxel_of_the_volume(gl, rng, name, method, grid):
    matrix = MAPS[name]
    volume = (rng.normal(0, 1, SHAPE) + 10).astype(np.float32)  # no voxel is 0
    src = rng.uniform(0, 10, (8, 3))
    dst = (src - CENTRE) @ matrix + CENTRE
    u = np.indices(SHAPE)[::-1].reshape(3, -1).T.astype(np.float64)
    s = (u - CENTRE) @ np.linalg.inv(matrix) + CENTRE
    top = np.array(SHAPE[::-1]) - 0.5
    inside = np.all((s >= -0.5 - 1e-9) & (s <= top + 1e-9), axis=1).reshape(SHAPE)
    expected = map_coordinates(volume.astype(np.float64), s[:, ::-1].T, order=1, mode="nearest")
    with glmls.MLS(src, dst, transform="similarity", shape=SHAPE) as m:
        out = m.warp(volume, method=method, interpolation="linear", grid=grid)
    missed = np.argwhere(inside & (out == 0))
    assert len(missed) == 0, f"{len(missed)} voxels of the volume uncovered: {missed[:4].tolist()}"
    np.testing.assert_allclose(out[inside], expected.reshape(SHAPE)[inside], atol=1e-4)
