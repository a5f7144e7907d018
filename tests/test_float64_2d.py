"""glmls's MLS in 2D against an independent float64 implementation of the paper (``mls64``).

Both ``glmls.reference`` and the GPU (``glmls.MLS(...)(points)`` and ``m.matrices``) are
checked, for every transform, every weight of ``glmls.WEIGHTS`` with its parameters, and
``interpolating``, at random points inside and around a 96 x 128 image, on the handles and
next to them. Segment handles are checked against the limit they are defined as: densely
sampled point handles weighted per unit of length (Schaefer et al. 2006, section 4).

Tolerances: the reference within 1e-9 px (f) and 1e-9 (M), float64 rounding; the GPU, in
float32 on coordinates scaled to the image (spacing ~1e-7 of its size), within 1e-5 of the
image's size for f (0.0013 px here) and 1e-4 for M; affine with a radius, where points have
only two handles in reach, 1e-4 of the size (0.013 px) and 3e-4: there the ridge toward the
similarity solution (docs/mathematics.md, "Affine near one line") divides float32's rounding
of the moments' small eigenvalue, ~1e-7 of their trace, by 1e-3.
"""

from __future__ import annotations

import numpy as np
import pytest
from mls64 import mls64, sampled_segments

import glmls
from glmls import reference

H, W = 96, 128
SIZE = max(H, W)
rng = np.random.default_rng(0)
P = rng.uniform(5, [W - 5, H - 5], (7, 2))
Q = P + rng.uniform(-8, 8, P.shape)
POINTS = np.concatenate([rng.uniform(-20, [W + 20, H + 20], (60, 2)), P, P + 0.3, P - 2e-2])

PARAMETERS = {
    "idw": [{}, {"alpha": 2.0}, {"alpha": 0.5, "s": 0.0}, {"s": 5.0}, {"interpolating": True}],
    "radius": [
        {"radius": 60.0},
        {"radius": 200.0},
        {"radius": 60.0, "interpolating": True},
        {"radius": 200.0, "alpha": 2.0, "interpolating": True},
    ],
}
CASES = [
    (transform, weight, params)
    for transform in glmls.TRANSFORMS
    for weight in glmls.WEIGHTS
    for params in PARAMETERS["idw" if weight == "idw" else "radius"]
]


def case_id(case):
    transform, weight, params = case
    return "-".join([transform, weight, *(f"{k}={v}" for k, v in params.items())])


@pytest.mark.parametrize("case", CASES, ids=case_id)
def test_reference_and_gpu_are_the_paper(gl, case):
    transform, weight, params = case
    f0, m0, t0 = mls64(P, Q, POINTS, transform, weight, **params)
    f1, m1, t1 = reference.mls(P, Q, POINTS, transform=transform, weight=weight, **params)
    assert np.abs(f1 - f0).max() < 1e-9
    assert np.abs(m1 - m0).max() < 1e-9
    assert np.abs(t1 - t0).max() < 1e-7
    with glmls.MLS(P, Q, transform=transform, weight=weight, shape=(H, W), **params) as m:
        f2 = m(POINTS)
        m2, t2 = m.matrices(POINTS)
    ridge = transform == "affine" and "radius" in params
    f_tol, m_tol = (1e-4 * SIZE, 3e-4) if ridge else (1e-5 * SIZE, 1e-4)
    assert np.abs(f2 - f0).max() < f_tol
    assert np.abs(m2 - m0).max() < m_tol
    assert np.abs(t2 - t0).max() < f_tol + m_tol * np.abs(POINTS).max()


def assert_gpu_next_to_a_handle(transform, v, f0, m0, params) -> None:
    """The GPU's f and M at ``v`` next to a handle, against float64's ``f0`` and ``m0``:
    affine inverts the others' 2 x 2 moments, tiny against the handle's (M within 3e-4)."""
    with glmls.MLS(P, Q, transform=transform, shape=(H, W), **params) as m:
        assert np.abs(m(v) - f0).max() < 1e-5 * SIZE
        assert np.abs(m.matrices(v)[0] - m0).max() < (3e-4 if transform == "affine" else 1e-4)


