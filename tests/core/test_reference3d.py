"""The float64 reference in 3D: (N, 3) handles, every transform and weight, the degenerate
handle sets (two handles, three, coplanar, collinear, coincident) and the 2D reduction."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import random_rotation
from numpy.testing import assert_allclose

import glmls
from glmls import reference
from glmls.core.config import MLSConfig

RADIUS = 150.0


def _handle_sets(rng) -> dict[str, np.ndarray]:
    general = rng.uniform(0, 100, (12, 3))
    plane_axes = random_rotation(rng)[:2]  # a tilted plane through (50, 50, 50)
    coplanar = 50.0 + rng.uniform(-40, 40, (6, 2)) @ plane_axes
    line = 50.0 + np.linspace(-40, 40, 5)[:, None] * np.array([[1.0, 2.0, -0.5]]) / 2.3
    return {
        "general": general,
        "one": general[:1],
        "two": general[:2],
        "three": general[:3],
        "coplanar": coplanar,
        "collinear": line,
        "coincident": np.repeat(general[:1], 4, axis=0),
    }


def _points(rng, p) -> np.ndarray:
    """Random points in the box, the handles themselves, and points 1e-7 from a handle."""
    return np.vstack([rng.uniform(-10, 110, (20, 3)), p, p[:1] + 1e-7])


def _configs():
    for transform in glmls.TRANSFORMS:
        for weight in glmls.WEIGHTS:
            for interpolating in (False, True):
                yield MLSConfig(
                    transform=transform,
                    weight=weight,
                    interpolating=interpolating,
                    radius=RADIUS if weight in glmls.RADIUS_WEIGHTS else None,
                )


CONFIGS = list(_configs())


def _ids(config):
    return f"{config.transform}-{config.weight}-{'interp' if config.interpolating else 'plain'}"


@pytest.mark.parametrize("config", CONFIGS, ids=_ids)
def test_identity_is_exact_for_every_handle_set(rng, config):
    for name, p in _handle_sets(rng).items():
        v = _points(rng, p)
        f, big_m, t = reference.mls(p, p, v, config)
        assert np.isfinite(f).all() and np.isfinite(big_m).all(), name
        assert_allclose(f, v, rtol=0, atol=1e-10, err_msg=name)
        assert_allclose(np.einsum("ki,kij->kj", v, big_m) + t, f, rtol=0, atol=1e-10)


@pytest.mark.parametrize("config", CONFIGS, ids=_ids)
def test_global_motions_are_reproduced(rng, config):
    p = _handle_sets(rng)["general"]
    v = _points(rng, p)
    rot = random_rotation(rng)
    shift = np.array([7.0, -3.0, 11.0])
    motions = {"rigid": rot, "similarity": 1.3 * rot, "affine": rot @ np.diag([1.2, 0.8, 1.1])}
    order = glmls.TRANSFORMS.index(config.transform)  # affine reproduces all three, ...
    for kind in list(motions)[: {0: 3, 1: 2, 2: 1}[order]]:
        matrix = motions[kind]
        f, big_m, _ = reference.mls(p, p @ matrix + shift, v, config)
        in_reach = ~np.all(big_m == np.eye(3), axis=(1, 2))  # compact weights: out of reach
        assert_allclose(f[in_reach], (v @ matrix + shift)[in_reach], atol=1e-9, err_msg=kind)
        assert_allclose(big_m[in_reach], np.broadcast_to(matrix, big_m.shape)[in_reach], atol=1e-12)


@pytest.mark.parametrize("weight", glmls.WEIGHTS)
@pytest.mark.parametrize("transform", glmls.TRANSFORMS)
def test_interpolating_weights_hit_the_targets(rng, transform, weight):
    config = MLSConfig(transform=transform, weight=weight, interpolating=True, radius=RADIUS)
    for name, p in _handle_sets(rng).items():
        q = p + rng.normal(0, 5, p.shape)
        if name == "coincident":
            q = np.repeat(q[:1], len(p), axis=0)
        f, _, _ = reference.mls(p, q, p, config)
        assert_allclose(f, q, atol=1e-9, err_msg=name)


@pytest.mark.parametrize("transform", ["rigid", "similarity"])
def test_rigid_is_a_rotation_and_similarity_a_scaled_one(rng, transform):
    config = MLSConfig(transform=transform)
    for name, p in _handle_sets(rng).items():
        q = p + rng.normal(0, 8, p.shape)
        if name == "coincident":  # one source point has one target
            q = np.repeat(q[:1], len(p), axis=0)
        _, big_m, _ = reference.mls(p, q, _points(rng, p), config)
        scale = np.cbrt(np.linalg.det(big_m))
        assert (scale > 0).all(), name
        rot = big_m / scale[:, None, None]
        if transform == "rigid":
            assert_allclose(scale, 1.0, atol=1e-12, err_msg=name)
        eye = np.broadcast_to(np.eye(3), rot.shape)
        assert_allclose(np.swapaxes(rot, 1, 2) @ rot, eye, atol=1e-12, err_msg=name)


def _max_step(p, q, config, start, end, count):
    v = start + np.linspace(0.0, 1.0, count)[:, None] * (end - start)
    f, big_m, _ = reference.mls(p, q, v, config)
    assert np.isfinite(f).all() and np.isfinite(big_m).all()
    return np.linalg.norm(np.diff(f, axis=0), axis=1).max()


@pytest.mark.parametrize("transform", glmls.TRANSFORMS)
@pytest.mark.parametrize(
    "case",
    ["two", "three", "collinear", "coplanar", "near-collinear", "entering", "entering-plane"],
)
def test_no_jumps_near_degenerate_sets(rng, transform, case):
    """A jump keeps its size when the step shrinks tenfold; a continuous f's steps shrink."""
    config = MLSConfig(transform=transform)
    sets = _handle_sets(rng)
    if case in ("near-collinear", "entering", "entering-plane"):
        p = np.vstack([sets["collinear"][[0, 4]], sets["collinear"][2] + [0.0, 0.0, 1e-3]])
    else:
        p = sets[case]
    q = p + rng.normal(0, 6, p.shape)
    start, end = p[0] + [-3.0, 2.0, 1.0], p[-1] + [2.0, -1.0, 3.0]  # passes near the handles
    if case == "entering":
        # cressman: the third handle enters the reach along the line, its weight from 0 up
        config = MLSConfig(transform=transform, weight="cressman", radius=30.0)
        p = np.vstack([p[:2] * 0.2 + 40.0, [40.0, 40.0, 80.0]])
        q = p + rng.normal(0, 6, p.shape)
        start, end = np.array([40.0, 40.0, 45.0]), np.array([40.0, 40.0, 55.0])
        # around the crossing, where the third handle's weight is 0 to 1e-2 of the others
        start, end = start + (end - start) * 0.48, start + (end - start) * 0.52
    if case == "entering-plane":
        # cressman: a fourth handle out of the plane of three enters the reach at z = 56
        config = MLSConfig(transform=transform, weight="cressman", radius=30.0)
        p = np.array([[35.0, 38, 50], [46, 37, 50], [41, 45, 50], [40, 40, 86]])
        q = p + rng.normal(0, 6, p.shape)
        start, end = np.array([40.0, 40.0, 55.8]), np.array([40.0, 40.0, 56.2])
    coarse = _max_step(p, q, config, start, end, 2001)
    fine = _max_step(p, q, config, start, end, 20001)
    assert fine < 0.3 * coarse or coarse < 1e-9


