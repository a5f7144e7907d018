"""``backward-swap`` keypoints of a batch move for the whole chunk in a few dispatches
(:mod:`glmls.batch.preimages`): against the single path (one image's :class:`glmls.MLS`,
s's inverse by its mesh's guess and Newton) within :data:`ATOL` pixels with the same validity
flags, against the float64 s (``s(moved) = keypoint``), and against the picture (a hot pixel
at the keypoint shows where the keypoint lands). Maps that fold, compact weights and maps
whose Newton from f leaves a point move image by image, as the single path does."""

from __future__ import annotations

import numpy as np
import pytest

import glmls
import glmls.batch.run
import glmls.batch.swap
from glmls import reference
from glmls.batch import preimages
from glmls.batch.single import SingleWarper
from glmls.imaging.inverse import length_unit
from glmls.mls import InverseMLS

SHAPE = (40, 56)
#: Pixels: batched against single keypoints (both Newton on s to 1e-4 px of residual, from
#: other first guesses, in float32).
ATOL = 1e-3
#: Pixels: s at a moved keypoint against the keypoint, float64 s against the GPU's float32.
REFERENCE_ATOL = 2e-3


def handles(rng, count: int, jitter: float = 1.0):
    """Per image a 3 x 4 lattice of sources, jittered, less some rows (ragged counts), and
    targets moved by ``jitter`` px (no fold)."""
    height, width = SHAPE
    xs, ys = np.linspace(6, width - 7, 4), np.linspace(6, height - 7, 3)
    grid = np.stack(np.meshgrid(xs, ys), -1).reshape(-1, 2)
    src, dst = [], []
    for i in range(count):
        p = grid[: len(grid) - i % 3] + rng.uniform(-2, 2, (len(grid) - i % 3, 2))
        src.append(p)
        dst.append(p + rng.normal(0, jitter, p.shape))
    return src, dst


def keypoints(rng, count: int):
    """Ragged (P_i, 2) keypoints, one set empty, some off the canvas."""
    height, width = SHAPE
    sizes = [5, 0, 9, 1, 13, 4][:count]
    return [rng.uniform((-4, -4), (width + 4, height + 4), (k, 2)) for k in sizes]


def images(rng, dtype, count: int):
    shape = (count, *SHAPE, 3)
    if dtype == np.float32:
        return rng.uniform(0, 1, shape).astype(np.float32)
    return rng.integers(0, np.iinfo(dtype).max, shape, dtype=dtype, endpoint=True)


def swap(batch, src, dst, **options):
    return glmls.warp_batch(batch, src, dst, method="backward-swap", **options)


def single(monkeypatch, batch, src, dst, **options):
    """The same batch image by image (each image's own warp and keypoints)."""
    with monkeypatch.context() as m:
        m.setattr(glmls.batch.run, "batchable", lambda chosen: False)
        return swap(batch, src, dst, **options)


def alone_moves(monkeypatch) -> list[int]:
    """The point counts that ``SingleWarper.move`` moves image by image from now on (each
    keypoint with the 8 points of its footprint's edge: 9 points)."""
    moves: list[int] = []
    move = SingleWarper.move
    monkeypatch.setattr(
        SingleWarper, "move", lambda self, *a: moves.append(len(a[-1])) or move(self, *a)
    )
    return moves


def assert_close(got, want, *, exact=()):
    """Keypoints within ATOL (``exact``: images that must be bit for bit), flags equal."""
    for i, (a, b) in enumerate(zip(got.keypoints, want.keypoints, strict=True)):
        assert a.shape == b.shape and a.dtype == b.dtype
        if i in exact:
            np.testing.assert_array_equal(a, b)
        else:
            np.testing.assert_allclose(a, b, rtol=0, atol=ATOL, err_msg=f"image {i}")
    for a, b in zip(got.keypoints_valid, want.keypoints_valid, strict=True):
        np.testing.assert_array_equal(a, b)
    for a, b in zip(got.images, want.images, strict=True):
        np.testing.assert_array_equal(a, b)  # the pixels stay the single warp's


CASES = [
    (np.uint8, "constant", None),
    (np.float32, "edge", None),
    (np.uint16, "reflect", ((36, 60), (-3.0, 2.5))),
    (np.uint8, "wrap", ((44, 50), (2.0, -1.5))),
    (np.float32, "constant", ((30, 70), (-6.5, 4.0))),
]