@pytest.mark.parametrize("weight", glmls.WEIGHTS)
def test_handles_are_interpolated_where_the_weight_is_infinite(gl, weight):
    """f(p_i) = q_i exactly where w is infinite at d = 0 (idw with s = 0, shepard, any weight
    made interpolating); M there is the limit, the fit of the other handles about p_i."""
    params = {"s": 0.0} if weight == "idw" else {"radius": 150.0, "interpolating": True}
    f0, m0, _ = mls64(P, Q, P, "similarity", weight, **params)
    assert np.array_equal(f0, Q)
    near, _, _ = mls64(P, Q, P + 1e-7, "similarity", weight, **params)  # the limit, from aside
    assert np.abs(near - Q).max() < 1e-5
    f1, m1, _ = reference.mls(P, Q, P, transform="similarity", weight=weight, **params)
    assert np.abs(f1 - Q).max() < 1e-12 and np.abs(m1 - m0).max() < 1e-9
    with glmls.MLS(P, Q, transform="similarity", weight=weight, shape=(H, W), **params) as m:
        assert np.abs(m(P) - Q).max() < 1e-3
        assert np.abs(m.matrices(P)[0] - m0).max() < 1e-4


STEEP = [
    {"weight": "idw", "alpha": 1.5, "interpolating": True},
    {"weight": "gaussian", "radius": 25.0, "alpha": 2.0, "interpolating": True},
    {"weight": "shepard", "radius": 25.0, "alpha": 2.0, "interpolating": True},
    {"weight": "linear", "radius": 40.0, "alpha": 2.0, "interpolating": True},
]


@pytest.mark.parametrize("params", STEEP, ids=lambda params: params["weight"])
@pytest.mark.parametrize("transform", glmls.TRANSFORMS)
def test_m_next_to_a_handle_whose_weight_is_steep(gl, transform, params):
    """Within 1e-2 px of a handle whose weight grows like 1 / d^(2 alpha) with alpha > 1, its
    own w d^2 is 1e17 times the others' spread about p*: that is no sign of coincident
    sources (M = I), M is still the others' fit, continuous up to the handle's limit; and
    the others' moments (~1e-27 on the GPU) are not lost to float32 underflow."""
    v = np.concatenate([P + 1e-3, P - 3e-3, P + [4e-3, -2e-3]])
    f0, m0, _ = mls64(P, Q, v, transform, **params)
    limit = mls64(P, Q, P, transform, **params)[1]
    assert np.abs(m0 - np.tile(limit, (3, 1, 1))).max() < 1e-2  # continuous
    f1, m1, _ = reference.mls(P, Q, v, transform=transform, **params)
    assert np.abs(f1 - f0).max() < 1e-9
    assert np.abs(m1 - m0).max() < 1e-6
    assert_gpu_next_to_a_handle(transform, v, f0, m0, params)


@pytest.mark.parametrize("transform", glmls.TRANSFORMS)
def test_m_next_to_a_handle_of_idw_alpha_4_keeps_the_others(gl, transform):
    """idw with s = 0 and alpha = 4, just outside the snapping distance: the others weigh
    (d / D)^8 ~ 1e-31 of the nearest, inside float32's range (docs/mathematics.md,
    "Coincident sources"), so M is their fit, not the nearest's alone (I)."""
    v = np.concatenate([P + [2e-3, 0.0], P - [0.0, 5e-3]])
    params = {"alpha": 4.0, "s": 0.0}
    f0, m0, _ = mls64(P, Q, v, transform, **params)
    assert np.abs(m0 - np.eye(2)).max() > 0.02  # I would fail the checks below
    assert_gpu_next_to_a_handle(transform, v, f0, m0, params)


