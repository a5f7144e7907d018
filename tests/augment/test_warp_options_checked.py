"""``Augment(warp_options=...)`` is checked where it is made, not at the first batch (in a
data loader's worker, far from the mistake): the names, the values, and the labels, which
are keywords of each call."""

from __future__ import annotations

import pytest

from glmls.augment import Augment


@pytest.mark.parametrize(
    ("options", "error", "message"),
    [
        ({"spacing": 1}, TypeError, "warp_options has no keyword spacing"),
        ({"method": "nope"}, ValueError, "warp_options: unknown method 'nope'"),
        ({"transform": "rigidd"}, ValueError, "warp_options: unknown transform 'rigidd'"),
        ({"grid": 0}, ValueError, "warp_options: grid must be an integer"),
        ({"weight": "gaussian", "radius": -1}, ValueError, "warp_options: radius must be > 0"),
        ({"keypoints": 1}, TypeError, "warp_options cannot hold keypoints: give them to the call"),
        (
            {"src_segments": [[[0, 0], [4, 0]]]},
            TypeError,
            "warp_options cannot hold src_segments: the preset draws each image's handles",
        ),
    ],
)
def test_bad_warp_options_are_refused_by_the_constructor(options, error, message):
    with pytest.raises(error) as caught:
        Augment("grid", warp_options=options)
    assert message in str(caught.value)


def test_good_warp_options_are_kept():
    aug = Augment("grid", warp_options={"transform": "rigid", "border": "reflect", "grid": 2})
    assert aug.warp_options == {
        "transform": "rigid", "interpolation": "linear", "border": "reflect", "grid": 2,
    }  # fmt: skip
