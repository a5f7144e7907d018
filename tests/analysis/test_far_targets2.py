"""The 2D analyses of a GPU MLS whose targets lie far from its sources (every q = p + t,
t ~ 1e5 px) give those of the map near its sources: MLS moves with its targets (f + t
exactly), the folds and the triangles' errors do not change with a translation, and the error
field takes its fits' misses of the far handles. The analyses judge flatness by f less the
kernel's whole-pixel offset (the float32 rounding of the near map) for every weight of
unbounded reach. Against the float64 reference (which rounds
at 1e-16 of 1e5, far below these tolerances).

Tolerances: folded cells equal to the near map's, and to the float64 reference's at the
cells (over 99%) whose signed areas are clear of 0 by 1e-3 px² (a hundred times the near
map's GPU error); the error field within 1e-5 of its largest value (the near
map's: ~1e-7); the triangles' flipped flags equal, their angles within 1e-3 degrees and
their distance errors within 1e-5."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import reference_mesh

import glmls
from glmls.analysis import error_field, foldovers, triangle_errors
from glmls.analysis.field import target_offset
from glmls.analysis.folding import folded_cells

FAR = np.array([1e5, -7e4])
SHAPE = (64, 64)


def _handles() -> tuple[np.ndarray, np.ndarray]:
    """Handles in the image, two of them swapped across it: some cells fold."""
    rng = np.random.default_rng(0)
    src = rng.uniform(4, 60, (12, 2))
    dst = src + rng.normal(0, 4, src.shape)
    dst[0], dst[1] = src[1], src[0]
    return src, dst


def _areas(f: np.ndarray) -> np.ndarray:
    """The signed areas of both triangles of every cell of mesh ``f``, (2, rows, cols)."""

    def cross(o: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        a, b = x - o, y - o
        return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]

    a, b, c, d = f[:-1, :-1], f[:-1, 1:], f[1:, 1:], f[1:, :-1]
    return np.stack([cross(a, b, c), cross(a, c, d)])


def test_far_targets_fold_as_near_ones(gl):
    src, dst = _handles()
    masks = []
    for t in (np.zeros(2), FAR):
        with glmls.MLS(src, dst + t, ctx=gl) as m:
            reference = reference_mesh(m, SHAPE)
            masks.append(foldovers(m, SHAPE, grid=1).mask)
    expected = folded_cells(reference - FAR, rounding=float(np.finfo(np.float64).eps))
    assert 0 < expected.sum() < expected.size
    clear = np.abs(_areas(reference - FAR)).min(axis=0) > 1e-3  # off the edge of folding
    assert clear.mean() > 0.99
    near, far = masks  # grid 1: one pixel per cell
    assert (near == far).all()
    assert (far == expected)[clear].all()


def test_far_targets_error_field(gl):
    src, dst = _handles()
    with glmls.MLS(src, dst + FAR, ctx=gl) as m:
        for grid in (1, 4):
            field = error_field(m, SHAPE, grid=grid)
            with glmls.MLS(src, dst, ctx=gl) as near:
                expected = error_field(near, SHAPE, grid=grid)
            assert np.abs(field - expected).max() <= 1e-5 * expected.max()


def test_far_targets_triangles(gl):
    src, dst = _handles()
    points = np.random.default_rng(4).uniform(0, 63, (80, 2))
    results = []
    for t in (np.zeros(2), FAR):
        with glmls.MLS(src, dst + t, ctx=gl) as m:
            results.append(triangle_errors(m, points))
    near, far = results
    assert (near.simplices == far.simplices).all()
    assert near.flipped.any() and (near.flipped == far.flipped).all()
    assert np.abs(near.angle - far.angle).max() <= 1e-3
    assert np.abs(near.distance - far.distance).max() <= 1e-5


@pytest.mark.parametrize(
    ("weight", "settings"), [("idw", {"alpha": 2.0}), ("gaussian", {"radius": 40.0})]
)
def test_far_targets_keep_the_near_maps_precision_for_every_unbounded_weight(gl, weight, settings):
    """The analyses judge flatness by f - t, f's float32 rounding near its sources, for every
    weight whose kernel moves the targets back (a gaussian's too): judged at |f| ~ 1e5 that
    rounding would call cells and triangles of sound area flat. Against the near map and the
    float64 reference of the far one."""
    src, dst = _handles()
    points = np.random.default_rng(4).uniform(0, 63, (80, 2))
    options = {"weight": weight, **settings}
    masks, triangles, fields = [], [], []
    for t in (np.zeros(2), FAR):
        with glmls.MLS(src, dst + t, ctx=gl, **options) as m:
            assert (target_offset(m) == m.kernel.offset).all()
            reference = reference_mesh(m, SHAPE)
            masks.append(foldovers(m, SHAPE).mask)
            triangles.append(triangle_errors(m, points))
            fields.append(error_field(m, SHAPE, grid=4))
    expected = folded_cells(reference - FAR, rounding=float(np.finfo(np.float64).eps))
    clear = np.abs(_areas(reference - FAR)).min(axis=0) > 1e-3
    assert clear.mean() > 0.99
    assert (masks[0] == masks[1]).all() and (masks[1] == expected)[clear].all()
    near, far = triangles
    assert (near.flipped == far.flipped).all()
    assert np.abs(near.distance - far.distance).max() <= 1e-5
    assert np.abs(near.angle - far.angle).max() <= 1e-3
    assert np.abs(fields[1] - fields[0]).max() <= 1e-5 * fields[0].max()


def test_the_offset_is_the_kernels_where_it_moves_the_targets(gl):
    """Ordinary maps (targets near their sources), weights of bounded reach (the identity
    beyond the handles, not v + t) and plain functions are analysed as they are (t = 0)."""
    src, dst = _handles()
    with glmls.MLS(src, dst, ctx=gl) as m:
        assert not target_offset(m).any()
    with glmls.MLS(src, dst + FAR, weight="cressman", radius=30.0, ctx=gl) as m:
        assert not target_offset(m).any()
    with glmls.MLS(src, dst + FAR, ctx=gl) as m:
        t = target_offset(m)
        # whole pixels, the difference of the boxes' centres; a copy of the kernel's
        assert (t == np.round(t)).all() and np.abs(t - FAR).max() <= 8
        t[:] = 0.0
        assert (m.kernel.offset == target_offset(m)).all() and target_offset(m).any()

    def shifted(points):
        return points + FAR

    assert not target_offset(shifted).any()
