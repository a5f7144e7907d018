"""The flat rule of the meshes' folds (glmls.core.mesh3.flat_to_zero): det J is 0 where it
is within FLAT_ROUNDINGS roundings of J's entries times |cof J|, bit for bit the plain test
of every vertex (the rule takes |cof J| only where a cheaper bound leaves the answer open)."""

from __future__ import annotations

import numpy as np
import pytest

from glmls.core import mesh3


def _plain(det, jacobian, rounding):
    """The rule at every vertex, as written: |cof J| everywhere, one comparison."""
    size = np.linalg.norm(mesh3.cofactor(jacobian).reshape(len(det), 9), axis=1)
    return np.where(np.abs(det) <= mesh3.FLAT_ROUNDINGS * rounding * size, 0.0, det)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_the_rule_equals_the_plain_test_bit_for_bit(rng, dtype):
    """Random J, half of them of rank 2 to float32's rounding, and det J set at the rule's
    threshold and one rounding either side of it; -0.0, NaN and infinities too. The
    roundings are float32 per vertex (the GPU's), or float64 ones."""
    count = 20000
    j = rng.normal(size=(count, 3, 3)) * np.exp(rng.uniform(-5, 5, (count, 1, 1)))
    flat = rng.random(count) < 0.5
    mix = rng.normal(size=(flat.sum(), 2, 1))
    j[flat, 2] = mix[:, 0] * j[flat, 0] + mix[:, 1] * j[flat, 1]
    j = j.astype(np.float32).astype(np.float64)
    j[5, 0, 0], j[6, 1, 1] = np.nan, np.inf
    rounding = np.exp(rng.uniform(-20, -5, count)).astype(dtype)
    with np.errstate(invalid="ignore", over="ignore"):  # the NaN and infinite J
        det = mesh3.determinant(j, mesh3.cofactor(j)).astype(np.float32).astype(np.float64)
        # a third of them at the threshold, or one rounding below or above it
        size = np.linalg.norm(mesh3.cofactor(j).reshape(count, 9), axis=1)
        edge = rng.random(count) < 0.3
        at = mesh3.FLAT_ROUNDINGS * rounding * size * rng.choice([-1.0, 1.0], count)
        away = rng.choice([0.0, 2.0], count) ** rng.integers(0, 2, count)  # 1, 0 or 2
        det[edge] = np.nextafter(at, at * away)[edge]
        det[:5] = [-0.0, np.nan, np.inf, -np.inf, 0.0]
        expected = _plain(det.copy(), j, rounding)
        got = mesh3.flat_to_zero(det.copy(), j, rounding)
        scalar = mesh3.flat_to_zero(det.copy(), j, 1e-9)
        scalar_expected = _plain(det.copy(), j, 1e-9)
    assert got.tobytes() == expected.tobytes()
    assert 0.2 * count < (got == 0).sum() < 0.9 * count  # both sides of the rule are met
    assert scalar.tobytes() == scalar_expected.tobytes()
