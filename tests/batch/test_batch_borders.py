"""warp_batch's quads with a border mode on the batched GPU path: each image's mesh margin
found as its single warp finds it, the images run in parts of one margin, and images,
masks, keypoints and maps equal to the single pipeline's."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from numpy.testing import assert_array_equal

import glmls
from glmls.batch import chunks as chunks_module
from glmls.batch import run
from glmls.batch.gpu import BatchQuads
from glmls.batch.inputs import check_batch
from glmls.batch.margins import batch_margins
from glmls.core.config import MLSConfig
from glmls.core.mesh import MeshLattice
from glmls.errors import BorderWarning
from glmls.imaging.frame import border_margin, make_frame

SHAPE = (26, 34)
BORDERS = [b for b in glmls.BORDERS if b != "constant"]


def draw(rng, count: int, spreads=(0.0, 2.0, 6.0, 12.0)):
    """Images whose handles move by different amounts: their meshes need different
    margins."""
    height, width = SHAPE
    src = rng.uniform((1, 1), (width - 2, height - 2), (count, 7, 2))
    spread = np.resize(np.asarray(spreads), count)[:, None, None]
    dst = src + rng.normal(0, 1, src.shape) * spread
    batch = rng.integers(0, 256, (count, *SHAPE, 3), dtype=np.uint8)
    return batch, src, dst


def single_path(monkeypatch, *args, **kwargs):
    """warp_batch with the batched GPU path turned off: each image by the single pipeline."""
    with monkeypatch.context() as patch:
        patch.setattr(run, "batchable", lambda options: False)
        return glmls.warp_batch(*args, **kwargs)


def counting(monkeypatch, method: str = "warp") -> list[int]:
    """The images of each call of the batched path's ``BatchQuads.<method>``, as made."""
    calls: list[int] = []
    original = getattr(BatchQuads, method)

    def counted(self, lattices, *args, **kwargs):
        calls.append(len(lattices))
        return original(self, lattices, *args, **kwargs)

    monkeypatch.setattr(BatchQuads, method, counted)
    return calls


@pytest.mark.parametrize("border", BORDERS)
@pytest.mark.parametrize("interpolation", glmls.INTERPOLATIONS)
def test_border_modes_run_batched_as_single_warps(gl, rng, monkeypatch, border, interpolation):
    batch, src, dst = draw(rng, 8)
    masks = rng.integers(0, 7, (8, *SHAPE)).astype(np.uint16)
    points = rng.uniform((-6, -6), (SHAPE[1] + 6, SHAPE[0] + 6), (8, 12, 2))
    options = {
        "border": border,
        "interpolation": interpolation,
        "grid": 3,
        "output_shape": (30, 40),
        "origin": (-3.0, -2.0),
    }
    labels = {"keypoints": points, "masks": masks, "return_maps": True}
    calls = counting(monkeypatch)
    got = glmls.warp_batch(batch, src, dst, **labels, **options)
    assert sum(calls) == 8  # the images and their masks from one scan per chunk
    assert len(calls) > 1  # several margins, a part each
    want = single_path(monkeypatch, batch, src, dst, **labels, **options)
    for name in ("images", "masks", "keypoints_valid", "maps", "valid"):
        np.testing.assert_array_equal(getattr(got, name), getattr(want, name), err_msg=name)
    # the batched meshes' vertices are f read from the lattice pass, the single path's from
    # the points pass: the same f to float32's rounding
    np.testing.assert_allclose(got.keypoints, want.keypoints, rtol=0, atol=1e-3)
    for i in range(8):
        np.testing.assert_array_equal(
            got.images[i], glmls.warp(batch[i], src[i], dst[i], **options)
        )


@pytest.mark.parametrize("dtype", [np.uint16, np.float32])
def test_border_modes_for_other_dtypes_and_packed_masks(gl, rng, monkeypatch, dtype):
    data, src, dst = draw(rng, 5)
    batch = data.astype(np.float32) / 255 if dtype == np.float32 else data.astype(dtype) * 257
    masks = rng.integers(0, 3, (5, *SHAPE)).astype(np.uint8)
    options = {"border": "reflect", "interpolation": "linear", "transform": "rigid"}
    got = glmls.warp_batch(batch, src, dst, masks=masks, **options)
    want = single_path(monkeypatch, batch, src, dst, masks=masks, **options)
    assert got.images.dtype == dtype
    np.testing.assert_array_equal(got.images, want.images)
    np.testing.assert_array_equal(got.masks, want.masks)
    nearest = {"border": "wrap", "interpolation": "nearest"}
    got = glmls.warp_batch(data, src, dst, masks=masks, **nearest)
    want = single_path(monkeypatch, data, src, dst, masks=masks, **nearest)
    np.testing.assert_array_equal(got.images, want.images)  # the mask rides as a channel
    np.testing.assert_array_equal(got.masks, want.masks)


