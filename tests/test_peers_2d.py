"""2D image warps against their peers: scipy.ndimage, numpy.pad, scikit-image.

The backward method resamples the source at f's inverse; here the inverse is solved
independently in float64 (Newton's method on the float64 MLS of ``mls64``, not on
``glmls.reference``) and the source is sampled by ``scipy.ndimage.map_coordinates`` with the
mode that the docs name for each border. Then the pixel-centre convention (translations by
whole and half pixels against numpy shifts), the identity bit for bit, dtypes and channels
against ``skimage.transform.warp(preserve_range=True)``, the background and alpha, and
scikit-image's transform protocol.
"""

from __future__ import annotations

import numpy as np
import pytest
import skimage.transform
from mls64 import mls64
from scipy import ndimage

import glmls

H, W = 20, 28
P = np.array([[4.0, 4.0], [22.0, 5.0], [5.0, 15.0], [23.0, 16.0], [13.0, 10.0]])
Q = P + np.array([[1.5, -2.0], [-2.5, 1.0], [2.0, 2.5], [-1.0, -2.0], [3.0, 1.5]])
#: glmls's border names (numpy.pad's) and scipy.ndimage's modes of the same meaning
SCIPY_MODES = {"edge": "nearest", "symmetric": "reflect", "reflect": "mirror", "wrap": "grid-wrap"}


def float64_inverse(u: np.ndarray, start: np.ndarray) -> np.ndarray:
    """s with f(s) = u for the rigid idw MLS of P -> Q, Newton's method in float64."""

    def f(s):
        return mls64(P, Q, s)[0]

    s = start.astype(np.float64).copy()
    h = 1e-5
    for _ in range(20):
        r = f(s) - u
        if np.abs(r).max() < 1e-11:
            break
        jx = (f(s + [h, 0.0]) - f(s - [h, 0.0])) / (2 * h)  # d f / d x
        jy = (f(s + [0.0, h]) - f(s - [0.0, h])) / (2 * h)
        jacobian = np.stack([jx, jy], axis=-1)  # [k, i, a] = d f_i / d s_a
        s -= np.linalg.solve(jacobian, r[..., None])[..., 0]
    assert np.abs(f(s) - u).max() < 1e-9
    return s


@pytest.fixture(scope="module")
def deformed(gl):
    """The MLS, the float64 preimages (y, x) of every output pixel, a float32 image."""
    image = np.random.default_rng(2).uniform(0, 1, (H, W)).astype(np.float32)
    with glmls.MLS(P, Q, shape=(H, W)) as m:
        yy, xx = np.mgrid[0:H, 0:W]
        u = np.stack([xx.ravel(), yy.ravel()], 1).astype(np.float64)
        guess = m.coordinate_map((H, W)).reshape(-1, 2)
        s = float64_inverse(u, guess)
        yield m, s[:, 1].reshape(H, W), s[:, 0].reshape(H, W), image


def not_a_tie(coordinate: np.ndarray, margin: float = 1e-3) -> np.ndarray:
    """Farther than ``margin`` px from the half-pixel ties of nearest sampling (float32's s
    may fall either side of them)."""
    return np.abs(np.abs(coordinate - np.floor(coordinate)) - 0.5) > margin


@pytest.mark.parametrize("border", sorted(SCIPY_MODES))
def test_backward_is_map_coordinates_at_the_float64_inverse(deformed, border):
    m, sy, sx, image = deformed
    source = image.astype(np.float64)
    linear = m.warp(image, method="backward", interpolation="linear", border=border)
    order1 = ndimage.map_coordinates(source, [sy, sx], order=1, mode=SCIPY_MODES[border])
    # Newton stops below 1e-3 px: the sample moves by that times the local contrast (< 1 / px)
    assert np.abs(linear - order1).max() < 5e-3
    nearest = m.warp(image, method="backward", interpolation="nearest", border=border)
    order0 = ndimage.map_coordinates(source, [sy, sx], order=0, mode=SCIPY_MODES[border])
    decided = not_a_tie(sx) & not_a_tie(sy)
    assert decided.mean() > 0.95
    assert np.array_equal(nearest[decided], order0[decided].astype(np.float32))


