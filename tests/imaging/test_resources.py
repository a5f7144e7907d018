"""GL objects and memory stay flat over many warps; release is explicit and final."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import live_gl_objects

import glmls


def resident_bytes() -> int:
    with open("/proc/self/statm") as statm:
        return int(statm.read().split()[1]) * 4096


def test_a_thousand_warps_of_varying_sizes_stay_flat(gl):
    rng = np.random.default_rng(3)
    p = np.array([[1, 1], [9, 2], [4, 8.0]])
    q = p + np.array([[1, 0], [0, 1], [-1, 0.5]])

    def one(i: int, m: glmls.MLS) -> None:
        shape = (1 + (i * 7) % 23, 1 + (i * 5) % 31, 1 + i % 4)
        img = rng.integers(0, 255, shape, dtype=np.uint8)
        method = glmls.METHODS[i % 4]
        if i % 10 == 0:  # the shortcut makes and releases its own MLS
            glmls.warp(img, p, q, method=method, ctx=gl)
        else:
            m.warp(img, method=method, interpolation=glmls.INTERPOLATIONS[i % 3 % 2])

    with glmls.MLS(p, q, ctx=gl) as m:
        for i in range(100):  # compile every program, reach steady state
            one(i, m)
        objects, memory = live_gl_objects(), resident_bytes()
        for i in range(100, 1000):
            one(i, m)
        assert live_gl_objects() == objects
        assert resident_bytes() - memory < 8 << 20
    assert live_gl_objects() < objects  # the MLS's own objects went with it


def test_release_frees_the_mls_objects_and_later_use_raises(gl):
    def use(m: glmls.MLS) -> None:
        m.warp(np.zeros((6, 7), np.uint8), method="backward")
        m.coordinate_map((6, 7), method="backward-swap")

    with glmls.MLS([[0, 0], [5, 5]], [[1, 0], [5, 6]], ctx=gl) as warm:
        use(warm)  # compiles the programs, which the context keeps
    before = live_gl_objects()
    m = glmls.MLS([[0, 0], [5, 5]], [[1, 0], [5, 6]], ctx=gl)
    use(m)
    assert live_gl_objects() > before
    m.release()
    m.release()  # harmless
    assert live_gl_objects() == before
    with pytest.raises(glmls.ReleasedError):
        m.warp(np.zeros((6, 7), np.uint8))
    with pytest.raises(glmls.ReleasedError):
        m.coordinate_map((6, 7))
    with pytest.raises(glmls.ReleasedError):
        glmls.analysis.foldovers(m, (6, 7))


def test_one_pipeline_per_context_shared_by_every_mls(gl):
    """Every MLS on a context warps through its one pipeline, whose cached objects the
    context releases (release_shared) and makes again when next needed."""
    image = np.zeros((6, 7), np.uint8)
    pipe = glmls.gl.WarpPipeline.of(gl)
    assert glmls.gl.WarpPipeline.of(gl.mgl) is pipe  # the adopted moderngl context too
    with glmls.MLS([[0, 0]], [[1, 0]], ctx=gl) as a, glmls.MLS([[0, 0]], [[0, 1]], ctx=gl) as b:
        a.warp(image)
        objects = live_gl_objects()
        b.warp(image)  # nothing new: the same pipeline, the same cached sizes
        assert live_gl_objects() == objects
        gl.release_shared()
        assert live_gl_objects() < objects
        with pytest.raises(glmls.ReleasedError, match="warp pipeline"):
            pipe.warp(a, image)
        fresh = glmls.gl.WarpPipeline.of(gl)
        assert fresh is not pipe
        np.testing.assert_array_equal(a.warp(image), b.warp(image))