def test_margins_are_the_single_warps(gl, rng):
    batch, src, dst = draw(rng, 12, spreads=(0.0, 1.0, 4.0, 9.0, 20.0, 40.0))
    config = MLSConfig(transform="similarity", weight="gaussian")  # as the MLS below
    checked = check_batch(batch, src, dst, None, None)
    lattice = MeshLattice.corners(SHAPE, 2)
    for output_shape, origin in ((None, None), ((40, 50), (-8.0, -6.0)), ((10, 12), (20, 5))):
        frame = make_frame(output_shape, origin, SHAPE, 16384)
        parts, short = batch_margins(gl, config, checked, list(range(12)), lattice, frame)
        found = {i: margin for margin, part in parts.items() for i in part}
        assert sorted(found) == list(range(12))
        for i in range(12):
            with glmls.MLS(
                src[i], dst[i], shape=SHAPE, transform="similarity", weight="gaussian"
            ) as mls:
                want = border_margin(mls.kernel, lattice, frame, warn=False)
            assert found[i] == want, (i, output_shape)
        assert len(parts) > 1 and short == {}


def test_a_canvas_the_mesh_cannot_cover_warns_naming_the_image(gl, rng, monkeypatch):
    """A map that shrinks the plane and a canvas 100,000 px off the image: no margin within
    the budget covers it, a BorderWarning names each image, and the pixels equal the single
    warps'."""
    batch, src, dst = draw(rng, 3)
    dst = [p * 0.3 + 3.0 for p in src]
    options = {
        "border": "edge",
        "transform": "similarity",
        "grid": 4,
        "output_shape": (10, 10),
        "origin": (-1e5, 0.0),
    }
    calls = counting(monkeypatch)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        got = glmls.warp_batch(batch, src, dst, **options)
    messages = [str(w.message) for w in caught if issubclass(w.category, BorderWarning)]
    assert [m.split(":")[0] for m in messages] == ["images[0]", "images[1]", "images[2]"]
    assert all("does not cover the whole canvas" in m for m in messages)
    assert {w.filename for w in caught} == {__file__}  # the caller of warp_batch
    assert calls == [3]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BorderWarning)
        want = single_path(monkeypatch, batch, src, dst, **options)
    np.testing.assert_array_equal(got, want)


def test_segments_with_a_border_take_the_single_pipeline(gl, rng, monkeypatch):
    batch, src, dst = draw(rng, 3)
    segments = [np.array([[[4.0, 4.0], [20.0, 6.0]]])] * 3
    moved = [s + 1.5 for s in segments]
    options = {"border": "symmetric", "src_segments": segments, "dst_segments": moved}
    calls = counting(monkeypatch)
    got = glmls.warp_batch(batch, src, dst, **options)
    assert calls == []
    for i in range(3):
        one = glmls.warp(
            batch[i],
            src[i],
            dst[i],
            border="symmetric",
            src_segments=segments[i],
            dst_segments=moved[i],
        )
        np.testing.assert_array_equal(got[i], one)


def test_a_mesh_too_large_for_one_dispatch_takes_the_single_pipeline(gl, rng, monkeypatch):
    """Past the GL limits of one lattice dispatch (a large image at grid 1, or a large
    margin), images take the single pipeline, which runs their mesh in bands: the same
    pixels, no error."""
    batch, src, dst = draw(rng, 3)
    calls = counting(monkeypatch)
    want = [glmls.warp(batch[i], src[i], dst[i], border="edge", grid=1) for i in range(3)]
    limits = type(gl).limits
    few = property(lambda self: limits.fget(self) | {"max_work_groups_x": 4})
    monkeypatch.setattr(type(gl), "limits", few)  # 35 x 27 points or more: 8 groups
    got = glmls.warp_batch(batch, src, dst, border="edge", grid=1)
    assert calls == []
    np.testing.assert_array_equal(got, want)
    got = glmls.warp_batch(batch, src, dst, grid=1)
    assert calls == []
    np.testing.assert_array_equal(
        got, [glmls.warp(b, p, q, grid=1) for b, p, q in zip(batch, src, dst, strict=True)]
    )


