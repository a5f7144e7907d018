"""f's inverse at points (``MLS.inverse``, :class:`glmls.InverseMLS`) and ``MLS.residuals``:
solved on the GPU, checked against the float64 reference (glmls.reference)."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

import glmls
from glmls import reference
from glmls.core.mesh import MeshLattice
from glmls.imaging.inverse import NEWTON_ACCEPT
from glmls.imaging.pipeline import GUESS_MESH_POINTS, WarpPipeline
from glmls.mls import GUESS_MESH_LIMIT

#: |f(inverse(u)) - u| with f in float64 (glmls.reference), pixels: Newton stops below
#: 1e-4 px on the GPU's float32 f, whose own error here is ~1e-5 px.
EXACT = 1e-3
SHAPE = (60, 80)
SRC = np.array([[10, 10], [70, 12], [12, 50], [68, 48], [40, 30]], float)
DST = SRC + [[3, -2], [-4, 3], [2, 4], [5, -3], [-2, -2]]


def back_error(m: glmls.MLS, s: np.ndarray, u: np.ndarray) -> np.ndarray:
    f, _, _ = reference.mls(
        m.src, m.dst, s, m.config, shape=m.shape, src_segments=m.src_segments,
        dst_segments=m.dst_segments,
    )  # fmt: skip
    return np.hypot(*(f - u).T)


@pytest.mark.parametrize("transform", ["rigid", "similarity", "affine"])
def test_f_of_the_inverse_is_the_point(gl, transform, rng):
    inside = rng.uniform([-0.5, -0.5], [79.5, 59.5], (400, 2))
    outside = rng.uniform([-80, -60], [160, 120], (100, 2))  # the plane past the image too
    u = np.concatenate([inside, outside, DST])
    with glmls.MLS(SRC, DST, transform=transform, shape=SHAPE, ctx=gl) as m:
        s, valid = m.inverse(u, return_valid=True)
        assert s.shape == (len(u), 2) and s.dtype == np.float64
        assert valid.all()
        assert back_error(m, s, u).max() < EXACT
        assert_allclose(s[-len(DST) :], SRC, atol=EXACT)  # the handles interpolate
        # and the other way: where f is one-to-one, inverse(f(v)) is v
        v = rng.uniform([0, 0], [79, 59], (200, 2))
        assert_allclose(m.inverse(m(v)), v, atol=5 * EXACT)


def test_segments_and_radius_weights(gl, rng):
    segments_src = np.array([[[20, 40], [60, 40]]], float)
    segments_dst = np.array([[[22, 44], [58, 38]]], float)
    u = rng.uniform([0, 0], [79, 59], (300, 2))
    with glmls.MLS(
        SRC, DST, src_segments=segments_src, dst_segments=segments_dst, weight="gaussian",
        shape=SHAPE, ctx=gl,
    ) as m:  # fmt: skip
        s, valid = m.inverse(u, return_valid=True)
        assert valid.all()
        assert back_error(m, s, u).max() < EXACT


def test_points_spread_far_apart_use_a_coarser_guess(gl, rng):
    """Points over 10^4 px: the first guess's canvas is coarser than a pixel and its mesh
    does not reach the farthest (Newton starts from u there, where f is close to its
    far-field affine map); all land, within float32's ~1e-7 of the coordinates."""
    u = np.concatenate([rng.uniform(-4000, 6000, (200, 2)), rng.uniform(0, 60, (50, 2))])
    with glmls.MLS(SRC, DST, transform="similarity", shape=SHAPE, ctx=gl) as m:
        s, valid = m.inverse(u, return_valid=True)
        assert valid.all()
        tolerance = np.maximum(EXACT, 2e-7 * np.abs(u).max(axis=1))
        assert (back_error(m, s, u) < tolerance).all()


def test_no_preimage_gives_nan():
    """One handle moved 10 px left with a compact-support weight: inside its reach f is that
    translation, outside it the identity. A point within the reach of p but farther than R
    from p + d has no preimage (s = u + 10 would lie outside the reach, s = u inside it)."""
    p, d, radius = np.array([40.0, 30.0]), np.array([-10.0, 0.0]), 20.0
    crescent = np.array([[55, 30], [52, 36], [58, 26], [45, 45]], float)
    assert (np.hypot(*(crescent - p).T) < radius).all()
    assert (np.hypot(*(crescent - p - d).T) > radius).all()
    covered = np.array([[30, 30], [25, 35], [70, 30], [5, 5], [40, 55]], float)
    with glmls.MLS([p], [p + d], weight="cressman", radius=radius, shape=SHAPE) as m:
        s, valid = m.inverse(np.concatenate([crescent, covered]), return_valid=True)
        assert_array_equal(valid, [False] * 4 + [True] * 5)
        assert np.isnan(s[:4]).all() and np.isfinite(s[4:]).all()
        assert back_error(m, s[4:], covered).max() < EXACT
        assert np.isnan(m.inverse(crescent)).all()  # without the mask: NaN rows


