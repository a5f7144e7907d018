"""Bad input gets a ValueError/TypeError that names the problem."""

from __future__ import annotations

import numpy as np
import pytest

import glmls
from glmls.core.handles import same_source_pair

P = [[0.0, 0.0], [10.0, 0.0], [0.0, 10.0]]


@pytest.mark.parametrize(
    ("src", "dst", "error", "match"),
    [
        ([[0, 0, 0, 0]], [[0, 0, 0, 0]], ValueError, r"src must have shape \(N, 2\)"),
        ([[0, 0, 0, 0]], [[0, 0, 0, 0]], ValueError, r"or \(N, 3\) as \(x, y, z\) rows, got"),
        ([0, 0], [0, 0], ValueError, r"shape \(N, 2\)"),
        (P, P[:2], ValueError, "same length, got 3 and 2"),
        ([[0, np.nan]], [[0, 0]], ValueError, "src must be finite; row 0"),
        ([[0, 0]], [[np.inf, 0]], ValueError, "dst must be finite"),
        ([[0, 0], [1, 1], [np.inf, 2]], P, ValueError, "src must be finite; row 2"),
        ([["a", "b"]], [[0, 0]], TypeError, "src must be real numbers"),
        ([[1 + 1j, 0]], [[0, 0]], TypeError, "src must be real numbers"),
        ([[1, 1], [1, 1]], [[2, 2], [3, 3]], ValueError, r"src\[0\] and src\[1\] are the same"),
        ([[0, 0], [1]], [[0, 0], [1, 1]], ValueError, r"src must have shape \(N, 2\)"),
        (np.zeros((4, 0)), np.zeros((4, 0)), ValueError, r"src must have shape \(N, 2\)"),
    ],
)
def test_bad_handles(src, dst, error, match):
    with pytest.raises(error, match=match):
        glmls.MLS(src, dst)


@pytest.mark.parametrize(
    ("options", "error", "match"),
    [
        ({"transform": "projective"}, ValueError, "choose one of affine, similarity, rigid"),
        ({"weight": "cubic"}, ValueError, "choose one of idw, cressman, shepard"),
        ({"transform": 3}, TypeError, "transform must be a string"),
        ({"alpha": 0}, ValueError, "alpha must be a finite number > 0"),
        ({"alpha": -1.0}, ValueError, "alpha must be a finite number > 0"),
        ({"alpha": float("nan")}, ValueError, "alpha must be a finite number > 0"),
        ({"alpha": 1000.0}, ValueError, "alpha must be <= 10"),
        ({"alpha": 1e308}, ValueError, "alpha must be <= 10"),
        ({"alpha": "1"}, TypeError, "alpha must be a finite number > 0"),
        ({"s": -1e-3}, ValueError, "s must be a finite number >= 0"),
        ({"radius": 0}, ValueError, "radius must be a finite number > 0"),
        ({"radius": -5.0}, ValueError, "radius must be a finite number > 0"),
        ({"radius": float("inf")}, ValueError, "radius must be a finite number > 0"),
        ({"interpolating": 1}, TypeError, "interpolating must be True or False"),
        ({"shape": (0, 5)}, ValueError, "H, W >= 1"),
        ({"shape": "big"}, TypeError, "shape must be"),
    ],
)
def test_bad_options(options, error, match):
    with pytest.raises(error, match=match):
        glmls.MLS(P, P, **options)


def test_radius_weight_without_radius_or_shape(gl):
    with glmls.MLS(P, P, weight="gaussian", ctx=gl) as m:
        with pytest.raises(ValueError, match="needs an influence radius"):
            m([[1.0, 1.0]])
    with glmls.MLS(P, P, weight="gaussian", shape=(20, 30), ctx=gl) as m:
        assert m.uniforms()["u_radius"] == pytest.approx(np.hypot(20, 30) / m.scaling.scale)


@pytest.mark.parametrize(
    "points",
    [[[1, 2, 3]], np.zeros((2, 2, 2)), [[np.nan, 1]], np.zeros((4, 0)), np.zeros((2, 0, 2))],
)
def test_bad_points(gl, points):
    with glmls.MLS(P, P, ctx=gl) as m, pytest.raises(ValueError, match="points"):
        m(points)


