"""glmls.warp_batch: equal to one glmls.warp per image for every method, interpolation, dtype
and border; ragged handles, different shapes, chunks; keypoints land on the pixels the warp
placed them at (also where the map folds); masks keep their labels; maps agree with
MLS.coordinate_map; bad input is named."""

from __future__ import annotations

import numpy as np
import pytest

import glmls

N = 3
SHAPE = (24, 32)


def handles(rng, count=N, k=6, shape=SHAPE, spread=3.0):
    height, width = shape
    src = rng.uniform((2, 2), (width - 3, height - 3), (count, k, 2))
    return src, src + rng.normal(0, spread, src.shape)


def images(rng, count=N, shape=SHAPE, channels=3, dtype=np.uint8):
    size = (count, *shape) + ((channels,) if channels else ())
    if np.issubdtype(dtype, np.integer):
        return rng.integers(0, np.iinfo(dtype).max, size, dtype=dtype, endpoint=True)
    return rng.uniform(0, 1, size).astype(dtype)


def singles(batch, src, dst, **options):
    return [glmls.warp(image, p, q, **options) for image, p, q in zip(batch, src, dst, strict=True)]


@pytest.mark.parametrize("method", glmls.METHODS)
@pytest.mark.parametrize("interpolation", glmls.INTERPOLATIONS)
def test_equals_single_warps(gl, rng, method, interpolation):
    batch = images(rng)
    src, dst = handles(rng)
    out = glmls.warp_batch(batch, src, dst, method=method, interpolation=interpolation)
    assert isinstance(out, np.ndarray) and out.shape == batch.shape and out.dtype == np.uint8
    np.testing.assert_array_equal(
        out, singles(batch, src, dst, method=method, interpolation=interpolation)
    )


@pytest.mark.parametrize(
    ("dtype", "channels"),
    [
        (np.uint8, 0),
        (np.uint8, 1),
        (np.uint8, 2),
        (np.uint8, 4),
        (np.uint16, 3),
        (np.float32, 1),
        (np.float32, 4),
    ],
)
@pytest.mark.parametrize("method", ["quads", "backward"])
def test_dtypes_and_channels(gl, rng, dtype, channels, method):
    batch = images(rng, channels=channels, dtype=dtype)
    src, dst = handles(rng)
    options = {"method": method, "interpolation": "linear", "grid": 2}
    out = glmls.warp_batch(batch, src, dst, **options)
    assert out.dtype == dtype and out.shape == batch.shape
    np.testing.assert_array_equal(out, singles(batch, src, dst, **options))


@pytest.mark.parametrize("border", glmls.BORDERS)
@pytest.mark.parametrize("method", ["quads", "backward"])
def test_borders_and_canvas(gl, rng, border, method):
    batch = images(rng)
    src, dst = handles(rng, spread=5.0)
    options = {
        "method": method,
        "border": border,
        "output_shape": (20, 36),
        "origin": (-2.0, 1.0),
        "background": (9, 8, 7),
    }
    out = glmls.warp_batch(batch, src, dst, **options)
    assert out.shape == (N, 20, 36, 3)
    np.testing.assert_array_equal(out, singles(batch, src, dst, **options))


def test_ragged_handles_and_shapes(gl, rng):
    shapes = [(20, 30), (24, 32), (20, 30)]
    batch = [images(rng, 1, shape)[0] for shape in shapes]
    src = [handles(rng, 1, k, shape)[0][0] for k, shape in zip((3, 7, 5), shapes, strict=True)]
    dst = [p + rng.normal(0, 2, p.shape) for p in src]
    out = glmls.warp_batch(batch, src, dst, grid=2)
    assert isinstance(out, list) and [o.shape[:2] for o in out] == shapes
    for got, want in zip(out, singles(batch, src, dst, grid=2), strict=True):
        np.testing.assert_array_equal(got, want)
    same = glmls.warp_batch([batch[0], batch[2]], [src[0], src[2]], [dst[0], dst[2]], grid=2)
    assert isinstance(same, np.ndarray) and same.shape == (2, 20, 30, 3)


def test_mls_options_and_segments(gl, rng):
    batch = images(rng)
    src, dst = handles(rng)
    segments = [None, np.array([[[2.0, 2.0], [20.0, 3.0]]]), None]
    moved = [None, segments[1] + 1.0, None]
    options = {"transform": "similarity", "weight": "gaussian", "radius": 20.0}
    out = glmls.warp_batch(batch, src, dst, src_segments=segments, dst_segments=moved, **options)
    for i in range(N):
        extra = (
            {} if segments[i] is None else {"src_segments": segments[i], "dst_segments": moved[i]}
        )
        np.testing.assert_array_equal(
            out[i], glmls.warp(batch[i], src[i], dst[i], **extra, **options)
        )


