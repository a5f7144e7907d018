"""``backward-swap`` runs on the batched GPU path: the swapped-handles map of every image of a
chunk in one dispatch, one draw sampling the sources, one read-back; images, masks and maps
equal to one :func:`glmls.warp` (and :meth:`glmls.MLS.coordinate_map`) per image, bit for
bit, and keypoints to the single path's within float32's rounding and Newton's stopping
(tests/batch/test_swap_keypoints.py)."""

from __future__ import annotations

import numpy as np
import pytest

import glmls
import glmls.batch.chunks
import glmls.batch.run
from glmls.batch.single import SingleWarper
from glmls.batch.swap import swapped_lattices
from glmls.core.config import MLSConfig
from glmls.core.handles import pack_handles
from glmls.engine.kernel import CAPPED_NEWTON_HANDLES

SHAPE = (20, 24)
COUNTS = (3, 6, 4, 17, 6)  # ragged: two unrollings of the handle loop
N = len(COUNTS)
FIELDS = ("images", "masks", "maps", "valid", "keypoints", "keypoints_valid")
#: Pixels: a batch's swap keypoints against one warp's (float32 rounding, Newton's stopping).
KEYPOINT_ATOL = 1e-3


def handles(rng, counts=COUNTS, spread=2.0):
    height, width = SHAPE
    src = [rng.uniform((2, 2), (width - 3, height - 3), (k, 2)) for k in counts]
    dst = [p + rng.normal(0, spread, p.shape) for p in src]
    return src, dst


def images(rng, dtype, channels, count=N):
    """``channels`` 0: (N, H, W) images."""
    shape = (count, *SHAPE) + ((channels,) if channels else ())
    if dtype == np.float32:
        return rng.uniform(-1.0, 2.0, shape).astype(np.float32)
    return rng.integers(0, np.iinfo(dtype).max, shape, dtype=dtype, endpoint=True)


def keypoints(rng, count=N):
    height, width = SHAPE
    sizes = [0, 7, 3, 12, 1, 5][:count]
    return [rng.uniform((-3, -3), (width + 3, height + 3), (k, 2)) for k in sizes]


def single_warps(monkeypatch) -> list[int]:
    """The indices of the images that ``SingleWarper.warp_one`` warps one by one from now on."""
    single: list[int] = []
    warp_one = SingleWarper.warp_one
    monkeypatch.setattr(
        SingleWarper,
        "warp_one",
        lambda self, *a, **k: single.append(k["index"]) or warp_one(self, *a, **k),
    )
    return single


def swap_calls(monkeypatch) -> list[int]:
    """The images of each batched ``backward-swap`` submission from now on."""
    calls: list[int] = []
    original = glmls.batch.chunks.warp_swapped

    def counted(quads, lattices, *args, **kwargs):
        calls.append(len(lattices))
        return original(quads, lattices, *args, **kwargs)

    monkeypatch.setattr(glmls.batch.chunks, "warp_swapped", counted)
    return calls


def swapped(images, src, dst, **options):
    return glmls.warp_batch(images, src, dst, method="backward-swap", **options)


CASES = [
    ("constant", "nearest", np.uint8, 3, np.uint8, None),  # the mask rides as a channel
    ("constant", "linear", np.float32, 1, np.int32, ((18, 30), (-2.0, 1.5))),
    ("edge", "linear", np.uint16, 0, np.uint8, None),
    ("reflect", "nearest", np.float32, 4, np.uint16, ((22, 17), (3.0, -2.5))),
    ("symmetric", "nearest", np.uint16, 3, bool, None),
    ("wrap", "linear", np.uint8, 4, np.uint8, ((18, 30), (-2.0, 1.5))),
    ("constant", "nearest", np.uint8, 1, np.uint16, ((25, 20), (-4.0, -3.0))),
]