@pytest.mark.parametrize(("dtype", "border", "canvas"), CASES)
def test_batched_keypoints_match_the_single_path(gl, rng, monkeypatch, dtype, border, canvas):
    count = 6
    batch = images(rng, dtype, count)
    src, dst = handles(rng, count)
    points = keypoints(rng, count)
    options = {"border": border, "keypoints": points, "masks": batch[..., 0] > 0}
    if canvas is not None:
        options |= {"output_shape": canvas[0], "origin": canvas[1]}
    moves = alone_moves(monkeypatch)
    got = swap(batch, src, dst, **options)
    assert moves == []  # no image's keypoints moved alone
    want = single(monkeypatch, batch, src, dst, **options)
    assert moves == [9 * len(p) for p in points]
    assert_close(got, want)
    assert [len(k) for k in got.keypoints] == [len(p) for p in points]


def test_a_plain_chunk_runs_no_inverse_of_its_own(gl, rng, monkeypatch):
    """The batched passes alone move a plain chunk's keypoints: neither an image's
    ``SingleWarper.move`` nor an MLS's inverse runs."""
    batch = images(rng, np.uint8, 5)
    src, dst = handles(rng, 5)
    points = keypoints(rng, 5)

    def refuse(*args, **kwargs):
        raise AssertionError("keypoints moved image by image")

    with monkeypatch.context() as m:
        m.setattr(SingleWarper, "move", refuse)
        m.setattr(InverseMLS, "__call__", refuse)
        got = swap(batch, src, dst, keypoints=points)
    assert_close(got, single(monkeypatch, batch, src, dst, keypoints=points))


def test_only_empty_keypoint_sets(gl, rng, monkeypatch):
    batch = images(rng, np.uint8, 3)
    src, dst = handles(rng, 3)
    points = [np.zeros((0, 2))] * 3
    got = swap(batch, src, dst, keypoints=points)
    assert [k.shape for k in got.keypoints] == [(0, 2)] * 3
    assert [v.shape for v in got.keypoints_valid] == [(0,)] * 3
    assert_close(got, single(monkeypatch, batch, src, dst, keypoints=points))


def test_a_folding_map_moves_its_keypoints_alone(gl, rng, monkeypatch):
    """An image whose s folds takes the single path's keypoints bit for bit (its mesh's
    guess picks the sheet); the chunk's others stay batched."""
    batch = images(rng, np.uint8, 4)
    src, dst = handles(rng, 4)
    dst[2] = dst[2].copy()
    dst[2][[0, 5]] = dst[2][[5, 0]]  # two targets exchanged: s turns over between them
    height, width = SHAPE
    points = [rng.uniform((0, 0), (width - 1, height - 1), (8, 2)) for _ in range(4)]
    folds = []
    found = preimages._folds

    def counted(*args):
        folded = found(*args)
        folds.append(folded.tolist())
        return folded

    monkeypatch.setattr(preimages, "_folds", counted)
    moves = alone_moves(monkeypatch)
    got = swap(batch, src, dst, keypoints=points)
    assert folds == [[False, False, True, False]] and moves == [9 * 8]
    assert_close(got, single(monkeypatch, batch, src, dst, keypoints=points), exact=(2,))


def test_a_radius_weight_moves_keypoints_alone(gl, rng, monkeypatch):
    batch = images(rng, np.uint8, 3)
    src, dst = handles(rng, 3)
    points = keypoints(rng, 3)
    options = {"keypoints": points, "weight": "cressman", "radius": 30.0}
    moves = alone_moves(monkeypatch)
    got = swap(batch, src, dst, **options)
    assert moves == [9 * len(p) for p in points]
    want = single(monkeypatch, batch, src, dst, **options)
    assert_close(got, want, exact=range(3))


@pytest.mark.parametrize("transform", ["affine", "similarity", "rigid"])
def test_moved_keypoints_are_the_float64_preimages(gl, rng, transform):
    """s, in float64 (:func:`glmls.reference.mls` with p and q swapped), takes each moved
    keypoint back to the keypoint."""
    batch = images(rng, np.uint8, 4)
    src, dst = handles(rng, 4, jitter=2.0)
    points = keypoints(rng, 4)
    origin = np.array([-2.0, 3.0])
    out = swap(
        batch, src, dst, keypoints=points, transform=transform, origin=tuple(origin.tolist())
    )
    for p, q, x, moved in zip(src, dst, points, out.keypoints, strict=True):
        if len(x):
            back = reference.mls(q, p, moved + origin, shape=SHAPE, transform=transform)[0]
            np.testing.assert_allclose(back, x, rtol=0, atol=REFERENCE_ATOL)


