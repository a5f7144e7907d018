"""Thousands of handles crowding a few spatial bins, and gaussian points far from every handle,
on a driver that caps a shader's loop iterations (Mesa's llvmpipe: 65,535 over all the loops
of an invocation): f and its inverse either count every handle or say that they cannot, never
a value that left handles out. On a GPU the same cases check plain correctness."""

from __future__ import annotations

import numpy as np
import pytest

import glmls
from glmls import reference
from glmls.engine.loops import CAPPED_NEWTON_HANDLES

#: f^-1's residual accepted (pixels), as glmls.imaging.inverse.NEWTON_ACCEPT.
ACCEPT = 0.05


def far_apart_with_a_crowd(crowd, *, extra=None, spacing=0.012):
    """Two handles 10,000 px apart (the bins, at most 1,024 a side, are ~10 px wide) and a
    patch of ``crowd`` handles spaced ``spacing`` px, all moved 30 px right: they fall into
    a bin or two."""
    side = int(np.ceil(np.sqrt(crowd)))
    y, x = np.divmod(np.arange(crowd), side)
    patch = np.stack([x, y], 1) * spacing + [100.0, 100.0]
    src = np.concatenate([[[-5000.0, 0.0], [5000.0, 0.0]], patch])
    dst = src + np.concatenate([np.zeros((2, 2)), np.tile([30.0, 0.0], (crowd, 1))])
    return src, dst


def test_f_in_a_crowded_bin_counts_every_handle(gl, rng):
    """25,000 handles in one bin: one evaluation through the bins walks them one a loop
    iteration, three times (75,000 > 65,535): f visits them all instead, sixteen an
    iteration."""
    src, dst = far_apart_with_a_crowd(25_000, spacing=0.004)
    options = {"weight": "cressman", "radius": 0.5}
    v = [100.0, 100.0] + rng.uniform(0.1, 0.5, (64, 2))
    with glmls.MLS(src, dst, **options, ctx=gl) as m:
        f = m(v)
    expected, _, _ = reference.mls(src, dst, v, **options)
    np.testing.assert_allclose(f, expected, atol=1e-3)


def test_no_preimage_is_found_where_f_walks_a_crowded_bin(gl, rng):
    """1,600 cressman discs of radius 0.012 px in one bin, moved 3,000 px: the points among
    them have no preimage. Newton's passes made ~60 evaluations of 4,800 loop iterations
    each, f left every handle out past the cap and read as the identity: u was its own
    preimage for 10 points in 200."""
    src, dst = far_apart_with_a_crowd(1_600)
    dst[2:] += [2970.0, 0.0]
    options = {"weight": "cressman", "radius": 0.012}
    u = [100.0, 100.0] + rng.uniform(0.05, 0.4, (200, 2))
    with glmls.MLS(src, dst, **options, ctx=gl) as m:
        s, valid = m.inverse(u, return_valid=True)
    assert not valid.any()
    assert np.isnan(s).all()


def test_the_inverse_in_a_crowded_bin_is_f_s(gl, rng):
    """The crowd moved 30 px: u 30 px right of it has its preimage in the crowd, found."""
    src, dst = far_apart_with_a_crowd(1_600)
    options = {"weight": "cressman", "radius": 0.05}
    u = [130.0, 100.0] + rng.uniform(0.1, 0.4, (100, 2))
    with glmls.MLS(src, dst, **options, ctx=gl) as m:
        s, valid = m.inverse(u, return_valid=True)
    assert valid.all()
    f, _, _ = reference.mls(src, dst, s, **options)
    assert np.hypot(*(f - u).T).max() <= ACCEPT