def test_constant_border_reads_the_image_up_to_its_border_and_background_past_it(deformed):
    m, sy, sx, image = deformed
    inside = (sx >= -0.5) & (sx <= W - 0.5) & (sy >= -0.5) & (sy <= H - 0.5)
    assert 0 < (~inside).sum() < inside.sum()  # the map pulls some pixels from outside
    edge = ndimage.map_coordinates(image.astype(np.float64), [sy, sx], order=1, mode="nearest")
    out = m.warp(image, method="backward", interpolation="linear", background=-1.0)
    far = np.minimum.reduce([sx + 0.5, W - 0.5 - sx, sy + 0.5, H - 0.5 - sy])
    decided = np.abs(far) > 1e-3  # s on the image's border: either
    assert np.abs(out - np.where(inside, edge, -1.0))[decided].max() < 5e-3


@pytest.mark.parametrize("method", ["quads", "backward", "splat", "backward-swap"])
@pytest.mark.parametrize("interpolation", ["nearest", "linear"])
@pytest.mark.parametrize("border", ["constant", "edge", "reflect"])
def test_the_identity_copies_every_dtype_bit_for_bit(gl, method, interpolation, border):
    """Every method samples at pixel centres exactly: the engine's scale is a power of two,
    so pixel coordinates go to the GPU and back unchanged, and quads' linear source point,
    interpolated over each cell from its corners, is the pixel's own."""
    rng = np.random.default_rng(3)
    images = [
        rng.integers(0, 256, (9, 11, 3), dtype=np.uint8),
        rng.integers(0, 65536, (9, 11), dtype=np.uint16),
        (rng.uniform(-1, 2, (9, 11, 2)) * np.pi).astype(np.float32),
        rng.uniform(0, 1, (9, 11, 4)).astype(np.float32).astype(np.float64),
    ]
    with glmls.MLS(P[:3] / 2, P[:3] / 2, shape=(9, 11)) as m:
        for image in images:
            out = m.warp(image, method=method, interpolation=interpolation, border=border)
            assert out.dtype == image.dtype and out.shape == image.shape
            assert np.array_equal(out, image), (image.dtype, np.abs(out - image).max())


@pytest.mark.parametrize("method", ["quads", "backward", "splat", "backward-swap", "paper-quads"])
@pytest.mark.parametrize("shape", [(1, 9), (2, 2), (224, 224), (100, 37), (480, 640)])
def test_identity_and_whole_pixel_shifts_are_exact_at_any_size(gl, method, shape):
    """A uint16 image at sizes whose half box is no power of two (112, 50, 320 px), handles
    off the image too: the identity and a shift by (2, -1) px copy every pixel, linear
    sampling included (one level of uint16 is 1.5e-5 of the range: a source point 1e-5 px
    off the pixel centre shows)."""
    rng = np.random.default_rng(shape[1])
    height = shape[0]
    image = rng.integers(0, 65536, shape, dtype=np.uint16)
    src = rng.uniform(-40, max(shape) + 40, (6, 2))
    for transform in glmls.TRANSFORMS:
        options = {"method": method, "interpolation": "linear", "border": "edge"}
        with glmls.MLS(src, src, transform=transform, shape=shape) as m:
            assert np.array_equal(m.warp(image, **options), image), transform
        with glmls.MLS(src, src + [2, -1], transform=transform, shape=shape) as m:
            out = m.warp(image, **options)
        expected = np.roll(image, (-1, 2), axis=(0, 1))
        assert np.array_equal(out[: height - 1, 2:], expected[: height - 1, 2:]), transform


