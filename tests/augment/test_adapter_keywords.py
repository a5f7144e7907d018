"""Keywords of the wrong name or type given to the adapters (albumentations' MLSDeform,
torchvision's MLSTransform) and to warp_batch's per-image segments: each a TypeError or
ValueError naming the keyword and the value, never an option taken in silence."""

from __future__ import annotations

import os

import numpy as np
import pytest

import glmls
from glmls.augment import Augment

os.environ.setdefault("NO_ALBUMENTATIONS_UPDATE", "1")  # no version check over the network

pytest.importorskip("albumentations", reason="albumentations not installed (the extra)")
pytest.importorskip("torchvision", reason="torchvision not installed (the torch extra)")

from glmls.augment.albumentations import MLSDeform
from glmls.augment.torchvision import MLSTransform


@pytest.mark.parametrize("name", ["seed", "densify", "clip_polygons", "dispalcement"])
def test_torchvision_options_its_preset_does_not_take_are_refused(name):
    """MLSTransform draws from torch's random numbers (no seed of its own) and moves no
    polygons: Augment's own seed, densify and clip_polygons are no options of it."""
    with pytest.raises(TypeError, match=rf"preset 'grid' has no option {name}; its options: "):
        MLSTransform("grid", **{name: 1})


@pytest.mark.parametrize(
    "name", ["seed", "densify", "clip_polygons", "box_step", "warp_options", "preset"]
)
def test_albumentations_preset_options_hold_the_presets_options_only(name):
    with pytest.raises(TypeError, match=rf"preset 'grid' has no option {name}; its options: "):
        MLSDeform("grid", preset_options={name: 1})


@pytest.mark.parametrize("value", [float("nan"), None, 1j, "2", True, np.array([2.0])])
def test_the_adapters_box_step_of_a_bad_value(value):
    error = ValueError if isinstance(value, float) else TypeError
    for make in (MLSTransform, MLSDeform):
        with pytest.raises(error, match=r"^box_step must be a finite number > 0, got "):
            make("grid", box_step=value)
    assert MLSDeform(box_step=np.array(3.0)).box_step == 3.0


@pytest.mark.parametrize("value", [float("nan"), 1j, "x", True, 5])
def test_warp_options_that_are_no_mapping_are_named_alike(value):
    message = rf"^warp_options must be a mapping or None, got {value!r}$".replace("(", r"\(")
    for make in (Augment, MLSTransform, MLSDeform):
        with pytest.raises(TypeError, match=message.replace(")", r"\)")):
            make("grid", warp_options=value)


@pytest.mark.parametrize(
    ("value", "error", "message"),
    [
        (3, TypeError, r"one value per image \(1\), got 3$"),
        ("ab", TypeError, r"one value per image \(1\), got 'ab'$"),
        (np.zeros((1, 2, 2)), ValueError, r"one value per image \(1\), got an array of shape"),
        ([None, None], ValueError, r"one value per image \(1\), got 2 values$"),
    ],
)
def test_warp_batch_segments_that_are_not_one_per_image(value, error, message):
    image, src = np.zeros((1, 4, 6), np.uint8), [[[0.0, 0.0]]]
    with pytest.raises(error, match=r"^src_segments must be a sequence of " + message):
        glmls.warp_batch(image, src, src, src_segments=value, dst_segments=value)
