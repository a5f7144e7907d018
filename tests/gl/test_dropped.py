"""An MLS dropped without release() (as scikit-image's transforms are used: made and let go in
a loop) gives its GPU buffers back: its context releases them at its next use, in the thread
that uses it, not in the garbage collector, which may run inside a GL call."""

from __future__ import annotations

import gc

import numpy as np

import glmls

SRC = np.array([[5.0, 5.0], [40.0, 8.0], [20.0, 30.0], [10.0, 12.0]])


def test_a_dropped_mls_is_released_at_the_contexts_next_use(gl):
    kernels = []
    for k in range(4):  # each new MLS's use releases the ones dropped before it
        m = glmls.MLS(SRC, SRC + k, ctx=gl)
        kernels += [m.kernel, m.swapped_kernel()]  # the swapped handles' kernel too
        assert np.isfinite(m(SRC)).all()
        del m
    gc.collect()
    assert all(kernel.released for kernel in kernels[:-2])
    assert not any(kernel.released for kernel in kernels[-2:])  # not in the collector
    with glmls.MLS(SRC, SRC + 1.0, ctx=gl) as m:
        m(SRC)
    assert all(kernel.released for kernel in kernels)


def test_a_released_or_kept_mls_is_not_touched(gl):
    kept = glmls.MLS(SRC, SRC + 1.0, ctx=gl)
    released = glmls.MLS(SRC, SRC + 2.0, ctx=gl)
    released.release()
    del released
    gc.collect()
    with glmls.MLS(SRC, SRC, ctx=gl) as m:
        m(SRC)
    assert not kept.released
    assert np.allclose(kept(SRC), SRC + 1.0, atol=1e-4)
    kept.release()


def test_a_dropped_3d_mls_is_released_too(gl):
    src = np.array([[5.0, 5, 5], [30, 6, 8], [10, 25, 9], [12, 8, 28]])
    m = glmls.MLS(src, src + 1.0, ctx=gl)
    kernel = m.kernel
    m(src)
    del m
    gc.collect()
    with glmls.MLS(src, src, ctx=gl) as other:
        other(src)
    assert kernel.released