@pytest.mark.parametrize("storage", ["ssbo", "ubo", "texture"])
@pytest.mark.parametrize("method", ["quads", "backward"])
def test_every_handle_storage_as_one_warp_takes_it(gl, rng, storage, method):
    """Each storage's shader rounds f in its own way (a texture's fetch compiles to other
    arithmetic than a buffer's read): the batch's f is each image's own, storage included."""
    batch = images(rng, count=8, channels=4, dtype=np.uint16)
    src, dst = handles(rng, count=8, k=5)
    options = {"method": method, "interpolation": "linear", "storage": storage}
    out = glmls.warp_batch(batch, src, dst, **options)
    np.testing.assert_array_equal(out, singles(batch, src, dst, **options))


@pytest.mark.parametrize("method", ["quads", "backward"])
def test_no_point_handles_as_one_warp_takes_them(gl, rng, method):
    """An image without point handles, as :func:`glmls.warp` takes it: the identity, or its
    segment handles alone, beside images with handles, keypoints and maps asked for."""
    batch = images(rng, count=4)
    p, q = handles(rng, count=4)
    none = np.zeros((0, 2))
    src, dst = [p[0], none, none, p[3]], [q[0], none, none, q[3]]
    segments = [None, None, np.array([[[3.0, 3.0], [25.0, 4.0]], [[3.0, 18.0], [25.0, 20.0]]])]
    segments.append(None)
    moved = [None, None, segments[2] + [[[0.0, 1.5], [1.0, -1.0]], [[1.0, 0.0], [0.0, 1.0]]], None]
    points = rng.uniform(2, 20, (4, 3, 2))
    options = {"method": method, "src_segments": segments, "dst_segments": moved}
    result = glmls.warp_batch(batch, src, dst, keypoints=points, return_maps=True, **options)
    plain = glmls.warp_batch(batch, src, dst, **options)
    for i in range(4):
        extra = (
            {} if segments[i] is None else {"src_segments": segments[i], "dst_segments": moved[i]}
        )
        one = glmls.warp(batch[i], src[i], dst[i], method=method, **extra)
        np.testing.assert_array_equal(result.images[i], one)
        np.testing.assert_array_equal(plain[i], one)
    np.testing.assert_array_equal(result.images[1], batch[1])
    np.testing.assert_allclose(result.keypoints[1], points[1], atol=1e-5)
    assert result.keypoints_valid[1].all()
    same = glmls.warp_batch(batch, np.zeros((4, 0, 2)), np.zeros((4, 0, 2)), method=method)
    np.testing.assert_array_equal(same, batch)


@pytest.mark.parametrize(
    ("images", "labels"),
    [
        (np.zeros((0, 5, 6, 3), np.uint8), {}),
        ([], {}),
        (np.zeros((0, 5, 6), np.uint16), {"keypoints": np.zeros((0, 4, 2)), "return_maps": True}),
        ([], {"keypoints": [], "masks": []}),
        (np.zeros((0, 8, 8), np.int64), {}),
    ],
)
def test_an_empty_batch_is_refused(images, labels):
    """A batch of no image is bad input: a ValueError that says so, whatever the empty
    array's dtype or the labels asked for."""
    none = np.zeros((0, 3, 2))
    with pytest.raises(ValueError, match=r"^images is an empty batch \(shape \(0"):
        glmls.warp_batch(images, none, none, **labels)


def test_masks_keep_their_labels(gl, rng):
    batch = images(rng)
    src, dst = handles(rng, spread=4.0)
    labels = rng.choice(np.array([0, 3, 70000, -5], np.int32), (N, *SHAPE))
    result = glmls.warp_batch(batch, src, dst, masks=labels, interpolation="linear")
    assert isinstance(result, glmls.BatchResult)
    assert result.masks.dtype == np.int32 and result.masks.shape == labels.shape
    assert set(np.unique(result.masks)) <= {0, 3, 70000, -5}
    np.testing.assert_array_equal(result.images, singles(batch, src, dst, interpolation="linear"))
    small = labels.astype(np.uint8) % 7
    ones = glmls.warp_batch(batch, src, dst, masks=small, method="backward")
    for i in range(N):
        want = glmls.warp(small[i], src[i], dst[i], method="backward")
        np.testing.assert_array_equal(ones.masks[i], want)


@pytest.mark.parametrize("method", ["quads", "backward", "splat"])
def test_bool_masks_stay_bool(gl, rng, method):
    """A binary mask may be bool: warped as the labels 0 and 1, it comes back bool, False
    where nothing is shown, in a list beside masks of other dtypes."""
    batch = images(rng)
    src, dst = handles(rng, spread=4.0)
    labels = rng.integers(0, 2, (N, *SHAPE), dtype=np.uint8)
    options = {"method": method, "output_shape": (30, 36), "origin": (-3, -2)}
    want = glmls.warp_batch(batch, src, dst, masks=labels, **options).masks
    result = glmls.warp_batch(batch, src, dst, masks=labels.astype(bool), **options)
    assert result.masks.dtype == bool and result.masks.shape == want.shape
    np.testing.assert_array_equal(result.masks, want.astype(bool))
    mixed = [labels[0].astype(bool), labels[1], labels[2].astype(bool).tolist()]
    some = glmls.warp_batch(batch, src, dst, masks=mixed, **options).masks
    assert isinstance(some, list) and [m.dtype for m in some] == [bool, np.uint8, bool]
    for got, expected in zip(some, want, strict=True):
        np.testing.assert_array_equal(got.astype(np.uint8), expected)


