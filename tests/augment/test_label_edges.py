"""Labels at the edges of what they can be: polygons clipped to the canvas keep no repeated
vertex and no polygon of no area, and the albumentations adapter names a bad image as
albumentations users pass it (``image``), not as an item of a batch."""

from __future__ import annotations

import os

import numpy as np
import pytest

from glmls.augment import clip_polygon

os.environ.setdefault("NO_ALBUMENTATIONS_UPDATE", "1")  # no version check over the network


def _twice_area(points: np.ndarray) -> float:
    x, y = points[:, 0], points[:, 1]
    return float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def _inside(polygon: np.ndarray, points: np.ndarray) -> np.ndarray:
    """The even-odd rule: a ray to +x from each point crosses the polygon's edges."""
    inside = np.zeros(len(points), bool)
    x, y = points[:, 0], points[:, 1]
    for a, b in zip(polygon, np.roll(polygon, -1, axis=0), strict=True):
        spans = (a[1] > y) != (b[1] > y)
        at = a[0] + (y - a[1]) * (b[0] - a[0]) / np.where(b[1] == a[1], 1.0, b[1] - a[1])
        inside ^= spans & (x < at)
    return inside


@pytest.mark.parametrize(
    ("polygon", "expected"),
    [
        # a vertex on the canvas's left side (x = -0.5): kept once
        (
            [[-0.5, 0.0], [2.0, 0.0], [2.0, 3.0], [-0.5, 3.0], [-2.0, 1.5]],
            [[-0.5, 0.0], [2.0, 0.0], [2.0, 3.0], [-0.5, 3.0]],
        ),
        # a corner of the canvas inside a triangle, two vertices on its sides
        (
            [[-3.0, -3.0], [2.0, -0.5], [-0.5, 2.0]],
            [[-0.5, -0.5], [2.0, -0.5], [-0.5, 2.0]],
        ),
        # wholly inside: as it is
        ([[1.0, 1.0], [3.0, 1.0], [2.0, 4.0]], [[1.0, 1.0], [3.0, 1.0], [2.0, 4.0]]),
    ],
)
def test_clipped_polygons_repeat_no_vertex(polygon, expected):
    clipped = clip_polygon(np.array(polygon), (8, 8))
    # the same cycle of vertices, wherever it starts
    start = int(np.argmin(np.abs(clipped - expected[0]).sum(axis=1)))
    np.testing.assert_allclose(np.roll(clipped, -start, axis=0), expected, atol=1e-12)
    assert not np.any(np.all(clipped == np.roll(clipped, 1, axis=0), axis=1))


@pytest.mark.parametrize(
    "polygon",
    [
        [[-0.5, 0.0], [-0.5, 3.0], [-3.0, 1.0]],  # touches the left side along an edge
        [[-3.0, -3.0], [-0.5, -0.5], [-3.0, -0.5]],  # touches the top-left corner only
        [[8.0, 2.0], [7.5, 2.0], [7.5, 5.0]],  # an edge along the right side, x = W - 0.5
        [[0.1, -3.0], [3.7, -3.0], [2.3, -0.5]],  # a vertex on the top side
    ],
)
def test_a_polygon_touching_the_canvas_only_is_not_on_it(polygon):
    assert clip_polygon(np.array(polygon), (8, 8)).shape == (0, 2)


def test_random_polygons_clip_to_areas_that_match_the_pixels(rng):
    """The clipped polygon's area equals the area of the polygon within the canvas
    (estimated on a fine sampling grid), and no two consecutive vertices are equal."""
    ys, xs = np.mgrid[-0.5:7.5:400j, -0.5:7.5:400j]
    cell = (8.0 / 399) ** 2
    samples = np.c_[xs.ravel(), ys.ravel()]
    for _ in range(20):
        centre = rng.uniform(-2, 10, 2)
        angles = np.sort(rng.uniform(0, 2 * np.pi, 7))
        radii = rng.uniform(1, 5, 7)
        polygon = centre + np.c_[np.cos(angles), np.sin(angles)] * radii[:, None]
        clipped = clip_polygon(polygon, (8, 8))
        inside = _inside(polygon, samples).sum() * cell
        area = abs(_twice_area(clipped)) / 2 if len(clipped) else 0.0
        assert area == pytest.approx(inside, abs=0.3)
        if len(clipped):
            assert not np.any(np.all(clipped == np.roll(clipped, 1, axis=0), axis=1))
            assert area > 0


def test_a_polyline_given_as_a_polygon_stays_one():
    """A polygon of no area of its own (two points) is clipped, not dropped."""
    np.testing.assert_allclose(
        clip_polygon(np.array([[1.0, 1.0], [5.0, 5.0]]), (8, 8)), [[1.0, 1.0], [5.0, 5.0]]
    )
    crossing = clip_polygon(np.array([[-3.0, 1.0], [20.0, 5.0]]), (8, 8))
    assert crossing.shape == (2, 2)


@pytest.mark.parametrize(
    ("image", "message"),
    [
        (np.full((10, 10, 3), np.nan), "image holds values that are not finite"),
        (np.zeros((10, 10, 3), np.int64), "image has dtype int64"),
        (np.zeros((10, 10, 3), np.float16), "image has dtype float16"),
        (np.zeros((10, 10, 0), np.uint8), r"image has shape \(10, 10, 0\): no channels"),
        (np.full((10, 10, 6), np.inf, np.float32), "image holds values that are not finite"),
    ],
)
def test_albumentations_names_the_image(gl, image, message):
    A = pytest.importorskip("albumentations", reason="albumentations not installed (the extra)")
    from glmls.augment.albumentations import MLSDeform

    pipeline = A.Compose([MLSDeform("grid", p=1.0)])
    with pytest.raises(ValueError, match="^" + message) as caught:
        pipeline(image=image)
    assert "images[0]" not in str(caught.value)