@pytest.mark.parametrize("params", [{"s": 0.0}, {"s": 1e-30}], ids=["s=0", "s=1e-30"])
@pytest.mark.parametrize("transform", glmls.TRANSFORMS)
def test_m_next_to_a_handle_of_idw_alpha_10_keeps_the_others(gl, transform, params):
    """idw with alpha = 10 next to a handle (on it, where s > 0 keeps its weight finite):
    the others weigh (d / D)^20, 1e-50 of the nearest and less, below float32's range
    relative to it; relative to the nearest of them they are in range, and M is their fit,
    not the nearest's alone (I)."""
    v = np.concatenate([P, P + [5e-2, 0.0], P - [0.0, 0.2]])
    params = {"alpha": 10.0, **params}
    f0, m0, _ = mls64(P, Q, v, transform, **params)
    assert np.abs(m0 - np.eye(2)).max() > 0.02  # I would fail the checks below
    f1, m1, _ = reference.mls(P, Q, v, transform=transform, **params)
    assert np.abs(f1 - f0).max() < 1e-9
    assert np.abs(m1 - m0).max() < 1e-9
    assert_gpu_next_to_a_handle(transform, v, f0, m0, params)


def far_tail_points(radius: float, low: float, high: float, count: int) -> np.ndarray:
    """Points around the image where the nearest handle apart from the nearest one's place
    weighs exp(-low) to exp(-high) of the nearest's under the gaussian of ``radius``."""
    far = np.random.default_rng(5)
    v = np.concatenate([far.uniform(-90, -20, (600, 2)), far.uniform(W + 20, W + 90, (600, 2))])
    d2 = np.sort(((P[None] - v[:, None]) ** 2).sum(-1), axis=1)
    excess = (d2[:, 1] - d2[:, 0]) / radius**2
    v = v[(excess > low) & (excess < high)]
    assert len(v) >= count
    return v[:count]


@pytest.mark.parametrize("transform", glmls.TRANSFORMS)
def test_m_is_the_fit_of_the_handles_apart_in_a_gaussians_far_tail(gl, transform):
    """Tens of pixels from every handle with R = 12 px, where the other handles weigh
    exp(-30) to exp(-55) of the nearest: their spread about p* still decides M, however
    small their weights, because the moments are taken about the nearest handle, which adds
    nothing to them (not a translation, M = I, where the nearest outweighs them). mls64
    computes exp(-d^2 / R^2) about v and keeps its digits only to exp(-30) or so: there it
    checks the reference, and beyond it a rigid motion, which every transform and weighting
    reproduces, checks both."""
    config = glmls.MLSConfig(transform=transform, weight="gaussian", radius=12.0)
    if transform != "affine":  # affine's moments there are nearly singular: its own rule
        near = far_tail_points(12.0, 16.0, 28.0, 40)
        f0, m0, _ = mls64(P, Q, near, transform, "gaussian", radius=12.0)
        f1, m1, _ = reference.mls(P, Q, near, config)
        assert np.abs(f1 - f0).max() < 1e-6
        assert np.abs(m1 - m0).max() < 1e-6
    tail = far_tail_points(12.0, 30.0, 55.0, 100)
    turn = np.array([[np.cos(0.4), np.sin(0.4)], [-np.sin(0.4), np.cos(0.4)]])
    moved = P @ turn + [3.0, -2.0]
    f_ref, m_ref, _ = reference.mls(P, moved, tail, config)
    assert np.abs(f_ref - (tail @ turn + [3.0, -2.0])).max() < 1e-7
    assert np.abs(m_ref - turn).max() < 1e-9
    f_ref, m_ref, _ = reference.mls(P, Q, tail, config)
    assert (np.abs(m_ref - np.eye(2)).max(axis=(1, 2)) > 1e-2).all()  # no translation
    # affine inverts the 2 x 2 moments of the handles apart, nearly singular there where the
    # nearest of them outweighs the rest (det A down to 1e-5 (tr A)^2): in float32 up to
    # 0.03 px over the 100 px from the handles (measured 0.027)
    tolerance = 0.05 if transform == "affine" else 1e-5 * SIZE
    with glmls.MLS.from_config(P, moved, config) as m:
        assert np.abs(m(tail) - (tail @ turn + [3.0, -2.0])).max() < tolerance
    with glmls.MLS.from_config(P, Q, config) as m:
        assert np.abs(m(tail) - f_ref).max() < tolerance
        assert np.abs(m.matrices(tail)[0] - m_ref).max() < (1e-3 if transform == "affine" else 1e-4)


