"""``backward`` with keypoints runs on the batched GPU path: one Newton dispatch over every
image of a chunk, the keypoints moved by f at every image's probes in one pass and tested
against the chunk's own maps; keypoints, flags, images, masks and maps equal to the single
path's, bit for bit, and the keypoints to a float64 f."""

from __future__ import annotations

import numpy as np
import pytest

import glmls
import glmls.batch.run
from glmls import reference
from glmls.batch.gpu import BatchQuads
from glmls.batch.single import SingleWarper

SHAPE = (20, 24)
FIELDS = ("images", "keypoints", "keypoints_valid", "masks", "maps", "valid")


def folding_handles(shape):
    height, width = shape
    src = np.array([[4.0, 4.0], [width - 5, 4], [4, height - 5], [width - 5, height - 5]])
    src = np.r_[src, [[width / 2 - 4, height / 2]], [[width / 2 + 4, height / 2]]]
    dst = src.copy()
    dst[4, 0], dst[5, 0] = width / 2 + 6, width / 2 - 6  # two handles pass each other
    return src, dst


def batch(rng, count=5):
    """Images, handles (image 1's folding), masks and ragged keypoints, some off the image."""
    height, width = SHAPE
    src = rng.uniform((2, 2), (width - 3, height - 3), (count, 6, 2))
    dst = src + rng.normal(0, 2.0, src.shape)
    src[1], dst[1] = folding_handles(SHAPE)
    images = rng.integers(0, 256, (count, *SHAPE, 3), dtype=np.uint8)
    masks = rng.integers(0, 4, (count, *SHAPE)).astype(np.uint8)
    sizes = [0, 40, 3, 60, 1][:count]
    points = [rng.uniform((-3, -3), (width + 3, height + 3), (k, 2)) for k in sizes]
    return images, src, dst, masks, points


def warped(images, src, dst, **options):
    return glmls.warp_batch(images, src, dst, method="backward", **options)


def single_warps(monkeypatch) -> list:
    """The indices of the images that ``SingleWarper.warp_one`` warps one by one from now on
    (the list fills as it is called)."""
    single = []
    warp_one = SingleWarper.warp_one
    monkeypatch.setattr(
        SingleWarper,
        "warp_one",
        lambda self, *a, **k: single.append(k["index"]) or warp_one(self, *a, **k),
    )
    return single


@pytest.mark.parametrize(
    "options",
    [
        {"grid": 1},
        {"grid": 4, "interpolation": "linear"},
        {"grid": 4, "border": "edge"},
        {"grid": 2, "border": "wrap", "output_shape": (18, 30), "origin": (-2.0, 1.5)},
    ],
)
@pytest.mark.parametrize("maps", [False, True])
def test_backward_keypoints_run_batched_as_the_single_path(gl, rng, monkeypatch, options, maps):
    images, src, dst, masks, points = batch(rng)
    labels = {"keypoints": points, "masks": masks, "return_maps": maps}
    single = single_warps(monkeypatch)
    calls = []
    backward = BatchQuads.backward

    def counted(self, lattices, *args, **kwargs):
        calls.append(len(lattices))
        return backward(self, lattices, *args, **kwargs)

    monkeypatch.setattr(BatchQuads, "backward", counted)
    result = warped(images, src, dst, **labels, **options)
    # every image in a batched chunk (one per margin past the images with a border mode)
    assert sum(calls) == len(images) and single == []
    calls.clear()
    chunked = warped(images, src, dst, max_batch_bytes=1, **labels, **options)
    assert calls == [1] * len(images)
    monkeypatch.setattr(glmls.batch.run, "batchable", lambda chosen: False)
    alone = warped(images, src, dst, **labels, **options)
    assert single == list(range(len(images)))
    for name in FIELDS:
        want = getattr(alone, name)
        for got in (getattr(result, name), getattr(chunked, name)):
            if want is None:
                assert got is None
                continue
            assert len(got) == len(want)
            for a, b in zip(got, want, strict=True):
                np.testing.assert_array_equal(a, b, err_msg=name)
    assert [len(k) for k in result.keypoints] == [len(p) for p in points]
    assert not result.keypoints_valid[1].all()  # the fold hides some of image 1's points