def test_newton_through_crowded_bins_keeps_what_the_cap_left_whole(gl, rng):
    """More handles than a Newton pass may visit all on llvmpipe (it walks the bins), 3,000
    of them within a 6 px patch: an evaluation there walks ~13,000 loop iterations, five fit
    in the cap. Newton keeps the last iterate whose f was whole, the second dispatch goes on
    from it: every point accepted is a preimage (5 in 300 were up to 3 px off)."""
    lattice = np.stack(np.meshgrid(np.arange(0, 1024, 4.0), np.arange(0, 1024, 4.0)), -1)
    crowd = rng.uniform(500, 506, (3000, 2))
    src = np.concatenate([lattice.reshape(-1, 2), crowd])
    assert len(src) > CAPPED_NEWTON_HANDLES
    dst = src.copy()
    dst[-len(crowd) :] += [3.0, 1.0]
    options = {"weight": "cressman", "radius": 24.0}
    u = rng.uniform(495, 512, (300, 2))
    with glmls.MLS(src, dst, **options, ctx=gl) as m:
        assert m.kernel.bins is not None
        s, valid = m.inverse(u, return_valid=True)
    assert valid.mean() > 0.9
    f, _, _ = reference.mls(src, dst, s[valid], **options)
    assert np.hypot(*(f - u[valid]).T).max() <= ACCEPT


def test_gaussian_far_from_a_crowd_counts_every_handle(gl, rng):
    """20,000 gaussian handles in a 200 px square of a 1,000 px plane: a point far from
    them walks every one, several times, through the bins (f was 880 px off)."""
    src = rng.uniform(400, 600, (20_000, 2))
    dst = src + rng.normal(0, 3, src.shape)
    options = {"weight": "gaussian", "radius": 4.0}
    v = np.concatenate([rng.uniform(0, 1000, (40, 2)), rng.uniform(450, 550, (40, 2))])
    with glmls.MLS(src, dst, **options, ctx=gl) as m:
        f = m(v)
    with glmls.MLS(src, dst, **options, bins=False, ctx=gl) as plain:
        np.testing.assert_allclose(f, plain(v), atol=1e-3)


def test_bins_asked_for_where_they_cannot_serve_are_refused(gl):
    if gl.loop_limit is None:
        pytest.skip("this driver runs every loop iteration")
    src, dst = far_apart_with_a_crowd(25_000, spacing=0.004)
    with pytest.raises(ValueError, match=r"bins=True: one evaluation of f .* llvmpipe"):
        glmls.MLS(src, dst, weight="cressman", radius=0.5, bins=True, ctx=gl)


def test_more_handles_than_one_evaluation_may_visit_are_refused(gl, rng):
    """A million handles, sixteen a loop iteration, walked thrice: more than the cap."""
    if gl.loop_limit is None:
        pytest.skip("this driver runs every loop iteration")
    src = rng.uniform(0, 50, (1_000_000, 2))
    with pytest.raises(ValueError, match=r"1,000,000 handles: one evaluation of f .* llvmpipe"):
        glmls.MLS(src, src + 1.0, ctx=gl)
    with glmls.MLS(src[:200_000], src[:200_000] + 1.0, ctx=gl) as m:
        np.testing.assert_allclose(m([[10.0, 10.0]]), [[11.0, 11.0]], atol=1e-3)


def test_points_whose_lanes_walk_apart_are_evaluated_alone(gl):
    """5,000 handles in one bin, f at a column of points through it: the eight points that
    llvmpipe runs together walk the crowd at different rows of their squares, and their
    iterations add up past the cap (16 of 64 were NaN). Those points are evaluated again,
    each alone in its vector of lanes."""
    src, dst = far_apart_with_a_crowd(5_000, spacing=0.004)
    options = {"weight": "cressman", "radius": 50.0}
    ys = np.linspace(-45, 45, 64)
    v = np.stack([np.full_like(ys, 100.1), 100.1 + ys], 1)
    with glmls.MLS(src, dst, **options, ctx=gl) as m:
        f = m(v)
    expected, _, _ = reference.mls(src, dst, v, **options)
    np.testing.assert_allclose(f, expected, atol=1e-3)


