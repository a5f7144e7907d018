"""Any similarity of 3D space, a reflection included, against the tetrahedra's measures:
every face angle kept (0 degrees of change), every edge scaled by s (distance |s - 1|),
and the orientation reversed exactly where the map reflects."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from glmls.analysis import tetrahedron_errors


def orthogonal(rng: np.random.Generator, reflect: bool) -> np.ndarray:
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    q *= np.sign(np.linalg.det(q))  # a rotation
    return q @ np.diag([1.0, 1.0, -1.0]) if reflect else q


@pytest.mark.parametrize("reflect", [False, True])
@pytest.mark.parametrize("seed", range(4))
def test_a_random_similarity_keeps_the_angles_and_scales_the_edges(seed, reflect):
    rng = np.random.default_rng(seed)
    points = rng.uniform(-30, 80, (30, 3))
    turn, scale, shift = orthogonal(rng, reflect), rng.uniform(0.2, 5.0), rng.normal(0, 100, 3)
    found = tetrahedron_errors(lambda r: scale * r @ turn + shift, points)
    assert len(found.simplices) > 0
    # float64 rounding of atan2 and of the edges: far below any real change
    assert found.angle.max() < 1e-9
    assert_allclose(found.distance, abs(scale - 1), rtol=0, atol=1e-12)
    assert found.inverted.all() if reflect else not found.inverted.any()
    stats = found.stats()
    assert stats["inverted"] == (len(found.simplices) if reflect else 0)
