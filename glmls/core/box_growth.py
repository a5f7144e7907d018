"""When a border mode's margin search ends (:func:`box_gains`): the rule shared by the
image's mesh (:func:`glmls.imaging.frame.border_margin`) and the volume's lattice
(:func:`glmls.volume.margins.search_margins3`), judged by the bounding box of f's image of
the extended border, in any number of dimensions."""

from __future__ import annotations

import numpy as np

__all__ = ["BOX_GROWTH", "Box", "box_gains", "boxes_meet"]

#: How far (pixels or voxels per one of margin) a deformed border's box must move out for
#: the margin search to count it as grown: float32's noise in f moves the border of a map
#: that collapses the plane or the volume, and a map that shrinks it a thousandfold is one.
BOX_GROWTH = 1e-3

#: A margin and the (low, high) corners of the box of f's image of the border with it.
Box = tuple[float, np.ndarray, np.ndarray]


def boxes_meet(box: tuple[np.ndarray, np.ndarray], low: np.ndarray, high: np.ndarray) -> bool:
    """Whether the box ``box`` ((low, high) corners) and the box [``low``, ``high``] meet
    (an empty box, low above high, meets none)."""
    return bool((box[0] <= high).all() and (box[1] >= low).all())


def box_gains(before: Box, now: Box, reach: float, low: np.ndarray, high: np.ndarray) -> bool:
    """Whether a larger margin may cover more of the canvas (box ``low``, ``high``), judged
    by the deformed border's box, grown from ``before`` to ``now`` as the margin grew: it
    holds the canvas and still grows, or its part in the canvas grew, or, still outside the
    canvas, growing on twice as fast as it did up to the margin ``reach`` (the budget's) it
    would meet it. A map that collapses the image or volume (a box that stopped growing and
    did not shrink: one that shrank, as f folds the border in, goes on) or a canvas far from
    anything the budget's margin could reach ends the search; so does a border with no
    finite image, and a margin that did not grow decides nothing (True)."""
    (m0, low0, high0), (m1, low1, high1) = before, now
    if not (np.isfinite(low1).all() and np.isfinite(high1).all()):
        return False
    if not (np.isfinite(low0).all() and np.isfinite(high0).all()) or m1 <= m0:
        return True
    least = BOX_GROWTH * (m1 - m0)
    if not ((low0 - low1 > least).any() or (high1 - high0 > least).any()):
        # stopped growing (f collapses the plane or volume): ends, unless it shrank, as f
        # folds the border in (handles that swap places), to grow further out
        return bool((low1 - low0 > least).any() or (high0 - high1 > least).any())
    if (low1 <= low).all() and (high1 >= high).all():
        return True  # the box holds the canvas: the border's shape decides
    if boxes_meet((low1, high1), low, high):
        if not boxes_meet((low0, high0), low, high):
            return True
        in0 = np.maximum(low0, low), np.minimum(high0, high)
        in1 = np.maximum(low1, low), np.minimum(high1, high)
        return bool((in0[0] - in1[0] > least).any() or (in1[1] - in0[1] > least).any())
    rest = 2.0 * (reach - m1) / (m1 - m0)
    out_low = low1 - (low0 - low1).clip(0.0) * rest
    out_high = high1 + (high1 - high0).clip(0.0) * rest
    return boxes_meet((out_low, out_high), low, high)