@pytest.mark.parametrize("method", ["backward", "backward-swap"])
def test_maps_agree_with_coordinate_map(gl, rng, method):
    batch = images(rng)
    src, dst = handles(rng)
    result = glmls.warp_batch(batch, src, dst, return_maps=True, method=method, grid=2)
    assert result.maps.shape == (N, *SHAPE, 2) and result.valid.dtype == bool
    for i in range(N):
        with glmls.MLS(src[i], dst[i], shape=SHAPE) as m:
            want = m.coordinate_map(SHAPE, method=method, grid=2)
        np.testing.assert_array_equal(result.maps[i], want)


def test_quads_maps_are_close_to_f_inverse(gl, rng):
    batch = images(rng)
    src, dst = handles(rng, spread=2.0)
    result = glmls.warp_batch(batch, src, dst, return_maps=True, grid=1)
    for i in range(N):
        with glmls.MLS(src[i], dst[i], shape=SHAPE) as m:
            want = m.coordinate_map(SHAPE)
        inside = result.valid[i]
        assert inside.mean() > 0.8
        error = np.abs(result.maps[i][inside] - want[inside]).max(axis=1)
        assert np.median(error) < 0.02 and np.percentile(error, 95) < 0.25


def folding_handles(shape):
    height, width = shape
    src = np.array([[4.0, 4.0], [width - 5, 4], [4, height - 5], [width - 5, height - 5]])
    src = np.r_[src, [[width / 2 - 4, height / 2]], [[width / 2 + 4, height / 2]]]
    dst = src.copy()
    dst[4, 0], dst[5, 0] = width / 2 + 6, width / 2 - 6  # two handles pass each other: a fold
    return src, dst


def hot_pixels(rng, shape, count, margin, dtype, fold):
    """(hot (count, 2) pixels at least ``margin`` from the edges, a batch of images each
    black but for its hot pixel at full scale, src, dst): a folding map for every image, or
    random handles of each its own."""
    height, width = shape
    hot = np.c_[
        rng.integers(margin, width - margin, count), rng.integers(margin, height - margin, count)
    ]
    batch = np.zeros((count, *shape), dtype)
    batch[np.arange(count), hot[:, 1], hot[:, 0]] = 255 if dtype == np.uint8 else 1.0
    if fold:
        p, q = folding_handles(shape)
        return hot, batch, np.repeat(p[None], count, 0), np.repeat(q[None], count, 0)
    return hot, batch, *handles(rng, count, 6, shape, spread=1.5)


@pytest.mark.parametrize("method", ["quads", "backward"])
@pytest.mark.parametrize("grid", [1, 4])
@pytest.mark.parametrize("fold", [False, True])
def test_keypoints_land_on_their_pixels(gl, rng, method, grid, fold):
    shape = (28, 36)
    count = 40
    hot, batch, src, dst = hot_pixels(rng, shape, count, 2, np.uint8, fold)
    options = {"method": method, "grid": grid, "weight": "idw", "alpha": 2.0}
    result = glmls.warp_batch(batch, src, dst, keypoints=hot[:, None, :].astype(float), **options)
    errors = []
    for i in range(count):
        rows, cols = np.nonzero(result.images[i] == 255)
        if not result.keypoints_valid[i, 0]:
            continue
        if not len(rows):  # squeezed between output pixel centres: shown by none
            continue
        # the distance to the nearest output pixel centre showing the hot pixel
        centres = np.c_[cols, rows]
        errors.append(np.abs(result.keypoints[i, 0] - centres).max(axis=1).min())
    assert len(errors) >= count // 2
    # a pixel turned by the map reaches up to half its diagonal from its centre on an axis
    assert np.percentile(errors, 90) <= 0.5 + 1e-6, np.sort(errors)[-5:]
    assert max(errors) <= 0.5 * np.sqrt(2) + 0.15, np.sort(errors)[-5:]


