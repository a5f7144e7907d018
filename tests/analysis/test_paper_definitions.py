"""Section 5 of the paper, written out by hand: eqs. (7)-(11) on small cases, computed here
from the printed formulas alone (affine MLS with Table 1's weights, no glmls.reference), and
compared with what glmls reports."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

import glmls
from glmls import reference

SRC = np.array([[2.0, 2.0], [13.0, 3.0], [3.0, 12.0], [12.0, 13.0], [7.0, 7.0]])
DST = SRC + [[0.0, 0.0], [1.0, -1.0], [-1.0, 1.0], [-2.0, -2.0], [1.5, 0.5]]
R, ALPHA, S = 14.0, 1.5, 0.3


def table_1(name: str, d: np.ndarray) -> np.ndarray:
    """Table 1 as printed (shepard's 1 / d read as +inf's stand-in 1e300 at d = 0)."""
    with np.errstate(divide="ignore"):
        return {
            "idw": 1.0 / (S + d ** (2 * ALPHA)),
            "cressman": np.maximum(0.0, (R**2 - d**2) / (R**2 + d**2)),
            "shepard": np.maximum(0.0, (R - d) / (R * np.maximum(d, 1e-300))),
            "gaussian": np.exp(-(d**2) / R**2),
            "linear": np.maximum(0.0, R - d),
        }[name]


def paper_error(name: str, v: np.ndarray) -> np.ndarray:
    """Eq. (7), E(v) = sum_i |p_i M + T - q_i|^2, for the affine fit of eqs. (2)-(4)."""
    errors = []
    for x in v:
        w = table_1(name, np.hypot(*(SRC - x).T))
        p_star, q_star = w @ SRC / w.sum(), w @ DST / w.sum()
        p_hat, q_hat = SRC - p_star, DST - q_star
        big_m = np.linalg.solve((w * p_hat.T) @ p_hat, (w * p_hat.T) @ q_hat)
        t = q_star - p_star @ big_m  # eq. (3)
        errors.append(((SRC @ big_m + t - DST) ** 2).sum())
    return np.array(errors)


@pytest.mark.parametrize("name", glmls.WEIGHTS)
def test_eq_7_with_table_1_weights(gl, name):
    options = dict(transform="affine", weight=name, alpha=ALPHA, s=S)
    if name != "idw":
        options["radius"] = R
    pixels = np.array([[x, y] for y in range(0, 16, 3) for x in range(0, 16, 3)], float)
    expected = paper_error(name, pixels)  # (3, 12) is a handle: shepard's weight is inf there
    assert_allclose(reference.mls_error(SRC, DST, pixels, **options), expected, rtol=1e-10)
    with glmls.MLS(SRC, DST, **options) as m:
        field = m.error_field((16, 16))  # every pixel centre, square pixels
    on_grid = field[pixels[:, 1].astype(int), pixels[:, 0].astype(int)]
    assert_allclose(on_grid, expected, rtol=1e-5)


def test_eqs_8_and_9_over_the_pixels(gl):
    with glmls.MLS(SRC, DST, transform="similarity") as m:
        field = m.error_field((16, 16))
    stats = glmls.analysis.error_stats(field)
    size = field.size  # |I|: every pixel counts once
    mean = field.sum() / size  # eq. (8)
    std = np.sqrt(((field - mean) ** 2).sum() / size)  # eq. (9), over |I|, not |I| - 1
    assert stats["count"] == size
    assert stats["mean"] == pytest.approx(mean, rel=1e-12)
    assert stats["std"] == pytest.approx(std, rel=1e-12)
    assert (stats["min"], stats["max"]) == (field.min(), field.max())
    shares = [np.count_nonzero(np.abs(field - mean) <= k * std) / size for k in (1, 2, 3)]
    assert stats["within"] == pytest.approx(shares)  # fractions, the paper's per cent / 100


def test_eqs_10_and_11_on_a_hand_triangle():
    # a 3-4-5 right triangle under the shear-and-stretch (x, y) -> (x + y / 2, 1.2 y)
    r = np.array([[0.0, 0.0], [4.0, 0.0], [0.0, 3.0]])
    fr = np.array([[0.0, 0.0], [4.0, 0.0], [1.5, 3.6]])
    tri = glmls.analysis.triangle_errors(lambda p: p @ [[1.0, 0.0], [0.5, 1.2]], r)
    assert_allclose(tri.deformed_points, fr)
    # eq. (10): edges 4 -> 4, 5 -> |(2.5, -3.6)|, 3 -> |(1.5, 3.6)| = 3.9, relative
    lengths = [4.0, np.hypot(2.5, 3.6), 3.9]
    distance = (abs(4 - lengths[0]) / 4 + abs(5 - lengths[1]) / 5 + abs(3 - lengths[2]) / 3) / 3
    assert tri.distance[0] == pytest.approx(distance, rel=1e-12)
    # corners before: 90, atan(3/4), atan(4/3) degrees; after, from the deformed edges
    cos_before = np.array([0.0, 4 / 5, 3 / 5])
    cos_after = np.array(
        [
            (4 * 1.5) / (4 * 3.9),
            (-4 * -2.5) / (4 * lengths[1]),
            (-1.5 * 2.5 + -3.6 * -3.6) / (3.9 * lengths[1]),
        ]
    )
    degrees = np.abs(np.degrees(np.arccos(cos_before)) - np.degrees(np.arccos(cos_after)))
    assert tri.angle[0] == pytest.approx(degrees.mean(), rel=1e-12)  # the default measure
    eps = 1e-6
    paper = glmls.analysis.triangle_errors(lambda p: p @ [[1.0, 0.0], [0.5, 1.2]], r, angle="paper")
    eq_11 = ((np.abs(cos_before - cos_after) + eps) / (np.abs(cos_before) + eps)).mean()
    assert paper.angle[0] == pytest.approx(eq_11, rel=1e-12)
    assert paper.angle[0] > 1e5  # the right angle's |cos a| + eps = 1e-6 in the denominator