@pytest.mark.parametrize("transform", ["rigid", "similarity"])
def test_collinear_targets_are_continuous(rng, transform):
    """Sources spread in 3D, targets on one line: B has rank 1 and leaves the rotation about
    the targets' line free. The rule of the collinear sources, on B B^T, decides it, so f
    has no jumps."""
    p = rng.uniform(0, 100, (10, 3))
    direction = np.array([0.6, 0.8, 0.0])
    q = p.mean(0) + np.outer((p - p.mean(0)) @ [1 / 3, 2 / 3, 2 / 3], direction)
    start, end = p[0] - 10.0, p[3] + 10.0
    coarse = _max_step(p, q, MLSConfig(transform=transform), start, end, 2001)
    fine = _max_step(p, q, MLSConfig(transform=transform), start, end, 20001)
    assert fine < 0.3 * coarse


@pytest.mark.parametrize("weight", ["idw", "gaussian", "cressman"])
@pytest.mark.parametrize("transform", glmls.TRANSFORMS)
def test_the_plane_z_0_gives_the_2d_reference(rng, transform, weight):
    config = MLSConfig(transform=transform, weight=weight, radius=RADIUS)
    p2 = rng.uniform(0, 100, (9, 2))
    q2 = p2 + rng.normal(0, 6, p2.shape)
    v2 = np.vstack([rng.uniform(-10, 110, (40, 2)), p2[:2]])

    def lift(a):
        return np.hstack([a, np.zeros((len(a), 1))])

    f2, m2, t2 = reference.mls(p2, q2, v2, config)
    f3, m3, t3 = reference.mls(lift(p2), lift(q2), lift(v2), config)
    assert_allclose(f3[:, :2], f2, atol=1e-9)
    assert_allclose(f3[:, 2], 0.0, atol=1e-9)
    assert_allclose(m3[:, :2, :2], m2, atol=1e-9)
    assert_allclose(t3[:, :2], t2, atol=1e-9)