def slope_inverse(p, q, x) -> np.ndarray:
    """(2, 2) the float64 Jacobian's inverse of s (handles ``q`` -> ``p``) at ``x`` (2,)."""
    h = 1e-4
    at = np.array([x + (h, 0), x - (h, 0), x + (0, h), x - (0, h)])
    values = reference.mls(q, p, at, shape=SHAPE)[0]
    jacobian = np.stack([values[0] - values[1], values[2] - values[3]], axis=1) / (2 * h)
    return np.linalg.inv(jacobian)


@pytest.mark.parametrize("interpolation", ["nearest", "linear"])
def test_a_hot_pixel_lands_where_its_keypoint_does(gl, rng, interpolation):
    """An image dark but for one pixel at the keypoint: with nearest sampling the moved
    keypoint lies within half a pixel of a lit pixel's centre (half a source pixel through
    the map's slope, where it magnifies), with linear sampling the pixel under it is lit."""
    height, width = SHAPE
    count = 6
    batch = np.zeros((count, *SHAPE), np.float32)
    spots = np.stack([rng.integers(8, width - 8, count), rng.integers(8, height - 8, count)], 1)
    for k, (x, y) in enumerate(spots):
        batch[k, y, x] = 1.0
    src, dst = handles(rng, count, jitter=1.5)
    points = [spot[None].astype(np.float64) for spot in spots]
    out = swap(batch, src, dst, keypoints=points, interpolation=interpolation)
    for k in range(count):
        moved = out.keypoints[k][0]
        assert out.keypoints_valid[k][0]
        if interpolation == "linear":
            column, row = np.rint(moved).astype(int)
            assert out.images[k][row, column] > 0, (k, moved)
            continue
        lit = np.argwhere(out.images[k] > 0)[:, ::-1]  # (x, y) of the hot pixel's copies
        assert len(lit)
        reach = 0.5 * max(1.0, np.abs(slope_inverse(src[k], dst[k], moved)).sum(axis=1).max())
        assert np.abs(lit - moved).max(axis=1).min() <= reach + 1e-3, (k, moved, lit)


def test_points_newton_leaves_take_the_second_dispatch(gl, rng, monkeypatch):
    """First guesses far off (f moved 10,000 px away): the first dispatch's bounded steps
    leave every point, the damped second dispatch (from the point itself) finds each, and
    the keypoints still land where the single path puts them."""
    batch = images(rng, np.uint8, 4)
    src, dst = handles(rng, 4)
    points = keypoints(rng, 4)
    guessed = preimages.f_at
    calls: list[int] = []

    def far(*args):
        values = guessed(*args)
        calls.append(len(values))
        return [v + 1e4 for v in values] if len(calls) == 1 else values

    dispatches: list[bool] = []
    newton = preimages._newton

    def counted(*args, rescue):
        dispatches.append(rescue)
        return newton(*args, rescue=rescue)

    monkeypatch.setattr(preimages, "f_at", far)
    monkeypatch.setattr(preimages, "_newton", counted)
    moves = alone_moves(monkeypatch)
    got = swap(batch, src, dst, keypoints=points)
    assert dispatches == [False, True] and moves == []
    assert_close(got, single(monkeypatch, batch, src, dst, keypoints=points))


def test_images_left_alone_leave_the_others_batched(gl, rng, monkeypatch):
    """Where some images of a chunk move their keypoints image by image (here: as if their
    swapped handles needed the far-target translation), those equal the single path's bit
    for bit and the others take the passes of the remaining images alone."""
    batch = images(rng, np.uint8, 5)
    src, dst = handles(rng, 5)
    points = keypoints(rng, 5)
    lone = np.array([True, False, False, True, False])
    monkeypatch.setattr(glmls.batch.swap, "lone_images", lambda *args: lone)
    moves = alone_moves(monkeypatch)
    got = swap(batch, src, dst, keypoints=points)
    assert moves == [9 * len(points[i]) for i in np.flatnonzero(lone)]
    assert_close(got, single(monkeypatch, batch, src, dst, keypoints=points), exact=(0, 3))


