"""The backward method under a thousandfold magnification: a float32 step of a source voxel
moves f(s) by more than the 0.05 voxel accepted elsewhere, so the residual accepted grows
with f's stretch at s, measured on the side of s where f has no jump. Every voxel is found,
each source point within float32's reach of the float64 preimage; the disc a compact
weight's reach leaves uncovered keeps the background."""

from __future__ import annotations

import numpy as np
import pytest

import glmls
from glmls import reference

FRAME = {"output_shape": (12, 14, 16), "origin": (0.0, 0.0, 0.0)}


@pytest.mark.parametrize(
    ("noise", "transform"), [(0.0, "affine"), (300.0, "affine"), (0.0, "similarity")]
)
def test_a_thousandfold_magnification_keeps_every_voxel(gl, noise, transform):
    """Targets a thousand times as far apart as the sources (and moved at random by
    ``noise``), maps that do not fold on the canvas: the backward method draws every voxel,
    as ``quads`` does."""
    rng = np.random.default_rng(1)
    n = 24
    src = rng.uniform(0, n - 1, (10, 3))
    center = np.full(3, (n - 1) / 2)
    dst = (src - center) * 1000 + center + rng.normal(0, 1, (10, 3)) * noise
    z, y, x = np.mgrid[:n, :n, :n]
    volume = ((x // 4 + y // 4 + z // 4) % 2 * 200 + 20).astype(np.uint8)
    with glmls.MLS(src, dst, transform=transform, ctx=gl) as m:
        backward = m.warp(volume, method="backward", background=7, **FRAME)
        quads = m.warp(volume, method="quads", background=7, **FRAME)
        points, _, covered = m.coordinate_map(volume.shape, **FRAME)
    assert (backward != 7).all() and covered.all()
    assert (backward == quads).mean() > 0.99  # quads: the cells', not f's, at their faces
    s = points.reshape(-1, 3).astype(np.float64)
    u = np.indices(FRAME["output_shape"])[::-1].reshape(3, -1).T.astype(np.float64)
    f = reference.mls(src, dst, s, m.config)[0]
    # |f(s) - u| in float64 over f's stretch (~1,000): the error of s, source voxels
    assert (np.linalg.norm(f - u, axis=1) / 1000).max() < 5e-3


def test_the_reach_of_a_compact_weight_widens_nothing(gl):
    """One handle moved 300 voxels with a compact weight: f jumps where its reach ends, and
    the ball it leaves behind has no preimage; differences across the jump are no stretch
    of f, and those voxels keep the background."""
    src = np.array([[40.0, 40.0, 40.0]])
    volume = np.full((80, 80, 80), 200, np.uint8)
    origin = (40.0 - 10, 40.0 - 10, 40.0 - 10)
    frame = {"output_shape": (21, 21, 21), "origin": origin}
    with glmls.MLS(src, src + [300, 0, 0], weight="cressman", radius=12.0, ctx=gl) as m:
        out = m.warp(volume, method="backward", background=0, **frame)
    u = np.stack(np.meshgrid(*(np.arange(21) + o for o in origin), indexing="ij")[::-1], -1)
    inside = np.linalg.norm(u - src[0], axis=-1) < 12 - 1.5
    assert inside.sum() > 3000
    assert (out[inside] == 0).all()


def _sliver(gap: float = 0.01):
    """Two cressman balls of radius 1000 whose surfaces lie ``gap`` voxels apart at about
    x = 1000.3, their handles moved apart by 1000 voxels each along x: src, dst, options."""
    a = np.array([0.3, 8.0, 8.0])
    src = np.array([a, a + [2000.0 + gap, 0.0, 0.0]])
    return src, src + [[-1000.0, 0, 0], [1000.0, 0, 0]], {"weight": "cressman", "radius": 1000.0}


def test_no_voxel_is_drawn_in_a_sliver_between_two_reaches(gl):
    """A source point in the gap has a jump of f on both sides, within any difference step:
    the stretch taken there must not be the jump's. Every voxel of the frame lies in a ball
    whose content moved away: none has a preimage, all keep the background."""
    src, dst, options = _sliver()
    frame = {"output_shape": (16, 16, 16), "origin": (992.0, 0.0, 0.0)}
    with glmls.MLS(src, dst, ctx=gl, **options) as m:
        out = m.warp(np.full((16, 16, 16), 255, np.uint8), method="backward", background=0,
                     border="edge", **frame)  # fmt: skip
    assert (out == 0).all()


def test_no_point_is_taken_in_a_sliver_between_two_reaches(gl):
    src, dst, options = _sliver()
    rng = np.random.default_rng(0)
    u = np.c_[1000.3 + rng.uniform(-5, 5, 300), rng.uniform(6, 10, (300, 2))]
    with glmls.MLS(src, dst, ctx=gl, **options) as m:
        s, valid = m.inverse(u, return_valid=True)
    f = reference.mls(src, dst, s[valid], **options)[0]
    assert np.linalg.norm(f - u[valid], axis=1).max(initial=0.0) < 0.05 + 2e-3
