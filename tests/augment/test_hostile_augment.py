"""Hostile inputs to glmls.augment.Augment: keypoints, recorded params and shapes that are
not what they should be are refused, the error naming the item, before any warp."""

from __future__ import annotations

import copy
import json

import numpy as np
import pytest

from glmls.augment import (
    Augment,
    box_outlines,
    boxes_from_outlines,
    clip_polygon,
    densify_polygon,
)

IMAGES = np.random.default_rng(0).integers(0, 255, (2, 16, 20), dtype=np.uint8)


@pytest.mark.parametrize(
    "points",
    [
        np.ones((2, 2, 2), np.complex128),  # the imaginary part may not be dropped
        [np.array([[1, None]])] * 2,
        [np.array([["a", "b"]])] * 2,
    ],
)
def test_keypoints_that_are_not_real_numbers_are_refused(points):
    with pytest.raises(TypeError, match=r"keypoints\[0\] has dtype .*; expected real numbers"):
        Augment("grid")(IMAGES, keypoints=points)


@pytest.fixture
def recorded(gl):
    aug = Augment("grid", seed=3)
    return aug, json.loads(json.dumps(aug(IMAGES).params))


def _edited(params, edit):
    params = copy.deepcopy(params)
    edit(params)
    return params


@pytest.mark.parametrize(
    ("edit", "error", "message"),
    [
        (lambda p: p[1].__setitem__("src", "abc"), TypeError, r"params\[1\]\['src'\] has dtype"),
        (
            lambda p: p[0]["dst"].__setitem__(0, [1.0]),
            ValueError,
            r"params\[0\]\['dst'\] is ragged \(rows of different lengths\)",
        ),
        (  # JSON's true among the numbers: numpy's cast made it 1.0, a coordinate
            lambda p: p[1]["dst"][3].__setitem__(0, True),
            TypeError,
            r"params\[1\]\['dst'\] row 3 holds a bool, \[True, .*\]; expected real numbers",
        ),
        (
            lambda p: p[0].__setitem__("src", [[1.0, 2.0, 3.0]]),
            ValueError,
            r"params\[0\]\['src'\] has shape \(1, 3\); expected \(K, 2\)",
        ),
        (
            lambda p: [d["options"].__setitem__("keypoints", 1) for d in p],
            TypeError,
            r"params\[0\]\['options'\] cannot hold keypoints",
        ),
        (
            lambda p: p[0].__setitem__("shape", [16.0, 20.0]),
            TypeError,
            r"params\[0\]\['shape'\] must be \[H, W\], integers >= 1, got \[16.0, 20.0\]",
        ),
        (
            lambda p: [d["options"].__setitem__("method", "swirl") for d in p],
            ValueError,
            r"params\[0\]\['options'\]: unknown method 'swirl'",
        ),
        (  # the draws' options are checked once per set: a later set of its own is checked
            lambda p: p[1]["options"].__setitem__("grid", 0),
            ValueError,
            r"params\[1\]\['options'\]",
        ),
        (  # a list where a number goes: not the first draw's options, though alike as text
            lambda p: p[1]["options"].__setitem__("grid", [p[0]["options"]["grid"]]),
            TypeError,
            r"params\[1\]\['options'\]",
        ),
        (
            lambda p: p[1]["options"].__setitem__("background", np.full(3, np.nan)),
            ValueError,
            r"params\[1\]\['options'\]",
        ),
    ],
)
def test_replay_of_edited_params_names_the_bad_entry(recorded, edit, error, message):
    aug, params = recorded
    with pytest.raises(error, match=message):
        aug.replay(IMAGES, _edited(params, edit))


def test_replay_of_the_params_through_json_gives_the_same_images(recorded):
    aug, params = recorded
    first = aug.replay(IMAGES, params)
    np.testing.assert_array_equal(first.images, aug(IMAGES).images)
    np.testing.assert_array_equal(aug.replay(IMAGES, params).images, first.images)


@pytest.mark.parametrize(
    ("shapes", "error", "message"),
    [
        ([(0, 5)], ValueError, r"shapes\[0\]: shape must be \(H, W\) with H, W >= 1"),
        ([(8, 8), (-3, 5)], ValueError, r"shapes\[1\]: shape must be \(H, W\) with H, W >= 1"),
        ([(3.5, 5)], TypeError, r"shapes\[0\]: shape must be \(H, W\) integers"),
        ("ab", TypeError, "shapes must be a sequence of"),
    ],
)
def test_draw_refuses_shapes_that_are_no_image_sizes(shapes, error, message):
    with pytest.raises(error, match=message):
        Augment("grid").draw(shapes)


