"""scikit-image's transform protocol: ``skimage.transform.warp(image, m.inverse)`` resamples an
image by f, and agrees with glmls's own backward construction.

skimage calls ``inverse_map`` with the (x, y) = (column, row) points of the output pixels,
converts images to float in [0, 1] (unless ``preserve_range``) and samples with
scipy.ndimage.map_coordinates: ``mode="edge"`` is glmls's ``border="edge"``; with
``mode="constant"`` (scipy's ``grid-constant``) skimage blends towards ``cval`` past the
edge pixels' centres where glmls's bilinear sampling still reads the edge pixels up to
n - 0.5, so the two differ on the image's rim. At points without preimage (NaN rows of
``m.inverse``) skimage's pixels are NaN, in every mode, where glmls leaves ``background``:
``np.nan_to_num(out, nan=cval)`` makes them the same.
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

import glmls

transform = pytest.importorskip("skimage.transform")

#: Largest difference between the two resamplings, image values in [0, 1]: both sample the
#: same source points (f's inverse to ~1e-4 px against Newton's 1e-3 px in glmls's pass),
#: GL's bilinear weights have 8 bits of sub-texel precision.
AGREE = 3e-3


@pytest.fixture(scope="module")
def photo() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The astronaut at a quarter of its size, float32 in [0, 1], and its handles."""
    image = glmls.data.astronaut()[::4, ::4].astype(np.float32) / 255
    src, dst = glmls.data.astronaut_handles()
    return image, src / 4, dst / 4


def test_skimage_warp_by_the_inverse_is_the_backward_method(gl, photo):
    image, src, dst = photo
    with glmls.MLS(src, dst, shape=image.shape[:2], ctx=gl) as m:
        ours = m.warp(image, method="backward", interpolation="linear", border="edge")
        theirs = transform.warp(image, m.inverse, order=1, mode="edge")
    assert theirs.shape == ours.shape
    assert np.abs(theirs - ours).max() < AGREE


def test_constant_mode_and_points_without_preimage(gl):
    """A compact-support map that leaves a crescent of the output without preimage: skimage
    gives NaN there, glmls the background. Elsewhere the two agree, but for the image's rim
    (see the module) and the crescent's."""
    rng = np.random.default_rng(3)
    image = rng.uniform(0.2, 1.0, (48, 64)).astype(np.float32)
    p, d = np.array([32.0, 24.0]), np.array([-8.0, 0.0])
    with glmls.MLS([p], [p + d], weight="cressman", radius=14, shape=image.shape, ctx=gl) as m:
        ours = m.warp(image, method="backward", interpolation="linear", background=0)
        theirs = transform.warp(image, m.inverse, order=1, mode="constant", cval=0)
        rows, cols = np.mgrid[0:48, 0:64]
        pixels = np.stack([cols.ravel(), rows.ravel()], -1).astype(float)
        s, valid = m.inverse(pixels, return_valid=True)
    uncovered = ~valid.reshape(image.shape)
    assert 20 < uncovered.sum() < 400  # the crescent
    assert np.isnan(theirs[uncovered]).all() and not np.isnan(theirs[~uncovered]).any()
    assert_array_equal(ours[uncovered], 0)
    assert_array_equal(np.nan_to_num(theirs, nan=0)[uncovered], 0)
    inside = np.zeros(image.shape, bool)
    ok = valid & (s >= 1).all(axis=1) & (s[:, 0] <= 62) & (s[:, 1] <= 46)
    inside.ravel()[ok] = True
    # Next to the crescent f jumps: one handle moves every point its weight reaches the whole
    # way, however small the weight, and none past the radius. A preimage there is a point
    # on that edge, within the residual accepted, which the two solvers approach from their
    # own first guesses: the crescent's rim is left out, as the image's.
    rim = uncovered.copy()
    rim[1:] |= uncovered[:-1]
    rim[:-1] |= uncovered[1:]
    rim[:, 1:] |= uncovered[:, :-1]
    rim[:, :-1] |= uncovered[:, 1:]
    inside &= ~rim
    assert inside.mean() > 0.8
    assert np.abs(theirs - ours)[inside].max() < AGREE


