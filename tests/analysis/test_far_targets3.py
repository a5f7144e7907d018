"""The 3D analyses of a GPU MLS whose targets lie far from its sources (every q = p + t,
t ~ 1e5 voxels) give those of the map near its sources: MLS moves with its targets (f + t
exactly), det J and the folds do not change with a translation, and the error field takes
its fits' misses of the far handles. Against the float64 reference (which rounds at 1e-16
of 1e5, far below these tolerances).

Tolerances: det J and the Kuhn tetrahedra's least det J within 1e-3 of the reference's
(the near map's GPU is within ~1e-6); folds equal to the near map's and the reference's,
on a map whose every cell's det J and least det J are clear of 0 by 1e-3 (a thousand
times the near map's GPU error); the error field
within 1e-5 of its largest value (the near map's: ~2e-7); the tetrahedra's inverted flags
equal and their angles within 1e-3 degrees."""

from __future__ import annotations

import numpy as np

import glmls
from glmls.analysis import (
    ReferenceDeformation,
    cell_jacobians,
    tetrahedron_errors,
    volume_error_field,
)

FAR = np.array([1e5, -7e4, 3e4])
SHAPE = (12, 12, 12)


def _handles() -> tuple[np.ndarray, np.ndarray]:
    """Handles in the volume, two of them swapped across it: some cells fold."""
    rng = np.random.default_rng(0)
    src = rng.uniform(1, 11, (10, 3))
    dst = src + rng.normal(0, 1.0, src.shape)
    dst[0], dst[1] = src[1], src[0]
    return src, dst


def test_far_targets_fold_as_near_ones(gl):
    src, dst = _handles()
    reference = cell_jacobians(ReferenceDeformation(src, dst, shape=SHAPE), SHAPE)
    clear = (np.abs(reference.det) > 1e-3) & (np.abs(reference.min_det) > 1e-3)
    assert clear.all() and 0 < reference.count < reference.det.size  # no cell on the edge
    counts = []
    for t in (np.zeros(3), FAR):
        with glmls.MLS(src, dst + t, shape=SHAPE) as m:
            cells = cell_jacobians(m, SHAPE)
        assert np.abs(cells.det - reference.det).max() <= 1e-3
        assert np.abs(cells.min_det - reference.min_det).max() <= 1e-3
        assert (cells.folded == reference.folded).all()
        counts.append(cells.count)
    assert counts[0] == counts[1] == reference.count
    far_reference = cell_jacobians(ReferenceDeformation(src, dst + FAR, shape=SHAPE), SHAPE)
    assert (far_reference.folded == reference.folded).all()


def test_far_targets_error_field(gl):
    src, dst = _handles()
    expected = volume_error_field(ReferenceDeformation(src, dst + FAR, shape=SHAPE), SHAPE)
    near = volume_error_field(ReferenceDeformation(src, dst, shape=SHAPE), SHAPE)
    assert np.abs(expected - near).max() <= 1e-9 * near.max()
    with glmls.MLS(src, dst + FAR, shape=SHAPE) as m:
        field = volume_error_field(m, SHAPE, grid=2)
    expected = volume_error_field(ReferenceDeformation(src, dst + FAR, shape=SHAPE), SHAPE, grid=2)
    assert np.abs(field - expected).max() <= 1e-5 * expected.max()


def test_far_targets_tetrahedra(gl):
    src, dst = _handles()
    points = np.random.default_rng(4).uniform(0, 11, (60, 3))
    results = []
    for t in (np.zeros(3), FAR):
        with glmls.MLS(src, dst + t, shape=SHAPE) as m:
            results.append(tetrahedron_errors(m, points))
    near, far = results
    assert (near.simplices == far.simplices).all()
    assert (near.inverted == far.inverted).all()
    assert np.abs(near.angle - far.angle).max() <= 1e-3