@pytest.mark.parametrize(("border", "interpolation", "dtype", "channels", "mask", "canvas"), CASES)
def test_backward_swap_runs_batched_as_single_warps(
    gl, rng, monkeypatch, border, interpolation, dtype, channels, mask, canvas
):
    batch = images(rng, dtype, channels)
    src, dst = handles(rng)
    masks = rng.integers(0, 2 if mask is bool else 5, (len(batch), *SHAPE)).astype(mask)
    points = keypoints(rng)
    on_canvas = {"border": border, "grid": 2}
    if canvas is not None:
        on_canvas |= {"output_shape": canvas[0], "origin": canvas[1]}
    options = on_canvas | {"interpolation": interpolation}
    labels = {"masks": masks, "keypoints": points, "return_maps": True}
    single = single_warps(monkeypatch)
    calls = swap_calls(monkeypatch)
    pipeline = glmls.gl.WarpPipeline.of(gl)
    result = swapped(batch, src, dst, **labels, **options)
    assert calls == [len(batch)] and single == []  # one submission, no image alone
    for i in range(len(batch)):
        want = glmls.warp(batch[i], src[i], dst[i], method="backward-swap", **options)
        assert result.images[i].dtype == want.dtype
        np.testing.assert_array_equal(result.images[i], want)
        with glmls.MLS(src[i], dst[i], shape=SHAPE) as m:
            where = m.coordinate_map(SHAPE, method="backward-swap", **on_canvas)
            _, _, covered = pipeline.coordinate_map(m, SHAPE, method="backward-swap", **on_canvas)
        np.testing.assert_array_equal(result.maps[i], where)
        if border == "constant":
            np.testing.assert_array_equal(result.valid[i], covered)
        else:  # a border mode's copies beyond the image show no source pixel there
            height, width = SHAPE
            on = np.all((where >= -0.5) & (where < (width - 0.5, height - 0.5)), axis=-1)
            np.testing.assert_array_equal(result.valid[i], covered & on)
    monkeypatch.setattr(glmls.batch.run, "batchable", lambda chosen: False)
    alone = swapped(batch, src, dst, **labels, **options)
    assert single == list(range(len(batch)))
    for name in FIELDS:
        want_all = getattr(alone, name)
        got_all = getattr(result, name)
        assert len(got_all) == len(want_all)
        for got, want in zip(got_all, want_all, strict=True):
            assert got.dtype == want.dtype, name
            if name == "keypoints":  # Newton on s stops elsewhere within its 1e-4 px
                np.testing.assert_allclose(got, want, rtol=0, atol=KEYPOINT_ATOL, err_msg=name)
            else:
                np.testing.assert_array_equal(got, want, err_msg=name)
    assert [len(k) for k in result.keypoints] == [len(p) for p in points]


def test_small_chunks_equal_one_chunk(gl, rng, monkeypatch):
    batch = images(rng, np.uint8, 3)
    src, dst = handles(rng)
    masks = rng.integers(0, 5, (len(batch), *SHAPE)).astype(np.int32)
    options = {"masks": masks, "return_maps": True, "interpolation": "linear"}
    calls = swap_calls(monkeypatch)
    whole = swapped(batch, src, dst, **options)
    chunked = swapped(batch, src, dst, max_batch_bytes=1, **options)
    assert calls == [len(batch)] + [1] * len(batch)
    for name in ("images", "masks", "maps", "valid"):
        np.testing.assert_array_equal(getattr(chunked, name), getattr(whole, name))


def test_the_batched_path_warps_no_image_alone(gl, rng, monkeypatch):
    """The loop of single warps is not taken: a batch of images of one shape never calls
    ``SingleWarper.warp_one``."""
    batch = images(rng, np.float32, 3)
    src, dst = handles(rng)

    def refuse(*args, **kwargs):
        raise AssertionError("an image warped alone")

    monkeypatch.setattr(SingleWarper, "warp_one", refuse)
    out = swapped(batch, src, dst, keypoints=keypoints(rng), masks=batch[..., 0] > 0.5)
    assert out.images.shape == batch.shape and out.masks.dtype == bool


def test_a_list_of_images_of_two_shapes_runs_a_chunk_per_shape(gl, rng, monkeypatch):
    src, dst = handles(rng, (5, 5, 5, 5))
    small = rng.integers(0, 256, (2, *SHAPE, 3), dtype=np.uint8)
    large = rng.integers(0, 256, (2, 26, 31, 3), dtype=np.uint8)
    batch = [small[0], large[0], small[1], large[1]]
    calls = swap_calls(monkeypatch)
    single = single_warps(monkeypatch)
    out = swapped(batch, src, dst, border="edge")
    assert sorted(calls) == [2, 2] and single == []
    for i, image in enumerate(batch):
        want = glmls.warp(image, src[i], dst[i], method="backward-swap", border="edge")
        np.testing.assert_array_equal(out[i], want)