def test_the_nearest_handles_second_square_counts(gl, rng):
    """Four crowds of 10,000 handles at the corners of a 36 px square, R = 10 px, the
    handles' mean spacing just under R: a point at the centre finds no handle in its first
    square and looks in one of up to twice the reach, which holds all four crowds (a square
    of the reach holds one). The warp equals the one visiting every handle (1,746 pixels
    were background)."""
    centre = np.array([32.0, 32.0])
    corners = [(-1, -1), (1, -1), (-1, 1), (1, 1)]
    crowds = [rng.uniform(-0.5, 0.5, (10_000, 2)) + centre + 18.0 * np.array(c) for c in corners]
    side = 0.95 * 10.0 * np.sqrt(40_000)
    src = np.concatenate([[centre - side / 2, centre + side / 2], *crowds])
    dst = src + [2.0, 1.0]
    options = {"weight": "cressman", "radius": 10.0}
    image = (np.arange(64 * 64) % 251).astype(np.uint8).reshape(64, 64)
    v = centre + rng.uniform(-0.8, 0.8, (16, 2))
    with glmls.MLS(src, dst, **options, ctx=gl) as m:
        warped = m.warp(image)
        f = m(v)
    with glmls.MLS(src, dst, **options, bins=False, ctx=gl) as plain:
        np.testing.assert_array_equal(warped, plain.warp(image))
    np.testing.assert_allclose(f, reference.mls(src, dst, v, **options)[0], atol=1e-3)


def test_affine_segments_beyond_the_cap_are_refused(gl):
    """Affine's float64 moments walk the segments once more for each point: 12,000
    segments take more than the cap (f was NaN)."""
    if gl.loop_limit is None:
        pytest.skip("this driver runs every loop iteration")
    x = np.linspace(0, 1000, 12_001)
    a = np.stack([np.stack([x[:-1], 0 * x[:-1]], 1), np.stack([x[1:], 0 * x[1:]], 1)], 1)
    far = np.array([[500.0, 3000.0]])
    with pytest.raises(ValueError, match=r"1 handle and 12,000 segments: one evaluation"):
        glmls.MLS(far, far, src_segments=a, dst_segments=a + 5.0, transform="affine", ctx=gl)


def test_newton_through_bins_that_fit_no_step_is_refused(gl):
    """9,000 handles in one bin (more than a Newton pass visits all on llvmpipe): one Newton
    step, four evaluations of f, exceeds the cap, and no point could be found."""
    src, dst = far_apart_with_a_crowd(9_000, spacing=0.004)
    u = np.stack([np.full(8, 130.1), np.linspace(60, 140, 8)], 1)
    with glmls.MLS(src, dst, weight="cressman", radius=50.0, ctx=gl) as m:
        if gl.loop_limit is not None:
            with pytest.raises(ValueError, match=r"9,002 handles crowd the spatial bins: one step"):
                m.inverse(u)
            return
        s, valid = m.inverse(u, return_valid=True)
    assert valid.all()
    f, _, _ = reference.mls(src, dst, s, weight="cressman", radius=50.0)
    assert np.hypot(*(f - u).T).max() <= ACCEPT


def test_refusals_name_what_to_change(gl, rng):
    """The advice never sends the user around in a circle: where visiting every handle
    cannot serve either, bins=True is told to use fewer handles, and bins=False to try
    the bins."""
    if gl.loop_limit is None:
        pytest.skip("this driver runs every loop iteration")
    spread = rng.uniform(0, 5000, (258_000, 2))
    crowd = rng.uniform(100, 100.05, (12_000, 2))
    src = np.concatenate([spread, crowd])
    options = {"weight": "cressman", "radius": 5.0, "ctx": gl}
    with pytest.raises(ValueError, match="use fewer handles or a GPU"):
        glmls.MLS(src, src + 1.0, bins=True, **options)
    with pytest.raises(ValueError, match=r"spatial bins \(bins=None\) where they spread"):
        glmls.MLS(src, src + 1.0, bins=False, **options)
    with pytest.raises(ValueError, match="nor can the spatial bins"):
        glmls.MLS(src, src + 1.0, **options)