def test_empty_points_give_empty_results(gl):
    with glmls.MLS(P, P, ctx=gl) as m:
        assert m(np.zeros((0, 2))).shape == (0, 2)
        big_m, t = m.matrices([])
        assert big_m.shape == (0, 2, 2) and t.shape == (0, 2)


def test_same_source_pairs_match_brute_force():
    """Ties in x are common on a lattice: the pair found conflicts, and one is found iff any."""
    rng = np.random.default_rng(3)
    for _ in range(200):
        p = rng.integers(0, 4, (12, 2)).astype(float)
        q = p + rng.integers(0, 2, (12, 2))  # same p: often the same q, sometimes not
        conflicts = {
            (i, j)
            for i in range(12)
            for j in range(i + 1, 12)
            if (p[i] == p[j]).all() and (q[i] != q[j]).any()
        }
        pair = same_source_pair(p, q)
        assert (pair is None) == (not conflicts)
        assert pair is None or pair in conflicts


def test_exact_duplicate_pairs_are_accepted(gl):
    src = [[0, 0], [0, 0], [10, 0], [0, 10]]
    dst = [[1, 1], [1, 1], [11, 1], [1, 11]]
    with glmls.MLS(src, dst, transform="affine", ctx=gl) as m:
        np.testing.assert_allclose(m([[5.0, 5.0]]), [[6.0, 6.0]], atol=1e-3)


def test_release_twice_is_harmless_and_use_after_release_is_clear(gl):
    m = glmls.MLS(P, P, ctx=gl)
    m.release()
    m.release()
    assert m.released and "released" in repr(m)
    with pytest.raises(glmls.ReleasedError, match="released"):
        m([[1.0, 1.0]])
    with pytest.raises(glmls.ReleasedError):
        m.mesh((4, 4))
    with pytest.raises(glmls.ReleasedError, match="released"), m:
        pass


def test_handles_are_read_only_copies(gl):
    src = np.array(P)
    with glmls.MLS(src, src, ctx=gl) as m:
        src[0] = 99
        assert m.src[0].tolist() == [0.0, 0.0]
        with pytest.raises(ValueError):
            m.src[0, 0] = 1.0


def test_set_handles_matches_a_new_mls(gl):
    src = np.array([[10.0, 10.0], [90.0, 20.0], [50.0, 80.0]])
    dst = src + [[5.0, 0.0], [0.0, -4.0], [3.0, 3.0]]
    points = np.array([[30.0, 40.0], [60.0, 60.0]])
    with glmls.MLS(src[:1], src[:1], shape=(100, 100)) as m:
        m.set_handles(src, dst)
        with glmls.MLS(src, dst, shape=(100, 100)) as fresh:
            np.testing.assert_allclose(m(points), fresh(points), atol=1e-4)
            assert m.scaling == fresh.scaling
        np.testing.assert_array_equal(m.dst, dst)
        assert not m.dst.flags.writeable


def test_set_handles_rejects_bad_handles_and_keeps_the_old(gl):
    src = np.array([[0.0, 0.0], [10.0, 0.0], [0.0, 10.0]])
    with glmls.MLS(src, src + 1, transform="affine") as m:
        with pytest.raises(ValueError, match="same length"):
            m.set_handles(src, src[:2])
        with pytest.raises(glmls.DegenerateHandlesError):
            m.set_handles(src[:2], src[:2])
        np.testing.assert_array_equal(m.dst, src + 1)
        np.testing.assert_allclose(m([[5.0, 5.0]]), [[6.0, 6.0]], atol=1e-4)
    with pytest.raises(glmls.ReleasedError):
        m.set_handles(src, src)