def test_backward_swap_keypoints_land_on_their_pixels(gl, rng):
    """``backward-swap`` shows at output pixel u the source point s(u), s the MLS map with p
    and q swapped: a keypoint moves by s's inverse, which differs from f by pixels where the
    handles move far, not by f."""
    shape = (20, 26)
    count = 30
    hot, batch, _, _ = hot_pixels(rng, shape, count, 3, np.uint8, False)
    src, dst = handles(rng, count, 6, shape, spread=2.5)
    points = hot[:, None, :].astype(float)
    result = glmls.warp_batch(batch, src, dst, keypoints=points, method="backward-swap")
    errors = []
    for i in range(count):
        rows, cols = np.nonzero(result.images[i] == 255)
        if result.keypoints_valid[i, 0] and len(rows):
            errors.append(np.abs(result.keypoints[i, 0] - np.c_[cols, rows]).max(axis=1).min())
    assert len(errors) >= count * 3 // 4
    # as for the other methods; the greatest error where s folds a pixel's square away
    assert np.percentile(errors, 90) <= 0.5 + 1e-6, np.sort(errors)[-5:]
    assert max(errors) <= 1.5, np.sort(errors)[-5:]


@pytest.mark.parametrize("method", ["quads", "backward"])
@pytest.mark.parametrize("grid", [1, 4])
@pytest.mark.parametrize("fold", [False, True])
def test_keypoints_on_the_warped_hot_pixel_centre(gl, rng, method, grid, fold):
    """One image per keypoint with a single hot pixel, warped with linear sampling: the
    keypoint lies on the centre of the warped pixel, the intensity-weighted centroid of what
    shows it, within 0.5 px at the 99th percentile, where the map folds too. The centroid
    stands for the centre where the pixel's footprint (its bilinear tent, source points
    within 1 px) is seen whole and sampled: none of it hidden by a fold (the keypoints at its
    corners and edge midpoints are all valid) and none of it squeezed (they land at 0.9 times
    their source distance from the centre's keypoint or farther). A map that squeezes the
    footprint between output pixel centres shows it by a pixel or two, or by none, whose
    centroid is the pixels' own (docs/batch.md)."""
    shape = (28, 36)
    count = 300
    hot, batch, src, dst = hot_pixels(rng, shape, count, 3, np.float32, fold)
    options = {"method": method, "grid": grid, "weight": "idw", "alpha": 2.0}
    ring = np.array([[x, y] for y in (0.0, -0.99, 0.99) for x in (0.0, -0.99, 0.99)])
    points = hot[:, None, :] + ring  # the centre first, then the footprint's edge
    result = glmls.warp_batch(batch, src, dst, keypoints=points, interpolation="linear", **options)
    rows, cols = np.mgrid[: shape[0], : shape[1]]
    errors = []
    for i in range(count):
        if not result.keypoints_valid[i].all():
            continue
        point = result.keypoints[i, 0]
        near = (np.abs(cols - point[0]) <= 2) & (np.abs(rows - point[1]) <= 2)
        weight = np.where(near, result.images[i], 0.0)
        spread = np.hypot(*(result.keypoints[i, 1:] - point).T) / np.hypot(*ring[1:].T)
        if spread.min() < 0.9:  # the map squeezes the footprint
            continue
        if not weight.any():  # not shown
            errors.append(np.inf)
            continue
        centroid = np.array([(weight * cols).sum(), (weight * rows).sum()]) / weight.sum()
        errors.append(np.hypot(*(centroid - point)))
    assert len(errors) >= count // 8
    assert np.percentile(errors, 99) <= 0.5, np.sort(errors)[-5:]


def test_keypoints_outside_and_ragged(gl, rng):
    batch = images(rng)
    src, dst = handles(rng)
    points = [np.array([[5.0, 5.0], [-30.0, 4.0]]), np.zeros((0, 2)), np.array([[3.0, 9.0]])]
    result = glmls.warp_batch(batch, src, dst, keypoints=points)
    assert isinstance(result.keypoints, list)
    assert [len(k) for k in result.keypoints] == [2, 0, 1]
    assert not result.keypoints_valid[0][1]
    assert result.masks is None and result.maps is None and result.params is None


def test_keypoint_sets_given_as_empty_lists(gl, rng):
    """A sample without keypoints may be an empty list, as a list of point lists has it."""
    batch = images(rng)
    src, dst = handles(rng)
    result = glmls.warp_batch(batch, src, dst, keypoints=[[[5.0, 5.0]], [], [[3.0, 9.0]]])
    assert [len(k) for k in result.keypoints] == [1, 0, 1]
    assert [np.shape(k) for k in result.keypoints_valid] == [(1,), (0,), (1,)]
    none = glmls.warp_batch(batch, src, dst, keypoints=[[], [], []])
    assert none.keypoints.shape == (N, 0, 2) and none.keypoints_valid.shape == (N, 0)