def test_draw_takes_an_image_s_shape_with_its_channels():
    aug = Augment("grid", rows=2, cols=2)
    assert aug.draw([(8, 9, 3)]) == aug.draw([(8, 9)])


@pytest.mark.parametrize(
    ("labels", "error", "message"),
    [
        ({"boxes": [np.ones((1, 4), np.complex128), []]}, TypeError, r"boxes\[0\] has dtype"),
        ({"polygons": [[np.ones((3, 2), np.complex128)], []]}, TypeError, r"polygons\[0\]\[0\]"),
        ({"boxes": [[[0, 0, 1e30, 4]], []]}, ValueError, r"boxes\[0\] must lie within"),
        (
            {"polygons": [[[[1, 1], [1e30, 1], [5, 8]]], []]},
            ValueError,
            r"polygons\[0\]\[0\] must lie within",  # not the keypoints they become
        ),
    ],
)
def test_labels_that_are_not_real_coordinates_are_named(labels, error, message):
    with pytest.raises(error, match=message):
        Augment("grid")(IMAGES, **labels)


@pytest.mark.parametrize(
    ("options", "labels", "message"),
    [
        ({"box_step": 1e-9}, {"boxes": [[[1, 1, 10, 10]], []]}, r"boxes\[0\] with box_step=1e-09"),
        (
            {"densify": 1e-9},
            {"polygons": [[[[1, 1], [10, 1], [5, 8]]], []]},
            r"polygons\[0\] with densify=1e-09",
        ),
    ],
)
def test_a_step_that_would_take_billions_of_points_is_refused(options, labels, message):
    with pytest.raises(ValueError, match=message + r": step 1e-09 px puts \d+ points"):
        Augment("grid", **options)(IMAGES, **labels)


def test_the_label_helpers_refuse_coordinates_that_are_not_finite():
    with pytest.raises(ValueError, match="polygon holds values that are not finite"):
        clip_polygon(np.array([[1.0, 1.0], [np.nan, 1.0], [5.0, 8.0]]), (20, 24))
    with pytest.raises(ValueError, match="boxes holds values that are not finite"):
        box_outlines(np.array([[0.0, 0.0, np.inf, 4.0]]), 2.0)
    with pytest.raises(ValueError, match="use a larger step"):
        densify_polygon(np.array([[0.0, 0.0], [9.0, 0.0], [5.0, 8.0]]), 1e-12)
    with pytest.raises(ValueError, match="polygon holds values that are not finite"):
        densify_polygon(np.array([[np.nan, 0.0]]), 1.0)  # one vertex: no edge to measure


@pytest.mark.parametrize(
    ("call", "error", "message"),
    [
        (lambda: densify_polygon(np.zeros((3, 3)), 1.0), ValueError, r"polygon has shape \(3, 3\)"),
        (lambda: densify_polygon(np.ones((3, 2), complex), 1.0), TypeError, "dtype complex128"),
        (lambda: clip_polygon(np.ones((3, 2), complex), (8, 8)), TypeError, "dtype complex128"),
        (lambda: clip_polygon(np.zeros((3, 2)), (8,)), ValueError, r"shape must be \(H, W\)"),
        (lambda: clip_polygon(np.zeros((3, 2)), (8, -1)), ValueError, "two integers >= 0"),
        (lambda: clip_polygon(np.zeros((3, 2)), (8.5, 8)), ValueError, "two integers >= 0"),
        # a (2, 2) array holds two points, not one box; a (3,) row is no box either
        (lambda: box_outlines(np.zeros((2, 2)), 1.0), ValueError, r"boxes has shape \(2, 2\)"),
        (lambda: box_outlines([0.0, 0.0, 4.0], 1.0), ValueError, r"boxes has shape \(1, 3\)"),
        (lambda: box_outlines(np.ones((1, 4), bool), 1.0), TypeError, "dtype bool"),
        (
            lambda: boxes_from_outlines(np.zeros((2, 2)), np.array([0, 2]), (8, 8)),
            ValueError,
            r"counts\[0\] is 0: each box needs at least 1 point",
        ),
        (
            lambda: boxes_from_outlines(np.zeros((2, 2)), np.array([1.0, 1.0]), (8, 8)),
            ValueError,
            "counts must be a 1-D array of integers",
        ),
        (
            lambda: boxes_from_outlines(np.zeros((1, 2)), np.array([1]), (8,)),
            ValueError,
            r"shape must be \(H, W\)",
        ),
    ],
)
def test_the_label_helpers_name_a_bad_argument(call, error, message):
    with pytest.raises(error, match=message):
        call()


