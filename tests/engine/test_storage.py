"""Handle storages (ssbo, ubo, texture) and the unrolled evaluation agree with each other."""

from __future__ import annotations

import moderngl
import numpy as np
import pytest
from helpers import live_gl_objects, random_handles
from numpy.testing import assert_allclose, assert_array_equal

import glmls
from glmls import reference
from glmls.engine.storage import (
    STORAGES,
    SSBOHandleStorage,
    UBOHandleStorage,
    capacities,
    capacity_advice,
    make_storage,
    unroll_slots,
)

SHAPE = (256, 256)


@pytest.mark.parametrize("n", [0, 1, 5, 16, 17, 64, 65])
def test_storages_and_unrolled_slots_give_the_same_f(gl, rng, n):
    """16 and 64 handles fill the unrolled slots exactly; 17 and 65 leave empty slots or
    switch to the loop."""
    p, q = random_handles(rng, n, size=256.0, displacement=10.0)
    v = rng.uniform(0, 255, (500, 2))
    out = {}
    for storage in STORAGES:
        with glmls.MLS(p, q, shape=SHAPE, ctx=gl, storage=storage) as m:
            out[storage] = m(v)
    assert_allclose(out["ubo"], out["ssbo"], rtol=0, atol=1e-4)
    assert_allclose(out["texture"], out["ssbo"], rtol=0, atol=1e-4)
    if n:
        f_ref, _, _ = reference.mls(p, q, v, shape=SHAPE)
        assert_allclose(out["ssbo"], f_ref, rtol=0, atol=2e-3)


def test_storages_warp_identically(gl, rng):
    p, q = random_handles(rng, 20, size=64.0, displacement=4.0)
    img = rng.integers(0, 255, (64, 64, 3), dtype=np.uint8)
    warps = []
    for storage in STORAGES:
        with glmls.MLS(p, q, ctx=gl, storage=storage) as m:
            warps.append(m.warp(img, method="backward"))
    assert (warps[0] == warps[1]).all(axis=-1).mean() > 0.999
    assert (warps[0] == warps[2]).all(axis=-1).mean() > 0.999


def test_unroll_slots():
    assert [unroll_slots(n) for n in (0, 1, 16, 17, 64, 65, 10_000)] == [16, 16, 16, 64, 64, 0, 0]


def test_auto_takes_the_uniform_block_where_the_handles_fit(gl):
    capacity = UBOHandleStorage(gl.mgl).capacity
    for n, expected in ((3, "ubo"), (capacity, "ubo"), (capacity + 1, "ssbo")):
        p = np.stack([np.arange(n), np.zeros(n)], -1).astype(float)
        with glmls.MLS(p, p, ctx=gl) as m:
            assert m.storage == expected
    with glmls.MLS(p, p, ctx=gl, storage="texture") as m:
        assert m.storage == "texture"


def test_bad_storage_and_capacity(gl):
    with pytest.raises(ValueError, match="unknown storage 'uniform'"):
        glmls.MLS([[0, 0]], [[1, 1]], ctx=gl, storage="uniform")
    with pytest.raises(TypeError, match="storage must be a string"):
        glmls.MLS([[0, 0]], [[1, 1]], ctx=gl, storage=1)
    ubo = UBOHandleStorage(gl.mgl)
    too_many = ubo.capacity + 1
    p = np.stack([np.arange(too_many), np.zeros(too_many)], -1).astype(float)
    with pytest.raises(
        ValueError, match=f"exceed the ubo handle storage's capacity of {too_many - 1}"
    ):
        glmls.MLS(p, p, ctx=gl, storage="ubo")
    ubo.release()


def test_capacity_advice_names_a_storage_that_holds_them(gl):
    """Past one storage's capacity the message offers the storage that holds the handles on
    this driver (the roomiest), not the one that failed; past every storage, fewer handles."""
    held = capacities(gl.mgl)
    for name in STORAGES:
        advice = capacity_advice(gl.mgl, name, held[name] + 1)
        roomy = [other for other in STORAGES if other != name and held[other] > held[name]]
        if roomy:
            assert advice == f"use storage={max(roomy, key=held.__getitem__)!r}"
        else:
            assert advice.startswith("use fewer handles")
    assert capacity_advice(gl.mgl, "ssbo", max(held.values()) + 1).startswith(
        "use fewer handles (every storage holds at most"
    )
    ubo = UBOHandleStorage(gl.mgl)
    too_many = ubo.capacity + 1
    ubo.release()
    p = np.stack([np.arange(too_many), np.zeros(too_many)], -1).astype(float)
    with pytest.raises(ValueError, match=r"use storage='(ssbo|texture)'"):
        glmls.MLS(p, p, ctx=gl, storage="ubo")


