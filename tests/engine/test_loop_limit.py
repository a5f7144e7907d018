"""Tens of thousands of handles on a driver that caps a shader's loop iterations (Mesa's
llvmpipe: 65,535 over all the loops of an invocation): every handle counts in f, and the
Newton passes refuse what they could not finish instead of leaving handles out."""

from __future__ import annotations

import numpy as np
import pytest

import glmls
from glmls.engine.kernel import CAPPED_NEWTON_HANDLES


@pytest.mark.parametrize("dim", [2, 3])
def test_the_last_of_40000_handles_counts(gl, rng, dim):
    """One handle among 40,000 moves its point 10 px: were the handles after the driver's
    loop limit left out, f would keep it in place."""
    src = rng.uniform(0, 50, (40_000, dim))
    dst = src.copy()
    src[-1] = dst[-1] = 100.0
    dst[-1, 0] = 110.0
    with glmls.MLS(src, dst, transform="affine", ctx=gl) as m:
        f = m(src[-1:])
    np.testing.assert_allclose(f[0], dst[-1], atol=1e-3)


def test_a_newton_pass_beyond_the_loop_limit_is_refused(gl, rng):
    if gl.loop_limit is None:
        pytest.skip("this driver runs every loop iteration")
    count = CAPPED_NEWTON_HANDLES + 1
    src = rng.uniform(0, 50, (count, 2))
    with glmls.MLS(src, src + 0.5, ctx=gl) as m:
        np.testing.assert_allclose(m([[10.0, 10.0]]), [[10.5, 10.5]], atol=1e-3)
        with pytest.raises(ValueError, match=f"{count:,} handles: the inverse of f .* llvmpipe"):
            m.inverse([[10.0, 10.0]])
    with glmls.MLS(src[:CAPPED_NEWTON_HANDLES], src[:CAPPED_NEWTON_HANDLES] + 0.5, ctx=gl) as m:
        np.testing.assert_allclose(m.inverse([[10.5, 10.5]]), [[10.0, 10.0]], atol=1e-3)
