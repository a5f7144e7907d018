"""The margin search's stopping rule, :func:`glmls.core.box_growth.box_gains`, on boxes
whose answer follows from the rule's own words, in 2D and 3D."""

import numpy as np
import pytest

from glmls.core.box_growth import box_gains, boxes_meet


def _box(margin, low, high):
    return float(margin), np.asarray(low, float), np.asarray(high, float)


@pytest.mark.parametrize("dim", [2, 3])
def test_a_box_that_stopped_growing_ends_the_search(dim):
    canvas = np.zeros(dim), np.full(dim, 100.0)
    still = [49.9] * dim, [50.1] * dim  # a collapse: the border's image stays at a point
    # moved by float32's noise alone, well below the rule's least growth a unit of margin
    nudged = [49.9 - 1e-6] * dim, [50.1 + 1e-6] * dim
    assert not box_gains(_box(4, *still), _box(8, *nudged), 1000.0, *canvas)


@pytest.mark.parametrize("dim", [2, 3])
def test_a_box_that_shrank_goes_on(dim):
    """f folds the border in (handles that swap places): its image's box shrinks before it
    grows, further out; no collapse."""
    canvas = np.zeros(dim), np.full(dim, 100.0)
    before = _box(0, [-20.0] * dim, [130.0] * dim)
    after = _box(104, [5.0] * dim, [110.0] * dim)
    assert box_gains(before, after, 1000.0, *canvas)


@pytest.mark.parametrize("dim", [2, 3])
def test_a_box_growing_inside_the_canvas_goes_on(dim):
    canvas = np.zeros(dim), np.full(dim, 100.0)
    before = _box(4, [40.0] * dim, [60.0] * dim)
    after = _box(8, [30.0] * dim, [70.0] * dim)
    assert box_gains(before, after, 1000.0, *canvas)


def test_a_box_holding_the_canvas_and_growing_goes_on():
    canvas = np.zeros(2), np.full(2, 10.0)
    assert box_gains(_box(2, [-5, -5], [15, 15]), _box(4, [-7, -7], [17, 17]), 100.0, *canvas)


def test_a_far_canvas_out_of_the_budgets_reach_ends_the_search():
    # the box grows by 1 a unit of margin; at twice that pace the rest of the budget (50
    # more units) takes it to x = 110 at most, short of a canvas from x = 1000
    canvas = np.array([1000.0, 0.0]), np.array([1100.0, 100.0])
    before, after = _box(4, [0, 0], [10, 100]), _box(8, [-4, -4], [14, 104])
    assert not box_gains(before, after, 58.0, *canvas)
    # ... and a canvas within that reach goes on
    near = np.array([40.0, 0.0]), np.array([140.0, 100.0])
    assert box_gains(before, after, 58.0, *near)


def test_a_border_without_a_finite_image_ends_the_search_and_a_first_round_decides_nothing():
    canvas = np.zeros(2), np.full(2, 10.0)
    finite = _box(2, [0, 0], [5, 5])
    assert not box_gains(finite, _box(4, [np.nan, 0], [5, 5]), 100.0, *canvas)
    assert box_gains(_box(0, [np.inf] * 2, [-np.inf] * 2), finite, 100.0, *canvas)
    assert box_gains(finite, _box(2, [0, 0], [5, 5]), 100.0, *canvas)  # margin not grown


def test_boxes_meet():
    low, high = np.zeros(3), np.ones(3)
    assert boxes_meet((np.full(3, 0.5), np.full(3, 2.0)), low, high)
    assert boxes_meet((np.full(3, 1.0), np.full(3, 2.0)), low, high)  # a shared face
    assert not boxes_meet((np.full(3, 1.5), np.full(3, 2.0)), low, high)
    assert not boxes_meet((np.full(3, np.inf), np.full(3, -np.inf)), low, high)  # empty