def test_a_map_that_collapses_the_plane():
    """Every target one point: a similarity map with scale 0, f = q everywhere."""
    with glmls.MLS([[0, 0], [10, 0], [0, 10]], [[5, 5]] * 3, transform="similarity") as m:
        s, valid = m.inverse([[5, 5], [7, 7], [500, -50]], return_valid=True)
        assert valid.tolist() == [True, False, False]
        assert_allclose(m(s[:1]), [[5, 5]], atol=EXACT)


def test_hostile_points(gl):
    with glmls.MLS(SRC, DST, shape=SHAPE, ctx=gl) as m:
        inverse = m.inverse
        for empty in (np.zeros((0, 2)), [], np.zeros((0, 2), np.float32)):
            out = inverse(empty)
            assert out.shape == (0, 2) and out.dtype == np.float64
        out, valid = inverse(np.zeros((0, 2)), return_valid=True)
        assert valid.shape == (0,) and valid.dtype == bool
        with pytest.raises(ValueError, match="finite; row 1"):
            inverse([[1, 2], [np.nan, 3]])
        with pytest.raises(ValueError, match="finite"):
            inverse([[np.inf, 3]])
        with pytest.raises(ValueError, match=r"shape \(N, 2\)"):
            inverse([[1, 2, 3]])
        with pytest.raises(ValueError, match=r"shape \(N, 2\)"):
            inverse(np.zeros((2, 2, 2)))
        with pytest.raises(TypeError, match="real numbers"):
            inverse([["a", "b"]])
        with pytest.raises(ValueError, match="1e\\+06"):
            inverse([[2e6, 0]])
        # 5 images away, and beyond the first guess's reach (Newton from u itself, where f
        # is close to its far-field affine map; float32 keeps ~1e-7 of the coordinates)
        for far in ([[400.0, -300.0]], [[1e5, -1e5]], [[400.0, -300.0], [1e5, -1e5]]):
            s, valid = inverse(far, return_valid=True)
            assert valid.all()
            far = np.array(far)
            tolerance = np.maximum(EXACT, 1e-7 * np.abs(far).max(axis=1))
            assert (back_error(m, s, far) < tolerance).all()
        assert_allclose(inverse(np.array([[30, 20]], np.int64)), inverse([[30.0, 20.0]]))


@pytest.mark.parametrize(
    ("src", "dst"),
    [([[5.0, 5.0]], [[8.0, 9.0]]), ([[5.0, 5.0], [6.0, 5.0]], [[8.0, 9.0], [9.0, 9.0]])],
)
def test_far_points_of_handles_in_a_pixel_box_keep_their_preimage(gl, src, dst):
    """Handles within a pixel and no shape: Newton's differences there shrink with the box
    (an eighth of a pixel), below float32's step of points 5e5-9e5 px away; they take at
    least 2^-16 of the point's coordinate, so f (a translation by (3, 4)) is inverted
    there too instead of every far point being left without a preimage."""
    u = np.array([[6e5, 6e5], [9e5, 9e5], [-9.5e5, 4e5]])
    with glmls.MLS(src, dst, ctx=gl) as m:
        s, valid = m.inverse(u, return_valid=True)
    assert valid.all()
    tolerance = 1e-7 * np.abs(u).max(axis=1) * 4
    assert (np.abs(s - (u - [3.0, 4.0])).max(axis=1) <= tolerance).all()


def test_the_inverse_follows_set_handles_and_release(gl):
    m = glmls.MLS([[10, 10]], [[12, 10]], shape=SHAPE, ctx=gl)
    inverse = m.inverse
    assert inverse.inverse is m and m.inverse.inverse is m
    assert_allclose(inverse([[20, 20]]), [[18, 20]], atol=EXACT)
    m.set_handles([[10, 10]], [[10, 15]])
    assert_allclose(inverse([[20, 20]]), [[20, 15]], atol=EXACT)  # no stale first guess
    assert_allclose(m.inverse([[20, 20]]), [[20, 15]], atol=EXACT)
    m.set_handles(SRC, DST)
    u = np.array([[30.0, 30.0], [50, 10]])
    assert back_error(m, inverse(u), u).max() < EXACT
    m.release()
    with pytest.raises(glmls.ReleasedError):
        m.inverse  # noqa: B018
    with pytest.raises(glmls.ReleasedError):
        inverse([[1, 2]])
    with pytest.raises(glmls.ReleasedError):
        m.residuals([[1, 2]], [[1, 2]])