@pytest.mark.parametrize("method", ["backward", "backward-swap"])
def test_the_backward_identity_copies_a_float_image_whatever_its_size(gl, method):
    """The backward map keeps each pixel's own point where f leaves it in place, so linear
    sampling of a float image lands on the pixel centres exactly, and the map and the inverse
    are the pixel grid itself."""
    shape = (17, 23)
    image = (np.random.default_rng(6).standard_normal((*shape, 2)) * 1e3).astype(np.float32)
    yy, xx = np.mgrid[0 : shape[0], 0 : shape[1]]
    centres = np.stack([xx, yy], axis=-1).astype(np.float64)
    for handles in (np.zeros((0, 2)), P[:3] * 0.7):
        with glmls.MLS(handles, handles.copy(), shape=shape) as m:
            for border in ("constant", "edge", "wrap"):
                out = m.warp(image, method=method, interpolation="linear", border=border)
                assert np.array_equal(out, image), (border, np.abs(out - image).max())
            xy = m.coordinate_map(shape, method=method)
            assert np.array_equal(xy, centres.astype(np.float32))
            assert np.array_equal(m.inverse(centres.reshape(-1, 2)), centres.reshape(-1, 2))


def test_the_identity_with_paper_quads(gl):
    """paper-quads copies exactly when nearest; its linear blend (weights from the inverse of
    each square's bilinear map, in float32) keeps the values within a few float32 ulps."""
    image = (np.random.default_rng(4).uniform(0, 1, (9, 11, 3)) * np.pi).astype(np.float32)
    with glmls.MLS(P[:3] / 3, P[:3] / 3, shape=(9, 11)) as m:
        assert np.array_equal(m.warp(image, method="paper-quads"), image)
        linear = m.warp(image, method="paper-quads", interpolation="linear")
        assert np.abs(linear - image).max() < 1e-5


def shifted(image: np.ndarray, dx: float, order: int) -> np.ndarray:
    """Output pixel (r, c) shows source point (c - dx, r), edge pixels repeated."""
    yy, xx = np.mgrid[0 : image.shape[0], 0 : image.shape[1]].astype(np.float64)
    return ndimage.map_coordinates(image, [yy, xx - dx], order=order, mode="nearest")


@pytest.mark.parametrize("method", ["quads", "backward", "splat", "backward-swap"])
def test_a_translation_by_one_pixel_is_numpy_shift(gl, method):
    image = np.random.default_rng(5).integers(0, 65536, (8, 12), dtype=np.uint16)
    with glmls.MLS(P / 3, P / 3 + [1.0, 0.0]) as m:
        for interpolation in ("nearest", "linear"):
            out = m.warp(image, method=method, interpolation=interpolation, background=7)
            assert (out[:, 0] == 7).all()
            assert np.array_equal(out[:, 1:], image[:, :-1])
            edge = m.warp(image, method=method, interpolation=interpolation, border="edge")
            assert np.array_equal(edge, np.pad(image, ((0, 0), (1, 0)), mode="edge")[:, :-1])


@pytest.mark.parametrize("method", ["quads", "backward", "backward-swap"])
def test_a_translation_by_half_a_pixel_averages_neighbours(gl, method):
    """Pixel centres at integers: a shift of +0.5 shows the mean of pixels c - 1 and c; nearest
    sampling is a tie there, and shows one of the two."""
    image = np.random.default_rng(6).uniform(0, 1, (8, 12)).astype(np.float32)
    expected = shifted(image.astype(np.float64), 0.5, order=1)
    with glmls.MLS(P / 3, P / 3 + [0.5, 0.0]) as m:
        linear = m.warp(image, method=method, interpolation="linear", border="edge")
        assert np.abs(linear - expected).max() < 1e-6
        assert np.abs(linear[:, 1:] - (image[:, 1:] + image[:, :-1]) / 2).max() < 1e-6
        nearest = m.warp(image, method=method, border="edge")[:, 1:]
        assert ((nearest == image[:, 1:]) | (nearest == image[:, :-1])).all()