def test_small_images_take_their_length_unit(gl, rng, monkeypatch):
    """Images whose box is under 32 px: Newton's steps and tolerance are shares of a length
    unit below a pixel (:func:`glmls.imaging.inverse.length_unit`), each image its own."""
    shape = (10, 14)
    count = 4
    batch = rng.integers(0, 255, (count, *shape), dtype=np.uint8)
    corners = np.array([[2.0, 2.0], [11.0, 2.0], [2.0, 7.0], [11.0, 7.0]])
    src = [corners[: 3 + k % 2] + rng.uniform(-0.5, 0.5, (3 + k % 2, 2)) for k in range(count)]
    dst = [p + rng.normal(0, 0.3, p.shape) for p in src]
    points = [rng.uniform((-1, -1), (14, 10), (k, 2)) for k in (3, 6, 2, 5)]
    units = []
    found = preimages._units

    def seen(lattices):
        values = found(lattices)
        units.append(values)
        return values

    monkeypatch.setattr(preimages, "_units", seen)
    moves = alone_moves(monkeypatch)
    got = swap(batch, src, dst, keypoints=points)
    assert moves == [] and (units[0] < 1).all()
    for i in range(count):  # the unit of the swapped MLS's own inverse
        with glmls.MLS(dst[i], src[i], shape=shape) as swapped:
            assert units[0][i] == pytest.approx(length_unit(swapped.kernel), rel=1e-12)
    assert_close(got, single(monkeypatch, batch, src, dst, keypoints=points))


@pytest.mark.parametrize("grid", [1, 4])
def test_hot_pixels_centre_on_their_keypoints_where_s_folds(gl, grid):
    """Strong random moves (6 handles moved by N(0, 3 px) on 40 x 44 images): next to a
    fold of s its inverse stretches a pixel several times and bends across it, and what
    shows of the pixel is centred off the keypoint. The footprint's image is tested for
    that (its edge points' mean against the keypoint): over the valid keypoints the
    intensity-weighted centroid of the warped hot pixel (bilinear) lies within 0.5 px of
    the keypoint at the 99th percentile (0.97 px, 1.9 at most, without the test)."""
    rng = np.random.default_rng(0)
    height, width = 40, 44
    errors = []
    for _ in range(4):
        p = rng.uniform(4, 40, (6, 2))
        q = p + rng.normal(0, 3.0, p.shape)
        count = 48
        hot = np.stack([rng.integers(1, width - 1, count), rng.integers(1, height - 1, count)], 1)
        images = np.zeros((count, height, width), np.float32)
        images[np.arange(count), hot[:, 1], hot[:, 0]] = 1.0
        result = glmls.warp_batch(
            images,
            np.repeat(p[None], count, 0),
            np.repeat(q[None], count, 0),
            keypoints=hot[:, None, :].astype(float),
            method="backward-swap",
            grid=grid,
            interpolation="linear",
        )
        for i in np.flatnonzero(result.keypoints_valid[:, 0]):
            rows, cols = np.nonzero(result.images[i])
            weight = result.images[i][rows, cols]
            centre = np.array([cols @ weight, rows @ weight]) / weight.sum()
            errors.append(np.linalg.norm(centre - result.keypoints[i, 0]))
    assert len(errors) > 150
    assert np.percentile(errors, 99) <= 0.5, np.sort(errors)[-5:]


@pytest.mark.parametrize(
    ("transform", "targets"),
    [
        ("rigid", [[12.0, 9.0], [12.0, 9.0], [30.0, 24.0]]),  # two q, one point
        ("affine", [[8.0, 8.0], [20.0, 14.0], [32.0, 20.0]]),  # q on one line
    ],
)
def test_swapped_handles_without_an_mls_keep_f(gl, rng, transform, targets):
    """Handles whose swap makes no MLS (the single warp evaluates its kernel unchecked) warp
    with keypoints as without, each such keypoint at f's value; the chunk's other images
    move theirs by s's inverse as before."""
    batch = images(rng, np.uint8, 3)
    src, dst = handles(rng, 3)
    src[1] = np.array([[10.0, 8.0], [40.0, 30.0], [12.0, 30.0]])
    dst[1] = np.array(targets)
    points = keypoints(rng, 3)
    points[1] = np.array([[20.0, 15.0], [33.5, 21.25]])
    options = {"transform": transform}
    got = swap(batch, src, dst, keypoints=points, **options)
    plain = swap(batch, src, dst, **options)
    for a, b in zip(got.images, plain, strict=True):
        np.testing.assert_array_equal(a, b)
    with glmls.MLS(src[1], dst[1], shape=SHAPE, **options) as m:
        np.testing.assert_allclose(got.keypoints[1], m(points[1]), rtol=0, atol=1e-4)
    others = swap(
        batch[[0, 2]],
        [src[0], src[2]],
        [dst[0], dst[2]],
        keypoints=[points[0], points[2]],
        **options,
    )
    for k, i in enumerate((0, 2)):
        np.testing.assert_allclose(got.keypoints[i], others.keypoints[k], rtol=0, atol=ATOL)
        np.testing.assert_array_equal(got.keypoints_valid[i], others.keypoints_valid[k])
