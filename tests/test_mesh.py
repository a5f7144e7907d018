"""Mesh evaluation (pixel-square corners) and dispatch chunking."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import random_handles
from numpy.testing import assert_allclose

import glmls
from glmls import reference
from glmls.context import GLContext
from glmls.mls import mesh_axes


def test_mesh_axes_are_pixel_square_corners():
    xs, ys = mesh_axes((3, 5), 2)
    assert_allclose(xs, [-0.5, 1.5, 3.5, 4.5])
    assert_allclose(ys, [-0.5, 1.5, 2.5])
    xs, _ = mesh_axes((3, 5), 1)
    assert_allclose(xs, np.arange(6) - 0.5)


@pytest.mark.parametrize("grid", [0, -1, 1.5, True])
def test_bad_grid(grid):
    with pytest.raises(ValueError, match="grid must be an integer >= 1"):
        mesh_axes((4, 4), grid)


@pytest.mark.parametrize("grid", [1, 4, 7])
def test_mesh_matches_the_reference(gl, rng, grid):
    p, q = random_handles(rng, 16, size=120, displacement=10)
    with glmls.MLS(p, q, transform="similarity", shape=(90, 120), ctx=gl) as m:
        vertices, deformed = m.mesh((90, 120), grid=grid)
    xs, ys = mesh_axes((90, 120), grid)
    assert vertices.shape == deformed.shape == (len(ys), len(xs), 2)
    f_ref, _, _ = reference.mls(p, q, vertices.reshape(-1, 2), transform="similarity")
    assert_allclose(deformed.reshape(-1, 2), f_ref, atol=1e-3)


def test_dispatches_are_split_at_the_work_group_limit(gl, rng, monkeypatch):
    limits = dict(gl.limits, max_work_groups_x=3)  # 3 groups of 64 per dispatch
    monkeypatch.setattr(GLContext, "limits", property(lambda self: limits))
    p, q = random_handles(rng, 5, size=100, displacement=10)
    v = rng.uniform(0, 100, (1000, 2))
    with glmls.MLS(p, q, ctx=gl) as m:
        f = m(v)
    assert_allclose(f, reference.mls(p, q, v)[0], atol=1e-3)