def test_capacities_meet_the_gl_guarantees(gl):
    """GL 4.3: uniform blocks >= 16 KB (1,024 handles), storage blocks >= 16 MB."""
    capacities = {}
    for name in STORAGES:
        storage = make_storage(name, gl.mgl)
        capacities[name] = storage.capacity
        storage.release()
    assert capacities["ubo"] >= 1024
    assert capacities["ssbo"] >= 1 << 20
    assert capacities["texture"] >= 1 << 20


def live_textures() -> int:
    return live_gl_objects(moderngl.Texture)


def test_storage_is_released(gl):
    m = glmls.MLS([[0, 0], [5, 5]], [[1, 1], [6, 5]], ctx=gl, storage="texture")
    before = live_textures()
    m.release()
    assert live_textures() == before - 1
    assert_array_equal(m.src, [[0, 0], [5, 5]])


def _crowded_segments(count):
    """``count`` short segments on a grid 8 px apart, and their targets."""
    i = np.arange(count)
    x, y = (i % 64) * 8.0, (i // 64) * 8.0
    a = np.stack([np.stack([x, y], 1), np.stack([x + 4.0, y], 1)], 1)
    return a, a + [1.0, 0.5]


def test_the_padding_of_the_points_counts_against_the_uniform_block(gl):
    """A buffer pads the point handles to the unrolled slots before the segments' rows:
    1 point and 2047 segments are 4,095 rows, 4,110 in the uniform block of 4,096. "auto"
    takes another storage for them, and an explicit "ubo" is refused
    before anything changes: f, the handles and the storage stay those before."""
    rows = capacities(gl.mgl)["ubo"]
    a, b = _crowded_segments(rows // 2 - 1)
    p0 = np.array([[10.0, 10.0], [300.0, 200.0], [100.0, 400.0]])
    q0 = p0 + [[3.0, 0.0], [0.0, 3.0], [2.0, 2.0]]
    v = np.array([[50.0, 60.0], [250.0, 250.0], [10.0, 10.0]])
    segments = {"src_segments": a, "dst_segments": b}
    with glmls.MLS([[0.3, 0.3]], [[1.3, 1.3]], ctx=gl, **segments) as m:
        assert m.storage != "ubo"
        assert np.isfinite(m(v)).all()
    with glmls.MLS(p0, q0, ctx=gl, storage="ubo") as m:
        before = m(v)
        with pytest.raises(ValueError, match=r"rows of padding after the points"):
            m.set_handles([[0.3, 0.3]], [[1.3, 1.3]], **segments)
        assert_array_equal(m(v), before)
        assert_array_equal(m.src, p0)
        assert m.storage == "ubo"


def test_an_upload_that_fails_leaves_the_handles_before(gl, monkeypatch):
    """Whatever stops the storage's upload, the MLS keeps the handles before, on the host as
    on the GPU (set_handles: "on error nothing changes")."""
    p0 = np.array([[10.0, 10.0], [300.0, 200.0], [100.0, 400.0]])
    q0 = p0 + [[3.0, 0.0], [0.0, 3.0], [2.0, 2.0]]
    v = np.array([[50.0, 60.0], [250.0, 250.0], [10.0, 10.0]])
    with glmls.MLS(p0, q0, ctx=gl, storage="ssbo") as m:
        before = m(v)

        def refuse(*args, **kwargs):
            raise RuntimeError("out of GPU memory")

        monkeypatch.setattr(SSBOHandleStorage, "upload", refuse)
        with pytest.raises(RuntimeError, match="out of GPU memory"):
            m.set_handles(p0 * 2.0, q0 * 2.0)
        monkeypatch.undo()
        assert_array_equal(m(v), before)
        assert_array_equal(m.src, p0)