@pytest.mark.parametrize("transform", glmls.TRANSFORMS)
@pytest.mark.parametrize("weight", ["idw", "gaussian"])
def test_the_plane_z_0_gives_the_2d_reference_near_one_line(rng, transform, weight):
    """Handles 0.01-2 px off one line over 200 px, moved by a rotation and scale (and a
    little noise, so that the 2D fit is a rotation, not a mirror, which 3D would take as a
    half turn), and for affine the four handles of docs/mathematics.md whose exact fit sends
    points 90 px off: 2D and 3D take the same ridge toward the similarity solution, so the
    3D reference in the plane is the 2D one; the rotation about the near line that 3D
    blends toward its least rotation moves M by ~1e-7."""
    config = MLSConfig(transform=transform, weight=weight, radius=120.0)
    turn = np.array([[np.cos(0.2), np.sin(0.2)], [-np.sin(0.2), np.cos(0.2)]])
    sets = []
    if transform == "affine":  # its 2D rotation fit is a mirror's near the fourth handle
        p4 = np.array([[0.0, 100], [100, 100], [200, 100], [100, 100.5]])
        sets.append((p4, [[0, 0], [0, 3], [0, 0], [2, 1]]))
    for offset in (0.01, 0.1, 0.5, 2.0):
        p2 = np.stack([rng.uniform(0, 200, 6), 100.0 + rng.uniform(-offset, offset, 6)], 1)
        moved = p2 @ turn * 1.05 + [3.0, -2.0] + rng.normal(0, 0.05 * offset, p2.shape)
        sets.append((p2, moved - p2))
    v2 = rng.uniform(-50, 250, (60, 2))
    for p2, shift in sets:
        q2 = p2 + np.asarray(shift)
        f2, m2, _ = reference.mls(p2, q2, v2, config)
        f3, m3, _ = reference.mls(_lift(p2), _lift(q2), _lift(v2), config)
        assert_allclose(f3[:, :2], f2, atol=1e-4)
        assert_allclose(m3[:, :2, :2], m2, atol=1e-6)


def _lift(a: np.ndarray) -> np.ndarray:
    return np.hstack([a, np.zeros((len(a), 1))])


def test_mls_error_in_3d(rng):
    p = _handle_sets(rng)["general"]
    rot = random_rotation(rng)
    v = rng.uniform(0, 100, (6, 3))
    assert_allclose(reference.mls_error(p, p @ rot + 5.0, v), 0.0, atol=1e-16 * 1e8)
    error = reference.mls_error(p, p + rng.normal(0, 3, p.shape), v, transform="affine")
    assert error.shape == (6,) and (error > 0).all()


def test_a_volume_shape_gives_its_diagonal_as_radius(rng):
    p = _handle_sets(rng)["general"]
    q = p + 1.0
    v = rng.uniform(0, 100, (4, 3))
    by_shape = reference.mls(p, q, v, weight="linear", shape=(10, 20, 20))[0]
    by_radius = reference.mls(p, q, v, weight="linear", radius=30.0)[0]
    assert_allclose(by_shape, by_radius, atol=1e-12)


@pytest.mark.parametrize("weight", ["gaussian", "linear"])
def test_a_radius_weight_without_radius_or_shape_asks_for_a_volume_s(rng, weight):
    p = _handle_sets(rng)["general"]
    message = r"pass radius=R \(in the handles' units.*or shape=\(D, H, W\)"
    for evaluate in (reference.mls, reference.mls_error):
        with pytest.raises(ValueError, match=message):
            evaluate(p, p + 1.0, p[:2], weight=weight)


@pytest.mark.parametrize(
    ("src", "dst", "points", "match"),
    [
        ((4, 3), (4, 2), (5, 3), r"dst \(4, 2\)"),
        ((4, 3), (4, 3), (5, 2), r"points \(5, 2\)"),
        ((4, 2), (4, 2), (5, 3), r"src \(4, 2\)"),
        ((4, 3), (3, 3), (5, 3), "same length"),
    ],
)
def test_mixed_dimensions_are_refused(src, dst, points, match):
    with pytest.raises(ValueError, match=match):
        reference.mls(np.zeros(src), np.zeros(dst), np.zeros(points))
    with pytest.raises(ValueError, match=match):
        reference.mls_error(np.zeros(src), np.zeros(dst), np.zeros(points))