def test_the_label_helpers_take_one_box_as_a_row_and_no_box_as_an_empty_list():
    points, counts = box_outlines([0.0, 0.0, 4.0, 2.0], 2.0)
    assert counts.tolist() == [6] and points[:3].tolist() == [[0, 0], [2, 0], [4, 0]]
    points, counts = box_outlines([], 2.0)
    assert points.shape == (0, 2) and counts.shape == (0,)
    assert densify_polygon([], 1.0).shape == (0, 2)


def test_a_polygon_is_clipped_where_a_far_vertex_lies_beyond_float_rounding():
    """The crossing of an edge with the canvas's side is computed from its end on the
    canvas: from the far end it would be that end's rounding error (1e300 * 2**-53 ~
    1e284), and the crossing of x = 7.5 with the edge (1e300, 0) - (3, 3) would land at
    x = 0."""
    # the edge meets x = 7.5 at y = 3 (1e300 - 7.5) / (1e300 - 3), 3 in float64
    triangle = np.array([[0.0, 0.0], [1e300, 0.0], [3.0, 3.0]])
    clipped = clip_polygon(triangle, (8, 8))
    np.testing.assert_allclose(
        clipped, [[0.0, 0.0], [7.5, 0.0], [7.5, 3.0], [3.0, 3.0]], atol=1e-12
    )


RAGGED = [[1.0, 2.0], [3.0]]


@pytest.mark.parametrize(
    ("labels", "message"),
    [
        ({"keypoints": [RAGGED, [[1.0, 2.0]]]}, r"keypoints\[0\] is ragged"),
        ({"boxes": [[[1.0, 2.0, 3.0, 4.0]], [[1.0, 2.0, 3.0, 4.0], [3.0]]]}, r"boxes\[1\] is"),
        ({"polygons": [[], [[[1.0, 2.0], [3.0]]]]}, r"polygons\[1\]\[0\] is ragged"),
    ],
)
def test_ragged_labels_are_named(labels, message):
    with pytest.raises(ValueError, match=message):
        Augment("grid")(IMAGES, **labels)


def test_ragged_images_are_named():
    with pytest.raises(ValueError, match=r"images\[1\] is ragged"):
        Augment("grid")([IMAGES[0], [[1, 2], [3]]])


@pytest.mark.parametrize(
    ("options", "error", "message"),
    [
        ({"max_batch_bytes": -1}, ValueError, "max_batch_bytes must be an integer >= 1"),
        ({"return_maps": 1}, TypeError, "return_maps must be True or False"),
        ({"storage": "fast"}, ValueError, "unknown storage 'fast'"),
        ({"bins": 4}, TypeError, "bins must be True, False or None"),
        ({"bins": True}, ValueError, "bins need a weight with a radius"),
        ({"ctx": "gpu0"}, TypeError, "ctx must be a moderngl.Context or None"),
    ],
)
def test_warp_options_are_checked_when_the_augment_is_made(options, error, message):
    # not at the first batch, in a data-loader worker
    with pytest.raises(error, match=f"warp_options: {message}"):
        Augment("grid", warp_options=options)


@pytest.mark.parametrize(
    ("landmarks", "message"),
    [
        ([np.zeros((1, 2))], "landmarks holds 1 point set for 2 images"),
        ([np.zeros((1, 2)), np.full((1, 2), np.nan)], r"landmarks\[1\] holds values that are"),
        ([np.zeros((1, 3)), np.zeros((1, 2))], r"landmarks\[0\] has shape \(1, 3\)"),
        ([RAGGED, np.zeros((1, 2))], r"landmarks\[0\] is ragged"),
    ],
)
def test_draw_checks_its_landmarks(landmarks, message):
    with pytest.raises(ValueError, match=message):
        Augment("landmarks").draw([(8, 8), (8, 8)], landmarks=landmarks)


@pytest.mark.parametrize("indices", [0, np.arange(2).reshape(1, 2)])
def test_indices_of_another_shape_are_refused(indices):
    with pytest.raises(ValueError, match="indices must be a sequence of N integers"):
        Augment("grid").draw([(8, 8), (8, 8)], indices=indices)


