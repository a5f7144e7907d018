"""A preset whose draws could take handles beyond the coordinate range (±1e6 px) is refused
for every sample of that image size, whatever its random numbers: before, the check looked at
each draw, so that a magnitude near the limit failed at some indices and not at others (a run
over a data set stopped at one unlucky sample). Each preset's ``reach`` bounds its draws."""

from __future__ import annotations

import numpy as np
import pytest

from glmls.augment import (
    PRESETS,
    Augment,
    GridPreset,
    LandmarksPreset,
    TextDistortPreset,
    TextPerspectivePreset,
    TextStretchPreset,
)

SHAPE = (8, 12)


@pytest.mark.parametrize(
    ("preset", "options"),
    [
        ("grid", {"displacement": 1.05e6, "units": "pixels"}),
        ("grid", {"displacement": 1.05e6 / 12, "units": "fraction"}),
        ("text-distort", {"radius": 1.2e6}),
        ("text-stretch", {"radius": 2.1e6}),
        ("text-perspective", {"radius": 1.2e6}),
        ("landmarks", {"displacement": 1.05e6, "units": "pixels"}),
    ],
)
def test_a_magnitude_that_can_leave_the_range_is_refused_at_every_index(preset, options):
    aug = Augment(preset, seed=0, **options)
    landmarks = [np.array([[3.0, 4.0]])]
    for index in range(40):
        with pytest.raises(ValueError, match=r"images\[0\]: the .* can move handles to"):
            aug.draw([SHAPE], indices=[index], landmarks=landmarks)


@pytest.mark.parametrize(
    ("preset", "options"),
    [
        ("grid", {"displacement": 1e6 - 12, "units": "pixels"}),
        ("text-distort", {"radius": 1e6 - 12}),
        ("landmarks", {"displacement": 1e6 - 12, "units": "pixels"}),
    ],
)
def test_a_magnitude_within_the_range_draws_at_every_index(preset, options):
    aug = Augment(preset, seed=0, **options)
    params = aug.draw([SHAPE] * 40, indices=range(40), landmarks=[[[3.0, 4.0]]] * 40)
    assert max(np.abs(p["dst"]).max() for p in params) <= 1e6


@pytest.mark.parametrize("name", list(PRESETS))
def test_reach_bounds_every_draw(name):
    rng = np.random.default_rng(3)
    for trial in range(300):
        shape = tuple(int(n) for n in rng.integers(1, 200, 2))
        landmarks = rng.uniform(-300, 300, (int(rng.integers(1, 5)), 2))
        if name == "grid":
            units = str(rng.choice(["fraction", "pixels"]))
            preset = GridPreset(displacement=float(rng.uniform(0, 3)), units=units)
        elif name == "landmarks":
            pinned = bool(rng.integers(2))
            preset = LandmarksPreset(displacement=float(rng.uniform(0, 3)), pin_corners=pinned)
        else:
            cls = {
                "text-distort": TextDistortPreset,
                "text-stretch": TextStretchPreset,
                "text-perspective": TextPerspectivePreset,
            }[name]
            radius = None if trial % 2 else float(rng.uniform(0, 500))
            preset = cls(segments=int(rng.integers(1, 8)), radius=radius)
        _, dst = preset.draw(np.random.default_rng(trial), shape, landmarks)
        assert np.abs(dst).max() <= preset.reach(shape, landmarks)