@pytest.mark.parametrize(
    "image",
    [
        np.arange(6 * 7 * 3, dtype=np.uint8).reshape(6, 7, 3),
        (np.arange(42, dtype=np.uint16) * 1500).reshape(6, 7),
        np.linspace(-1, 1, 42 * 2, dtype=np.float32).reshape(6, 7, 2),
        np.linspace(0, 3, 42 * 4).reshape(6, 7, 4),
    ],
    ids=["uint8-rgb", "uint16-grey", "float32-la", "float64-rgba"],
)
def test_dtype_and_channels_as_skimage_preserve_range(gl, image):
    """The same dtype and channels back, with the values skimage's preserve_range gives:
    within the inverses' precision (1e-3 px) times the contrast per pixel, and the rounding
    to integers."""
    src = np.array([[1.0, 1.0], [5.0, 1.0], [1.0, 4.0], [5.0, 4.0]])
    with glmls.MLS(src, src + [[0.3, 0.2], [-0.2, 0.1], [0.1, -0.3], [0.2, 0.2]]) as m:
        ours = m.warp(image, method="backward", interpolation="linear", border="edge")
        theirs = skimage.transform.warp(image, m.inverse, order=1, mode="edge", preserve_range=True)
    assert ours.dtype == image.dtype and ours.shape == image.shape
    assert theirs.shape == image.shape
    values = image.astype(np.float64)
    contrast = max(np.abs(np.diff(values, axis=a)).max() for a in (0, 1))
    rounding = 0.5 if image.dtype.kind == "u" else 0.0
    assert np.abs(ours - theirs).max() <= 2e-3 * contrast + rounding


def test_background_and_alpha(gl):
    rgba = np.full((6, 8, 4), 200, np.uint8)
    with glmls.MLS(P / 3, P / 3 + [3.0, 0.0]) as m:
        for method in glmls.METHODS:
            assert (m.warp(rgba, method=method)[:, :2] == 0).all()  # alpha 0 too
            colour = m.warp(rgba, method=method, background=(9, 8, 7))[:, :2]
            assert (colour == [9, 8, 7, 0]).all()  # fewer values than channels: alpha 0
            whole = m.warp(rgba, method=method, background=(9, 8, 7, 6))[:, :2]
            assert (whole == [9, 8, 7, 6]).all()
            grey_alpha = m.warp(rgba[..., :2], method=method, background=5)[:, :2]
            assert (grey_alpha == [5, 0]).all()  # a scalar fills the colour, not alpha


def test_quads_at_grid_1_and_backward_show_the_same_pixels(deformed):
    """quads interpolates the source point linearly over each pixel-corner cell: within a
    hundredth of a pixel of f's inverse here, so the pixels agree away from the ties."""
    m, sy, sx, image = deformed
    quads = m.warp(image, method="quads", border="edge")
    backward = m.warp(image, method="backward", border="edge")
    decided = not_a_tie(sx, 0.01) & not_a_tie(sy, 0.01)
    assert decided.mean() > 0.9
    assert np.array_equal(quads[decided], backward[decided])


# -- scikit-image's transform protocol ---------------------------------------------------


def test_the_call_is_f_on_n_by_2_points(deformed):
    m = deformed[0]
    points = np.random.default_rng(8).uniform(-10, 40, (50, 2))
    assert np.abs(m(points) - mls64(P, Q, points)[0]).max() < 1e-4
    assert m(points[0]).shape == (1, 2)  # one (2,) point: a (1, 2) row, as in skimage
    assert np.array_equal(m(points[:3].tolist()), m(points[:3]))
    assert m(np.zeros((0, 2))).shape == (0, 2)


