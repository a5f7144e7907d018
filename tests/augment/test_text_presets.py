"""The text-line presets draw what Luo et al.'s toolkit draws (the rules in docs/augment.md):
2 (segments + 1) fiducial points evenly spaced along the top and bottom edges, moved in each
mode within its radius R as the toolkit moves them, each free coordinate uniform over its
whole range and independent of the others, over thousands of seeded draws."""

from __future__ import annotations

import numpy as np
import pytest

import glmls
from glmls.augment import DEFAULT_WARP_OPTIONS, Augment

#: draws per case: a bound missed by 1% of its range, a KS distance of 0.036 from the uniform
#: law (its 0.1% level at this count) or a correlation of 0.1 (5 standard deviations) fails
DRAWS = 3000
#: (shape (H, W), segments, radius): the defaults on a common crop, then other counts and R
CASES = [((32, 128), None, None), ((48, 200), 5, None), ((20, 90), 3, 7.5), ((32, 64), 1, None)]


def _draws(name: str, shape, segments, radius):
    """src (the same in every draw) and the (DRAWS, K, 2) displacements of ``Augment(name)``."""
    options = {k: v for k, v in (("segments", segments), ("radius", radius)) if v is not None}
    params = Augment(name, seed=7, **options).draw([shape] * DRAWS)
    src = np.array([p["src"] for p in params])
    assert (src == src[0]).all()
    return src[0], np.array([p["dst"] for p in params]) - src


def _radius(name: str, shape, segments, radius) -> float:
    """The toolkit's threshold R for an image of ``shape`` (without its integer rounding)."""
    height, width = shape
    if radius is not None:
        return radius
    return {
        "text-distort": width / segments / 3,
        "text-stretch": width / segments * 4 / 5,
        "text-perspective": height / 2,
    }[name]


def _assert_uniform(values: np.ndarray, low: float, high: float) -> None:
    """Each column of ``values`` lies in [low, high], reaches both ends and is uniform there."""
    span = high - low
    assert values.min() >= low - 1e-9 * span and values.max() <= high + 1e-9 * span
    assert (values.min(axis=0) < low + 0.01 * span).all()
    assert (values.max(axis=0) > high - 0.01 * span).all()
    u = np.sort((values - low) / span, axis=0)
    ecdf = np.arange(1, len(u) + 1)[:, None] / len(u)
    distance = np.maximum(np.abs(ecdf - u), np.abs(ecdf - 1 / len(u) - u)).max(axis=0)
    assert (distance < 1.95 / np.sqrt(len(u))).all(), distance


def _assert_independent(columns: np.ndarray) -> None:
    """No two columns (free coordinates) correlate beyond 0.1."""
    if columns.shape[1] > 1:
        corr = np.corrcoef(columns, rowvar=False)
        off = corr[~np.eye(len(corr), dtype=bool)]
        assert np.abs(off).max() < 0.1, np.abs(off).max()


def _corners(count: int) -> list[int]:
    """The corners' rows: top left, top right, bottom left, bottom right."""
    return [0, count - 1, count, 2 * count - 1]


@pytest.mark.parametrize("name", ["text-distort", "text-stretch", "text-perspective"])
@pytest.mark.parametrize(("shape", "segments", "radius"), CASES)
def test_fiducial_points_are_evenly_spaced_on_the_top_and_bottom_edges(
    name, shape, segments, radius
):
    """2 (S + 1) points: the top edge's left to right, then the bottom's, on the image's outer
    pixel edges (pixel centres at integers), x_k = -1/2 + k W / S."""
    height, width = shape
    count = (segments or 4) + 1
    src, _ = _draws(name, shape, segments, radius)
    xs = -0.5 + np.arange(count) * width / (count - 1)
    expected = np.concatenate(
        [np.stack([xs, np.full(count, -0.5)], 1), np.stack([xs, np.full(count, height - 0.5)], 1)]
    )
    np.testing.assert_allclose(src, expected, rtol=0, atol=1e-9)


@pytest.mark.parametrize(("shape", "segments", "radius"), CASES)
def test_distort_moves_corners_inwards_within_r_and_the_others_within_half_r(
    shape, segments, radius
):
    """Each corner's x and y move inwards by U[0, R], every other point's by U[-R/2, R/2],
    all 4 (S + 1) coordinates independent (R = W / S / 3 by default)."""
    name = "text-distort"
    r = _radius(name, shape, segments or 4, radius)
    src, moves = _draws(name, shape, segments, radius)
    count = len(src) // 2
    corners = _corners(count)
    inwards = np.array([[1, 1], [-1, 1], [1, -1], [-1, -1]], np.float64)
    _assert_uniform((moves[:, corners] * inwards).reshape(DRAWS, -1), 0.0, r)
    inner = [k for k in range(2 * count) if k not in corners]
    if inner:
        _assert_uniform(moves[:, inner].reshape(DRAWS, -1), -r / 2, r / 2)
    _assert_independent(moves.reshape(DRAWS, -1))


