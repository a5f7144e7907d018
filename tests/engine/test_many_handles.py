"""65,536 handles with a compact weight (docs/performance.md's many-handles case): the binned
evaluation, with bins sized to the handles' spacing, equals the plain one and the float64
reference."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

import glmls
from glmls import reference
from glmls.core.handles import validate_handles
from glmls.engine.bins import HandleBins

SIZE = 1024
SHAPE = (SIZE, SIZE)


def lattice_handles(rng, side=256, size=SIZE):
    """side x side handles on a lattice over a size^2 image, moved by up to 2 px."""
    axis = (np.arange(side) + 0.5) * size / side - 0.5
    p = np.stack(np.meshgrid(axis, axis), -1).reshape(-1, 2)
    return p, p + rng.uniform(-2, 2, p.shape)


@pytest.fixture(scope="module")
def handles():
    return lattice_handles(np.random.default_rng(7))


@pytest.mark.parametrize("weight", ["cressman", "shepard", "linear"])
def test_many_handles_equal_reference(gl, rng, handles, weight):
    p, q = handles
    # points anywhere, on handles, between them, and past the image
    v = np.concatenate([rng.uniform(-10, SIZE + 10, (400, 2)), p[::4099], p[:20] + 2.0])
    options = {"weight": weight, "radius": 24.0, "shape": SHAPE, "ctx": gl}
    with glmls.MLS(p, q, **options) as binned:
        bins = binned.kernel.bins
        assert bins is not None and binned.storage == "texture"
        # bins of about a handle each, a first nearest search about a spacing wide
        assert 2.0 <= bins.size * binned.scaling.scale <= 6.0
        assert bins.size <= bins.near <= bins.reach
        f_bins = binned(v)
    f_ref, _, _ = reference.mls(p, q, v, shape=SHAPE, weight=weight, radius=24.0)
    assert_allclose(f_bins, f_ref, rtol=0, atol=1e-3)


@pytest.mark.parametrize("weight", ["cressman", "shepard", "linear"])
def test_many_handles_equal_plain(gl, rng, weight):
    """Against the plain loop over every handle, at 16,384 handles: llvmpipe's plain loop
    goes wrong from ~65,000 iterations on (0.3 px at 65,535 handles; the binned pass visits
    ~100 and matches the float64 reference there, see above)."""
    p, q = lattice_handles(np.random.default_rng(3), side=128)
    v = np.concatenate([rng.uniform(-10, SIZE + 10, (400, 2)), p[::997], p[:20] + 2.0])
    options = {"weight": weight, "radius": 24.0, "shape": SHAPE, "ctx": gl}
    with glmls.MLS(p, q, **options) as binned:
        assert binned.kernel.bins is not None
        f_bins = binned(v)
    with glmls.MLS(p, q, bins=False, **options) as plain:
        f_plain = plain(v)
    assert_allclose(f_bins, f_plain, rtol=0, atol=1e-3)


def test_many_handles_mesh_equals_points(gl, handles):
    """The lattice pass (what warp evaluates) gives the points pass's f."""
    p, q = handles
    with glmls.MLS(p, q, weight="cressman", radius=24.0, shape=(256, 256), ctx=gl) as m:
        vertices, deformed = m.mesh((256, 256), grid=4)
        f = m(vertices.reshape(-1, 2))
    assert_allclose(deformed.reshape(-1, 2), f, rtol=0, atol=1e-4)


def test_bin_side_follows_spacing(rng):
    """Dense handles: bins about a spacing wide, within [R / 10, R / 2]."""
    p = rng.uniform(0, 1, (10_000, 2))  # spacing 0.01
    bins = HandleBins.build(p, 0.5, 0.5)
    assert bins.size == pytest.approx(0.05)  # R / 10: never smaller
    bins = HandleBins.build(p, 0.05, 0.05)
    assert bins.size == pytest.approx(0.01, rel=0.05)
    bins = HandleBins.build(p[:20], 0.05, 0.05)
    assert bins.size == pytest.approx(0.025)  # R / 2: never larger


def test_duplicate_check_reports_first_pair():
    """The tie check of validate_handles (one lexsort where some x repeat) reports the pair
    that meets first in (x, y) order, equal points in index order."""
    p = np.array([[1.0, 2.0], [1.0, 3.0], [1.0, 2.0], [0.0, 0.0], [1.0, 2.0]])
    q = p.copy()
    q[4] += 1
    with pytest.raises(ValueError, match=r"src\[2\] and src\[4\]"):
        validate_handles(p, q)