@pytest.mark.parametrize("transform", glmls.TRANSFORMS)
def test_the_deep_tail_does_not_underflow(gl, transform):
    """With R = 4 px the others weigh exp(-100) to exp(-600) of the nearest, below float32's
    range (~e^-87): relative to the nearest handles apart from the nearest one's place they
    do not underflow, and M is still their fit, on the GPU as in the reference."""
    config = glmls.MLSConfig(transform=transform, weight="gaussian", radius=4.0)
    v = far_tail_points(4.0, 100.0, 600.0, 100)
    turn = np.array([[np.cos(0.4), np.sin(0.4)], [-np.sin(0.4), np.cos(0.4)]])
    moved = P @ turn + [3.0, -2.0]
    tolerance = 0.05 if transform == "affine" else 1e-5 * SIZE
    f_ref, _, _ = reference.mls(P, moved, v, config)
    assert np.abs(f_ref - (v @ turn + [3.0, -2.0])).max() < 1e-7
    with glmls.MLS.from_config(P, moved, config) as m:
        assert np.abs(m(v) - f_ref).max() < tolerance
    f_ref, m_ref, _ = reference.mls(P, Q, v, config)
    assert (np.abs(m_ref - np.eye(2)).max(axis=(1, 2)) > 1e-2).all()
    with glmls.MLS.from_config(P, Q, config) as m:
        assert np.abs(m(v) - f_ref).max() < tolerance


def test_f_is_continuous_in_a_gaussians_tail(gl):
    """Along a line out of four handles' square into the gaussian's tail (R = 50 px, the
    others down to exp(-80) of the nearest), f moves by about the step: it does not jump."""
    p = np.array([[0.0, 0], [200, 0], [0, 200], [200, 200]])
    q = p @ np.array([[0.94, 0.34], [-0.34, 0.94]]) + [3.0, 2.0]
    s = np.arange(0.0, 150.0, 0.5)
    v = -np.stack([s, s], 1)
    for transform in glmls.TRANSFORMS:
        f_ref, _, _ = reference.mls(p, q, v, transform=transform, weight="gaussian", radius=50.0)
        with glmls.MLS(p, q, transform=transform, weight="gaussian", radius=50.0) as m:
            f = m(v)
        for g in (f_ref, f):
            steps = np.linalg.norm(np.diff(g, axis=0), axis=1)
            assert steps.max() < 1.5 * np.median(steps), transform
        assert np.abs(f - f_ref).max() < 1e-3


def test_affine_takes_the_similarity_solution_where_the_handles_in_reach_are_on_a_line(gl):
    """Two handles in a compact weight's reach (the rest beyond R): the affine fit is not
    defined, and both glmls's reference and the GPU take the similarity solution."""
    p = np.array([[10.0, 10.0], [40.0, 12.0], [200.0, 200.0], [10.0, 200.0]])
    q = p + [[2.0, 1.0], [-1.0, 3.0], [0.0, 0.0], [0.0, 0.0]]
    v = np.array([[25.0, 20.0], [20.0, 5.0]])
    options = {"weight": "cressman", "radius": 60.0}
    similarity, _, _ = mls64(p, q, v, "similarity", **options)
    affine, _, _ = mls64(p, q, v, "affine", **options)
    assert np.abs(affine - similarity).max() < 1e-12
    f, _, _ = reference.mls(p, q, v, transform="affine", **options)
    assert np.abs(f - similarity).max() < 1e-9
    with glmls.MLS(p, q, transform="affine", shape=(256, 256), **options) as m:
        assert np.abs(m(v) - similarity).max() < 1e-3


