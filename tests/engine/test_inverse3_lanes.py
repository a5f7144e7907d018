"""The 3D inverse at points with thousands of handles: each point's preimage is its own, bit
for bit, whatever the other points of the call.

A CPU renderer (Mesa's llvmpipe) runs the invocations of a vector together and caps their
loop iterations; Newton's passes must fit within that cap whatever lanes a point shares, and
resume the points that need more evaluations than one invocation may make
(glmls.engine.passes3.invert_points3)."""

from __future__ import annotations

import numpy as np
from numpy.testing import assert_array_equal

import glmls
from glmls.engine.passes3 import length_unit
from glmls.imaging.inverse import accept_residual


def test_a_points_preimage_does_not_depend_on_its_lane_mates(gl):
    """4,000 handles moved up to 10 voxels in a 50^3 box (f folds in places): the preimages
    of 600 points in one call, and in calls of 97 points in reverse order, are the same."""
    rng = np.random.default_rng(1)
    src = rng.uniform(0, 50, (4000, 3))
    dst = src + rng.uniform(-10, 10, src.shape)
    x = rng.uniform(0, 50, (600, 3))
    with glmls.MLS(src, dst, transform="rigid", ctx=gl) as m:
        u = m(x)
        together, valid = m.inverse(u, return_valid=True)
        apart = np.concatenate(
            [m.inverse(u[first : first + 97][::-1])[::-1] for first in range(0, len(u), 97)]
        )
        assert_array_equal(apart, together)
        assert valid.all()
        miss = np.linalg.norm(m(together) - u, axis=1)
        accepted = accept_residual(m.scaling, u, together, unit=length_unit(m.kernel))
    assert (miss <= accepted).all(), (miss / accepted).max()
    # Newton's tolerance at all but the few points where a start ends in a dip of |f(s) - u|
    assert np.median(miss) <= 1e-4 and (miss > 2e-4).sum() <= 3
