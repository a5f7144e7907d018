"""A 2D MLS whose targets lie far from its sources (every q = p + t, t = (1e5, -7e4)): MLS
moves with its targets where every weight is positive (f + t exactly), so f, M and T, the
inverse, the meshes and the images over a canvas placed on the far targets are those of the
map near its sources, translated by t. The GPU holds the targets less a whole-pixel
translation (:meth:`glmls.HandleSet.near_targets`) and adds it back in float64; without
that, float32 over the whole span would keep ~1e-2 px of f.

Tolerances: the near map's own against the float64 reference (~1e-5 px in f, ~5e-7 in M;
at the worst of 2000 points over 40 random sets of 16 handles: similarity and rigid up to
7e-5 px and 1e-5 in M, next to a handle with idw alpha = 2; affine up to 2.7e-4 px and
8.3e-5 in M, where a point has two handles in reach or lies 40 px past the others, A's small
eigenvalue a few 1e-3 of its trace magnifying float32's rounding), with room: f within
1e-4 px, M within 5e-5 (affine: 5e-4 px and 2e-4), T within 1e-2 (affine: 4e-2; T = f - v M,
v up to 200 px: M's error times 200);
the inverse within 1e-3 px of the near map's and its round trip within 1e-3 px (as
documented for :class:`glmls.InverseMLS`); images over the far canvas bit-equal to the near
map's where t is the GPU's translation, coordinate maps within 2e-3 px otherwise."""

from __future__ import annotations

import numpy as np
import pytest

import glmls
from glmls import reference
from glmls.core.weights import REGISTRY

#: A translation of the targets far beyond the handles' box.
FAR = np.array([1e5, -7e4])
#: Weights of unbounded reach, with the settings they are tried with.
UNBOUNDED = [
    ("idw", {}),
    ("idw", {"alpha": 2.0}),
    ("idw", {"interpolating": True, "alpha": 0.75}),
    ("gaussian", {"radius": 80.0}),
    ("gaussian", {"radius": 50.0}),
]


def _handles(seed: int = 0, n: int = 16, extent: float = 200.0):
    rng = np.random.default_rng(seed)
    src = rng.uniform(0, extent, (n, 2))
    dst = src + rng.normal(0, extent / 40, src.shape)
    return src, dst, rng.uniform(0, extent, (2000, 2))


def test_the_unbounded_weights_are_those_of_the_registry():
    assert {w for w, _ in UNBOUNDED} == {
        name for name, entry in REGISTRY.items() if entry.support != "radius"
    }


#: (f px, M, T px) of the near map against the reference, per transform.
NEAR_TOLERANCE = {
    "rigid": (1e-4, 5e-5, 1e-2),
    "similarity": (1e-4, 5e-5, 1e-2),
    "affine": (5e-4, 2e-4, 4e-2),
}


@pytest.mark.parametrize("seed", [0, 22, 35])
@pytest.mark.parametrize("transform", ["rigid", "similarity", "affine"])
@pytest.mark.parametrize(("weight", "settings"), UNBOUNDED)
def test_far_targets_give_f_and_matrices_of_the_reference(gl, transform, weight, settings, seed):
    src, dst, v = _handles(seed)
    f_tol, m_tol, t_tol = NEAR_TOLERANCE[transform]
    options = {"transform": transform, "weight": weight, **settings}
    for target in (dst, dst + FAR):  # the near map's tolerance holds for the far one too
        f_ref, m_ref, t_ref = reference.mls(src, target, v, **options)
        with glmls.MLS(src, target, **options) as m:
            f = m(v)
            big_m, t = m.matrices(v)
            residuals = m.residuals(v, f_ref)
        assert np.abs(f - f_ref).max() <= f_tol
        assert np.abs(big_m - m_ref).max() <= m_tol
        assert np.abs(t - t_ref).max() <= t_tol
        assert residuals.max() <= f_tol


@pytest.mark.parametrize("transform", ["rigid", "similarity", "affine"])
@pytest.mark.parametrize("weight", ["idw", "gaussian"])
def test_far_segment_targets_give_f_of_the_reference(gl, transform, weight):
    src, dst, v = _handles(seed=3, n=6)
    segments = np.array([[[20.0, 30.0], [150.0, 40.0]], [[60.0, 170.0], [90.0, 60.0]]])
    moved = segments + np.random.default_rng(4).normal(0, 4, segments.shape)
    options = {"transform": transform, "weight": weight}
    if weight == "gaussian":
        options["radius"] = 120.0
    none = np.zeros((0, 2))
    for shift in (np.zeros(2), FAR):
        far = {"src_segments": segments, "dst_segments": moved + shift}
        # with point handles, and segments alone: their ends are the targets that move back
        for p, q in ((src, dst + shift), (none, none)):
            expected = reference.mls(p, q, v, **far, **options)[0]
            with glmls.MLS(p, q, **far, **options) as m:
                assert np.abs(m(v) - expected).max() <= 1e-4


@pytest.mark.parametrize("weight", ["idw", "gaussian"])
def test_the_inverse_of_far_points_comes_back_to_the_sources(gl, weight):
    src, dst, _ = _handles(seed=1, extent=60.0, n=10)
    u = np.random.default_rng(2).uniform(5, 55, (300, 2))
    options = {"weight": weight, "radius": 40.0} if weight == "gaussian" else {}
    with glmls.MLS(src, dst, shape=(60, 60), **options) as near:
        expected = near.inverse(u)
    with glmls.MLS(src, dst + FAR, shape=(60, 60), **options) as m:
        s, valid = m.inverse(u + FAR, return_valid=True)
        back = m(s)
        assert np.abs(m.inverse.residuals(u + FAR, expected)).max() <= 1e-3
    assert valid.all() and not np.isnan(expected).any()
    assert np.abs(s - expected).max() <= 1e-3
    assert np.abs(back - (u + FAR)).max() <= 1e-3