@pytest.mark.parametrize(
    ("kwargs", "error", "message"),
    [
        ({"src": np.zeros((2, 4, 2))}, ValueError, "src holds 2 handle sets for 3 images"),
        (
            {"dst": [np.zeros((4, 2))] * 2 + [np.zeros((5, 3))]},
            ValueError,
            r"dst\[2\] has shape \(5, 3\)",
        ),
        (
            {"dst": [np.zeros((4, 2))] * 2 + [np.zeros((5, 2))]},
            ValueError,
            r"src\[2\] and dst\[2\]",
        ),
        (
            {"src": np.full((3, 4, 2), np.nan)},
            ValueError,
            r"src\[0\] holds values that are not finite",
        ),
        (
            {"dst": [np.zeros((4, 2))] * 2 + [np.full((4, 2), 2e9)]},
            ValueError,
            r"dst\[2\] must lie within ±1e\+06 px",
        ),
        ({"images": [np.zeros((4, 4), np.int8)] * 3}, TypeError, r"images\[0\] has dtype int8"),
        ({"images": np.zeros((3, 4, 4, 5), np.uint8)}, ValueError, r"images\[0\] has shape"),
        (  # volumes, with 3D handles: said to be warped one at a time
            {"images": np.zeros((3, 4, 4, 6), np.uint8), "src": np.zeros((3, 4, 3))},
            ValueError,
            r"images\[0\] has shape \(4, 4, 6\).*a volume is warped by glmls\.MLS",
        ),
        ({"keypoints": np.zeros((3, 2, 3))}, ValueError, r"keypoints\[0\] has shape \(2, 3\)"),
        ({"keypoints": [np.zeros((1, 2))] * 2}, ValueError, "keypoints holds 2 point sets"),
        ({"keypoints": [np.zeros((1, 2))]}, ValueError, "keypoints holds 1 point set for 3"),
        ({"masks": np.zeros((1, 4, 4), np.uint8)}, ValueError, "masks holds 1 mask for 3 images"),
        (
            {"keypoints": [[[1.0, 2.0]], [[1e30, 2.0]], [[1.0, 2.0]]]},
            ValueError,
            r"keypoints\[1\] must lie within ±1e\+06 px",
        ),
        (
            {"keypoints": np.array([[[1.0, 2.0]], [[1.0, 2.0]], [[2.0, -3e6]]])},
            ValueError,
            r"keypoints\[2\] must lie within ±1e\+06 px",
        ),
        ({"masks": np.zeros((3, 4, 5), np.uint8)}, ValueError, r"masks\[0\] has shape \(4, 5\)"),
        ({"masks": np.zeros((3, 4, 4), np.float32)}, TypeError, r"masks\[0\] has dtype float32"),
        ({"methd": "quads"}, TypeError, "unknown keyword methd"),
        (
            {"src_segments": [None, None, [[[0, 0], [3, 0]]]]},
            ValueError,
            r"images\[2\]: src_segments needs dst_segments",
        ),
        (
            {
                "src_segments": [None, [[[0, 0], [3, 0]]], None],
                "dst_segments": [None, [[0, 0]], None],
            },
            ValueError,
            r"images\[1\]: dst_segments must have shape \(S, 2, 2\)",
        ),
        ({"max_batch_bytes": 0}, ValueError, "max_batch_bytes must be an integer >= 1 or None"),
        ({"max_batch_bytes": -5}, ValueError, "max_batch_bytes must be .* got -5"),
        ({"max_batch_bytes": "1M"}, TypeError, "max_batch_bytes must be .* got '1M'"),
        ({"return_maps": "yes"}, TypeError, "return_maps must be True or False, got 'yes'"),
        ({"method": "swirl"}, ValueError, "unknown method 'swirl'"),
    ],
)
def test_bad_input_is_named(gl, kwargs, error, message):
    arguments = {
        "images": np.zeros((3, 4, 4), np.uint8),
        "src": np.tile([[0.0, 0.0], [3.0, 0.0], [0.0, 3.0], [3.0, 3.0]], (3, 1, 1)),
        "dst": np.tile([[0.0, 0.0], [3.0, 0.0], [0.0, 3.0], [3.0, 3.0]], (3, 1, 1)),
    } | kwargs
    with pytest.raises(error, match=message):
        glmls.warp_batch(**arguments)


