"""warp_batch's keypoints against an independent float64 reference: for ``quads`` the mesh's
piecewise linear map (each cell's triangles (00, 10, 11) and (00, 11, 01) over f at the
lattice, computed here from :func:`glmls.reference.mls`), for ``backward`` f itself, on
grids that divide the image and grids that do not, border modes (whose mesh reaches past the
image), output canvases and origins other than the input's, and images of several shapes in
one batch; and ``keypoints_valid`` of ``backward`` against the pixels its backward map shows
where f folds."""

from __future__ import annotations

import numpy as np
import pytest

import glmls
from glmls import reference
from glmls.batch.footprints import RING, footprint_radius, turned, with_footprints
from glmls.core.mesh import MeshLattice
from glmls.imaging.frame import border_margin, make_frame

CONFIG = {"weight": "idw", "alpha": 2.0}


def mesh_map(values, lattice: MeshLattice, points: np.ndarray) -> np.ndarray:
    """The deformed mesh's map at source ``points`` inside the lattice, point by point:
    the cell holding it (the last one past the last line), its triangle by u >= v."""
    origin, last = np.asarray(lattice.origin), np.asarray(lattice.last)
    cells = np.asarray(lattice.cells)
    out = np.empty_like(points)
    for k, point in enumerate(points):
        index = np.clip(np.floor((point - origin) / lattice.grid), 0, cells - 1)
        low = np.minimum(origin + index * lattice.grid, last)
        high = np.minimum(origin + (index + 1) * lattice.grid, last)
        u, v = (point - low) / (high - low)
        d00, d10, d01, d11 = values(
            np.array([low, [high[0], low[1]], [low[0], high[1]], high], np.float64)
        )
        if u >= v:
            out[k] = d00 + u * (d10 - d00) + v * (d11 - d10)
        else:
            out[k] = d00 + u * (d11 - d01) + v * (d01 - d00)
    return out


def expected(method, src, dst, shape, options, points) -> np.ndarray:
    """Where ``points`` land on the output canvas, in float64."""

    def f(x):
        return reference.mls(src, dst, x, shape=shape, **CONFIG)[0]

    moved = f(points)
    if method == "quads":
        lattice = MeshLattice.corners(shape, options.get("grid", 1))
        if options.get("border", "constant") != "constant":  # the margin the pipeline draws
            frame = make_frame(options.get("output_shape"), options.get("origin"), shape, 1 << 14)
            with glmls.MLS(src, dst, shape=shape, **CONFIG) as mls:
                margin = border_margin(mls.kernel, lattice, frame, warn=False)
            lattice = lattice.with_margin(margin)
        origin, last = np.asarray(lattice.origin), np.asarray(lattice.last)
        inside = np.all((points >= origin) & (points <= last), axis=1)
        moved[inside] = mesh_map(f, lattice, points[inside])
    return moved - np.asarray(options.get("origin") or (0.0, 0.0))


