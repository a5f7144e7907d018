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
