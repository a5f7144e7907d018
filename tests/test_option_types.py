"""The option rule beyond the warps: the analyses, the image reader, the augmentation's
options, presets and records take integers and real numbers as glmls.warp does (numpy's
and 0-d arrays too), a value of the wrong type (a float for an integer, a bool, a string,
None, a complex) being a ``TypeError`` and a wrong value a ``ValueError``, both naming the
option and the value."""

from __future__ import annotations

import json

import numpy as np
import pytest

import glmls
from glmls.analysis import ReferenceDeformation
from glmls.analysis.construction import construction_errors
from glmls.analysis.volume_field import volume_error_field
from glmls.analysis.volume_pictures import render_volume_slices
from glmls.augment import Augment, GridPreset, LandmarksPreset, TextDistortPreset

SRC3 = np.array([[0.0, 0, 0], [5, 0, 0], [0, 4, 0], [0, 0, 3]])
IMAGE = np.zeros((12, 14, 3), np.float64)
POINTS = np.array([[5.0, 6.0]])


def _shift(points):
    return np.asarray(points, np.float64) + 0.5


@pytest.mark.parametrize(
    ("keywords", "error", "message"),
    [
        ({"radius": 2.0}, TypeError, r"radius must be an integer >= 0 \(output pixels\), got 2.0"),
        ({"radius": True}, TypeError, r"radius must be an integer >= 0 .*, got True"),
        ({"radius": -1}, ValueError, r"radius must be an integer >= 0 .*, got -1"),
        ({"snap": "0.1"}, TypeError, r"snap must be a finite number in \[0, 0.5\) .*, got '0.1'"),
        ({"snap": None}, TypeError, r"snap must be a finite number in \[0, 0.5\) .*, got None"),
        ({"snap": 0.5}, ValueError, r"snap must be a finite number in \[0, 0.5\) .*, got 0.5"),
        ({"alignment": None}, TypeError, r"alignment must be a string, one of .*; got None"),
        ({"alignment": "x"}, ValueError, r"unknown alignment 'x'; choose one of"),
        ({"border": 3}, TypeError, r"border must be a string, one of .*; got 3"),
    ],
)
def test_the_construction_errors_options(keywords, error, message):
    with pytest.raises(error, match=message):
        construction_errors(IMAGE, IMAGE, _shift, POINTS, **keywords)


def test_the_construction_radius_takes_numpy_integers():
    ours = construction_errors(IMAGE, IMAGE, _shift, POINTS, radius=np.array(2), snap=np.float32(0))
    assert ours.values.shape == (1,)


def test_the_volume_error_field_grid():
    m = ReferenceDeformation(SRC3, SRC3 + [1, 0, 0])
    for value in (2.0, True, None):
        with pytest.raises(
            TypeError, match=rf"grid must be an integer from 1 to \d+ \(voxels\), got {value}"
        ):
            volume_error_field(m, (4, 4, 4), grid=value)
    with pytest.raises(
        ValueError, match=r"grid must be an integer from 1 to \d+ \(voxels\), got 0"
    ):
        volume_error_field(m, (4, 4, 4), grid=0)
    assert volume_error_field(m, (4, 4, 4), grid=np.array(2)).shape == (4, 4, 4)


VOLUME = np.zeros((4, 5, 6), np.uint8)


@pytest.mark.parametrize(
    ("keywords", "error", "message"),
    [
        ({"slices": (1.0, 2, 2)}, TypeError, r"slices must be \(z, y, x\) voxel indices within"),
        ({"slices": (True, 2, 2)}, TypeError, r"slices must be \(z, y, x\) voxel indices within"),
        ({"slices": "abc"}, TypeError, r"slices must be \(z, y, x\) voxel indices within .*'abc'"),
        ({"slices": 3}, TypeError, r"slices must be \(z, y, x\) voxel indices within .*got 3"),
        ({"slices": (4, 2, 2)}, ValueError, r"slices must be \(z, y, x\) voxel indices within"),
        ({"slices": (-1, 2, 2)}, ValueError, r"slices must be \(z, y, x\) voxel indices within"),
        ({"slices": (1, 2)}, ValueError, r"slices must be \(z, y, x\) voxel indices within"),
        ({"scale": 2.0}, TypeError, r"scale must be an integer >= 1, got 2.0"),
        ({"scale": 0}, ValueError, r"scale must be an integer >= 1, got 0"),
        ({"near": "1"}, TypeError, r"near must be a finite number >= 0 \(voxels\), got '1'"),
        ({"near": 1j}, TypeError, r"near must be a finite number >= 0 \(voxels\), got 1j"),
        ({"near": -1}, ValueError, r"near must be a finite number >= 0 \(voxels\), got -1"),
        (
            {"projection": None},
            TypeError,
            r"projection must be a string, one of max, min; got None",
        ),
        ({"projection": "mean"}, ValueError, r"unknown projection 'mean'; choose one of max, min"),
    ],
)
def test_the_volume_slices_options(keywords, error, message):
    with pytest.raises(error, match=message):
        render_volume_slices(VOLUME, **keywords)


def test_the_volume_slices_take_numpy_integers(gl):
    picture = render_volume_slices(VOLUME, slices=np.array([1, 2, 3]), scale=np.int64(1))
    assert picture.ndim == 3