EDGE_CASES = {
    # a second handle enters reach: the translation of one turns into a rotation
    "two": ([[100.0, 100], [160, 100]], [[0.0, 0], [0, 10]], [110.0, 100.0]),
    # a third handle enters reach: the similarity of two becomes the exact fit of three
    "three": ([[100.0, 100], [140, 100], [120, 160]], [[0.0, 0], [5, 0], [-10, 8]], [120.0, 110.0]),
}
COMPACT = [w for w in glmls.RADIUS_WEIGHTS if w != "gaussian"]


def across_edge(case: str, offsets) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """p, q and points at ``offsets`` px along the line from the last handle through the
    case's point, from the edge of its reach at R = 50 px (negative: inside)."""
    p, q, v = (np.array(a) for a in EDGE_CASES[case])
    toward = (v - p[-1]) / np.linalg.norm(v - p[-1])
    edge = p[-1] + 50.0 * toward
    return p, p + q, edge + np.asarray(offsets)[:, None] * toward


@pytest.mark.parametrize("transform", ["rigid", "similarity"])
@pytest.mark.parametrize("weight", COMPACT)
def test_f_jumps_where_a_second_handle_enters_a_compact_weights_reach(gl, transform, weight):
    """MLS itself is discontinuous at the edge of a compact weight's reach where the handle
    that enters decides what the one in reach left free: as its weight tends to 0 the
    rotation tends to the one it makes exact, not to the identity of one handle. The GPU
    follows the float64 implementation across that edge (R = 50 px, points 0.001 px on
    either side), jump included."""
    p, q, points = across_edge("two", [-1e-3, 1e-3])
    options = {"weight": weight, "radius": 50.0}
    expected, _, _ = mls64(p, q, points, transform, **options)
    assert np.linalg.norm(expected[1] - expected[0]) > 1.0  # the jump, in float64
    with glmls.MLS(p, q, transform=transform, **options) as m:
        assert np.abs(m(points) - expected).max() < 1e-3


@pytest.mark.parametrize("weight", COMPACT)
def test_affine_is_continuous_where_a_third_handle_enters_a_compact_weights_reach(gl, weight):
    """Where a third handle enters reach off the line of two, the affine fit of three is
    exact however small its weight; the ridge toward the similarity solution makes the
    change continuous (f within 1e-3 px across 2e-7 px of the edge), though steep: about
    2 px over the last 0.01 px of the reach. The GPU follows the float64 implementation
    outside that ramp."""
    p, q, points = across_edge("three", [-1e-7, 1e-7, -1.0, -0.1, 0.1, 1.0])
    options = {"weight": weight, "radius": 50.0}
    expected, _, _ = mls64(p, q, points, "affine", **options)
    assert np.linalg.norm(expected[1] - expected[0]) < 1e-3
    assert np.linalg.norm(expected[2] - expected[5]) > 1.0  # the fit of three against two
    with glmls.MLS(p, q, transform="affine", **options) as m:
        assert np.abs(m(points[2:]) - expected[2:]).max() < 1e-3


def test_affine_near_one_line_is_continuous(gl):
    """Four handles, one 0.5 px off the line of the others, moved by a few pixels (idw): the
    exact affine fit sends points 20 px off the line by ~90 px, and a switch to the
    similarity solution at a threshold tore f there (94 px between points 0.016 px apart).
    Along lines across the plane f moves by about the step, in float64 and on the GPU, and
    the GPU follows the float64 implementation."""
    p = np.array([[0.0, 100], [100, 100], [200, 100], [100, 100.5]])
    q = p + [[0, 0], [0, 3], [0, 0], [2, 1]]
    t = np.linspace(0.0, 1.0, 4001)[:, None]
    with glmls.MLS(p, q, transform="affine") as m:
        for a, b in (([-50.0, 50], [250, 150]), ([100.0, 0], [100, 200])):
            v = np.array(a) + t * (np.array(b) - np.array(a))
            expected, _, _ = mls64(p, q, v, "affine")
            f = m(v)
            step = np.linalg.norm(np.array(b) - np.array(a)) / 4000
            for g in (expected, f):
                assert np.linalg.norm(np.diff(g, axis=0), axis=1).max() < 10 * step
            assert np.abs(f - expected).max() < 1e-3


