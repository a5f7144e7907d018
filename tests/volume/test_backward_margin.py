"""The backward method's first guesses with the ``constant`` border come from a lattice with a
margin past the volume, so that the voxels where f moves the volume's faces inward (no cell
of the volume covers them) start Newton from a guess, not from themselves; the margin's
cells rank after the volume's, so that they never choose which of a voxel's preimages
Newton finds where the volume folds over its own face."""

from __future__ import annotations

import numpy as np
import pytest

import glmls
from glmls import reference
from glmls.core.config import MLSConfig
from glmls.gl import dispatch
from glmls.volume import volume_coordinate_map
from glmls.volume.frame import CornerLattice

SHAPE = (12, 12, 16)


def test_the_volume_cells_are_those_past_the_margin():
    lattice = CornerLattice((11, 13, 14), 5, 10, box_first=True)
    # 10 voxels of margin = 2 cells of 5; the volume's 14 x 13 x 11 voxels take 3 cells a side
    assert lattice.box_cells == ((2, 2, 2), (5, 5, 5))
    assert lattice.key_count == 2 * lattice.cell_count
    assert CornerLattice((11, 13, 14), 5, 10).key_count == lattice.cell_count
    assert lattice.uniforms()["u_lattice_box_first"] is True


def _listed(monkeypatch) -> list[int]:
    """The voxels each second pass of Newton is given, as the first pass counted them."""
    counts: list[int] = []
    finish = dispatch.SecondPass.finish

    def counting(self, program):
        header = np.frombuffer(self._buffer().read(size=16), np.uint32)
        counts.append(int(header[3]))
        finish(self, program)

    monkeypatch.setattr(dispatch.SecondPass, "finish", counting)
    return counts


@pytest.mark.parametrize("grid", [1, 2])
def test_voxels_past_a_shrunk_volume_start_from_a_guess(gl, monkeypatch, grid):
    """f shrinks the volume by 1.5 voxels a side: the output's outer shell (two thirds of its
    voxels) has preimages outside the volume. Each starts from the margin's guess and most
    end in the first pass, as the voxels inside do (from themselves, every one of them took
    the second pass)."""
    d, h, w = SHAPE
    corners = np.array(
        [[x, y, z] for z in (0, d - 1) for y in (0, h - 1) for x in (0, w - 1)], np.float64
    )
    centre = corners.mean(axis=0)
    dst = centre + (corners - centre) * (1 - 3 / np.array([w - 1, h - 1, d - 1]))
    counts = _listed(monkeypatch)
    with glmls.MLS(corners, dst, transform="affine", shape=SHAPE) as m:
        points, residual, covered = volume_coordinate_map(m, SHAPE, grid=grid)
        assert gl.mgl.error == "GL_NO_ERROR"
    voxels = d * h * w
    assert 0.6 * voxels < (~covered).sum() < 0.75 * voxels
    assert sum(counts) < 0.05 * voxels, counts
    # the preimages, inside and outside: f's inverse is the affine map's own
    k, j, i = np.meshgrid(*(np.arange(n) for n in SHAPE), indexing="ij")
    u = np.stack([i, j, k], axis=-1).astype(np.float64)
    scale = (1 - 3 / np.array([w - 1, h - 1, d - 1])).astype(np.float64)
    np.testing.assert_allclose(points, centre + (u - centre) / scale, atol=2e-3)
    assert residual.max() < 1e-3


def test_a_fold_over_the_volume_face_keeps_the_volume_preimage(gl):
    """A handle 6 voxels before the volume's x = 0 face pulled 7 voxels into it: the line
    y = z = 5 folds, and its voxels x = 3 .. 7 have one preimage outside the volume (and a
    third on the fold's far side) and one inside, near themselves. The margin's cells cover
    them too, before the volume's cells in scan order: the volume's are still first, and
    Newton finds the preimage inside."""
    d, h, w = SHAPE
    zs, ys, xs = np.meshgrid([0, d - 1], [0, h - 1], [6, w - 1], indexing="ij")
    far = np.stack([xs.ravel(), ys.ravel(), zs.ravel()], 1).astype(np.float64)
    src = np.concatenate([far, [[-6.0, 5.0, 5.0], [3.0, 5.0, 5.0]]])
    dst = src.copy()
    dst[-2] = [7.0, 5.0, 5.0]
    config = MLSConfig(transform="rigid", weight="idw")
    # the fold, in float64: along the line f(x) - x changes sign three times for x = 3..7
    x = np.linspace(-12.0, 16.0, 2801)
    line = np.stack([x, np.full_like(x, 5.0), np.full_like(x, 5.0)], 1)
    fx = reference.mls(src, dst, line, config)[0][:, 0]
    for u in range(3, 8):
        roots = x[np.flatnonzero(np.diff(np.sign(fx - u)))]
        assert (roots < -0.5).sum() >= 1 and ((roots > 2) & (roots < 8)).sum() == 1, roots
    with glmls.MLS(src, dst, transform="rigid", weight="idw", shape=SHAPE) as m:
        for grid in (1, 2):
            points, residual, covered = volume_coordinate_map(m, SHAPE, grid=grid)
            found = points[5, 5, 3:8]
            assert residual[5, 5, 3:8].max() < 1e-3
            assert covered[5, 5, 3:8].all(), (grid, found)
            assert np.all(found[:, 0] > 2) and np.all(found[:, 0] < 8), (grid, found)
            f = reference.mls(src, dst, found.astype(np.float64), config)[0]
            u = np.stack([np.arange(3, 8), np.full(5, 5), np.full(5, 5)], 1)
            np.testing.assert_allclose(f, u, atol=2e-3)
        assert gl.mgl.error == "GL_NO_ERROR"
