"""One upload path: handles reach the GPU only through MLSKernel.upload, so replacing them
(set_handles) gives exactly what a freshly built MLS gives: storage chosen for the count,
spatial bins rebuilt for the radius in use, the swapped-handles map built the same way."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

import glmls
from glmls.core.weights import RADIUS_WEIGHTS
from glmls.engine.storage import UBOHandleStorage

#: Two handles that fix the box around all handles, so that two handle sets share a scaling.
CORNERS = np.array([[-40.0, -40.0], [560.0, 560.0]])


def handle_set(rng, n, *, displacement=4.0):
    p = rng.uniform(1, 511, (n, 2))
    q = p + rng.uniform(-displacement, displacement, p.shape)
    return np.concatenate([CORNERS, p]), np.concatenate([CORNERS, q])


def fresh(p, q, v, **options):
    with glmls.MLS(p, q, **options) as m:
        return m(v), m.kernel.bins


@pytest.mark.parametrize("weight", RADIUS_WEIGHTS)
def test_set_handles_with_bins_equals_a_fresh_mls(gl, rng, weight):
    """The issue's case: 1,500 handles moved with the scaling unchanged (the bins used to keep
    the old handles' order: up to ~40 px off)."""
    p1, q1 = handle_set(rng, 1500)
    p2, q2 = handle_set(rng, 1500, displacement=30.0)
    v = rng.uniform(0, 511, (4000, 2))
    options = {"weight": weight, "radius": 20.0, "ctx": gl}
    with glmls.MLS(p1, q1, **options) as m:
        assert m.kernel.bins is not None
        scaling = m.scaling
        m.set_handles(p2, q2)
        assert m.scaling == scaling
        moved = m(v)
        assert m.kernel.bins is not None
    expected, _ = fresh(p2, q2, v, **options)
    assert_allclose(moved, expected, rtol=0, atol=1e-3)


@pytest.mark.parametrize("weight", RADIUS_WEIGHTS)
def test_set_handles_that_change_the_radius_equal_a_fresh_mls(gl, rng, weight):
    """New handles over a larger box: a new scaling, so another radius in GPU units, and
    bins of another size."""
    p1, q1 = handle_set(rng, 1500)
    p2, q2 = (3.0 * a for a in handle_set(rng, 1500))  # three times the extent
    v = rng.uniform(0, 1500, (3000, 2))
    options = {"weight": weight, "radius": 20.0, "ctx": gl, "bins": True}
    with glmls.MLS(p1, q1, **options) as m:
        reach, scale = m.kernel.bins.reach, m.scaling.scale
        m.set_handles(p2, q2)
        assert m.scaling.scale > scale
        assert m.kernel.bins.reach == pytest.approx(reach * scale / m.scaling.scale, rel=1e-6)
        moved = m(v)
    expected, _ = fresh(p2, q2, v, **options)
    assert_allclose(moved, expected, rtol=0, atol=1e-3)


def test_radius_of_the_image_diagonal_follows_each_image(gl, rng):
    """radius=None: the radius is the diagonal of the image being processed; bins follow it
    through the same upload, for new handles too."""
    p1, q1 = handle_set(rng, 1500)
    p2, q2 = handle_set(rng, 1500, displacement=10.0)
    options = {"weight": "cressman", "shape": (48, 64), "ctx": gl, "bins": True}
    v = rng.uniform(0, 511, (2000, 2))
    with glmls.MLS(p1, q1, **options) as m:
        m.set_handles(p2, q2)
        small = m(v)
        field = m.error_field((24, 32))  # a smaller image: half the radius
        assert_allclose(m(v), small, rtol=0, atol=0)  # back to the MLS's own size
    with glmls.MLS(p2, q2, **options) as other:
        assert_allclose(other(v), small, rtol=0, atol=1e-3)
    with glmls.MLS(p2, q2, weight="cressman", radius=40.0, ctx=gl, bins=True) as half:
        assert_allclose(half.error_field((24, 32)), field, rtol=1e-5, atol=1e-4)


def test_set_handles_chooses_the_storage_and_bins_again(gl, rng):
    """'auto' storage is chosen for the new count (uniform block, then the texture for binned
    handles), and automatic bins switch on where they now pay."""
    capacity = UBOHandleStorage(gl.mgl).capacity
    few_p, few_q = handle_set(rng, 100)
    many_p, many_q = handle_set(rng, capacity + 10)
    v = rng.uniform(0, 511, (1000, 2))
    options = {"weight": "linear", "radius": 12.0, "ctx": gl}
    with glmls.MLS(few_p, few_q, **options) as m:
        assert m.storage == "ubo" and m.kernel.bins is None
        m.set_handles(many_p, many_q)
        assert m.storage == "texture" and m.kernel.bins is not None
        moved = m(v)
        m.set_handles(few_p, few_q)
        assert m.storage == "ubo" and m.kernel.bins is None
        back = m(v)
    assert_allclose(moved, fresh(many_p, many_q, v, **options)[0], rtol=0, atol=1e-3)
    assert_allclose(back, fresh(few_p, few_q, v, **options)[0], rtol=0, atol=1e-3)


def test_rejected_handles_change_nothing(gl, rng):
    p, q = handle_set(rng, 20)
    capacity = UBOHandleStorage(gl.mgl).capacity
    too_many = np.stack([np.arange(capacity + 1.0), np.zeros(capacity + 1)], -1)
    v = rng.uniform(0, 511, (50, 2))
    with glmls.MLS(p, q, storage="ubo", ctx=gl) as m:
        before = m(v)
        with pytest.raises(ValueError, match="capacity"):
            m.set_handles(too_many, too_many)
        with pytest.raises(ValueError, match="same point"):
            m.set_handles([[1, 1], [1, 1]], [[0, 0], [2, 2]])
        assert_allclose(m(v), before, rtol=0, atol=0)
        assert len(m.src) == len(p)


@pytest.mark.parametrize("weight", ["cressman", "gaussian"])
def test_backward_swap_with_bins_equals_the_plain_evaluation(gl, rng, weight):
    """The swapped-handles map is a kernel of its own, uploaded (and binned by q) the same
    way: with bins it used to read the swapped handles through p's bins (26 px off)."""
    p, q = handle_set(rng, 1500)
    maps = []
    for bins in (False, True):
        with glmls.MLS(p, q, weight=weight, radius=20.0, bins=bins, ctx=gl) as m:
            maps.append(m.coordinate_map((64, 64), method="backward-swap"))
            m.set_handles(q, p)  # the swapped map of the new handles is made again
            maps.append(m.coordinate_map((64, 64), method="backward-swap"))
    assert_allclose(maps[2], maps[0], rtol=0, atol=1e-3)
    assert_allclose(maps[3], maps[1], rtol=0, atol=1e-3)
    assert np.abs(maps[1] - maps[0]).max() > 0.5  # the two handle sets do differ
