"""A 3D MLS whose targets lie far from its sources (every q = p + t, t ~ 1e5 voxels): MLS
moves with its targets (f + t exactly), so f, J = df/dv, the deformed mesh's normals and
folds, and the inverse are those of the map near its sources, translated by t, against the
float64 reference. The GPU holds the targets less their common translation
(:func:`glmls.core.handles3.fit_offset3`) and adds it back in float64; without that, float32
would keep ~1e-2 voxel of f, J's steps would grow to ~10 voxels and the normals would turn
by tens of degrees.

Tolerances (of the near map's GPU against the reference, ~1e-6 voxel in f and ~1e-4 in J,
with room): f within 1e-4 voxels, J within 1e-3, det J within 1e-3 of it, the deformed unit
normals within 0.2 degree (J's error divided by its smallest singular value: up to 0.11
degree over 40 random sets of handles, at a folded vertex where that value is 0.08), folds
equal."""

from __future__ import annotations

import numpy as np
import pytest

import glmls
from glmls.analysis import ReferenceDeformation
from glmls.core import mesh3
from glmls.core.handles3 import fit_offset3

#: A translation of the targets far beyond the handles' box.
FAR = np.array([1e5, -7e4, 3e4])


def _handles(seed: int = 5) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    src = rng.uniform(1, 30, (10, 3))
    return src, src + rng.normal(0, 3, src.shape)


def _sphere(centre: float = 15.0, radius: float = 8.0, n: int = 10):
    theta, phi = np.meshgrid(
        np.linspace(0.2, np.pi - 0.2, n),
        np.linspace(0, 2 * np.pi, 2 * n, endpoint=False),
        indexing="ij",
    )
    unit = np.stack(
        [np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], axis=-1
    )
    vertices = unit.reshape(-1, 3) * radius + centre
    faces = []
    for i in range(n - 1):
        for j in range(2 * n):
            a, b = i * 2 * n + j, i * 2 * n + (j + 1) % (2 * n)
            faces += [[a, a + 2 * n, b], [b, a + 2 * n, b + 2 * n]]
    return vertices, np.array(faces)


def _reference_jacobian(m: ReferenceDeformation, v: np.ndarray, h: float = 1e-3) -> np.ndarray:
    """J[k, r, c] = d f_c / d v_r by float64 central differences (error ~h^2)."""
    steps = np.eye(3) * h
    return np.stack([(m(v + steps[r]) - m(v - steps[r])) / (2 * h) for r in range(3)], axis=1)


@pytest.mark.parametrize("shape", [None, (32, 32, 32)])
def test_far_targets_f_and_jacobian_match_the_reference(gl, shape):
    src, dst = _handles()
    v = np.random.default_rng(1).uniform(0, 31, (60, 3))
    reference = ReferenceDeformation(src, dst + FAR, shape=shape)
    with glmls.MLS(src, dst + FAR, shape=shape) as m:
        f, jacobian = m.jacobian(v)
        assert np.abs(m(v) - reference(v)).max() <= 1e-4
    assert np.abs(f - reference(v)).max() <= 1e-4
    assert np.abs(jacobian - _reference_jacobian(reference, v)).max() <= 1e-3


@pytest.mark.parametrize("seed", [5, 20, 28])
def test_far_targets_deform_a_mesh_as_near_ones(gl, seed):
    src, dst = _handles(seed)
    vertices, faces = _sphere()
    for target in (dst, dst + FAR):
        reference = ReferenceDeformation(src, target)
        jacobian = _reference_jacobian(reference, vertices)
        expected = mesh3.deform_mesh(vertices, faces, None, reference(vertices), jacobian)
        with glmls.MLS(src, target) as m:
            out = m.deform((vertices, faces))
        assert np.abs(out.vertices - expected.vertices).max() <= 1e-4
        assert np.abs(out.jacobian - jacobian).max() <= 1e-3
        assert np.abs(out.det_j - expected.det_j).max() <= 1e-3
        cosine = np.clip((out.normals * expected.normals).sum(axis=1), -1.0, 1.0)
        assert np.degrees(np.arccos(cosine)).max() <= 0.2
        assert (out.vertex_folds == expected.vertex_folds).all()
        assert (out.face_folds == expected.face_folds).all()


def test_far_targets_mesh_folds_as_near_ones(gl):
    """A map that folds part of the mesh folds the same vertices and faces far away."""
    src = np.array([[5.0, 15, 15], [25, 15, 15], [15, 5, 15], [15, 25, 15], [15, 15, 5]])
    dst = src.copy()
    dst[0], dst[1] = src[1] - [4, 0, 0], src[0] + [4, 0, 0]  # x turned over between them
    vertices, faces = _sphere()
    results = []
    for t in (np.zeros(3), FAR):
        with glmls.MLS(src, dst + t) as m:
            results.append(m.deform((vertices, faces)))
    near, far = results
    assert near.vertex_folds.any() and not near.vertex_folds.all()
    reference = ReferenceDeformation(src, dst)
    det = np.linalg.det(_reference_jacobian(reference, vertices))
    clear = np.abs(det) > 1e-3
    assert clear.mean() > 0.9
    assert (far.vertex_folds == (det <= 0))[clear].all()
    assert (far.vertex_folds == near.vertex_folds)[clear].all()
    assert np.abs(far.det_j - near.det_j).max() <= 1e-3


def test_far_targets_inverse(gl):
    src, dst = _handles()
    s = np.random.default_rng(2).uniform(5, 25, (30, 3))
    reference = ReferenceDeformation(src, dst + FAR)
    with glmls.MLS(src, dst + FAR) as m:
        back, valid = m.inverse(reference(s), return_valid=True)
    assert valid.all()
    assert np.abs(back - s).max() <= 1e-2


def test_offset_only_for_far_targets(gl):
    """Usual displacements take no offset (their float32 work is unchanged); far targets
    take a whole one; a weight of bounded reach, whose f is the identity beyond the handles
    (not v + t), takes none and keeps that identity."""
    src, dst = _handles()
    assert not fit_offset3(src, dst).any()
    assert not fit_offset3(src, dst + [40.0, 0, 0], (32, 32, 32)).any()
    offset = fit_offset3(src, dst + FAR)
    assert (offset == np.round(offset)).all() and np.abs(offset - FAR).max() < 10
    with glmls.MLS(src, dst + FAR) as m:
        assert (m.kernel.offset == offset).all()
    beyond = np.array([[500.0, 500.0, 500.0]])
    with glmls.MLS(src, dst + FAR, weight="cressman", radius=40.0) as m:
        assert not m.kernel.offset.any()
        assert (m(beyond) == beyond).all()


@pytest.mark.parametrize("weight", ["cressman", "shepard", "linear"])
def test_far_targets_of_a_bounded_weight_invert_to_the_near_preimage(gl, weight):
    """A weight of bounded reach takes no offset: its targets, thousands of voxels off,
    stay whole in float32, where Newton from the swapped MLS ends at x with a residual of
    float32's rounding there (~2e-4 voxel at 3,000). That counts as reached: a second
    start from u itself, where f is the identity out of the handles' reach (residual 0),
    must not replace x by u, thousands of voxels away."""
    rng = np.random.default_rng(0)
    src = rng.uniform(0, 64, (10, 3))
    dst = src + rng.normal(0, 3, src.shape) + [3000.0, -2100.0, 900.0]
    x = rng.uniform(0, 64, (100, 3))
    with glmls.MLS(src, dst, weight=weight, shape=(64, 64, 64)) as m:
        back, valid = m.inverse(m(x), return_valid=True)
    assert valid.all()
    assert np.abs(back - x).max() <= 1e-2