def test_without_shape_and_with_a_coarser_guess(gl, rng):
    u = rng.uniform(0, 70, (100, 2))
    with glmls.MLS(SRC, DST, ctx=gl) as m:  # the first guess's image: the handles' box
        s = m.inverse(u)
        assert back_error(m, s, u).max() < EXACT
        coarse = glmls.InverseMLS(m, grid=4)
        assert_allclose(coarse(u), s, atol=EXACT)
        assert repr(coarse).startswith("InverseMLS(MLS(5 handles") and "grid=4" in repr(coarse)
    with glmls.MLS([], [], ctx=gl) as m:  # the identity, no handles
        assert_allclose(m.inverse([[3, 4], [-50, 700]]), [[3, 4], [-50, 700]])
    with glmls.MLS(SRC, DST, weight="gaussian", ctx=gl) as m:
        with pytest.raises(ValueError, match="needs an influence radius"):
            m([[1, 2]])
        with pytest.raises(ValueError, match="needs an influence radius"):
            m.inverse([[1, 2]])


def test_without_shape_handles_far_from_the_origin_keep_the_guess_small(gl, monkeypatch):
    """Without a shape the first guess's image runs from pixel (0, 0) to the handles: handles
    9e5 px away span an image of 8e11 pixels, whose mesh takes a coarser step so that it
    stays within GUESS_MESH_POINTS points (at grid 1 it would not finish)."""
    meshes = []
    solve = WarpPipeline.inverse_points

    def bounded(self, mls, points, shape, *, grid=1):
        lattice = MeshLattice.corners(shape, grid)
        meshes.append(lattice.count)
        assert lattice.count <= 2 * GUESS_MESH_POINTS, f"a guess mesh of {lattice.count} points"
        return solve(self, mls, points, shape, grid=grid)

    monkeypatch.setattr(WarpPipeline, "inverse_points", bounded)
    src = np.array([[0.0, 0.0], [9e5, 10.0], [10.0, 9e5]])
    u = np.array([[3.0, 3.0], [4.5e5, 4.5e5], [9e5 + 1, 11.0]])
    with glmls.MLS(src, src + 1, ctx=gl) as m:
        s, valid = m.inverse(u, return_valid=True)
        assert valid.all() and meshes
        assert_allclose(m(s), u, atol=0.5)


@pytest.mark.parametrize(
    ("shape", "grid", "step"),
    [
        ((10**6, 10**6), 1, 245),
        ((4097, 4096), 1, 2),
        ((4096, 4096), 1, 1),
        ((10**6, 10**6), 300, 300),
    ],
)
def test_a_large_shape_starts_from_a_coarser_mesh(gl, monkeypatch, shape, grid, step):
    """An MLS of shape (10**6, 10**6) started from a mesh of 1e12 points, evaluated band
    by band: it did not finish. The guess's mesh holds at most a 4096 x 4096 image's corners
    (the most texels it is drawn into), at the least step from the grid asked on, and Newton
    finds the preimages."""
    steps = []
    solve = WarpPipeline.inverse_points

    def bounded(self, mls, points, shape, *, grid=1):
        steps.append(grid)
        assert MeshLattice.corners(shape, grid).count <= GUESS_MESH_LIMIT
        return solve(self, mls, points, shape, grid=grid)

    monkeypatch.setattr(WarpPipeline, "inverse_points", bounded)
    with glmls.MLS(SRC, DST, shape=shape, ctx=gl) as m:
        s, valid = glmls.InverseMLS(m, grid=grid)(DST, return_valid=True)
        assert valid.all()
        assert_allclose(m(s), DST, atol=1e-3)
    assert steps == [step]


def test_inverse_mls_checks_its_arguments(gl):
    with pytest.raises(TypeError, match=r"forward must be a glmls\.MLS"):
        glmls.InverseMLS(object())  # type: ignore[arg-type]
    with glmls.MLS(SRC, DST, ctx=gl) as m:
        with pytest.raises(ValueError, match="grid"):
            glmls.InverseMLS(m, grid=0)
        with pytest.raises(TypeError):
            m.inverse([[1, 2]], True)  # type: ignore[misc]


def test_inverse_mls_of_a_3d_mls_is_its_3d_inverse(gl):
    """``glmls.InverseMLS(m)`` of a 3D MLS is what ``m.inverse`` gives (as ``glmls.MLS``
    makes the class of its handles' dimension); the 3D inverse refuses a 2D MLS by name."""
    p3 = np.array([[0.0, 0, 0], [9, 0, 0], [0, 9, 0], [0, 0, 9]])
    with glmls.MLS(p3, p3 + [1, 2, 3], ctx=gl) as m3, glmls.MLS(SRC, DST, ctx=gl) as m:
        inverse = glmls.InverseMLS(m3)
        assert type(inverse) is type(m3.inverse) and inverse.inverse is m3
        assert_allclose(inverse([[5, 7, 9]]), [[4, 5, 6]], atol=1e-3)
        assert type(glmls.InverseMLS(m)) is glmls.InverseMLS
        with pytest.raises(TypeError, match=r"forward must be a glmls\.MLS of \(N, 3\) handles"):
            type(m3.inverse)(m)