@pytest.mark.parametrize("border", BORDERS)
def test_backward_with_a_border_runs_batched_as_single_warps(gl, rng, monkeypatch, border):
    """backward with a border mode: the first guess's meshes past the images by each one's
    margin, Newton and the sampling by the border rule, in one submission per part."""
    batch, src, dst = draw(rng, 6)
    masks = rng.integers(0, 5, (6, *SHAPE)).astype(np.uint16)
    calls = counting(monkeypatch, "backward")
    options = {
        "method": "backward",
        "border": border,
        "interpolation": "linear",
        "grid": 2,
        "output_shape": (30, 40),
        "origin": (-3.0, -2.0),
    }
    got = glmls.warp_batch(batch, src, dst, masks=masks, return_maps=True, **options)
    assert sum(calls) == 6  # the images, and their masks sampled at the same maps
    want = single_path(monkeypatch, batch, src, dst, masks=masks, return_maps=True, **options)
    for name in ("images", "masks", "maps", "valid"):
        np.testing.assert_array_equal(getattr(got, name), getattr(want, name), err_msg=name)


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.int32])
def test_masks_under_bilinear_images_come_from_the_images_scan(gl, rng, monkeypatch, dtype):
    """Bilinear images and their (nearest) masks from one scan, whose keys carry the nearest
    source pixel: the images' fill takes only the winning triangle from them, so both equal
    their single warps where the map folds too."""
    batch, src, dst = draw(rng, 5, spreads=(3.0, 9.0))
    dst[:, :2] = dst[:, 2:4]  # handles swapped over: the mesh folds
    masks = rng.integers(-3 if dtype == np.int32 else 0, 6, (5, *SHAPE)).astype(dtype)
    calls = counting(monkeypatch)
    options = {"interpolation": "linear", "grid": 2, "transform": "affine"}
    got = glmls.warp_batch(batch, src, dst, masks=masks, **options)
    assert calls == [5]
    want = single_path(monkeypatch, batch, src, dst, masks=masks, **options)
    np.testing.assert_array_equal(got.images, want.images)
    np.testing.assert_array_equal(got.masks, want.masks)
    assert got.masks.dtype == dtype


@pytest.mark.parametrize("border", ["edge", "constant"])
@pytest.mark.parametrize("method", ["quads", "backward"])
def test_parts_and_chunks_fill_the_batch_arrays(gl, rng, monkeypatch, method, border):
    """8-bit images and masks read back straight into the batch's arrays: chunks of
    consecutive images in place, the parts of one margin of a border mode (images apart
    in the batch) copied there, an image of its own MLS (its segments) beside them; all
    equal to the single warps."""
    batch, src, dst = draw(rng, 9)
    masks = rng.integers(0, 5, (9, *SHAPE), dtype=np.uint8)
    grey = batch[..., 1].copy()
    segments: list = [None] * 9
    segments[4] = np.array([[[3.0, 3.0], [12.0, 9.0]]])
    options = {"border": border, "interpolation": "linear", "grid": 2, "method": method}
    labels = {"masks": masks, "src_segments": segments, "dst_segments": segments}
    per_image = 4 * SHAPE[0] * SHAPE[1] * (12 if method == "quads" else 24)  # chunks of 1-3
    calls = counting(monkeypatch, "backward" if method == "backward" else "warp")
    for images in (batch, grey):
        got = glmls.warp_batch(images, src, dst, max_batch_bytes=per_image, **labels, **options)
        want = single_path(monkeypatch, images, src, dst, **labels, **options)
        assert_array_equal(got.images, want.images)
        assert_array_equal(got.masks, want.masks)
        assert got.images.dtype == np.uint8 and got.images.shape == images.shape
        assert got.masks.dtype == np.uint8 and got.masks.shape == masks.shape
    assert len(calls) > 4 and max(calls) > 1
    # image 4 by its own MLS in its chunk; the border's margins and backward leave it out
    assert sum(calls) == (18 if (method, border) == ("quads", "constant") else 16)


def test_chunks_keep_their_tables_within_the_texture_size(gl, rng, monkeypatch):
    """The fused path keeps a chunk's bytes, meshes and atlas in textures of the GL's size
    (a table: 8192 items a row): where the size is small, the chunks are smaller, the same
    pixels, no error."""
    batch, src, dst = draw(rng, 320, spreads=(0.0, 1.0))
    want = glmls.warp_batch(batch, src, dst, grid=4)
    chunks: list[int] = []
    original = chunks_module.warp_texels

    def counted(quads, lattices, images, *args, **kwargs):
        chunks.append(len(images))
        return original(quads, lattices, images, *args, **kwargs)

    monkeypatch.setattr(chunks_module, "warp_texels", counted)
    limits = type(gl).limits
    small = property(lambda self: limits.fget(self) | {"max_texture_size": max(SHAPE)})
    monkeypatch.setattr(type(gl), "limits", small)  # 33 rows: 305 images of 885 texels
    got = glmls.warp_batch(batch, src, dst, grid=4)
    assert len(chunks) == 2 and max(chunks) * (SHAPE[0] * SHAPE[1] + 1) <= 8192 * 33, chunks
    np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize("border", ["constant", "edge", "reflect"])
