"""The passes over f: points and lattices on the GPU against the float64 reference, and
dispatches split at the work-group limit."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import random_handles
from numpy.testing import assert_allclose

import glmls
from glmls import reference
from glmls.core.mesh import MeshLattice
from glmls.engine.passes import evaluate_lattice, evaluate_points


@pytest.mark.parametrize("grid", [1, 4, 7])
def test_mesh_matches_the_reference(gl, rng, grid):
    p, q = random_handles(rng, 16, size=120, displacement=10)
    with glmls.MLS(p, q, transform="similarity", shape=(90, 120), ctx=gl) as m:
        vertices, deformed = m.mesh((90, 120), grid=grid)
    xs, ys = MeshLattice.corners((90, 120), grid).axes
    assert vertices.shape == deformed.shape == (len(ys), len(xs), 2)
    f_ref, _, _ = reference.mls(p, q, vertices.reshape(-1, 2), transform="similarity")
    assert_allclose(deformed.reshape(-1, 2), f_ref, atol=1e-3)


def test_dispatches_are_split_at_the_work_group_limit(gl, rng):
    p, q = random_handles(rng, 5, size=100, displacement=10)
    v = rng.uniform(0, 100, (1000, 2))
    with glmls.MLS(p, q, ctx=gl) as m:
        # 192 invocations per dispatch
        f, _ = evaluate_points(m.kernel, v, with_matrix=False, max_groups=3)
        lattice = MeshLattice.corners((40, 50), 2)
        with gl:  # raw moderngl calls: the context current for the block
            buffer = gl.mgl.buffer(reserve=lattice.count * 8)
            try:
                count = evaluate_lattice(m.kernel, lattice, buffer, max_groups=2)
                gl.mgl.memory_barrier()
                mesh = np.frombuffer(buffer.read(), np.float32).reshape(-1, 2)
            finally:
                buffer.release()
    assert_allclose(f, reference.mls(p, q, v)[0], atol=1e-3)
    assert count == lattice.count
    expected = reference.mls(p, q, lattice.points().reshape(-1, 2))[0]
    assert_allclose(m.scaling.from_gpu(mesh), expected, atol=1e-3)


def test_lattice_bands_write_from_the_band_start(gl, rng):
    """A band of rows is written from the buffer's start: rows 5..9 of the lattice."""
    p, q = random_handles(rng, 6, size=60, displacement=5)
    lattice = MeshLattice.corners((40, 60), 4)
    nx = lattice.dims[0]
    with glmls.MLS(p, q, ctx=gl) as m:
        with gl:
            buffer = gl.mgl.buffer(reserve=5 * nx * 8)
            try:
                evaluate_lattice(m.kernel, lattice, buffer, first_row=5, rows=5)
                gl.mgl.memory_barrier()
                band = np.frombuffer(buffer.read(), np.float32).reshape(5, nx, 2)
            finally:
                buffer.release()
        whole = m.mesh((40, 60), grid=4)[1]
    assert_allclose(m.scaling.from_gpu(band), whole[5:10], rtol=0, atol=1e-5)


@pytest.mark.parametrize("handles", [5, 40, 100])  # unrolled 16 and 64 slots, and the loop
@pytest.mark.parametrize("count", [1, 2, 63, 129])
def test_every_point_of_a_pair_is_its_own_evaluation(gl, rng, handles, count):
    """The pass evaluates POINTS_PER_INVOCATION points per invocation: each is f at its
    point, bit for bit as when it is evaluated alone (first or second of a pair), and the
    invocation past an odd end stores nothing (the word after a kept store stays)."""
    p, q = random_handles(rng, handles, size=200, displacement=15)
    v = rng.uniform(-20, 220, (count, 2))
    v[0] = p[0]  # snapped
    with glmls.MLS(p, q, ctx=gl) as m:
        alone = np.concatenate(
            [evaluate_points(m.kernel, v[i : i + 1], with_matrix=False)[0] for i in range(count)]
        )
        shifted = evaluate_points(m.kernel, np.concatenate([v[1:], v[:1]]), with_matrix=False)[0]
        with gl:
            buffer = gl.mgl.buffer(np.full(2 * (count + 3), 7.0, np.float32).tobytes())
        try:
            f, _ = evaluate_points(m.kernel, v, with_matrix=False, keep=(buffer, 8))
            with gl:
                gl.mgl.memory_barrier()
                kept = np.frombuffer(buffer.read(), np.float32).reshape(-1, 2)
        finally:
            with gl:
                buffer.release()
    assert np.array_equal(f, alone)
    assert np.array_equal(f, np.concatenate([shifted[-1:], shifted[:-1]]))
    assert_allclose(f, reference.mls(p, q, v)[0], atol=1e-3)
    assert np.all(kept[0] == 7.0) and np.all(kept[count + 1 :] == 7.0)