def test_the_mask_is_the_residual_threshold(gl):
    """The rows the mask keeps are those Newton solved within NEWTON_ACCEPT."""
    with glmls.MLS([[40, 30]], [[30, 30]], weight="cressman", radius=20, ctx=gl) as m:
        u = np.array([[30.0, 30.0], [55, 30]])  # the second in the crescent: no preimage
        s, valid = m.inverse(u, return_valid=True)
        assert valid.tolist() == [True, False]
        assert m.residuals(s[:1], u[:1])[0] <= NEWTON_ACCEPT


@pytest.mark.parametrize("unit", [1e-2, 1e-5])
def test_handles_in_a_small_box_get_the_inverse_of_millimetres(gl, unit, rng):
    """Handles in metres (no shape): Newton's step and tolerances shrink with their box, so
    that the inverse is the one the same handles in millimetres get, to float32's precision
    of the box (a quarter-unit step and 1e-4 unit tolerance solved a box 8e-4 wide only to
    ~6% of its side), and a point of the crescent without a preimage stays invalid (0.05
    units accepted anything near the box)."""
    u = rng.uniform(5, 75, (40, 2))
    with glmls.MLS(SRC, DST, s=0.0, ctx=gl) as m:  # s = 0: the same map in any unit
        millimetres = m.inverse(u)
    side = 80 * unit
    with glmls.MLS(SRC * unit, DST * unit, s=0.0, ctx=gl) as m:
        s, valid = m.inverse(u * unit, return_valid=True)
        assert valid.all()
        assert np.abs(s / unit - millimetres).max() < 1e-3
        assert back_error(m, s, u * unit).max() < 1e-5 * side
    src, dst = np.array([[40.0, 30.0]]) * unit, np.array([[30.0, 30.0]]) * unit
    with glmls.MLS(src, dst, weight="cressman", radius=20 * unit, ctx=gl) as m:
        u = np.array([[30.0, 30.0], [55, 30]]) * unit  # the second in the crescent
        s, valid = m.inverse(u, return_valid=True)
        assert valid.tolist() == [True, False]
        assert_allclose(s[0], src[0], atol=1e-5 * 20 * unit)


def test_residuals(gl, rng):
    src = rng.uniform(0, 60, (30, 2))
    dst = src + rng.normal(0, 2, src.shape)
    with glmls.MLS(SRC, DST, shape=SHAPE, ctx=gl) as m:
        r = m.residuals(src, dst)
        assert r.shape == (30,) and r.dtype == np.float64
        f, _, _ = reference.mls(SRC, DST, src, m.config, shape=SHAPE)
        assert_allclose(r, np.hypot(*(f - dst).T), atol=1e-3)
        assert_allclose(m.residuals(SRC, DST), 0, atol=1e-3)  # the handles interpolate
        assert m.residuals(np.zeros((0, 2)), []).shape == (0,)
        with pytest.raises(ValueError, match="same length, got 30 and 29"):
            m.residuals(src, dst[:-1])
        with pytest.raises(ValueError, match="dst must have shape"):
            m.residuals(src, dst[:, :1])
        with pytest.raises(ValueError, match="src must be finite"):
            m.residuals([[np.nan, 0]], [[0, 0]])
        inverse = m.inverse.residuals(DST, SRC)
        assert inverse.shape == (5,) and inverse.max() < EXACT


@pytest.mark.parametrize("dst", [DST, SRC[[0, 1, 3, 2, 4]]], ids=["smooth", "folding"])
def test_at_pixel_centres_it_is_the_coordinate_map(gl, dst):
    """Over an image's pixel centres the first guess is drawn pixel for pixel, as the
    ``backward`` method's: the same preimage, where f folds too (the first cell in scan
    order), up to Newton's tolerance. With twice the steps, a few more pixels are solved.

    A pixel centre on the very edge of the fold's first cell may be given to either layer:
    the rasterizer's tie rule for points on an edge is the driver's, the compute scan's its
    own. Such points must be rare and still take a true preimage (f(s) = u)."""
    rows, cols = np.mgrid[0 : SHAPE[0], 0 : SHAPE[1]]
    pixels = np.stack([cols.ravel(), rows.ravel()], -1).astype(float)
    with glmls.MLS(SRC, dst, shape=SHAPE, ctx=gl) as m:
        xy, residual = m.coordinate_map(SHAPE, residual=True, border="edge")
        s, valid = m.inverse(pixels, return_valid=True)
        solved = (residual <= NEWTON_ACCEPT).ravel()
        assert valid[solved].all() and (valid & ~solved).sum() < 0.001 * len(pixels)
        same = np.all(np.abs(s - xy.reshape(-1, 2)) <= 0.01, axis=1)
        other = solved & ~same
        assert other.sum() <= 0.001 * len(pixels)
        assert_allclose(m(s[other]), pixels[other], atol=0.01)
    if np.array_equal(dst, DST):  # f is one to one: one preimage only
        assert not other.any()