SEGMENT_CASES = [
    ("idw", {}),
    ("idw", {"alpha": 2.0}),
    ("idw", {"alpha": 0.75, "s": 0.0}),
    ("gaussian", {"radius": 40.0}),
    ("cressman", {"radius": 200.0}),
    ("shepard", {"radius": 300.0}),
    ("linear", {"radius": 300.0}),
    ("gaussian", {"radius": 60.0, "interpolating": True}),
]


@pytest.fixture(scope="module")
def segments():
    rng = np.random.default_rng(1)
    a = np.array([[[20.0, 20.0], [100.0, 30.0]], [[30.0, 80.0], [60.0, 50.0]]])
    b = a + rng.uniform(-6, 6, a.shape)
    v = rng.uniform(0, [W, H], (40, 2))
    # points at least 3 px from the segments, where 4,000 samples per segment converge
    t = np.clip(
        np.einsum("ksi,si->ks", v[:, None] - a[None, :, 0], a[:, 1] - a[:, 0])
        / ((a[:, 1] - a[:, 0]) ** 2).sum(-1),
        0,
        1,
    )
    foot = a[None, :, 0] + t[..., None] * (a[:, 1] - a[:, 0])[None]
    v = v[np.hypot(*(v[:, None] - foot).transpose(2, 0, 1)).min(1) > 3]
    return a, b, v, sampled_segments(a, b, 4000)


@pytest.mark.parametrize("transform", glmls.TRANSFORMS)
@pytest.mark.parametrize(("weight", "params"), SEGMENT_CASES)
def test_segments_are_the_limit_of_dense_point_handles(gl, segments, transform, weight, params):
    a, b, v, (ps, qs, length) = segments
    p, q = np.array([[110.0, 80.0]]), np.array([[113.0, 78.0]])
    dense = np.concatenate([p, ps]), np.concatenate([q, qs])
    density = np.concatenate([[1.0], length])
    f0, m0, _ = mls64(*dense, v, transform, weight, density=density, **params)
    options = {"transform": transform, "weight": weight, "src_segments": a, "dst_segments": b}
    f1, m1, _ = reference.mls(p, q, v, **options, **params)
    assert np.abs(f1 - f0).max() < 1e-6  # the midpoint rule's error at 3 px and more
    assert np.abs(m1 - m0).max() < 1e-7
    with glmls.MLS(p, q, shape=(H, W), **options, **params) as m:
        assert np.abs(m(v) - f0).max() < 1e-5 * SIZE
        assert np.abs(m.matrices(v)[0] - m0).max() < 1e-4
        if weight in ("idw", "shepard") or params.get("interpolating"):
            t = np.linspace(0, 1, 9)[:, None]
            for (a0, a1), (b0, b1) in zip(a, b, strict=True):
                on = m((1 - t) * a0 + t * a1)
                assert np.abs(on - ((1 - t) * b0 + t * b1)).max() < 1e-3


@pytest.mark.parametrize("weight", ["cressman", "shepard", "gaussian", "linear"])
@pytest.mark.parametrize("transform", glmls.TRANSFORMS)
def test_m_next_to_a_handle_of_an_interpolating_weight_of_alpha_8(gl, transform, weight):
    """Any weight made interpolating (w / d^(2 alpha)) with alpha = 8 next to a handle: the
    others weigh (d / D)^16 of the nearest, below float32's range relative to it; relative
    to the nearest of them they are in range, and M is their fit, not the nearest's alone."""
    v = np.concatenate([P + [5e-2, 0.0], P - [0.0, 3e-3]])
    params = {"weight": weight, "radius": 150.0, "alpha": 8.0, "interpolating": True}
    f0, m0, _ = mls64(P, Q, v, transform, **params)
    assert np.abs(m0 - np.eye(2)).max() > 0.02  # I would fail the checks below
    f1, m1, _ = reference.mls(P, Q, v, transform=transform, **params)
    assert np.abs(f1 - f0).max() < 1e-9
    assert np.abs(m1 - m0).max() < 1e-6
    assert_gpu_next_to_a_handle(transform, v, f0, m0, params)