def test_nan_and_segments_are_refused_in_3d():
    p = np.zeros((3, 3))
    bad = p.copy()
    bad[1, 2] = np.nan
    for name, args in {"src": (bad, p, p), "dst": (p, bad, p), "points": (p, p, bad)}.items():
        with pytest.raises(ValueError, match=f"{name} must be finite; row 1"):
            reference.mls(*args)
    segments = np.zeros((1, 2, 2))
    with pytest.raises(ValueError, match="segment handles are 2D only"):
        reference.mls(p, p, p, src_segments=segments, dst_segments=segments)
    with pytest.raises(TypeError, match="src must be real numbers"):
        reference.mls(p.astype(str), p, p)


def _scipy_fit(ph, qh, w, transform, rng):
    """Minimise sum w |p^ M - q^|^2 over rotations (and a log scale) with scipy's BFGS."""
    from scipy.optimize import minimize
    from scipy.spatial.transform import Rotation

    def matrix(x):
        scale = np.exp(x[3]) if transform == "similarity" else 1.0
        return scale * Rotation.from_rotvec(x[:3]).as_matrix().T

    def cost(x):
        return (w * ((ph @ matrix(x) - qh) ** 2).sum(1)).sum()

    starts = [np.r_[rng.normal(0, 1.5, 3), 0.0] for _ in range(6)]
    best = min((minimize(cost, x0, method="BFGS") for x0 in starts), key=lambda r: r.fun)
    return matrix(best.x)


@pytest.mark.parametrize("transform", glmls.TRANSFORMS)
def test_the_fit_minimises_the_weighted_least_squares(rng, transform):
    """Against scipy's minimiser over rotation vectors (and a log scale), and numpy's weighted
    lstsq for affine (eq. 2 about the weighted centroids)."""
    p = _handle_sets(rng)["general"]
    q = p @ random_rotation(rng) + rng.normal(0, 10, p.shape)
    config = MLSConfig(transform=transform, weight="idw")
    v = rng.uniform(0, 100, (4, 3))
    _, big_m, _ = reference.mls(p, q, v, config)
    for k in range(len(v)):
        w = reference.weights(((p - v[k]) ** 2).sum(1)[None], config, None)[0]
        w = w / w.sum()
        ph, qh = p - w @ p, q - w @ q
        if transform == "affine":
            root = np.sqrt(w)[:, None]
            expected = np.linalg.lstsq(ph * root, qh * root, rcond=None)[0]
            assert_allclose(big_m[k], expected, atol=1e-9)
        else:
            assert_allclose(big_m[k], _scipy_fit(ph, qh, w, transform, rng), atol=1e-4)


@pytest.mark.parametrize("transform", glmls.TRANSFORMS)
def test_degenerate_sets_reproduce_what_they_determine(rng, transform):
    """Three or coplanar handles determine a rotation (and scale): every transform
    reproduces a global similarity of them; handles on a line determine the line's image,
    which a global rigid motion keeps exact on the line."""
    sets = _handle_sets(rng)
    rot = random_rotation(rng)
    motion = rot * (1.0 if transform == "rigid" else 1.3)
    config = MLSConfig(transform=transform)
    for name in ("three", "coplanar"):
        p = sets[name]
        v = _points(rng, p)
        f, big_m, _ = reference.mls(p, p @ motion + 4.0, v, config)
        assert_allclose(f, v @ motion + 4.0, atol=1e-9, err_msg=name)
        assert_allclose(big_m, np.broadcast_to(motion, big_m.shape), atol=1e-12, err_msg=name)
    for name in ("two", "collinear"):
        p = sets[name]
        on_line = p[0] + np.linspace(-1.0, 2.0, 7)[:, None] * (p[1] - p[0])
        f, big_m, _ = reference.mls(p, p @ rot + 4.0, on_line, config)
        assert_allclose(f, on_line @ rot + 4.0, atol=1e-9, err_msg=name)
        assert_allclose(np.linalg.det(big_m), 1.0, atol=1e-12)  # rotation (affine: similarity)


@pytest.mark.parametrize("transform", glmls.TRANSFORMS)
def test_on_a_handle_m_is_the_limit(rng, transform):
    """A point on a handle with an infinite weight: f = q_i, and M the limit of M nearby."""
    p = _handle_sets(rng)["general"]
    q = p + rng.normal(0, 6, p.shape)
    config = MLSConfig(transform=transform, weight="idw", interpolating=True)
    near = p[:3] + 1e-7 * rng.normal(size=(3, 3))
    f, big_m, _ = reference.mls(p, q, np.vstack([p[:3], near]), config)
    assert_allclose(f[:3], q[:3], rtol=0, atol=1e-12)
    assert_allclose(big_m[:3], big_m[3:], atol=1e-5)
