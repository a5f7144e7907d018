"""Property tests over random handle sets (hypothesis)."""

from __future__ import annotations

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

import glmls

SETTINGS = settings(
    max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
# integer source positions keep distinct handles at least 1 px apart
handle_sets = st.lists(
    st.tuples(st.integers(0, 500), st.integers(0, 500)), min_size=1, max_size=24, unique=True
).map(lambda pts: np.array(pts, dtype=np.float64))
# extrapolating far beyond a tiny cluster needs more than float32 (documented): keep the
# handles spread over at least 16 px where whole-image motions are compared
spread_sets = handle_sets.filter(lambda a: len(a) >= 3 and np.ptp(a, axis=0).max() >= 16)
configs = st.tuples(st.sampled_from(glmls.TRANSFORMS), st.sampled_from(glmls.WEIGHTS))
seeds = st.integers(0, 2**32 - 1)


def _mls(gl, p, q, transform, weight, **options):
    options.setdefault("radius", 2000.0)  # reaches every point of the 500 x 500 square
    options.setdefault("shape", (501, 501))  # the image: float32 scaling covers it
    if transform == "affine":
        # float32 affine degrades with the handles' aspect ratio (documented); keep it sane
        unique = np.unique(p, axis=0)
        sv = np.linalg.svd(unique - unique.mean(0), compute_uv=False)
        if len(unique) < 3 or sv[1] < 0.05 * sv[0]:
            transform = "similarity"
    return glmls.MLS(p, q, transform=transform, weight=weight, ctx=gl, **options)


def _motion_tolerance(v, expected):
    """0.01 px, plus float32's share when extrapolating a large motion far from the handles:
    q is stored to ~1e-7 of the image size, and that error grows with the lever arm."""
    return 0.01 + 5e-5 * np.abs(expected - v).max()


def _rotation(angle, scale=1.0):
    c, s = np.cos(angle) * scale, np.sin(angle) * scale
    return np.array([[c, s], [-s, c]])


@SETTINGS
@given(p=handle_sets, config=configs, seed=seeds)
def test_no_nan_anywhere(gl, p, config, seed):
    rng = np.random.default_rng(seed)
    q = p + rng.uniform(-80, 80, p.shape)
    v = np.concatenate([p, rng.uniform(-100, 600, (64, 2)), p + 1e-4])
    for options in ({}, {"radius": 30.0}, {"interpolating": True}):
        with _mls(gl, p, q, *config, **options) as m:
            big_m, t = m.matrices(v)
            assert np.isfinite(m(v)).all()
        assert np.isfinite(big_m).all() and np.isfinite(t).all()


@SETTINGS
@given(
    p=handle_sets,
    transform=st.sampled_from(glmls.TRANSFORMS),
    seed=seeds,
    options=st.sampled_from(
        [
            {"weight": "idw", "s": 0.0},
            {"weight": "idw"},
            {"weight": "shepard"},
            {"weight": "gaussian", "interpolating": True},
        ]
    ),
)
def test_interpolates_where_the_weight_is_infinite_at_zero(gl, p, transform, seed, options):
    q = p + np.random.default_rng(seed).uniform(-60, 60, p.shape)
    with _mls(gl, p, q, transform, **options) as m:
        assert_allclose(m(p), q, atol=1e-3)


@SETTINGS
@given(p=handle_sets, config=configs, seed=seeds)
def test_identity_when_targets_equal_sources(gl, p, config, seed):
    v = np.random.default_rng(seed).uniform(-50, 550, (100, 2))
    with _mls(gl, p, p, *config) as m:
        assert_allclose(m(v), v, atol=1e-3)


@SETTINGS
@given(
    p=spread_sets,
    config=configs,
    seed=seeds,
    angle=st.floats(-3.1, 3.1),
    shift=st.tuples(st.floats(-100, 100), st.floats(-100, 100)),
)
def test_rigid_motion_is_reproduced_by_every_transform(gl, p, config, seed, angle, shift):
    rot = _rotation(angle)
    q = p @ rot + shift
    v = np.random.default_rng(seed).uniform(0, 500, (100, 2))
    expected = v @ rot + shift
    with _mls(gl, p, q, *config) as m:
        assert_allclose(m(v), expected, atol=_motion_tolerance(v, expected))


@SETTINGS
@given(
    p=spread_sets,
    seed=seeds,
    transform=st.sampled_from(["affine", "similarity"]),
    weight=st.sampled_from(glmls.WEIGHTS),
    scale=st.floats(0.3, 3.0),
    angle=st.floats(-3.1, 3.1),
)
def test_uniform_scale_is_reproduced_by_similarity_and_affine(
    gl, p, seed, transform, weight, scale, angle
):
    lin = _rotation(angle, scale)
    q = p @ lin + [20.0, -15.0]
    v = np.random.default_rng(seed).uniform(0, 500, (100, 2))
    expected = v @ lin + [20.0, -15.0]
    with _mls(gl, p, q, transform, weight) as m:
        assert_allclose(m(v), expected, atol=_motion_tolerance(v, expected))