def test_a_translation_near_the_coordinate_limit_keeps_every_pixel(gl):
    """Handles and canvas 9.5e5 px away, within the 1e6 px coordinates may reach: float32
    steps by 0.0625 px there, more than the 0.05 px residual a preimage needs near the
    image, so the residual accepted grows to a few of float32's steps (backward, the batch's
    backward and the inverse at points)."""
    height, width = 24, 32
    image = np.full((height, width), 200, np.uint8)
    src = np.array([[3.0, 3.0], [28.0, 3.0], [3.0, 20.0], [28.0, 20.0]])
    shift = np.array([-9.5e5, 9e5])
    frame = {"output_shape": (height, width), "origin": tuple(shift)}
    with glmls.MLS(src, src + shift, shape=(height, width), ctx=gl) as m:
        assert (m.warp(image, method="backward", **frame) == 200).all()
        s, valid = m.inverse(shift + [[0.0, 5.0], [10.0, 5.0]], return_valid=True)
    assert valid.all()
    assert np.abs(s - [[0.0, 5.0], [10.0, 5.0]]).max() < 0.1
    batch = glmls.warp_batch(
        image[None], src[None], (src + shift)[None], method="backward", ctx=gl, **frame
    )
    assert (batch == 200).all()


@pytest.mark.parametrize("transform", ["affine", "rigid"])
def test_a_thousandfold_magnification_keeps_every_pixel(gl, transform):
    """Targets a thousand times as far apart as the sources: a float32 step of a preimage
    moves f(s) by more than the 0.05 px accepted elsewhere, so the residual accepted grows
    with f's stretch at s (backward, the batch's backward, the inverse at points). Each
    preimage is within float32's reach of the float64 one: a few thousandths of a source
    pixel."""
    rng = np.random.default_rng(1)
    src = rng.uniform(0, 63, (8, 2))
    center = np.array([31.5, 31.5])
    dst = (src - center) * 1000 + center + rng.normal(0, 3000, (8, 2))
    frame = {"output_shape": (64, 64), "origin": (0.0, 0.0)}
    rows, cols = np.mgrid[:64, :64]
    image = ((cols // 4 + rows // 4) % 2 * 255).astype(np.uint8)
    u = np.stack([cols, rows], -1).reshape(-1, 2).astype(float)
    with glmls.MLS(src, dst, transform=transform, ctx=gl) as m:
        xy = m.coordinate_map((64, 64), **frame).reshape(-1, 2).astype(np.float64)
        backward = m.warp(image, method="backward", background=7, **frame)
        quads = m.warp(image, method="quads", background=7, **frame)
        s, valid = m.inverse(u[::97], return_valid=True)
        batch = glmls.warp_batch(
            image[None], src[None], dst[None], transform=transform, method="backward",
            background=7, ctx=gl, **frame,
        )  # fmt: skip
    assert (backward != 7).all()
    assert (backward == quads).mean() > 0.999  # quads: the mesh's, not f's, at cells' edges
    assert_array_equal(batch[0], backward)
    assert valid.all()
    # |f(s) - u| in float64, over f's stretch (~1,000 here): the error of s, source pixels
    assert (back_error(m, xy, u) / 1000).max() < 5e-3
    assert (back_error(m, s, u[::97]) / 1000).max() < 5e-3


def test_a_thousandfold_magnification_in_3d_keeps_every_point(gl):
    """The inverse at points in 3D accepts the residual that f's stretch makes of s's
    rounding, as in 2D."""
    rng = np.random.default_rng(1)
    src = rng.uniform(0, 63, (10, 3))
    center = np.full(3, 31.5)
    dst = (src - center) * 1000 + center + rng.normal(0, 3000, (10, 3))
    u = rng.uniform(20, 40, (20, 3))
    with glmls.MLS(src, dst, transform="affine", ctx=gl) as m:
        s, valid = m.inverse(u, return_valid=True)
    assert valid.all()
    f = reference.mls(src, dst, s, m.config)[0]
    assert (np.linalg.norm(f - u, axis=1) / 1000).max() < 5e-3  # s's error, source voxels


def _preimages_inside(m: glmls.MLS, u: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """Whether each point of ``u`` has a preimage in the image's box by f in float64: the
    nearest of f's values on a quarter-pixel lattice of sources, refined by Newton."""
    height, width = shape
    rows, cols = np.mgrid[-0.5 : height - 0.5 : 0.25, -0.5 : width - 0.5 : 0.25]
    lattice = np.stack([cols.ravel(), rows.ravel()], -1)
    f = lambda v: reference.mls(m.src, m.dst, v, m.config, shape=shape)[0]  # noqa: E731
    values = f(lattice)
    found = np.zeros(len(u), bool)
    for k, point in enumerate(u):
        for start in lattice[np.argsort(np.hypot(*(values - point).T))[:4]]:
            s = start.copy()
            for _ in range(30):
                r = f(s[None])[0] - point
                h = 1e-5
                jacobian = np.stack([f((s + d)[None])[0] - r - point for d in np.eye(2) * h]) / h
                if np.hypot(*r) < 1e-6 or abs(np.linalg.det(jacobian)) < 1e-12:
                    break
                s = s - np.linalg.solve(jacobian.T, r)
            inside = (s >= -0.5).all() and (s <= [width - 0.5, height - 0.5]).all()
            if np.hypot(*(f(s[None])[0] - point)) < 1e-3 and inside:
                found[k] = True
                break
    return found


def test_backward_finds_the_preimages_next_to_a_handle(gl):
    """A pixel whose preimage lies half a pixel from a handle, where f curves fast: whole
    Newton steps from the mesh's guess cycle there and the pixel was left to the background.
    Damped steps, and Newton from the pixel itself, find it: every uncovered pixel of this
    folding edit has no preimage in the image (float64 search)."""
    shape = (40, 48)
    src = np.array([[24.01, 35.27], [8.2, 35.2], [15.41, 16.82], [37.59, 16.32],
                    [25.63, 2.96], [34.4, 20.84], [16.18, 29.6], [15.04, 17.87]])  # fmt: skip
    dst = np.array([[24.17, 34.1], [5.07, 34.17], [15.44, 15.71], [42.77, 20.35],
                    [14.79, -4.59], [33.7, 19.15], [17.03, 30.46], [23.51, 13.42]])  # fmt: skip
    with glmls.MLS(src, dst, shape=shape, ctx=gl) as m:
        xy, residual = m.coordinate_map(shape, residual=True)
        uncovered = ~(residual <= NEWTON_ACCEPT) | np.isnan(xy).any(axis=-1)
        rows, cols = np.nonzero(uncovered)
        u = np.stack([cols, rows], -1).astype(float)
        missed = u[_preimages_inside(m, u, shape)]
        assert len(missed) == 0, missed
        s, valid = m.inverse(np.array([[17.0, 15.0]]), return_valid=True)
        assert valid.all() and back_error(m, s, np.array([[17.0, 15.0]]))[0] < 0.05
    # the batch's second pass finds them too, each image's by its own handles
    batch = glmls.warp_batch(
        np.zeros((2, *shape), np.uint8), [src[::-1] + 1.0, src], [dst[::-1] + 1.0, dst],
        method="backward", return_maps=True,
    )  # fmt: skip
    assert batch.valid[1][15, 17] and not uncovered[batch.valid[1]].any()
    assert_allclose(batch.maps[1][batch.valid[1]], xy[batch.valid[1]], atol=1e-4)


def test_backward_finds_a_preimage_inside_where_newton_leaves_the_image(gl):
    """Next to a fold u has several preimages, and Newton from the mesh's guess (or from u)
    may end at one outside the image (the constant border shows the background there) while
    another lies inside: the second pass tries the points of the covered neighbours too. Every
    blank pixel of this folding edit has no preimage in the image (float64 search), every
    covered pixel shows a true preimage inside it, and the batch agrees."""
    shape = (40, 48)
    src = np.array([[17.73, 4.05], [29.52, 3.63], [4.94, 4.8], [13.69, 22.17],
                    [36.63, 11.35], [14.18, 30.86], [34.08, 6.44], [36.67, 31.09]])  # fmt: skip
    dst = np.array([[22.83, 3.8], [33.4, 16.43], [-13.31, 6.89], [4.89, 26.91],
                    [26.13, 7.39], [15.8, 35.77], [34.67, 0.1], [32.25, 38.17]])  # fmt: skip
    image = np.full(shape, 200, np.uint8)
    with glmls.MLS(src, dst, shape=shape, ctx=gl) as m:
        out = m.warp(image, method="backward")
        xy = m.coordinate_map(shape)
        blank = out == 0
        rows, cols = np.nonzero(blank)
        u = np.stack([cols, rows], -1).astype(float)
        missed = u[_preimages_inside(m, u, shape)]
        assert len(missed) == 0, missed
        rows, cols = np.nonzero(~blank)
        s = xy[~blank].astype(float)
        assert back_error(m, s, np.stack([cols, rows], -1).astype(float)).max() < NEWTON_ACCEPT
        assert ((s >= -0.5) & (s <= [shape[1] - 0.5, shape[0] - 0.5])).all()
    batch = glmls.warp_batch(
        image[None], src[None], dst[None], method="backward", return_maps=True, ctx=gl
    )
    assert_array_equal(batch.images[0] == 0, blank)
    assert_allclose(batch.maps[0][~blank], xy[~blank], atol=1e-4)


def test_backward_with_many_handles_gives_the_same_pixels_every_time(gl):
    """Thousands of handles crowded into a small image fold it everywhere, and the second
    pass runs damped Newton from many starts: on a CPU renderer whose loops stop at a cap
    counted for a vector's lanes together, the pixels then depended on their lane mates (and
    so on the list's order, which differs between runs). The starts stay within the cap."""
    rng = np.random.default_rng(12345)
    image = rng.integers(0, 256, (24, 32, 3), dtype=np.uint8)
    src = rng.uniform(0, 20, (5000, 2))
    dst = src + rng.normal(0, 1.0, src.shape)
    with glmls.MLS(src, dst, shape=image.shape[:2]) as m:
        first = m.warp(image, method="backward", grid=2)
        for _ in range(3):
            np.testing.assert_array_equal(m.warp(image, method="backward", grid=2), first)


def test_a_backward_pixel_does_not_depend_on_the_canvas_around_it(gl):
    """The second pass's list holds the pixels the first left, in an order that differs
    between canvases (and between calls): a pixel's lane mates on a CPU renderer differ with
    it. Its damped Newton from several starts must not stop at a loop cap counted for the
    lanes together: a canvas moved by whole pixels shows the same pixels where both canvases
    find one. The second pass's later runs start from the points of pixels found before,
    which one canvas may lack: a few pixels are found on one canvas alone (3 of 690 here)."""
    rng = np.random.default_rng(12345)
    image = rng.uniform(0, 1, (24, 32, 3)).astype(np.float32)
    src = rng.uniform(0, 20, (7000, 2))
    dst = src + rng.normal(0, 1.0, src.shape)
    with glmls.MLS(src, dst, shape=image.shape[:2], ctx=gl) as m:
        whole = m.warp(image, method="backward", grid=2, background=np.nan)
        for oy, ox in [(3, 5), (1, 2)]:
            part = m.warp(
                image, method="backward", grid=2, output_shape=(24 - oy, 32 - ox),
                origin=(ox, oy), background=np.nan,
            )  # fmt: skip
            overlap = whole[oy:, ox:]
            both = ~np.isnan(part[..., 0]) & ~np.isnan(overlap[..., 0])
            assert_array_equal(part[both], overlap[both])
            assert (np.isnan(part[..., 0]) != np.isnan(overlap[..., 0])).mean() < 0.01


@pytest.mark.parametrize("shape", [None, (10, 12)])
def test_where_f_is_the_identity_the_inverse_is_the_point_itself(gl, shape):
    """Where f leaves u in place (handles that stay, or u beyond every handle's reach), the
    inverse at points returns u exactly: the guess's float32 noise would move a point on the
    canvas's edge (a keypoint at x = -0.5) off it. Elsewhere it is Newton's point."""
    src = np.array([[1.0, 1.0], [8.0, 2.0], [3.0, 7.0]])
    points = np.array([[-0.5, 3.0], [3.0, -0.5], [-0.5, -0.5], [11.5, 9.5], [1e3, -2e3]])
    with glmls.MLS(src, src, shape=shape, ctx=gl) as m:
        s, valid = m.inverse(points, return_valid=True)
    assert valid.all() and np.array_equal(s, points)
    far = np.array([[40.0, 40.0], [-30.0, 55.5], [2.0, 2.0]])  # the last within the reach
    with glmls.MLS(src, src + 1.0, weight="cressman", radius=6.0, shape=shape, ctx=gl) as m:
        s, valid = m.inverse(far, return_valid=True)
        moved = m(s[2:])
    assert valid.all() and np.array_equal(s[:2], far[:2])
    assert not np.array_equal(s[2], far[2]) and np.abs(moved - far[2:]).max() < 1e-3


@pytest.mark.parametrize("shift", [(1000.0, 0.0), (0.0, 1000.0), (-700.0, -700.0)])
def test_no_point_is_taken_across_a_compact_weights_jump(gl, shift):
    """Where a compact weight's reach ends, f jumps: a difference across the jump measures
    the jump, not a stretch of f, and must not widen the residual accepted. Points on a
    ring about that edge: each one taken has its preimage within the residual accepted by
    the float64 reference (float32's few thousandths over 0.05 px)."""
    src = np.array([[2000.0, 0.0], [-2000.0, 0.0]])
    dst = src + [shift, (0.0, 0.0)]
    options = {"weight": "cressman", "radius": 100.0}
    rng = np.random.default_rng(0)
    angle, radius = rng.uniform(0, 2 * np.pi, 600), 100 + rng.uniform(-6, 6, 600)
    u = np.c_[2000 + radius * np.cos(angle), radius * np.sin(angle)]
    with glmls.MLS(src, dst, ctx=gl, **options) as m:
        s, valid = m.inverse(u, return_valid=True)
    assert 0 < valid.sum() < len(u)
    f = reference.mls(src, dst, s[valid], **options)[0]
    assert np.linalg.norm(f - u[valid], axis=1).max() < NEWTON_ACCEPT + 2e-3


@pytest.mark.parametrize(
    ("move", "origin"), [((-3000, 0), (3820, 2000)), ((0, -1500), (3870, 2080))]
)
def test_backward_draws_nothing_inside_a_disc_that_f_leaves_uncovered(gl, move, origin):
    """One handle moved thousands of pixels with a compact weight: the disc its reach
    leaves behind has no preimage, and the backward method keeps the background there
    (differences across the reach's edge are no stretch of f)."""
    src = np.array([[3900.0, 2048.0]])
    image = np.full((4096, 4096), 255, np.uint8)
    frame = {"output_shape": (96, 64), "origin": origin}
    with glmls.MLS(src, src + move, shape=image.shape, weight="cressman", radius=60.0, ctx=gl) as m:
        out = m.warp(image, method="backward", **frame)
    rows, cols = np.mgrid[:96, :64]
    u = np.stack([cols + origin[0], rows + origin[1]], -1)
    inside = np.linalg.norm(u - src[0], axis=-1) < 60 - 1.5
    assert inside.sum() > 1000
    assert (out[inside] == 0).all()


def test_no_point_is_taken_in_a_sliver_between_two_reaches(gl):
    """Two compact weights' reaches 0.01 px apart, their handles moved apart: a source point
    in the gap has a jump of f on both sides, within any difference step. The stretch taken
    there must not be the jump's (its differences do not halve with the step): no point is
    taken farther from u than the residual accepted, by the float64 reference."""
    radius, gap, move = 1000.0, 0.01, 1000.0
    src = np.array([[0.0, 0.0], [2 * radius + gap, 0.0]])
    dst = src + [[-move, 0.0], [move, 0.0]]
    options = {"weight": "cressman", "radius": radius}
    rng = np.random.default_rng(0)
    u = np.c_[radius + gap / 2 + rng.uniform(-5, 5, 400), rng.uniform(-3, 3, 400)]
    with glmls.MLS(src, dst, ctx=gl, **options) as m:
        s, valid = m.inverse(u, return_valid=True)
    f = reference.mls(src, dst, s[valid], **options)[0]
    assert np.linalg.norm(f - u[valid], axis=1).max(initial=0.0) < NEWTON_ACCEPT + 2e-3


def test_a_steep_but_smooth_edge_keeps_its_preimages(gl):
    """Where two compact weights' reaches cross, f is continuous but stretches lengths
    thousands of times within a pixel of the crossing: float32's rounding of s, times that
    stretch, exceeds 0.05 px. Those pixels are drawn, each s within 1e-3 source px of the
    float64 preimage (float64 Newton from it)."""
    radius = 1000.0
    rng = np.random.default_rng(9)
    src = np.array([[0.0, 0.0], [radius * rng.uniform(0.3, 1.8), radius * rng.uniform(-0.8, 0.8)]])
    dst = src + rng.normal(0, 1000.0, (2, 2))
    options = {"weight": "cressman", "radius": radius}
    # the crossing of the two reaches' circles below the line of the handles
    apart = np.linalg.norm(src[1])
    normal = np.array([-src[1, 1], src[1, 0]]) / apart
    crossing = src[1] / 2 - np.sqrt(radius**2 - (apart / 2) ** 2) * normal
    frame = {"output_shape": (32, 32), "origin": tuple(np.floor(crossing) - 16)}
    with glmls.MLS(src, dst, ctx=gl, **options) as m:
        xy, residual = m.coordinate_map((64, 64), residual=True, border="edge", **frame)
        out = m.warp(np.full((64, 64), 255, np.uint8), method="backward", border="edge", **frame)
    steep = (out != 0) & (residual > 0.06)
    assert steep.any()
    rows, cols = np.nonzero(steep)
    targets = np.c_[cols + frame["origin"][0], rows + frame["origin"][1]]
    for found, u in zip(xy[steep].astype(np.float64), targets, strict=True):
        s = found.copy()
        for _ in range(20):
            f = reference.mls(src, dst, s + [[0, 0], [1e-6, 0], [0, 1e-6]], **options)[0]
            s = s - np.linalg.solve(np.stack([f[1] - f[0], f[2] - f[0]], 1) / 1e-6, f[0] - u)
        assert np.linalg.norm(reference.mls(src, dst, s[None], **options)[0][0] - u) < 1e-6
        assert np.linalg.norm(s - found) < 1e-3