def test_inverse_is_a_transform_whose_call_inverts(deformed):
    m = deformed[0]
    inverse = m.inverse
    assert inverse.inverse is m
    u = np.array([[3.0, 2.0], [14.0, 9.0], [27.0, 19.0], [-5.0, 30.0]])
    s = inverse(u)
    exact = float64_inverse(u, u)
    assert np.abs(s - exact).max() < 1e-2  # Newton to a residual of 1e-4 px, f's stretch
    assert np.abs(mls64(P, Q, s)[0] - u).max() < 1e-3
    assert np.abs(m(inverse(m(u))) - m(u)).max() < 1e-3


def test_residuals_are_euclidean_distances_per_point(deformed):
    m = deformed[0]
    points = np.random.default_rng(9).uniform(0, 20, (7, 2))
    targets = mls64(P, Q, points)[0] + np.array([3.0, 4.0])
    assert np.allclose(m.residuals(points, targets), 5.0, atol=1e-4)
    # skimage's meaning, on a transform of its own: |T(src) - dst| per point
    affine = skimage.transform.AffineTransform(scale=1.5, translation=(2, 1))
    assert np.allclose(affine.residuals(points, targets), np.hypot(*(affine(points) - targets).T))
    assert m.residuals(points, targets).shape == (7,)


@pytest.mark.parametrize("mode", sorted(SCIPY_MODES))
def test_skimage_warp_takes_the_inverse_as_inverse_map(deformed, mode):
    m, _, _, image = deformed
    theirs = skimage.transform.warp(image, m.inverse, order=1, mode=mode, preserve_range=True)
    ours = m.warp(image, method="backward", interpolation="linear", border=mode)
    assert np.abs(theirs - ours).max() < 5e-3


def test_thin_plate_spline_and_piecewise_affine_agree_at_the_handles(deformed):
    """Sanity against scikit-image's interpolating transforms on the same handles: all three
    map p to q, and they differ inside by the pixel or so that distinguishes the models."""
    m = deformed[0]
    tps = skimage.transform.ThinPlateSplineTransform.from_estimate(P, Q)
    piecewise = skimage.transform.PiecewiseAffineTransform.from_estimate(P, Q)
    assert np.abs(m(P) - Q).max() < 1e-4
    assert np.abs(tps(P) - Q).max() < 1e-4
    assert np.abs(piecewise(P) - Q).max() < 1e-4
    inside = np.array([[10.0, 8.0], [16.0, 12.0], [12.0, 12.0]])
    assert np.hypot(*(m(inside) - tps(inside)).T).max() < 3.0
    assert np.hypot(*(m(inside) - piecewise(inside)).T).max() < 3.0


#: numpy.pad's modes and OpenCV's border types of the same meaning, as docs/warp.md names them
OPENCV_BORDERS = {
    "edge": "BORDER_REPLICATE",
    "symmetric": "BORDER_REFLECT",
    "reflect": "BORDER_REFLECT_101",
    "wrap": "BORDER_WRAP",
}


@pytest.mark.parametrize("border", sorted(OPENCV_BORDERS))
@pytest.mark.parametrize("method", glmls.METHODS)
def test_the_identity_on_a_larger_canvas_is_numpy_pad_and_opencv(gl, border, method):
    """Each border continues the image as numpy.pad's mode of its name (and OpenCV's
    copyMakeBorder with the type the docs give): a canvas 3 px wider on each side, and more
    than the image's size on one, so that symmetric, reflect and wrap come back round."""
    image = np.random.default_rng(10).integers(0, 256, (5, 7, 3), dtype=np.uint8)
    top, bottom, left, right = 3, 8, 3, 9
    padded = np.pad(image, ((top, bottom), (left, right), (0, 0)), mode=border)
    with glmls.MLS(np.zeros((0, 2)), np.zeros((0, 2))) as m:
        out = m.warp(
            image,
            method=method,
            border=border,
            output_shape=padded.shape[:2],
            origin=(-left, -top),
        )
    assert np.array_equal(out, padded)
    cv2 = pytest.importorskip("cv2")
    kind = getattr(cv2, OPENCV_BORDERS[border])
    assert np.array_equal(cv2.copyMakeBorder(image, top, bottom, left, right, kind), padded)