@pytest.mark.parametrize(("shape", "segments", "radius"), CASES)
def test_stretch_moves_inner_pairs_horizontally_within_half_r(shape, segments, radius):
    """The corners stay; each inner top point and the bottom point below it move by one
    horizontal U[-R/2, R/2], the pairs independent (R = 4/5 W / S by default)."""
    name = "text-stretch"
    r = _radius(name, shape, segments or 4, radius)
    src, moves = _draws(name, shape, segments, radius)
    count = len(src) // 2
    assert (moves[:, :, 1] == 0).all()
    assert (moves[:, _corners(count)] == 0).all()
    np.testing.assert_array_equal(moves[:, :count, 0], moves[:, count:, 0])
    if count > 2:
        _assert_uniform(moves[:, 1 : count - 1, 0], -r / 2, r / 2)
        _assert_independent(moves[:, 1 : count - 1, 0])


@pytest.mark.parametrize(("shape", "segments", "radius"), CASES)
def test_perspective_moves_each_corner_vertically_inwards_within_r(shape, segments, radius):
    """x stays; each corner moves vertically inwards by its own U[0, R] (R = H / 2 by
    default), and the points between stay on the straight edge between the two corners."""
    name = "text-perspective"
    r = _radius(name, shape, segments or 4, radius)
    src, moves = _draws(name, shape, segments, radius)
    count = len(src) // 2
    corners = _corners(count)
    assert (moves[:, :, 0] == 0).all()
    inward = moves[:, corners, 1] * np.array([1, 1, -1, -1])
    _assert_uniform(inward, 0.0, r)
    _assert_independent(inward)
    t = (src[:count, 0] - src[0, 0]) / (src[count - 1, 0] - src[0, 0])
    for edge in (slice(0, count), slice(count, 2 * count)):
        ys = moves[:, edge, 1]
        line = ys[:, :1] + t * (ys[:, -1:] - ys[:, :1])
        np.testing.assert_allclose(ys, line, rtol=0, atol=1e-9)


@pytest.mark.parametrize(
    ("name", "transform"),
    [
        ("text-distort", "similarity"),
        ("text-stretch", "similarity"),
        ("text-perspective", "affine"),
    ],
)
def test_text_presets_default_to_four_segments_and_an_mls_of_alpha_one(name, transform):
    """The toolkit's demo cuts a line into 4 patches; its warp is the similarity MLS with
    weights 1 / d^2 (idw, alpha 1, glmls's default weight); the perspective's trapezoid
    takes the affine MLS, which the similarity MLS folds."""
    augment = Augment(name)
    assert (augment.preset.segments, augment.preset.radius) == (4, None)
    assert DEFAULT_WARP_OPTIONS["transform"] == "similarity"
    assert augment.warp_options["transform"] == transform
    assert "warp_options" not in repr(augment)  # the default, not a choice
    assert Augment(name, warp_options={"transform": "rigid"}).warp_options["transform"] == "rigid"
    assert not {"weight", "alpha"} & set(DEFAULT_WARP_OPTIONS)
    config = glmls.MLSConfig()
    assert (config.weight, config.alpha) == ("idw", 1.0)


@pytest.mark.parametrize("name", ["text-distort", "text-stretch", "text-perspective"])
def test_sample_i_draws_from_its_seed_and_index(name):
    aug = Augment(name, seed=3)
    params = aug.draw([(24, 96)] * 3, indices=[5, 0, 9])
    for index, p in zip([5, 0, 9], params, strict=True):
        src, dst = aug.preset.draw(np.random.default_rng((3, index)), (24, 96))
        assert p["src"] == src.tolist() and p["dst"] == dst.tolist()


def test_the_perspective_keeps_a_trapezoid_unfolded():
    """200 draws at R = H / 2 on 32 x 128 crops, a lattice of keypoints: with the affine MLS
    no keypoint on the canvas is hidden by a fold, where the similarity MLS hides some in
    about half of the draws (mirrored glyphs)."""
    height, width, count = 32, 128, 200
    lattice = [[x, y] for x in range(2, width - 2, 3) for y in range(4, height - 4, 2)]
    keypoints = np.array([lattice] * count, float)
    images = np.zeros((count, height, width), np.uint8)

    def folded(**options) -> int:
        out = Augment("text-perspective", seed=0, **options)(images, keypoints=keypoints)
        k = out.keypoints
        on = (k[..., 0] >= 0) & (k[..., 0] <= width - 1) & (k[..., 1] >= 0)
        on &= k[..., 1] <= height - 1
        return int((on & ~out.keypoints_valid).any(axis=1).sum())

    assert folded() == 0
    assert folded(warp_options={"transform": "similarity"}) > count // 4