def test_quads_run_in_chunks_on_the_gpu_path(gl, rng, monkeypatch):
    """quads take the batched path, one submission per chunk (8-bit
    nearest images on their bytes, :mod:`glmls.batch.texels`); small chunks give what one
    chunk gives."""
    from glmls.batch import chunks
    from glmls.batch.gpu import BatchQuads

    calls = []
    warp, warp_texels = BatchQuads.warp, chunks.warp_texels

    def counted(self, kernels, *args, **kwargs):
        calls.append(len(kernels))
        return warp(self, kernels, *args, **kwargs)

    def counted_texels(quads, kernels, *args, **kwargs):
        calls.append(len(kernels))
        return warp_texels(quads, kernels, *args, **kwargs)

    monkeypatch.setattr(BatchQuads, "warp", counted)
    monkeypatch.setattr(chunks, "warp_texels", counted_texels)
    batch = images(rng, 7)
    src, dst = handles(rng, 7)
    masks = rng.integers(0, 9, (7, *SHAPE)).astype(np.uint16)
    points = rng.uniform(0, 20, (7, 4, 2))
    whole = glmls.warp_batch(batch, src, dst, grid=2, masks=masks, keypoints=points)
    assert calls == [7, 7]  # the images, then the masks (uint16: not packed)
    calls.clear()
    for budget, sizes in ((1, [1] * 14), (40_000, [2, 2, 2, 2, 2, 2, 1, 1])):
        calls.clear()
        chunked = glmls.warp_batch(
            batch, src, dst, grid=2, masks=masks, keypoints=points, max_batch_bytes=budget
        )
        assert calls == sizes
        for name in ("images", "masks", "keypoints", "keypoints_valid"):
            np.testing.assert_array_equal(getattr(chunked, name), getattr(whole, name))
    np.testing.assert_array_equal(whole.images, singles(batch, src, dst, grid=2))
    calls.clear()
    glmls.warp_batch(batch, src, dst, method="backward", keypoints=points)
    assert calls == []  # the single pipeline, image by image


def test_backward_runs_batched_on_the_gpu_path(gl, rng, monkeypatch):
    """backward without keypoints takes the batched path: one Newton dispatch over every
    image's pixels per chunk, the masks sampled at its maps; images, masks and maps equal to
    single warps, chunked or not."""
    from glmls.batch.gpu import BatchQuads

    calls = []
    backward = BatchQuads.backward

    def counted(self, lattices, *args, **kwargs):
        calls.append(len(lattices))
        return backward(self, lattices, *args, **kwargs)

    monkeypatch.setattr(BatchQuads, "backward", counted)
    batch = images(rng, 7)
    src, dst = handles(rng, 7, spread=4.0)
    masks = rng.integers(0, 9, (7, *SHAPE)).astype(np.uint16)
    for interpolation in ("nearest", "linear"):
        options = {"method": "backward", "grid": 2, "interpolation": interpolation}
        calls.clear()
        whole = glmls.warp_batch(batch, src, dst, masks=masks, return_maps=True, **options)
        assert calls == [7]  # the images, and the masks sampled at the same maps
        np.testing.assert_array_equal(whole.images, singles(batch, src, dst, **options))
        for i in range(7):
            with glmls.MLS(src[i], dst[i], shape=SHAPE) as m:
                want = m.coordinate_map(SHAPE, method="backward", grid=2)
            np.testing.assert_array_equal(whole.maps[i], want)
            mask = glmls.warp(masks[i], src[i], dst[i], method="backward", grid=2)
            np.testing.assert_array_equal(whole.masks[i], mask)
        calls.clear()
        small = glmls.warp_batch(batch, src, dst, max_batch_bytes=40_000, **options)
        assert len(calls) > 1
        np.testing.assert_array_equal(small, whole.images)


def test_chunk_size_follows_the_limits(gl):
    from glmls.batch.gpu import chunk_size
    from glmls.core.mesh import MeshLattice
    from glmls.imaging.frame import Frame
    from glmls.imaging.source import prepare_image

    source = prepare_image(np.zeros((224, 224, 3), np.uint8), 4096, normalized=True)
    frame, lattice = Frame((224, 224)), MeshLattice.corners((224, 224), 4)
    atlas = gl.limits["max_texture_size"] // 224
    assert chunk_size(gl, source, frame, lattice, 1 << 40) == min(atlas, 2048)
    assert chunk_size(gl, source, frame, lattice, 10 * 224 * 224 * 16) < 10
    assert chunk_size(gl, source, frame, lattice, 1) == 1


@pytest.mark.parametrize("fold", [False, True, "mixed"])
def test_the_fill_draw_equals_the_fused_scan(gl, rng, monkeypatch, fold):
    """Nearest 8-bit chunks: colours written in the scan (without keys for meshes shown to
    be embeddings, with keys and fix-ups for the others; the embeddings by a scan of their
    own or not) or drawn from the keys give the single warp's pixels, in chunks of folded and
    unfolded meshes alike."""
    from glmls.batch import texels
    from glmls.batch.gpu import BatchQuads

    shape = (28, 36)
    batch = images(rng, 4, shape)
    if fold:
        p, q = folding_handles(shape)
        src, dst = np.repeat(p[None], 4, 0), np.repeat(q[None], 4, 0)
    else:
        src, dst = handles(rng, 4, 6, shape, spread=4.0)
    if fold == "mixed":
        p, q = folding_handles(shape)
        src, dst = list(src), list(dst)
        src[1], dst[1], src[2], dst[2] = p, q, p, q[::-1] * 0.5 + p * 0.5
    want = singles(batch, src, dst, grid=1)
    for fused, fast in ((True, True), (True, False), (False, True)):
        monkeypatch.setattr(BatchQuads, "fused", fused)
        monkeypatch.setattr(texels, "FAST_PASS", fast)  # embeddings by a scan of their own
        np.testing.assert_array_equal(glmls.warp_batch(batch, src, dst, grid=1), want)