def test_uint8_images_and_the_forward_map(gl, photo):
    """An 8-bit image: skimage's float result is glmls's uint8 over 255 (rounding); and
    ``m.inverse.inverse`` is f, for skimage's functions that take the forward map."""
    image, src, dst = photo
    image8 = np.round(image * 255).astype(np.uint8)
    with glmls.MLS(src, dst, shape=image.shape[:2], ctx=gl) as m:
        ours = m.warp(image8, method="backward", interpolation="linear", border="edge")
        theirs = transform.warp(image8, m.inverse, order=1, mode="edge")
        assert theirs.dtype == np.float64
        assert np.abs(theirs * 255 - ours).max() <= 1.0
        ranged = transform.warp(image8, m.inverse, order=1, mode="edge", preserve_range=True)
        assert_allclose(ranged, theirs * 255, atol=1e-9)
        back = m.inverse.inverse
        assert back is m
        v = np.array([[20.0, 30.0], [64.0, 64.0]])
        assert_allclose(back(m.inverse(v)), v, atol=1e-3)


def test_points_as_scikit_image_takes_them(gl):
    """skimage's transforms take (N, D) array_likes, and one point as a (D,) array (a (1, D)
    row back); ``residuals`` are (N,) Euclidean distances, (0,) for no points."""
    affine = transform.AffineTransform(translation=(1, 2))
    src = np.array([[0.0, 0.0], [9.0, 0.0], [0.0, 9.0]])
    with glmls.MLS(src, src + [1, 2], shape=(12, 12), ctx=gl) as m:
        for points in ([4, 5], np.array([4.0, 5.0], np.float32), (4, 5)):
            assert m(points).shape == affine(points).shape == (1, 2)
            assert_allclose(m(points), affine(points), atol=1e-4)
            assert_allclose(m.inverse(points), affine.inverse(points), atol=1e-3)
        assert m.residuals([4, 5], [5, 8]).shape == affine.residuals([4, 5], [5, 8]).shape
        assert_allclose(m.residuals([4, 5], [5, 8]), [1.0], atol=1e-4)
        for points in ([[4, 5], [6, 7]], np.array([[4, 5]], np.int32), np.zeros((0, 2))):
            assert m(points).shape == affine(points).shape and m(points).dtype == np.float64
        assert m.residuals(np.zeros((0, 2)), np.zeros((0, 2))).shape == (0,)
    src3 = np.array([[0.0, 0, 0], [9, 0, 0], [0, 9, 0], [0, 0, 9]])
    with glmls.MLS(src3, src3 + [1, 2, 3], ctx=gl) as m3:
        assert_allclose(m3([4, 5, 6]), [[5, 7, 9]], atol=1e-4)
        assert_allclose(m3.inverse([5, 7, 9]), [[4, 5, 6]], atol=1e-3)
        assert_allclose(m3.residuals([4, 5, 6], [5, 7, 9]), [0.0], atol=1e-4)
        with pytest.raises(ValueError, match=r"shape \(N, 3\)"):
            m3([4, 5])


@pytest.mark.parametrize("mode", ["edge", "symmetric", "reflect", "wrap"])
def test_every_mode_is_the_border_of_its_name(gl, mode):
    """Handles pulled outwards make the output sample beyond the image on every side."""
    image = np.random.default_rng(0).random((32, 32)).astype(np.float32)
    src = np.array([[5.0, 5], [25, 5], [25, 25], [5, 25], [15, 15]])
    dst = src + [[-3, 0], [0, -3], [3, 0], [0, 3], [2, 2]]
    with glmls.MLS(src, dst, shape=image.shape, ctx=gl) as m:
        ours = m.warp(image, method="backward", interpolation="linear", border=mode)
        theirs = transform.warp(image, m.inverse, order=1, mode=mode)
    assert np.abs(theirs - ours).max() < AGREE


def test_a_volume_through_coordinates(gl):
    """skimage takes a callable inverse_map for 2-D images only; a volume goes through the
    coordinates that a 3D MLS's inverse gives at its voxels, (z, y, x) first."""
    volume = np.random.default_rng(1).random((10, 12, 14))
    src = np.array([[0.0, 0, 0], [13, 0, 0], [0, 11, 0], [0, 0, 9], [13, 11, 9]])
    with glmls.MLS(src, src + [1, 2, 3], ctx=gl) as m:
        z, y, x = np.indices(volume.shape).reshape(3, -1)
        s = m.inverse(np.stack([x, y, z], axis=1))
    coords = s[:, ::-1].T.reshape(3, *volume.shape)
    out = transform.warp(volume, coords, order=1, mode="edge")
    assert_allclose(out[3:, 2:, 1:], volume[:-3, :-2, :-1], atol=1e-3)
