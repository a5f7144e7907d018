"""``Augment(warp_options=...)`` is checked where it is made, not at the first batch (in a
data loader's worker, far from the mistake): the names, the values, and the labels, which
are keywords of each call."""

from __future__ import annotations

import numpy as np
import pytest

import glmls
from glmls.augment import Augment


@pytest.mark.parametrize(
    ("options", "error", "message"),
    [
        ({"spacing": 1}, TypeError, "warp_options has no keyword spacing"),
        ({"method": "nope"}, ValueError, "warp_options: unknown method 'nope'"),
        ({"transform": "rigidd"}, ValueError, "warp_options: unknown transform 'rigidd'"),
        ({"grid": 0}, ValueError, "warp_options: grid must be an integer"),
        ({"weight": "gaussian", "radius": -1}, ValueError, "warp_options: radius must be a finite"),
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


@pytest.mark.parametrize(
    "options", [{"tolerance": 0.05}, {"method": "paper-quads"}, {"tolerance": 0.05, "grid": 1}]
)
def test_a_mesh_of_its_own_replaces_the_presets_grid(gl, options):
    """The adaptive mesh (a tolerance) and paper-quads take no coarser grid: the preset's
    mesh step gives way to them, and the batch is what warp_batch makes of the draws."""
    aug = Augment("grid", seed=3, warp_options=options)
    assert "grid" not in aug.warp_options or aug.warp_options["grid"] == 1
    images = np.random.default_rng(0).integers(0, 255, (2, 12, 16), dtype=np.uint8)
    out = aug(images, keypoints=np.full((2, 1, 2), 6.0))
    same = glmls.warp_batch(
        images, [p["src"] for p in out.params], [p["dst"] for p in out.params], **aug.warp_options
    )
    np.testing.assert_array_equal(out.images, same)


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"tolerance": 0.05, "grid": 2}, "grid and tolerance exclude each other"),
        ({"method": "paper-quads", "grid": 4}, "grid must be 1, got 4"),
    ],
)
def test_options_that_exclude_each_other_are_refused_when_made(options, message):
    with pytest.raises(ValueError, match=message):
        Augment("grid", warp_options=options)
