"""The 3D passes over many points take only the solve's plain branch first (Cholesky for
affine, B's polar factor for the rotations: ``mls3/solve.glsl``, ``MLS3_SOLVE_LATER``) and
leave the points whose moments need another branch (the ridges of degenerate handle sets,
Horn's quaternion) to a second pass: f, M, J, a mesh's records, the volume lattice and the
backward method's map equal those of passes that take every branch at once, bit for bit,
on degenerate handle sets (where every point needs the second pass) and general ones next
to handles (where some do)."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import degenerate_sets3

import glmls
from glmls.engine.kernel3 import MLSKernel3
from glmls.volume import volume_coordinate_map

SHAPE = (20, 24, 28)


def _sets():
    rng = np.random.default_rng(11)
    sets = {
        name: src * 0.1
        for name, src in degenerate_sets3(rng).items()
        if name not in ("one", "coincident")
    }
    sets["general"] = rng.uniform(0, 26, (10, 3))
    return sets


SETS = _sets()


def _every_branch_at_once(monkeypatch):
    """Compile every 3D pass with the solve's branches all in the first pass."""
    program = MLSKernel3.program

    def one_pass(self, entry, defines=None):
        return program(self, entry, dict(defines or {}) | {"MLS3_SOLVE_LATER": 0})

    monkeypatch.setattr(MLSKernel3, "program", one_pass)


def _handles(name, transform):
    src = SETS[name]
    rng = np.random.default_rng(len(src))
    dst = src + rng.normal(0, 0.3, src.shape)
    if name == "collinear" and transform == "rigid":
        dst = src[::-1].copy()  # a half turn of the line: Horn's quaternion, not the polar
    return src, dst


@pytest.mark.parametrize("transform", glmls.TRANSFORMS)
@pytest.mark.parametrize("name", sorted(SETS))
def test_points_and_meshes(gl, monkeypatch, transform, name):
    src, dst = _handles(name, transform)
    rng = np.random.default_rng(5)
    near = (src[:, None, :] + rng.normal(0, 0.3, (len(src), 30, 3))).reshape(-1, 3)
    points = np.concatenate([rng.uniform(-2, 28, (600, 3)), near])
    faces = rng.integers(0, len(points), (500, 3))

    def run():
        with glmls.MLS(src, dst, transform=transform, ctx=gl) as m:
            matrices = m.matrices(points)
            f, jacobian = m.jacobian(points)
            mesh = m.deform((points, faces))
            return [m(points), *matrices, f, jacobian, mesh.vertices, mesh.normals, mesh.det_j]

    split = run()
    _every_branch_at_once(monkeypatch)
    together = run()
    for a, b in zip(split, together, strict=True):
        assert np.isfinite(a).all()
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("transform", glmls.TRANSFORMS)
@pytest.mark.parametrize("name", ["collinear", "three", "general"])
def test_volumes(gl, monkeypatch, transform, name):
    src, dst = _handles(name, transform)
    rng = np.random.default_rng(6)
    volume = rng.uniform(0, 1, SHAPE).astype(np.float32)

    def run():
        with glmls.MLS(src, dst, transform=transform, shape=SHAPE, ctx=gl) as m:
            forward = m.warp(volume, grid=2)
            points, residual, covered = volume_coordinate_map(m, SHAPE, grid=2)
            return forward, points, residual, covered

    split = run()
    _every_branch_at_once(monkeypatch)
    together = run()
    # the backward method found most voxels' preimages, the degenerate sets' too
    assert split[3].mean() > 0.3
    for a, b in zip(split, together, strict=True):
        np.testing.assert_array_equal(a, b)
