"""The batch's checks and tables for all images at once equal their image-by-image forms:
two targets of one source, far targets, point sets' checks, weight uniforms, footprints,
probes, the margins' search boxes and the chunk's prepared sources (no GL)."""

from __future__ import annotations

import numpy as np
import pytest

from glmls.batch.footprints import footprint_sets, with_footprints
from glmls.batch.inputs import check_point_sets, check_points
from glmls.batch.probes import _offsets
from glmls.core.config import MLSConfig
from glmls.core.handles import COORDINATE_LIMIT, fit_offset, same_source_pair, same_source_sets
from glmls.engine.kernel import weight_rows, weight_uniforms
from glmls.imaging.frame import _boxes
from glmls.imaging.source import prepare_image, prepare_images


def test_same_source_sets_is_same_source_pair_per_set():
    rng = np.random.default_rng(0)
    for count in (1, 2, 5, 16):
        # small integer coordinates: many shared sources, some with two targets
        p = rng.integers(0, 3, (200, count, 2)).astype(float)
        q = rng.integers(0, 2, (200, count, 2)).astype(float)
        pairs = zip(p, q, strict=True)
        expected = [count > 1 and same_source_pair(a, b) is not None for a, b in pairs]
        assert same_source_sets(p, q).tolist() == expected


def test_offsets_are_fit_offset_per_set():
    rng = np.random.default_rng(1)
    for _ in range(40):
        k = int(rng.integers(1, 6))
        shape = (int(rng.integers(1, 300)), int(rng.integers(1, 300)))
        src = rng.uniform(-50, 350, (30, k, 2)).round(int(rng.integers(0, 3)))
        far = rng.choice([0.0, 1.0, 1e3, 1e5, 1e7], (30, 1, 2)) * rng.normal(size=(30, 1, 2))
        dst = src + rng.normal(0, 3, src.shape) + far
        expected = [bool(fit_offset(a, b, shape).any()) for a, b in zip(src, dst, strict=True)]
        assert _offsets(src, dst, shape).tolist() == expected


def test_check_point_sets_names_the_first_bad_item():
    items = [np.zeros((3, 2), np.float32) for _ in range(4)]
    checked = check_point_sets(items, lambda i: f"src[{i}]", rows="K")
    assert all(c.dtype == np.float64 and c.shape == (3, 2) for c in checked)
    items[2] = items[2].copy()
    items[2][1, 0] = np.nan
    with pytest.raises(ValueError, match=r"src\[2\] holds values that are not finite"):
        check_point_sets(items, lambda i: f"src[{i}]", rows="K")
    items[2][1, 0] = 0.0
    items[1] = np.full((3, 2), 2 * COORDINATE_LIMIT, np.float32)
    with pytest.raises(ValueError, match=r"keypoints\[1\] must lie within"):
        check_point_sets(items, lambda i: f"keypoints[{i}]", rows="P")
    mixed = [np.zeros((3, 2)), np.zeros((3, 3))]  # not alike: item by item
    with pytest.raises(ValueError, match=r"src\[1\] has shape \(3, 3\)"):
        check_point_sets(mixed, lambda i: f"src[{i}]", rows="K")
    ints = [np.arange(6).reshape(3, 2)] * 2
    assert [c.tolist() for c in check_point_sets(ints, str, rows="K")] == [
        check_points(a, "a", rows="K").tolist() for a in ints
    ]


@pytest.mark.parametrize(
    "options",
    [{}, {"alpha": 0.1, "s": 0.0}, {"weight": "gaussian", "radius": 30.0}, {"weight": "shepard"}],
)
def test_weight_rows_are_weight_uniforms(options):
    config = MLSConfig(**options)
    rng = np.random.default_rng(2)
    pairs = [(float(10 ** rng.uniform(-3, 6)), float(10 ** rng.uniform(-8, 1))) for _ in range(50)]
    rows = weight_rows(config, pairs, 30.0)
    for (scale, extent), row in zip(pairs, rows, strict=True):
        single = weight_uniforms(config, scale, 30.0, extent=extent)
        names = ("u_log2_s", "u_radius", "u_hit2", "u_snap", "u_tiny_s")
        assert row == tuple(single[name] for name in names)


def test_footprint_sets_are_with_footprints():
    rng = np.random.default_rng(3)
    sets = [rng.uniform(0, 50, (7, 2)) for _ in range(5)]
    for given in (sets, [*sets[:2], sets[2][:3]]):  # one size, and sizes that differ
        every = footprint_sets(given, 0.99)
        for points, rings in zip(given, every, strict=True):
            assert np.array_equal(rings, with_footprints(points, 0.99))


def test_boxes_leave_out_points_that_are_not_finite():
    rings = np.array(
        [[[0.0, 1.0], [2.0, -1.0], [np.nan, 5.0]], [[np.inf, 0.0], [np.nan, 1.0], [0.0, np.inf]]]
    )
    lows, highs = _boxes(rings)
    assert lows.tolist() == [[0.0, -1.0], [np.inf, np.inf]]
    assert highs.tolist() == [[2.0, 1.0], [-np.inf, -np.inf]]


def test_prepare_images_is_prepare_image_per_image():
    """A chunk's sources prepared at once equal prepare_image of each image: uint8 images of
    one shape wrapped as they are (views and non-contiguous arrays included), other dtypes
    and shapes image by image; an error names the image."""
    rng = np.random.default_rng(3)
    base = rng.integers(0, 256, (6, 9, 7, 3), dtype=np.uint8)
    gray = rng.integers(0, 256, (4, 5, 8), dtype=np.uint8)
    floats = rng.normal(0, 1e3, (3, 5, 6)).astype(np.float32)
    chunks = [
        list(base),
        [base[0][:, ::-1], np.asfortranarray(base[1]), base[2]],
        list(gray),
        list(floats),
        [base[0], base[1].astype(np.uint16)],  # a chunk prepare_images does not wrap
        [gray[0], gray[1][:, :4]],
    ]
    for normalized in (True, False):
        for images in chunks:
            got = prepare_images(images, 64, normalized=normalized)
            for g, image in zip(got, images, strict=True):
                want = prepare_image(image, 64, normalized=normalized)
                assert g.data.dtype == want.data.dtype and g.data.flags.c_contiguous
                np.testing.assert_array_equal(g.data, want.data)
                assert (g.dtype, g.squeeze, g.normalized, g.exponent) == (
                    want.dtype,
                    want.squeeze,
                    want.normalized,
                    want.exponent,
                )
    bad = [floats[0], np.zeros((5, 6, 5), np.float32)]
    with pytest.raises(ValueError, match=r"^images\[7\]: image must be H x W or H x W x C"):
        prepare_images(bad, 64, names=["images[6]", "images[7]"])
    with pytest.raises(ValueError, match=r"^images\[6\]: image 7 pixels wide"):
        prepare_images([base[0]] * 3, 6, normalized=True, names=["images[6]"] * 3)