@pytest.mark.parametrize("indices", [(i for i in range(2)), iter([0, 1]), {0, 1}])
def test_indices_that_are_no_sequence_are_a_type_error_naming_them(indices):
    """A generator (or a set, of no order) is named as what it is, not as an array of
    shape (), which numpy would make of it."""
    name = type(indices).__name__
    with pytest.raises(TypeError, match=rf"indices must be a sequence of N integers, got {name}"):
        Augment("grid").draw([(8, 8), (8, 8)], indices=indices)


def test_draw_takes_the_shapes_as_an_array_of_rows():
    aug = Augment("grid", rows=2, cols=2)
    assert aug.draw(np.array([[8, 9], [6, 7]])) == aug.draw([(8, 9), (6, 7)])
    assert aug.draw(np.array([[8, 9, 3]])) == aug.draw([(8, 9)])


def test_polygons_of_one_size_as_arrays_move_as_the_sequences_do(gl):
    """An image's polygons of one size as one (P, V, 2) array, and a batch's as an (N, P,
    V, 2) array, give the polygons their lists of (V, 2) arrays give."""
    rng = np.random.default_rng(1)
    polygons = rng.uniform(1, 14, (2, 3, 4, 2))  # 2 images, 3 quadrilaterals each
    aug = Augment("grid", seed=4)
    lists = aug(IMAGES, polygons=[list(polygons[0]), list(polygons[1])])
    for form in ([polygons[0], polygons[1]], polygons):
        out = aug(IMAGES, polygons=form)
        for moved, expected in zip(out.polygons, lists.polygons, strict=True):
            for a, b in zip(moved, expected, strict=True):
                np.testing.assert_array_equal(a, b)
    assert [len(p) for p in lists.polygons] == [3, 3]


@pytest.mark.parametrize(
    ("polygons", "message"),
    [
        ([np.zeros((4, 2)), []], r"polygons\[0\] must be .* got an array of shape \(4, 2\)"),
        ([{"a": 1}, []], r"polygons\[0\] must be .* got dict"),
        (np.zeros((2, 4, 2)), r"polygons must be a sequence, got an array of shape \(2, 4, 2\)"),
        (np.zeros((2, 1, 1, 4, 2)), r"polygons must be a sequence, got an array of shape"),
    ],
)
def test_polygons_of_another_nesting_are_named(polygons, message):
    """One (V, 2) polygon where an image's sequence of them is expected is not read as V
    polygons of one vertex pair each: it is named, with what it is."""
    with pytest.raises(TypeError, match=message):
        Augment("grid")(IMAGES, polygons=polygons)


def test_replay_takes_options_edited_to_arrays_alike_in_every_draw(gl):
    """Draws whose options hold equal arrays (not JSON lists) are one set of options: the
    replay is that of the lists; NaN in both is equal too, and refused as a background."""
    aug = Augment("grid", seed=3)
    images = np.random.default_rng(0).integers(0, 255, (3, 16, 20, 3), dtype=np.uint8)
    listed = json.loads(json.dumps(aug(images).params))
    for draw in listed:
        draw["options"]["background"] = [1, 2, 3]
    as_lists = aug.replay(images, listed).images
    edited = copy.deepcopy(listed)
    for draw in edited:
        draw["options"]["background"] = np.array([1.0, 2.0, 3.0])
    np.testing.assert_array_equal(aug.replay(images, edited).images, as_lists)
    for draw in edited:
        draw["options"]["background"] = np.full(3, np.nan)
    with pytest.raises(ValueError, match="background"):
        aug.replay(images, edited)


@pytest.mark.parametrize(
    "landmarks",
    [
        [[100.1, 50.0], [float(np.float32(100.1)), 50.0]],  # a float32 copy of a point
        [[-0.5 + 1e-7, -0.5], [60.0, 60.0]],  # a hair off a pinned corner
    ],
    ids=["float32-copy", "near-corner"],
)
def test_landmarks_the_gpu_cannot_tell_apart_move_as_one(gl, landmarks):
    """Landmarks that float32 on the GPU would merge take one target (a pinned corner's
    where one lies on it): no refusal of two targets at one point mid-epoch."""
    from glmls.augment import Augment

    images = np.zeros((1, 128, 128), np.uint8)
    points = np.array([landmarks])
    result = Augment("landmarks", seed=0)(images, keypoints=points)
    moved = result.keypoints[0]
    if landmarks[0][0] < 0:
        assert np.abs(moved[0] - [-0.5, -0.5]).max() < 1e-3  # stays with the corner
    else:
        assert np.abs(moved[0] - moved[1]).max() < 1e-3
        assert np.abs(moved[0] - points[0, 0]).max() > 0.01  # moved, as one