@pytest.mark.parametrize(
    "mls_options",
    [{"bins": True, "weight": "cressman", "radius": 12.0}, {"storage": "texture"}],
)
def test_what_one_evaluation_does_not_take_warps_image_by_image(gl, rng, monkeypatch, mls_options):
    batch = images(rng, np.uint8, 3, 3)
    src, dst = handles(rng, (4, 6, 5))
    single = single_warps(monkeypatch)
    calls = swap_calls(monkeypatch)
    out = swapped(batch, src, dst, **mls_options)
    assert calls == [] and single == [0, 1, 2]
    for i in range(len(batch)):
        want = glmls.warp(batch[i], src[i], dst[i], method="backward-swap", **mls_options)
        np.testing.assert_array_equal(out[i], want)


def test_segment_handles_and_no_handles_warp_alone_the_others_batched(gl, rng, monkeypatch):
    batch = images(rng, np.uint8, 3, 4)
    src, dst = handles(rng, (4, 0, 5, 6))
    segments = [None, None, np.array([[[3.0, 3.0], [10.0, 12.0]]]), None]
    moved = [None, None, segments[2] + 1.5, None]
    single = single_warps(monkeypatch)
    calls = swap_calls(monkeypatch)
    options = {"src_segments": segments, "dst_segments": moved}
    out = swapped(batch, src, dst, **options)
    assert calls == [2] and single == [1, 2]
    for i in range(len(batch)):
        own = {} if segments[i] is None else {"src_segments": segments[i], "dst_segments": moved[i]}
        want = glmls.warp(batch[i], src[i], dst[i], method="backward-swap", **own)
        np.testing.assert_array_equal(out[i], want)


def test_targets_that_one_evaluation_refuses_take_the_single_path(gl, rng, monkeypatch):
    """Affine MLS of targets on one line: the swapped map's sources do not span the plane,
    which the batched evaluation refuses and the single path's swapped kernel takes."""
    batch = images(rng, np.uint8, 3, 3)
    src, dst = handles(rng, (4, 4, 4))
    dst[1] = np.c_[np.linspace(3.0, 20.0, 4), np.full(4, 9.0)]
    single = single_warps(monkeypatch)
    out = swapped(batch, src, dst, transform="affine")
    assert single == [0, 1, 2]
    for i in range(len(batch)):
        want = glmls.warp(batch[i], src[i], dst[i], method="backward-swap", transform="affine")
        np.testing.assert_array_equal(out[i], want)


@pytest.mark.parametrize("transform", ["affine", "similarity", "rigid"])
def test_swapped_lattices_hold_the_swapped_kernels_handles(gl, rng, transform):
    """Each image's scaling and scaled handles are those its MLS's swapped kernel has."""
    src, dst = handles(rng, spread=6.0)
    dst[2] = dst[2] + (40.0, -25.0)  # targets beyond the image widen the box
    config = MLSConfig(transform=transform)
    lattices = swapped_lattices(config, src, dst, SHAPE)
    assert lattices is not None
    starts = np.cumsum([0, *COUNTS])
    for k, (p, q) in enumerate(zip(src, dst, strict=True)):
        with glmls.MLS(p, q, shape=SHAPE, transform=transform) as m:
            scaling = m.swapped_kernel().scaling
        assert tuple(lattices.centers[k]) == scaling.center
        assert lattices.scales[k] == scaling.scale
        rows = lattices.packed[starts[k] : starts[k + 1]]
        np.testing.assert_array_equal(rows, pack_handles(q, p, scaling))


def test_a_batch_beyond_the_loop_limit_is_refused_as_its_warp(gl, rng):
    """The single warp's swapped pass refuses more handles than a capped driver's loops
    visit; the batched pass refuses the same image, naming it."""
    if gl.loop_limit is None:
        pytest.skip("this driver runs every loop iteration")
    count = CAPPED_NEWTON_HANDLES + 1
    batch = rng.integers(0, 255, (2, 8, 8), dtype=np.uint8)
    src = [rng.uniform(0, 7, (3, 2)), rng.uniform(0, 7, (count, 2))]
    dst = [p + 0.25 for p in src]
    with pytest.raises(ValueError, match=f"{count:,} handles"):
        glmls.warp(batch[1], src[1], dst[1], method="backward-swap", ctx=gl)
    with pytest.raises(ValueError, match=f"images\\[1\\]: {count:,} handles"):
        swapped(batch, src, dst, ctx=gl)