@pytest.mark.parametrize("border", ["constant", "edge"])
def test_backward_keypoints_equal_the_float64_f(gl, rng, border):
    images, src, dst, _, points = batch(rng)
    origin = np.array([-2.0, 1.5])
    result = warped(images, src, dst, keypoints=points, border=border, origin=tuple(origin))
    height, width = SHAPE
    for i, p in enumerate(points):
        want = reference.mls(src[i], dst[i], p, shape=SHAPE)[0] - origin if len(p) else p
        # float32 f on the GPU: about 1e-6 of the coordinates
        np.testing.assert_allclose(result.keypoints[i], want, rtol=0, atol=1e-4)
        on = np.all((want >= -0.5) & (want < (width - 0.5, height - 0.5)), axis=1)
        inside = np.all((p >= -0.5) & (p <= (width - 0.5, height - 0.5)), axis=1)
        allowed = on & (inside if border == "constant" else True)
        assert not np.any(result.keypoints_valid[i] & ~allowed)  # never valid off the canvas


def test_one_image_with_many_keypoints_pads_no_other(gl, rng, monkeypatch):
    """f at the keypoints runs in slices of every image's points; the images whose points
    have run out leave the later passes, and the result is the single path's."""
    import glmls.batch.chunks
    from glmls.engine.batched import BatchLattices

    images, src, dst, _, _ = batch(rng, 4)
    points = [rng.uniform(0, 19, (k, 2)) for k in (1, 31, 0, 7)]
    passes = []
    evaluate = BatchLattices.evaluate_points

    def counted(self, gl, resources, slices, shape):
        passes.append([len(s) for s in slices])
        return evaluate(self, gl, resources, slices, shape)

    monkeypatch.setattr(BatchLattices, "evaluate_points", counted)
    monkeypatch.setattr(glmls.batch.probes, "SLICE_BYTES", 8 * 4 * 100)  # 100 points each
    result = warped(images, src, dst, keypoints=points)
    # the probes: five points for each keypoint and each of its footprint's eight edge
    # points, so 45, 1395, 0 and 315 points; image 2 has none
    assert passes == [[45, 100, 100]] + [[100, 100]] * 2 + [[100, 15]] + [[100]] * 9 + [[95]]
    monkeypatch.setattr(glmls.batch.run, "batchable", lambda chosen: False)
    alone = warped(images, src, dst, keypoints=points)
    for name in ("keypoints", "keypoints_valid"):
        for got, want in zip(getattr(result, name), getattr(alone, name), strict=True):
            np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize("border", ["constant", "edge"])
def test_images_of_their_own_mls_leave_the_others_batched(gl, rng, monkeypatch, border):
    """An image without point handles or with segment handles takes the single path alone:
    the other images of its chunk stay batched, every image equal to its single warp."""
    images, src, dst, masks, points = batch(rng, 5)
    src, dst = list(src), list(dst)
    src[2] = dst[2] = np.zeros((0, 2))
    segments = [None, None, None, np.array([[[3.0, 3.0], [15.0, 12.0]]]), None]
    moved = [None if s is None else s + 0.75 for s in segments]
    labels = {"keypoints": points, "masks": masks, "return_maps": True, "border": border}
    labels |= {"src_segments": segments, "dst_segments": moved, "grid": 2}
    single = single_warps(monkeypatch)
    result = warped(images, src, dst, **labels)
    assert single == [2, 3]
    monkeypatch.setattr(glmls.batch.run, "batchable", lambda chosen: False)
    alone = warped(images, src, dst, **labels)
    for name in FIELDS:
        for got, want in zip(getattr(result, name), getattr(alone, name), strict=True):
            np.testing.assert_array_equal(got, want, err_msg=name)
    for i in range(5):
        own = {} if segments[i] is None else {"src_segments": segments[i]}
        own |= {} if moved[i] is None else {"dst_segments": moved[i]}
        options = {"method": "backward", "grid": 2, "border": border, **own}
        want = glmls.warp(images[i], src[i], dst[i], **options)
        np.testing.assert_array_equal(result.images[i], want)
