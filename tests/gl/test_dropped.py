"""An MLS, a warp pipeline or a canvas dropped without release() (as scikit-image's transforms
are used: made and let go in a loop) gives its GPU objects back: its context releases them at
its next use, in the thread that uses it, not in the garbage collector, which may run inside a
GL call. A context of one's own let go unreleased is freed when the next one is made."""

from __future__ import annotations

import gc

import moderngl
import numpy as np

import glmls
from glmls.analysis import Canvas
from glmls.gl import create_headless
from glmls.imaging.source import prepare_image

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


def test_a_dropped_warp_pipeline_is_released_at_the_contexts_next_use(gl):
    pipe = glmls.gl.WarpPipeline(gl)
    image = np.arange(48, dtype=np.uint8).reshape(6, 8)
    with glmls.MLS(SRC, SRC + 1.0, ctx=gl) as m:
        pipe.warp(m, image)
    texture = pipe.upload(prepare_image(image, pipe.max_image_size, normalized=True))
    del pipe
    gc.collect()
    assert not _released(texture)  # not in the collector
    with glmls.MLS(SRC, SRC, ctx=gl) as m:
        m(SRC)
    assert _released(texture)


def test_a_dropped_canvas_is_released_at_the_contexts_next_use(gl, monkeypatch):
    made = []

    def recorded(make):
        def wrapper(*args, **kwargs):
            made.append(make(*args, **kwargs))
            return made[-1]

        return wrapper

    for name in ("framebuffer", "renderbuffer"):
        monkeypatch.setattr(gl.mgl, name, recorded(getattr(gl.mgl, name)))
    canvas = Canvas((12, 16), ctx=gl).disks([[8, 6]], color=(255, 0, 0), radius=3)
    assert canvas.read()[6, 8].tolist() == [255, 0, 0]
    kept = Canvas((12, 16), ctx=gl)
    monkeypatch.undo()
    mine = made[: len(made) // 2]
    assert mine
    del canvas
    gc.collect()
    assert not any(_released(obj) for obj in mine)  # not in the collector
    with glmls.MLS(SRC, SRC, ctx=gl) as m:
        m(SRC)
    assert all(_released(obj) for obj in mine)
    assert kept.read().shape == (12, 16, 3)  # the kept canvas keeps its own
    kept.release()


def test_a_dropped_own_context_is_freed_when_the_next_is_made():
    image = np.arange(48, dtype=np.uint8).reshape(6, 8)
    dropped = []
    for k in range(3):  # each new context frees the ones dropped before it
        own = create_headless()
        assert all(_released(mgl) for mgl in dropped)
        with glmls.MLS(SRC, SRC + k, ctx=own) as m:  # its programs, pipeline and buffers
            out = m.warp(image)
        dropped.append(own.mgl)
        del own, m
        gc.collect()
        assert not _released(dropped[-1])  # not in the collector
    last = create_headless()
    try:
        assert all(_released(mgl) for mgl in dropped)
        with glmls.MLS(SRC, SRC + 2.0, ctx=last) as m:
            assert np.array_equal(m.warp(image), out)
    finally:
        last.release()


def test_a_released_own_context_or_the_shared_one_is_left_alone(gl):
    own = create_headless()
    own.release()
    del own
    gc.collect()
    with create_headless() as other:
        pass
    other.release()
    with glmls.MLS(SRC, SRC + 1.0, ctx=gl) as m:
        assert np.allclose(m(SRC), SRC + 1.0, atol=1e-4)
    assert not _released(gl.mgl)


def _released(obj: object) -> bool:
    return isinstance(obj.mglo, moderngl.InvalidObject)  # type: ignore[attr-defined]
