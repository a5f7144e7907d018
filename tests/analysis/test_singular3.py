"""The closed-form largest and smallest singular values of 3 x 3 matrices, against the
singular values a matrix was built with (U diag(s) V^T, rounded once) and numpy.linalg.svd.

Tolerances, relative: s1 within 16 float64 epsilons; s3 within 16 epsilons times J's
condition number s1 / s3 (the rounding of J's entries moves s3 by about eps x s1 whatever
computes it); the flat rule's decisions as with numpy's SVD, but where s3 lies within that
tolerance of the rule's threshold."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_array_equal

from glmls.analysis.singular3 import det_and_extremes, determinant, singular_extremes
from glmls.analysis.volume_lattice import FLAT_ULPS

EPS = np.finfo(np.float64).eps
RNG = np.random.default_rng(7)
N = 20000


def rotations(n):
    q, _ = np.linalg.qr(RNG.normal(size=(n, 3, 3)))
    return q * np.sign(np.linalg.det(q))[:, None, None]


def with_singular_values(s):
    """Random U diag(s) V^T, s (n, 3)."""
    return rotations(len(s)) @ (s[:, :, None] * rotations(len(s)))


def extremes(matrices):
    return singular_extremes([[matrices[:, a, b] for b in range(3)] for a in range(3)])


def s_sets():
    """(name, matrices, their singular values, largest first)."""
    one = np.ones(N)
    sets = {
        "rotation": np.tile([1.0, 1.0, 1.0], (N, 1)),
        "similarity": RNG.uniform(0.1, 10, (N, 1)) * [1.0, 1.0, 1.0],
        "near similarity": 1 + RNG.uniform(-1e-7, 1e-7, (N, 3)),
        "two large equal": np.tile([2.0, 2.0, 1.0], (N, 1)),
        "two small equal": np.tile([2.0, 1.0, 1.0], (N, 1)),
        "general": RNG.uniform(0.5, 2, (N, 3)),
        "nearly rank 2": np.c_[RNG.uniform(0.5, 2, (N, 2)), 1e-9 * one],
        "nearly rank 1": np.c_[one, 1e-4 * one, RNG.uniform(1e-6, 1e-4, N)],
        "nearly rank 1, a pair": np.c_[one, 1e-4 * one, 1e-4 * one],
        "tiny": RNG.uniform(0.5, 2, (N, 3)) * 1e-30,
        "huge": RNG.uniform(0.5, 2, (N, 3)) * 1e30,
    }
    for name, s in sets.items():
        s = -np.sort(-s, axis=1)
        yield name, with_singular_values(s), s


@pytest.mark.parametrize(("name", "matrices", "s"), list(s_sets()), ids=lambda v: None)
def test_the_extremes_are_those_the_matrices_were_built_with(name, matrices, s):
    s1, s3 = extremes(matrices)
    condition = s[:, 0] / s[:, 2]
    assert np.all(np.abs(s1 - s[:, 0]) <= 16 * EPS * s[:, 0]), name
    assert np.all(np.abs(s3 - s[:, 2]) <= 16 * EPS * condition * s[:, 2]), name


@pytest.mark.parametrize(
    "kind", ["normal", "shear", "reflection", "integers", "tiny normal", "huge normal"]
)
def test_the_extremes_agree_with_numpys_svd(kind):
    matrices = {
        "normal": RNG.normal(size=(N, 3, 3)),
        "shear": np.eye(3) + 10 * np.triu(RNG.normal(size=(N, 3, 3)), 1),
        "reflection": rotations(N) * [[-1.0], [1.0], [1.0]],
        "integers": RNG.integers(-3, 4, (N, 3, 3)).astype(float),
        "tiny normal": RNG.normal(size=(N, 3, 3)) * 1e-30,
        "huge normal": RNG.normal(size=(N, 3, 3)) * 1e30,
    }[kind]
    reference = np.linalg.svd(matrices, compute_uv=False)
    s1, s3 = extremes(matrices)
    assert np.all(np.abs(s1 - reference[:, 0]) <= 16 * EPS * reference[:, 0])
    regular = reference[:, 2] > 1e-12 * reference[:, 0]  # integer matrices: some singular
    tolerance = 16 * EPS * reference[:, 0]  # eps x s1 / s3, relative
    assert np.all(np.abs(s3 - reference[:, 2])[regular] <= tolerance[regular])
    assert np.all(s3[~regular] <= 16 * EPS * reference[~regular, 0])


def test_det_is_the_product_of_the_singular_values_with_the_orientation():
    s = RNG.uniform(0.5, 2, (N, 3))
    matrices = with_singular_values(s) * np.where(RNG.random(N) < 0.5, -1.0, 1.0)[:, None, None]
    det = determinant([[matrices[:, a, b] for b in range(3)] for a in range(3)])
    expected = s.prod(axis=1) * np.sign(np.linalg.det(matrices))
    assert np.all(np.abs(det - expected) <= 32 * EPS * s.max(axis=1) ** 3)


@pytest.mark.parametrize("level", ["zero", "rounding", "threshold", "above"])
@pytest.mark.parametrize("s2", [1.0, 1e-4, 0.0])  # rank 2 up to s3, nearly rank 1, rank 1
def test_the_flat_rule_decides_as_with_numpys_svd(s2, level):
    s1 = RNG.uniform(0.5, 2, N)
    threshold = FLAT_ULPS * EPS * s1  # the rule's, for f exact at the corners
    times = {"zero": 0.0, "rounding": 1e-3, "threshold": RNG.uniform(0.1, 10, N), "above": 1e3}
    s = np.c_[s1, np.full(N, s2), np.minimum(s2, threshold * times[level])]
    matrices = with_singular_values(s)
    reference = np.linalg.svd(matrices, compute_uv=False)
    s1, ours = extremes(matrices)
    flat_svd = reference[:, 2] <= FLAT_ULPS * EPS * reference[:, 0]
    flat = ours <= FLAT_ULPS * EPS * s1
    # near the threshold both round: s3 is known to about eps x s1 (half the threshold)
    decided = np.abs(reference[:, 2] / reference[:, 0] - FLAT_ULPS * EPS) > 16 * EPS
    assert_array_equal(flat[decided], flat_svd[decided])
    assert decided.mean() > 0.8  # the band holds the boundary cases only
    if s2 == 0.0 or level in ("zero", "rounding"):
        assert flat.all()
    if level == "above" and s2 > 0:
        assert not flat.any()


def test_zero_and_exact_diagonals():
    diagonal = RNG.integers(-3, 4, (200, 3)).astype(float)
    matrices = np.zeros((200, 3, 3))
    matrices[:, [0, 1, 2], [0, 1, 2]] = diagonal
    s1, s3 = extremes(matrices)
    magnitudes = np.sort(np.abs(diagonal), axis=1)
    assert_array_equal(s1, magnitudes[:, 2])
    assert_array_equal(s3, magnitudes[:, 0])
    s1, s3 = extremes(np.zeros((3, 3, 3)))
    assert_array_equal(s1, 0.0)
    assert_array_equal(s3, 0.0)


@pytest.mark.parametrize("tiny", [1e-8, 1e-120, 1e-160, 1e-300, 5e-324])
def test_an_identity_but_for_a_tiny_entry_is_no_nan(tiny):
    # A = J^T J then differs from the identity by tiny^2: its spread cubed underflows
    matrices = np.repeat(np.eye(3)[None], 3, axis=0)
    matrices[0, 0, 1], matrices[1, 2, 0], matrices[2, 1, 2] = tiny, -tiny, tiny
    s1, s3 = extremes(matrices)
    reference = np.linalg.svd(matrices, compute_uv=False)
    assert np.all(np.abs(s1 - reference[:, 0]) <= 4 * EPS)
    assert np.all(np.abs(s3 - reference[:, 2]) <= 4 * EPS)


def test_a_condition_beyond_float64_gives_zero_not_nan():
    # s3 / s1 = 1e-300: J^T J's smallest eigenvalue underflows; J is flat by any rule
    s1, s3 = extremes(np.diag([1e150, 1.0, 1e-150])[None])
    assert s1.tolist() == [1e150] and 0 <= s3[0] <= 1e-150


def test_det_from_the_scaled_matrix_has_the_bits_of_the_direct_one_and_no_nan():
    matrices = RNG.normal(size=(N, 3, 3)) * 10.0 ** RNG.integers(-90, 90, (N, 1, 1))
    entries = [[matrices[:, a, b] for b in range(3)] for a in range(3)]
    det, s1, s3 = det_and_extremes(entries)
    assert_array_equal(det, determinant(entries))
    assert_array_equal(s1, singular_extremes(entries)[0])
    assert_array_equal(s3, singular_extremes(entries)[1])
    # J of 1e200: det J overflows to its signed infinity (cofactors would give inf - inf)
    huge = RNG.normal(size=(100, 3, 3)) * 1e200
    det, s1, _ = det_and_extremes([[huge[:, a, b] for b in range(3)] for a in range(3)])
    assert_array_equal(det, np.sign(np.linalg.det(huge / 1e200)) * np.inf)
    assert np.all(np.abs(s1 / 1e200 - np.linalg.svd(huge / 1e200, compute_uv=False)[:, 0]) < 1e-14)