def batch(rng, shapes, count=24):
    """Images, handles and keypoints: inside each image, up to 8 px outside, and on its
    corners and edges."""
    images, src, dst, points = [], [], [], []
    for height, width in shapes:
        images.append(rng.integers(0, 255, (height, width), dtype=np.uint8))
        p = rng.uniform((2, 2), (width - 3, height - 3), (6, 2))
        src.append(p)
        dst.append(p + rng.normal(0, 2.0, p.shape))
        edges = [[-0.5, -0.5], [width - 0.5, height - 0.5], [width - 1, 0], [0, height - 0.5]]
        points.append(
            np.r_[
                rng.uniform((-0.5, -0.5), (width - 0.5, height - 0.5), (count, 2)),
                rng.uniform((-8, -8), (width + 8, height + 8), (count // 3, 2)),
                edges,
            ]
        )
    return images, src, dst, points


CASES = [
    *[("quads", {"grid": grid}) for grid in (1, 2, 3, 4, 5, 7, 16)],
    *[("backward", {"grid": grid}) for grid in (1, 3, 4)],
    *[
        (method, {"grid": 4, "border": border})
        for method in ("quads", "backward")
        for border in ("edge", "reflect", "wrap")
    ],
    ("quads", {"grid": 3, "border": "symmetric", "output_shape": (40, 50), "origin": (-6, -5)}),
    ("quads", {"grid": 4, "output_shape": (20, 60), "origin": (3.5, -2.25)}),
    ("backward", {"grid": 1, "output_shape": (40, 30), "origin": (-4.0, 2.0)}),
]


@pytest.mark.parametrize(("method", "options"), CASES)
def test_keypoints_equal_the_float64_map(gl, rng, method, options):
    shapes = [(28, 36), (17, 23), (28, 36), (40, 13)]
    images, src, dst, points = batch(rng, shapes)
    result = glmls.warp_batch(
        images, src, dst, keypoints=points, method=method, **options, **CONFIG
    )
    for i, shape in enumerate(shapes):
        want = expected(method, src[i], dst[i], shape, options, points[i])
        # float32 f on the GPU: about 1e-6 of the coordinates
        np.testing.assert_allclose(result.keypoints[i], want, rtol=0, atol=1e-4)
        canvas = options.get("output_shape") or shape
        on = np.all((want >= -0.5) & (want < (canvas[1] - 0.5, canvas[0] - 0.5)), axis=1)
        assert not np.any(result.keypoints_valid[i] & ~on)  # never valid off the canvas


def folding_handles(shape):
    height, width = shape
    src = np.array([[4.0, 4.0], [width - 5, 4], [4, height - 5], [width - 5, height - 5]])
    src = np.r_[src, [[width / 2 - 4, height / 2]], [[width / 2 + 4, height / 2]]]
    dst = src.copy()
    dst[4, 0], dst[5, 0] = width / 2 + 6, width / 2 - 6  # two handles pass each other: a fold
    return src, dst


def next_to_unshown(points, unshown, missed, shape, reach) -> np.ndarray:
    """Whether each of the keypoints ``missed`` (indices into ``points``) that its own pixel
    shows has, within ``reach`` (its footprint: the sampling's reach) on each axis, a point
    inside the image that lands on the canvas and that its pixel does not show: a fold
    hides part of its footprint, so it is not valid though it is shown itself."""
    height, width = shape
    hidden = points[unshown]
    hidden = hidden[np.all((hidden >= -0.5) & (hidden < (width - 0.5, height - 0.5)), axis=1)]
    if not len(missed):
        return np.zeros(0, bool)
    if not len(hidden):
        return np.zeros(len(missed), bool)
    gap = np.abs(points[missed][:, None, :] - hidden[None]).max(axis=2).min(axis=1)
    return gap <= reach + 1e-9


@pytest.mark.parametrize("grid", [1, 4])
def test_backward_keypoints_shown_by_their_pixel_are_valid(gl, grid):
    """Where f folds, ``backward`` shows at each output pixel the layer its Newton search
    finds, often not the one the regular mesh's scan order would show: a keypoint whose
    nearest output pixel shows its own source point (within 0.25 px) is valid, whatever
    the mesh says, unless the fold hides part of its footprint."""
    shape = (28, 36)
    height, width = shape
    src, dst = folding_handles(shape)
    ys, xs = np.mgrid[0:height:0.25, 0:width:0.25]
    points = np.c_[xs.ravel(), ys.ravel()] - 0.375
    result = glmls.warp_batch(
        np.zeros((1, *shape), np.uint8),
        src[None],
        dst[None],
        keypoints=points[None],
        return_maps=True,
        method="backward",
        grid=grid,
        **CONFIG,
    )
    moved, valid = result.keypoints[0], result.keypoints_valid[0]
    pixel = np.rint(moved).astype(int)
    on = np.all((pixel >= 0) & (pixel < (width, height)), axis=1)
    column, row = pixel[on].T
    shown = result.maps[0][row, column]
    covered = result.valid[0][row, column]
    near = covered & (np.abs(shown - points[on]).max(axis=1) <= 0.25)
    assert near.sum() > len(points) // 8
    missed = np.flatnonzero(on)[near & ~valid[on]]
    cut = next_to_unshown(points, np.flatnonzero(on)[~near], missed, shape, 1.0)
    assert cut.all(), (points[missed[~cut][:5]], moved[missed[~cut][:5]])


@pytest.mark.parametrize("method", ["quads", "backward", "backward-swap"])
@pytest.mark.parametrize("border", ["constant", "edge", "reflect", "symmetric"])
def test_maps_sampled_with_nearest_give_the_pixels(gl, rng, method, border):
    """The maps are the flow of the pixels: the input, read at each valid output pixel's
    map value rounded to the nearest pixel (by the border rule beyond the image), is that
    output pixel, on a canvas other than the input's too."""
    shape = (24, 34)
    images = rng.integers(0, 256, (3, *shape), dtype=np.uint8)
    src = rng.uniform((2, 2), (shape[1] - 3, shape[0] - 3), (3, 6, 2))
    dst = src + rng.normal(0, 2.0, src.shape)
    canvas = {"output_shape": (30, 40), "origin": (-4.0, -3.0)}
    result = glmls.warp_batch(
        images, src, dst, return_maps=True, method=method, border=border, grid=4, **canvas
    )
    pad = 100
    mode = border  # numpy.pad's names
    for i in range(len(images)):
        column, row = np.rint(result.maps[i]).astype(int).transpose(2, 0, 1)
        valid = result.valid[i]
        if border == "constant":
            valid = valid & (column >= 0) & (column < shape[1]) & (row >= 0) & (row < shape[0])
        padded = np.pad(images[i], pad, mode=mode)
        shown = padded[row + pad, column + pad]
        assert valid.mean() > 0.5
        np.testing.assert_array_equal(shown[valid], result.images[i][valid])


@pytest.mark.parametrize("method", ["splat", "paper-quads"])
@pytest.mark.parametrize("border", ["constant", "edge"])
def test_forward_keypoints_shown_by_their_pixel_are_valid(gl, method, border):
    """``splat`` and ``paper-quads`` push the source pixels forward: where f folds, the
    pixel they draw is the one their pass leaves there, not always the layer f's inverse
    finds. A keypoint whose nearest output pixel shows its own source pixel (an image of
    the pixels' numbers, warped alike, says which) is valid, unless the fold hides part of
    its footprint or f folds inside it."""
    shape = (28, 36)
    height, width = shape
    src, dst = folding_handles(shape)
    ys, xs = np.mgrid[0:height:0.5, 0:width:0.5]
    points = np.c_[xs.ravel(), ys.ravel()] - 0.25
    numbers = np.arange(1, height * width + 1, dtype=np.float32).reshape(shape)
    result = glmls.warp_batch(
        numbers[None],
        src[None],
        dst[None],
        keypoints=points[None],
        method=method,
        border=border,
        **CONFIG,
    )
    moved, valid = result.keypoints[0], result.keypoints_valid[0]
    pixel = np.rint(moved).astype(int)
    on = np.all((pixel >= 0) & (pixel < (width, height)), axis=1)
    number = result.images[0][pixel[on, 1], pixel[on, 0]].astype(int) - 1
    shown = np.c_[number % width, number // width]
    own = (number >= 0) & (np.abs(shown - points[on]).max(axis=1) <= 0.5)
    assert own.sum() > len(points) // 4
    missed = np.flatnonzero(on)[own & ~valid[on]]
    cut = next_to_unshown(points, np.flatnonzero(on)[~own], missed, shape, 0.5)
    # or f folds inside its footprint: the footprint's image turns over in part
    with glmls.MLS(src, dst, shape=shape, **CONFIG) as m:
        ring = m(with_footprints(points[missed], footprint_radius("nearest")))
    folds = turned(ring.reshape(len(missed), len(RING), 2))
    assert (cut | folds).all(), (points[missed[~cut][:5]], moved[missed[~cut][:5]])


def edge_keypoints(shape: tuple[int, int], rng) -> np.ndarray:
    """Keypoints along the four sides of an image of ``shape``: on the image's edge, in its
    outer half pixel, on the outermost pixel centres, and just inside them."""
    height, width = shape
    points = []
    for offset in (-0.5, -0.3, 0.0, 0.3):
        ys = rng.uniform(-0.5, height - 0.5, 6)
        xs = rng.uniform(-0.5, width - 0.5, 6)
        points += [[offset, y] for y in ys] + [[width - 1 - offset, y] for y in ys]
        points += [[x, offset] for x in xs] + [[x, height - 1 - offset] for x in xs]
    return np.array(points)


@pytest.mark.parametrize("method", glmls.METHODS)
@pytest.mark.parametrize("interpolation", glmls.INTERPOLATIONS)
@pytest.mark.parametrize("far", [False, True], ids=["batched", "single"])
def test_a_valid_keypoint_shows_at_its_nearest_pixel(gl, rng, method, interpolation, far):
    """A keypoint on the image's edge lands on the warped image's edge, and the pixel
    nearest it may lie just past the last pixel centre the warp draws: it shows the
    background there, and the keypoint is not valid, whatever the method. On an image of
    one value, every valid keypoint's nearest pixel holds that value (``far``: targets
    moved far off, the canvas with them, which the single path warps image by image)."""
    shape = (24, 28)
    count = 8
    images = np.full((count, *shape), 200, np.uint8)
    src = rng.uniform(0, 27, (count, 6, 2))
    dst = src + rng.normal(0, 3.0, src.shape)
    canvas = {}
    if far:
        dst[..., 0] += 1e4
        canvas = {"output_shape": shape, "origin": (1e4, 0.0)}
    points = edge_keypoints(shape, rng)
    grid = 1 if method == "paper-quads" else 4
    result = glmls.warp_batch(
        images,
        src,
        dst,
        keypoints=np.repeat(points[None], count, 0),
        method=method,
        interpolation=interpolation,
        grid=grid,
        **canvas,
    )
    pixel = np.rint(result.keypoints).astype(int)
    on = np.all((pixel >= 0) & (pixel < (shape[1], shape[0])), axis=2)
    image, point = np.nonzero(on)
    drawn = result.images[image, pixel[image, point, 1], pixel[image, point, 0]] != 0
    valid = result.keypoints_valid[image, point]
    assert (~drawn).sum() >= 10  # the case is met
    assert not (valid & ~drawn).any(), points[point[valid & ~drawn]][:5]
    assert valid.sum() > len(valid) // 3  # paper-quads draws none of the outer half pixel