def test_embedded_meshes_skip_the_fold_test_exactly(gl):
    from glmls.batch.embedding import embedded
    from glmls.batch.labels import mesh_keypoints
    from glmls.core.mesh import MeshLattice

    shape = (28, 36)
    lattice = MeshLattice.corners(shape, 2)
    identity = lattice.points()
    p, q = folding_handles(shape)
    with glmls.MLS(p, q, shape=shape) as m:
        folded = m(identity.reshape(-1, 2)).reshape(identity.shape)
    assert embedded(np.stack([identity, folded])).tolist() == [True, False]
    grid = np.stack(np.meshgrid(np.arange(36.0), np.arange(28.0)), -1).reshape(-1, 2)
    _, valid = mesh_keypoints(lattice, folded, grid, None)
    assert 0 < (~valid).sum() < len(grid) // 2  # the points that the fold hides
    _, valid = mesh_keypoints(lattice, identity, grid, None)
    assert valid.all()


def test_quads_maps_of_a_chunk_equal_the_single_fill(gl, rng):
    """The batched path's maps are the quads' own source points, as the single pipeline's
    coordinate fill gives them, bit for bit (folds included)."""
    from glmls.batch.single import SingleWarper
    from glmls.imaging.frame import make_frame

    shape = (28, 36)
    batch = images(rng, 3, shape)
    src, dst = handles(rng, 3, 6, shape, spread=3.0)
    p, q = folding_handles(shape)
    src, dst = [src[0], p, src[2]], [dst[0], q, dst[2]]
    options = {"grid": 2, "output_shape": (30, 40), "origin": (-1.0, 0.5)}
    result = glmls.warp_batch(batch, src, dst, return_maps=True, **options)
    warper = SingleWarper.of()
    chosen = glmls.WarpOptions(**options)
    frame = make_frame(chosen.output_shape, chosen.origin, shape, 4096)
    for i in range(3):
        with glmls.MLS(src[i], dst[i], shape=shape) as m:
            coords, covered = warper.source_points(m, shape, chosen, frame)
        np.testing.assert_array_equal(result.maps[i], coords)
        np.testing.assert_array_equal(result.valid[i], covered)


def test_one_mls_pass_for_many_handle_counts(gl, rng):
    """The chunk's f in one pass per handle-loop unrolling and per part whose handles fit in
    a uniform block (more handles: a storage buffer): each image's pixels are still its
    single warp's."""
    counts = [3, 16, 40, 2000, 2500, 5000]
    batch = images(rng, len(counts))
    src = [rng.uniform(0, 20, (k, 2)) for k in counts]
    dst = [p + rng.normal(0, 1.0, p.shape) for p in src]
    for method in ("quads", "backward"):
        out = glmls.warp_batch(batch, src, dst, method=method, grid=2)
        for i in range(len(counts)):
            want = glmls.warp(batch[i], src[i], dst[i], method=method, grid=2)
            np.testing.assert_array_equal(out[i], want)


@pytest.mark.parametrize("channels", [0, 1, 2, 3, 4])
def test_nearest_bytes_in_and_out(gl, rng, channels):
    """Nearest 8-bit chunks go up as the caller's bytes and come back packed into one array
    (glmls.batch.texels): any channel count, a canvas of its own, a pixel count not a
    multiple of 4, strided and listed inputs, small chunks, folded meshes among them; labels
    riding along with 1 and 3 channels; all equal to single warps."""
    shape = (13, 21)
    batch = images(rng, 5, shape, channels)
    src, dst = handles(rng, 5, 6, shape, spread=3.0)
    p, q = folding_handles(shape)
    src[2], dst[2] = p, q
    options = {"grid": 2, "output_shape": (15, 19), "origin": (-1.0, 0.5), "background": 7}
    want = np.stack(singles(batch, src, dst, **options))
    out = glmls.warp_batch(batch, src, dst, **options)
    np.testing.assert_array_equal(out, want)
    strided = np.repeat(batch, 2, axis=0)[::2]
    for given, budget in ((strided, None), (list(batch), None), (batch, 3000)):
        again = glmls.warp_batch(given, src, dst, max_batch_bytes=budget, **options)
        np.testing.assert_array_equal(again, want)
    masks = rng.integers(0, 256, (5, *shape), dtype=np.uint8)
    result = glmls.warp_batch(batch, src, dst, masks=masks, keypoints=src, **options)
    np.testing.assert_array_equal(result.images, want)
    for i in range(5):
        mask = glmls.warp(masks[i], src[i], dst[i], **(options | {"background": 0}))
        np.testing.assert_array_equal(result.masks[i], mask)
    assert result.keypoints_valid.shape == (5, 6)