@pytest.mark.parametrize("edited", [0, 1, 2])
def test_replay_names_the_record_whose_options_differ(gl, edited):
    """One call replays one set of options: the record edited apart from the others is
    the one named, the first one too."""
    images = np.zeros((3, 16, 20), np.uint8)
    aug = Augment("grid", seed=3)
    params = json.loads(json.dumps(aug(images).params))
    params[edited]["options"]["transform"] = "rigid"
    other = 1 if edited == 0 else 0
    expected = rf"params\[{edited}\]\['options'\] differ from params\[{other}\]'s in transform"
    with pytest.raises(ValueError, match=expected):
        aug.replay(images, params)


@pytest.mark.parametrize("mesh", [(4, (32, 32)), None])
def test_a_huge_box_is_sampled_sparsely_far_from_the_image(mesh):
    """A box of two million pixels a side is sampled every step near the image (four times
    its larger side, plus 64 px) and at steps that double beyond: hundreds of points, not
    millions (it took 16 s and 10 GB)."""
    points, counts = box_outlines(np.array([[-1e6, -1e6, 1e6, 1e6]]), 2.0, mesh=mesh, near=(32, 32))
    assert len(points) < 1_000 and counts.tolist() == [len(points)]
    assert points.min() == -1e6 and points.max() == 1e6  # the corners are points
    # a side that crosses the image: every 2 px within the window, sparser past it
    side, _ = box_outlines(np.array([[-1e6, 5.0, 1e6, 5.0]]), 2.0, mesh=mesh, near=(32, 32))
    near = np.sort(side[np.abs(side[:, 0] - 16) < 150, 0])
    assert np.diff(near).max() <= 2.0 + 1e-9
    assert len(side) < 1_000


def test_a_box_past_the_window_moves_as_the_dense_one_does(gl):
    """A box reaching 3,000 px past a 32 x 32 image, sampled sparsely past 192 px: its moved
    and clipped box is the densely sampled one's."""
    augment = Augment("grid", seed=1, displacement=0.15)
    image = np.zeros((1, 32, 32), np.uint8)
    box = np.array([[[-3000.0, 4.0, 20.0, 25.0]]])
    sparse = augment(image, boxes=box)
    grid = sparse.params[0]["options"]["grid"]
    # every 2 px and every crossing of the mesh: a window that holds the whole box
    points, _ = box_outlines(box[0], 2.0, mesh=(grid, (32, 32)), near=(4096, 4096))
    moved = augment.replay(image, sparse.params, keypoints=points[None]).keypoints[0]
    dense = np.r_[moved.min(axis=0), moved.max(axis=0)]
    dense = np.clip(dense, -0.5, 31.5)
    np.testing.assert_allclose(sparse.boxes[0, 0], dense, atol=0.05)


def test_a_box_given_without_area_stays_invalid(gl):
    """A line or a point given as a box has no object to keep: the map bends its moved
    outline into a box with an area, but boxes_valid stays False (as at no displacement);
    a box with an area beside them stays valid."""
    boxes = np.array([[[10.0, 5.0, 10.0, 20.0], [-0.5, 0.0, -0.5, 10.0], [7.0, 7.0, 7.0, 7.0],
                       [4.0, 4.0, 14.0, 12.0]]])  # fmt: skip
    image = np.zeros((1, 32, 32), np.uint8)
    bent = Augment("grid", seed=0, displacement=0.1)(image, boxes=boxes)
    assert bent.boxes_valid[0].tolist() == [False, False, False, True]
    width = bent.boxes[0, 0, 2] - bent.boxes[0, 0, 0]
    assert width > 0.1  # the line's outline did bend into an area
    still = Augment("grid", seed=0, displacement=0.0)(image, boxes=boxes)
    assert still.boxes_valid[0].tolist() == [False, False, False, True]


@pytest.mark.parametrize("mesh", [(4, (32, 32)), None])
def test_a_side_past_float64_s_integers_is_refused_with_a_window(mesh):
    """A side of 2e20 px has more step counts than float64 holds whole: refused as a side
    of too many points, as without a window, not sampled as Python integers."""
    with pytest.raises(ValueError, match="use a larger step"):
        box_outlines(np.array([[-1e20, 5.0, 1e20, 10.0]]), 2.0, mesh=mesh, near=(32, 32))