def test_points_of_no_coordinates_are_refused_in_3d(gl):
    """(4, 0) points were taken for no points: four rows in, none out."""
    p3 = [[0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [0.0, 10.0, 0.0], [0.0, 0.0, 10.0]]
    with glmls.MLS(p3, p3, ctx=gl) as m:
        with pytest.raises(ValueError, match=r"points must have shape \(N, 3\)"):
            m(np.zeros((4, 0)))
        assert m(np.zeros((0, 3))).shape == (0, 3)


def test_numpy_bools_and_strings_are_taken_as_python_ones():
    """``interpolating=np.True_`` (a mask's element, say) was refused as not a bool."""
    config = glmls.MLSConfig(transform=np.str_("affine"), interpolating=np.True_)
    assert config.interpolating is True and type(config.transform) is str
    assert config == glmls.MLSConfig(transform="affine", interpolating=True)


@pytest.mark.parametrize(
    ("bad", "message"),
    [
        (np.nan, r"points must be finite; row 2"),
        (np.inf, r"points must be finite; row 2"),
        (-np.inf, r"points must be finite; row 2"),
        (2e6, r"points must lie within ±1e\+06 voxels of the origin .* row 2"),
        (-2e6, r"points must lie within ±1e\+06 voxels of the origin .* row 2"),
    ],
)
def test_points3_name_the_first_bad_row(bad: float, message: str) -> None:
    from glmls.core.handles3 import as_points3

    points = np.zeros((4, 3))
    points[2, 1] = bad
    points[3, 0] = bad
    with pytest.raises(ValueError, match=message):
        as_points3(points)
    good = np.array([[1e6, -1e6, 0.5]])
    assert np.array_equal(as_points3(good), good)  # the limit itself is within


def test_mls_config_takes_keywords_only():
    """As WarpOptions and MLS's options: ``MLSConfig("affine", "idw", 2.0, 0.5)`` read which of
    alpha and s is which from the fields' order."""
    with pytest.raises(TypeError, match="positional"):
        glmls.MLSConfig("affine", "idw", 2.0, 0.5)  # type: ignore[misc]
    assert glmls.MLSConfig(transform="affine", alpha=2.0, s=0.5).s == 0.5


def test_no_points_of_the_other_dimension_are_refused(gl):
    """(0, 3) points were taken by a 2D MLS as no points (and (0, 2) by a 3D one): empty or
    not, rows of another width are another dimension's points, as scikit-image refuses them."""
    p3 = [[0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [0.0, 10.0, 0.0], [0.0, 0.0, 10.0]]
    with glmls.MLS([[0.0, 0.0]], [[1.0, 0.0]], ctx=gl) as m, glmls.MLS(p3, p3, ctx=gl) as m3:
        for mls, other, width in ((m, (0, 3), 2), (m3, (0, 2), 3)):
            for call in (mls, mls.inverse, lambda x, f=mls: f.residuals(x, x)):
                with pytest.raises(ValueError, match=rf"must have shape \(N, {width}\).*{other}"):
                    call(np.zeros(other))
            for empty in ([], np.zeros(0), np.zeros((0, width))):
                assert mls(empty).shape == (0, width)
    for src, dst in (((0, 2), (0, 3)), ((0, 3), (0, 2)), ((0, 5), (0, 5))):
        with pytest.raises(ValueError, match="must have shape"):
            glmls.MLS(np.zeros(src), np.zeros(dst), ctx=gl)


def test_the_repr_shows_the_shape_that_sets_the_default_radius(gl):
    """With ``radius=None`` a radius weight reaches the diagonal of ``shape``: two MLS of
    other shapes are other maps, and their reprs say so (as a 3D MLS's does)."""
    src, dst = [[2.0, 2.0], [20.0, 4.0]], [[3.0, 2.0], [20.0, 8.0]]
    with (
        glmls.MLS(src, dst, weight="cressman", shape=(6, 8), ctx=gl) as small,
        glmls.MLS(src, dst, weight="cressman", shape=(100, 300), ctx=gl) as large,
    ):
        assert np.abs(small([[12.0, 6.0]]) - large([[12.0, 6.0]])).max() > 0.5
        assert repr(small).endswith("interpolating=False, shape=(6, 8))")
        assert repr(large) != repr(small)
    with glmls.MLS(src, dst, ctx=gl) as m:
        assert repr(m).endswith("interpolating=False)")