def test_a_keypoint_whose_footprint_a_fold_cuts_is_not_valid(gl):
    """Where a fold hides part of a pixel's footprint, what shows of the pixel is cut off:
    over every valid keypoint of a folding map, the centroid of what shows its hot pixel
    (bilinear sampling) is within 0.5 px of it at the 99th percentile, with no keypoint left
    out for a squeezed footprint. Testing the keypoint alone left cut footprints valid
    (about 1.6 px at the 99th percentile on this map)."""
    shape = (28, 36)
    height, width = shape
    ys, xs = np.mgrid[3 : height - 3, 3 : width - 3]
    hot = np.c_[xs.ravel(), ys.ravel()]
    count = len(hot)
    batch = np.zeros((count, *shape), np.float32)
    batch[np.arange(count), hot[:, 1], hot[:, 0]] = 1.0
    p, q = folding_handles(shape)
    result = glmls.warp_batch(
        batch,
        np.repeat(p[None], count, 0),
        np.repeat(q[None], count, 0),
        keypoints=hot[:, None, :].astype(float),
        method="quads",
        interpolation="linear",
        weight="idw",
        alpha=2.0,
    )
    rows, cols = np.mgrid[:height, :width]
    errors = []
    for i in np.flatnonzero(result.keypoints_valid[:, 0]):
        weight = result.images[i]
        assert weight.any()  # a valid keypoint's pixel shows
        centroid = np.array([(weight * cols).sum(), (weight * rows).sum()]) / weight.sum()
        errors.append(np.hypot(*(centroid - result.keypoints[i, 0])))
    assert count // 3 <= len(errors) < count - 100  # the fold takes a share, not all
    assert np.percentile(errors, 99) <= 0.5, np.sort(errors)[-5:]


def test_footprints_that_turn_over_or_are_cut_make_their_keypoint_invalid():
    from glmls.batch.footprints import RING, seen_whole, turned, with_footprints

    points = np.array([[5.0, 5.0], [9.0, 5.0], [-0.2, -0.2]])
    ring = with_footprints(points, 0.5)
    assert ring.shape == (27, 2)
    np.testing.assert_array_equal(ring[::9], points)
    moved = ring * 2.0 + 1.0  # a zoom: nothing turns
    assert not turned(moved.reshape(3, 9, 2)).any()
    flipped = moved.reshape(3, 9, 2).copy()
    flipped[1, 2] = flipped[1, 0] - (flipped[1, 2] - flipped[1, 0])  # one edge point across
    assert turned(flipped).tolist() == [False, True, False]
    valid = np.ones(27, bool)
    valid[9 + 4] = False  # a hidden corner of the second footprint
    valid[18 + 4] = False  # the third's corner (-0.7, -0.7): outside the image, says nothing
    out, ok = seen_whole(ring, moved, valid, (12, 12), (30, 30))
    np.testing.assert_array_equal(out, points * 2.0 + 1.0)
    assert ok.tolist() == [True, False, True]
    _, ok = seen_whole(ring, moved, valid, (12, 12), (30, 30), hidden=False)
    assert ok.tolist() == [True, True, True]
    assert len(RING) == 9 and (RING[0] == 0).all()


def test_labels_and_maps_stack_by_their_own_shapes(gl, rng):
    """Masks, maps and valid come back as arrays where their N arrays share one shape and
    dtype, whatever the images' dtypes and channels; images of other shapes give lists of
    them, unless one output canvas gives every image one."""
    src, dst = handles(rng, spread=2.0)
    height, width = SHAPE
    mixed = [np.zeros(SHAPE, np.uint8), np.zeros((*SHAPE, 3), np.float32), np.ones(SHAPE, ">u2")]
    masks = np.ones((N, *SHAPE), np.uint8)
    result = glmls.warp_batch(mixed[:N], src, dst, masks=masks, return_maps=True)
    assert isinstance(result.images, list)
    assert result.masks.shape == (N, *SHAPE) and result.masks.dtype == np.uint8
    assert result.maps.shape == (N, *SHAPE, 2) and result.valid.shape == (N, *SHAPE)
    sizes = [np.zeros((height - k, width, 3), np.uint8) for k in range(N)]
    apart = glmls.warp_batch(
        sizes, src, dst, masks=[m[: height - k] for k, m in enumerate(masks)], return_maps=True
    )
    assert all(isinstance(f, list) for f in (apart.images, apart.masks, apart.maps, apart.valid))
    canvas = glmls.warp_batch(sizes, src, dst, return_maps=True, output_shape=(20, 24))
    assert isinstance(canvas.images, list) and canvas.maps.shape == (N, 20, 24, 2)
    for k, image in enumerate(sizes):
        single = glmls.warp_batch(
            [image], [src[k]], [dst[k]], return_maps=True, output_shape=(20, 24)
        )
        np.testing.assert_array_equal(canvas.maps[k], single.maps[0])
        np.testing.assert_array_equal(canvas.valid[k], single.valid[0])