@pytest.mark.parametrize(
    ("limit", "error", "message"),
    [
        (2.0, TypeError, "max_pixels must be an integer >= 1, got 2.0"),
        (None, TypeError, "max_pixels must be an integer >= 1, got None"),
        (0, ValueError, "max_pixels must be an integer >= 1, got 0"),
    ],
)
def test_imread_max_pixels(tmp_path, limit, error, message):
    path = tmp_path / "a.png"
    glmls.imwrite(path, np.zeros((3, 4), np.uint8))
    with pytest.raises(error, match=message):
        glmls.imread(path, max_pixels=limit)
    assert glmls.imread(path, max_pixels=np.array(12)).shape == (3, 4)
    with pytest.raises(ValueError, match="exceeds the limit of 11"):
        glmls.imread(path, max_pixels=np.array(11))


@pytest.mark.parametrize("name", ["box_step", "densify"])
@pytest.mark.parametrize("value", ["2", True, 1j, np.array([2.0])])
def test_the_label_steps_of_the_wrong_type(name, value):
    with pytest.raises(TypeError, match=rf"^{name} must be a finite number > 0, got "):
        Augment("grid", **{name: value})


@pytest.mark.parametrize("name", ["box_step", "densify"])
@pytest.mark.parametrize("value", [0, -1.0, float("nan"), float("inf")])
def test_the_label_steps_out_of_range(name, value):
    with pytest.raises(ValueError, match=rf"^{name} must be a finite number > 0, got "):
        Augment("grid", **{name: value})


def test_a_box_step_may_be_a_zero_dimensional_array():
    assert Augment("grid", box_step=np.array(4.0)).box_step == 4.0
    assert Augment("grid", densify=np.array(3)).densify == 3.0


D = "must be a finite number >= 0"


@pytest.mark.parametrize(
    ("make", "error", "message"),
    [
        (lambda: GridPreset(displacement="0.1"), TypeError, f"displacement {D}, got '0.1'"),
        (lambda: GridPreset(displacement=None), TypeError, f"displacement {D}, got None"),
        (lambda: GridPreset(displacement=True), TypeError, f"displacement {D}, got True"),
        (lambda: GridPreset(displacement=-1), ValueError, f"displacement {D}, got -1"),
        (lambda: TextDistortPreset(radius=1j), TypeError, f"radius {D}, got 1j"),
        (lambda: TextDistortPreset(radius=float("inf")), ValueError, f"radius {D}, got inf"),
        (lambda: GridPreset(units=None), TypeError, "units must be a string, one of fraction"),
        (lambda: GridPreset(units="cm"), ValueError, "unknown units 'cm'; choose one of fraction"),
        (lambda: LandmarksPreset(pin_corners="yes"), TypeError, "pin_corners must be True or"),
        (lambda: LandmarksPreset(pin_corners=1), TypeError, "pin_corners must be True or False"),
    ],
)
def test_the_preset_options(make, error, message):
    with pytest.raises(error, match=message.replace("(", r"\(").replace(")", r"\)")):
        make()


def test_zero_dimensional_options_are_recorded_as_numbers():
    """An option given as a 0-d array is taken, and the draw's record holds its number."""
    aug = Augment(
        "grid", rows=np.array(3), displacement=np.array(0.05), warp_options={"grid": np.array(2)}
    )
    draw = json.loads(json.dumps(aug.draw([(8, 8)])[0]))
    assert draw["config"]["rows"] == 3 and draw["config"]["displacement"] == 0.05
    assert draw["options"]["grid"] == 2 and len(draw["src"]) == 12


@pytest.mark.parametrize(
    ("shape", "error"),
    [
        ([16.0, 20.0], TypeError),
        ([16, True], TypeError),
        ("16x20", TypeError),
        (None, TypeError),
        ([16], ValueError),
        ([0, 20], ValueError),
    ],
)
def test_a_recorded_shape(shape, error):
    aug = Augment("grid")
    params = aug.draw([(16, 20)])
    params[0]["shape"] = shape
    with pytest.raises(error, match=r"params\[0\]\['shape'\] must be \[H, W\], integers >= 1, got"):
        aug.replay(np.zeros((1, 16, 20), np.uint8), params)


def test_max_batch_bytes_follows_the_integer_rule(gl):
    images = np.zeros((1, 4, 6), np.uint8)
    out = glmls.warp_batch(images, [[[0, 0]]], [[[1, 0]]], max_batch_bytes=np.array(10**8))
    assert out.shape == images.shape
    Augment("grid", warp_options={"max_batch_bytes": np.array(10**8)})
    with pytest.raises(
        TypeError, match=r"max_batch_bytes must be an integer >= 1 or None, got 2.0"
    ):
        glmls.warp_batch(images, [[[0, 0]]], [[[1, 0]]], max_batch_bytes=2.0)
    with pytest.raises(ValueError, match=r"max_batch_bytes must be an integer >= 1 or None, got 0"):
        glmls.warp_batch(images, [[[0, 0]]], [[[1, 0]]], max_batch_bytes=0)


@pytest.mark.parametrize("config", ["rigid", {"transform": "rigid"}, 3])
@pytest.mark.parametrize("function", ["mls", "mls_error", "weights"])
def test_the_reference_s_config_is_an_mls_config(function, config):
    """A transform's name or a dict is a keyword's value, not a config: a TypeError naming
    what was given, not an AttributeError from inside."""
    src = np.array([[1.0, 1], [8, 1], [1, 6]])
    args = (np.ones((1, 3)), config, None) if function == "weights" else (src, src, src, config)
    with pytest.raises(
        TypeError, match=rf"config must be an MLSConfig, got {type(config).__name__}"
    ):
        getattr(glmls.reference, function)(*args)
