"""One validator of a voxel spacing (dz, dy, dx): glmls.core.handles3.as_volume_spacing, and
every place that takes a spacing (files, volume warps, analyses, the window) gives its errors."""

from __future__ import annotations

import math

import numpy as np
import pytest

from glmls.analysis.volume_lattice import spacing_scale
from glmls.app.volume_controller import SliceGrid
from glmls.core.handles3 import as_volume_spacing
from glmls.files.volumes import Volume, world_to_volume
from glmls.volume.options import VolumeOptions

BAD = [
    ((1.0, 2.0), ValueError, r"three numbers .* got 2: \(1\.0, 2\.0\)"),
    ((1.0, 2.0, 3.0, 4.0), ValueError, r"got 4: \(1\.0, 2\.0, 3\.0, 4\.0\)"),
    ((1.0, 0.0, 1.0), ValueError, r"spacing must be positive and finite .*\(1\.0, 0\.0, 1\.0\)"),
    ((1.0, -2.0, 1.0), ValueError, r"spacing must be positive and finite .*\(1\.0, -2\.0, 1\.0\)"),
    ((1.0, math.inf, 1.0), ValueError, r"spacing must be positive and finite .*inf"),
    (np.array([1.0, np.nan, 1.0]), ValueError, r"spacing must be positive and finite .*nan"),
    ((1.0, "2", 1.0), TypeError, r"spacing must be .*'2' is not a number"),
    ((1.0, None, 1.0), TypeError, r"None is not a number"),
    ((1.0, True, 1.0), TypeError, r"True is not a number"),
    ("2,1,1", TypeError, r"spacing must be .*got '2,1,1'"),
    ("123", TypeError, r"got '123'"),
    (2.0, TypeError, r"spacing must be .*got 2\.0"),
    ({"dz": 1.0}, TypeError, r"got \{'dz': 1\.0\}"),
    (np.float64(2.0), TypeError, r"got np\.float64\(2\.0\)|got 2\.0"),
]

GOOD = [
    ((2, 1, 0.5), (2.0, 1.0, 0.5)),
    ([2.0, 1.0, 0.5], (2.0, 1.0, 0.5)),
    (np.array([2.0, 1.0, 0.5]), (2.0, 1.0, 0.5)),
    (np.array([2, 1, 3], dtype=np.int32), (2.0, 1.0, 3.0)),
    ((np.float32(2.0), np.int64(1), 0.5), (2.0, 1.0, 0.5)),
]


@pytest.mark.parametrize(("spacing", "expected"), GOOD)
def test_a_spacing_is_three_python_floats(spacing, expected):
    found = as_volume_spacing(spacing)
    assert found == expected and all(type(v) is float for v in found)


@pytest.mark.parametrize(("spacing", "error", "message"), BAD)
def test_a_bad_spacing_is_refused_naming_it(spacing, error, message):
    with pytest.raises(error, match=message):
        as_volume_spacing(spacing)


def test_the_name_is_the_callers():
    with pytest.raises(ValueError, match=r"^--spacing must be positive"):
        as_volume_spacing((0, 1, 1), "--spacing")


ENTRY_POINTS = {
    "Volume": lambda s: Volume(np.zeros((2, 2, 2)), spacing=s),
    "world_to_volume": lambda s: world_to_volume(np.zeros((1, 3)), np.eye(4), spacing=s),
    "VolumeOptions": lambda s: VolumeOptions(spacing=s),
    "spacing_scale": spacing_scale,
    "SliceGrid": lambda s: SliceGrid((2, 2, 2), spacing=s),
}


@pytest.mark.parametrize("entry", sorted(ENTRY_POINTS))
@pytest.mark.parametrize(("spacing", "error", "message"), BAD)
def test_every_place_taking_a_spacing_says_the_same(entry, spacing, error, message):
    with pytest.raises(error, match=message):
        ENTRY_POINTS[entry](spacing)