def test_a_radius_weight_keeps_its_targets_and_its_identity_beyond_reach(gl):
    """A weight of bounded reach is the identity beyond the handles, not v + t: the GPU
    keeps its targets as they are (f as precise as float32 over the whole span)."""
    src, dst, v = _handles(seed=5, extent=60.0)
    beyond = np.array([[400.0, 400.0], [-300.0, 50.0], [1000.5, -2000.25]])
    for weight in [name for name, entry in REGISTRY.items() if entry.support == "radius"]:
        options = {"weight": weight, "radius": 80.0}
        with glmls.MLS(src, dst + FAR, **options) as m:
            assert np.array_equal(m(beyond), beyond)
            f = m(v)
        expected = reference.mls(src, dst + FAR, v, **options)[0]
        reached = np.isfinite(expected).all(axis=1)
        # float32 over the span from the sources to the targets, as ever: ~1e-7 of 1.2e5
        assert np.abs(f[reached] - expected[reached]).max() <= 0.05


def _centred(seed: int = 7):
    """Handles whose targets' box has the sources' box's centre, so that the GPU moves far
    targets back by exactly t: the far map's GPU work is the near map's."""
    rng = np.random.default_rng(seed)
    src = rng.uniform(5, 45, (10, 2))
    dst = src + rng.normal(0, 2, src.shape)
    shift = (dst.min(axis=0) + dst.max(axis=0)) / 2 - (src.min(axis=0) + src.max(axis=0)) / 2
    return src, dst - shift


WARPS = [
    {"method": method, "interpolation": interpolation, "border": border}
    for method in ("quads", "splat", "backward", "backward-swap", "paper-quads")
    for interpolation in ("nearest", "linear")
    for border in ("constant", "edge")
] + [{"tolerance": 0.1}, {"grid": 4, "border": "reflect"}]


@pytest.mark.parametrize("segments", [False, True])
def test_a_far_canvas_shows_the_near_warp_bit_for_bit(gl, segments):
    src, dst = _centred()
    image = np.random.default_rng(8).integers(0, 256, (40, 50, 3), dtype=np.uint8)
    handles = {}
    if segments:
        line = np.array([[[5.0, 35.0], [40.0, 30.0]]])
        handles = {"src_segments": line, "dst_segments": line + [[1.0, -1.0], [0.5, 1.0]]}
    far_handles = {k: v + FAR if k == "dst_segments" else v for k, v in handles.items()}
    canvas = {"output_shape": (44, 56), "origin": (-2.0, -3.0)}
    far_canvas = {**canvas, "origin": tuple(np.add(canvas["origin"], FAR))}
    with (
        glmls.MLS(src, dst, shape=image.shape[:2], **handles) as near,
        glmls.MLS(src, dst + FAR, shape=image.shape[:2], **far_handles) as far,
    ):
        for options in WARPS:
            expected = near.warp(image, **options, **canvas)
            assert np.array_equal(far.warp(image, **options, **far_canvas), expected), options
        for method in ("backward", "backward-swap"):
            expected = near.coordinate_map(image.shape[:2], method=method, **canvas)
            found = far.coordinate_map(image.shape[:2], method=method, **far_canvas)
            assert np.array_equal(found, expected), method
        b_near, b_far = near.bounds(image.shape[:2]), far.bounds(image.shape[:2])
        assert b_far.output_shape == b_near.output_shape
        assert np.subtract(b_far.origin, b_near.origin).tolist() == FAR.tolist()
        deformed = far.mesh(image.shape[:2], grid=4)[1]
        assert np.abs(deformed - FAR - near.mesh(image.shape[:2], grid=4)[1]).max() <= 1e-9


def test_a_far_canvas_of_any_targets_maps_back_as_the_near_one(gl):
    """Targets not centred on the sources: the GPU's translation is t rounded to the centres'
    difference, so the far map's float32 differs from the near one's by its rounding."""
    src, dst, _ = _handles(seed=9, extent=45.0, n=10)
    with (
        glmls.MLS(src, dst, shape=(40, 50)) as near,
        glmls.MLS(src, dst + FAR, shape=(40, 50)) as far,
    ):
        expected = near.coordinate_map((40, 50), border="edge")
        found = far.coordinate_map((40, 50), border="edge", origin=tuple(FAR))
    assert np.abs(found - expected).max() <= 2e-3


@pytest.mark.parametrize("method", ["quads", "backward", "backward-swap", "splat", "paper-quads"])
@pytest.mark.parametrize("segments", [False, True])
def test_a_batch_of_far_targets_equals_each_images_warp(gl, method, segments):
    src, dst = _centred(seed=11)
    rng = np.random.default_rng(12)
    images = rng.integers(0, 256, (3, 40, 50), dtype=np.uint8)
    targets = [dst, dst + FAR, dst + [3.0, 1.0]]
    options = {"method": method, "origin": tuple(FAR), "output_shape": (40, 50)}
    line = np.array([[[5.0, 35.0], [40.0, 30.0]]])
    own = [{}] * 3
    if segments:  # the far image's, a near one's: each image's own MLS
        own = [{}, {"src_segments": line, "dst_segments": line + FAR}]
        own.append({"src_segments": line, "dst_segments": line + [3.0, 1.0]})
    per_image = {
        name: [handles.get(name) for handles in own] for name in ("src_segments", "dst_segments")
    }
    out = glmls.warp_batch(images, [src] * 3, targets, **options, **per_image)
    for image, target, handles, warped in zip(images, targets, own, out, strict=True):
        assert np.array_equal(warped, glmls.warp(image, src, target, **options, **handles))
    assert out[1].any()  # the far image shows on the far canvas