def test_bilinear_embeddings_are_coloured_by_the_scan(gl, rng, monkeypatch, border):
    """Bilinear chunks: the images whose meshes are embeddings are coloured by the scan
    itself, no keys kept, and the fill draw runs over the other images' rows only; either
    way, interleaved, the images and their masks equal the single warps, bit for bit."""
    batch, src, dst = draw(rng, 6, spreads=(1.0,))
    folding = [1, 3, 4]
    dst[folding, :2] = dst[folding, 2:4]  # handles swapped over: those meshes fold
    masks = rng.integers(0, 6, (6, *SHAPE)).astype(np.uint8)
    options = {"interpolation": "linear", "grid": 2, "border": border}
    want = single_path(monkeypatch, batch, src, dst, masks=masks, **options)
    drawn: list[list[bool]] = []
    original = BatchQuads._resolve

    def resolve(self, *args, keyed=None, **kwargs):
        drawn.append(None if keyed is None else keyed.tolist())
        return original(self, *args, keyed=keyed, **kwargs)

    monkeypatch.setattr(BatchQuads, "_resolve", resolve)
    for fused in (True, False):
        monkeypatch.setattr(BatchQuads, "fused_linear", fused)
        drawn.clear()
        got = glmls.warp_batch(batch, src, dst, masks=masks, **options)
        np.testing.assert_array_equal(got.images, want.images, err_msg=f"fused {fused}")
        np.testing.assert_array_equal(got.masks, want.masks, err_msg=f"fused {fused}")
        if not fused:
            assert drawn and all(keyed is None for keyed in drawn)
            continue
        flags = [flag for keyed in drawn for flag in keyed]
        assert sorted(flags) == [False] * 3 + [True] * 3
        if border == "constant":  # one chunk, in order
            assert drawn == [[i in folding for i in range(6)]]


@pytest.mark.parametrize("method", ["quads", "backward"])
def test_images_whose_margin_searches_double_past_each_other(gl, method):
    """Image 0's margin (a shrink) is found at the search's first ring, image 1's (a 19 px
    move) doubles from a smaller ring to image 0's size within the same step: each is judged
    by its own ring's values (the batch raised "all input arrays must have the same shape")."""
    images = np.random.default_rng(0).integers(0, 256, (2, 32, 32), dtype=np.uint8)
    corners = np.array([[8.0, 8.0], [24.0, 8.0], [8.0, 24.0]])
    src = [corners, corners[:1]]
    dst = [(corners - 16) * 0.5 + 16, corners[:1] + [19, 0]]
    options = {"border": "edge", "transform": "similarity", "method": method, "ctx": gl}
    out = glmls.warp_batch(images, src, dst, **options)
    for k in range(2):
        assert_array_equal(out[k], glmls.warp(images[k], src[k], dst[k], **options))


@pytest.mark.parametrize("method", ["quads", "backward", "splat"])
@pytest.mark.parametrize("border", BORDERS)
def test_valid_pixels_show_the_source_not_its_border_copies(gl, method, border):
    """With a border mode the pixels whose source point lies beyond the image show the
    border rule's copies: shown, but not covered by a source pixel, so not valid; the valid
    pixels are those whose map lies on the image and that some source pixel covers."""
    image = np.full((1, 20, 30), 9, np.uint8)
    src = np.array([[[2.0, 2.0], [27.0, 2.0], [2.0, 17.0], [27.0, 17.0]]])
    dst = src + [8.0, 0.0]  # a translation: columns 0..7 show copies of the border
    got = glmls.warp_batch(image, src, dst, return_maps=True, method=method, border=border)
    assert (got.images[0] == 9).all()  # every pixel shown
    want = np.zeros((20, 30), bool)
    want[:, 8:] = True
    assert_array_equal(got.valid[0], want)
    with_constant = glmls.warp_batch(image, src, dst, return_maps=True, method=method)
    assert_array_equal(with_constant.valid[0], want)
